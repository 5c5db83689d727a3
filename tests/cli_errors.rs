//! Bad input through the real binary: exit code 2, one line on stderr naming the file and the
//! problem, and no output file.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

fn reflect(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).output().expect("run reflect");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn assert_bad_input(args: &[&str], names: &str, mentions: &str, out: &Path) {
    let (code, err) = reflect(args);
    assert_eq!(code, 2, "exit code for {args:?}; stderr: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line expected for {args:?}, got: {err}");
    assert!(lines[0].contains(names), "error should name {names}: {err}");
    assert!(lines[0].to_lowercase().contains(&mentions.to_lowercase()), "error should mention {mentions:?}: {err}");
    assert!(!out.exists(), "no output file may be written for {args:?}");
}

const GOOD: &str = r#"
[render]
width = 8
height = 8
spp = 2
[camera]
type = "orthographic"
from = [3.0, 0.0, 0.0]
to = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
extent = 1.05
[lighting]
type = "uniform"
radiance = 1.0
[[objects]]
shape = "sphere"
brdf = { type = "lambert", albedo = 0.5 }
"#;

#[test]
fn bad_scene_files_exit_2_with_one_line() {
    let d = temp_dir("cli-errors");
    let out = d.join("out.exr");
    let o = out.to_str().unwrap();
    let w = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let p = w("malformed.toml", "[render\nwidth = 3");
    assert_bad_input(&["render", &p, "--out", o], "malformed.toml", "line", &out);
    let p = w("unknown.toml", &GOOD.replace("spp = 2", "spp = 2\nspeed = 3"));
    assert_bad_input(&["render", &p, "--out", o], "unknown.toml", "unknown field", &out);
    let p = w("absurd.toml", &GOOD.replace("width = 8", "width = 1000000"));
    assert_bad_input(&["render", &p, "--out", o], "absurd.toml", "resolution", &out);
    assert_bad_input(
        &["render", d.join("missing.toml").to_str().unwrap(), "--out", o],
        "missing.toml",
        "cannot read",
        &out,
    );
    let p = w(
        "missing-env.toml",
        &GOOD.replace(
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"envmap\"\nfile = \"nowhere.hdr\"\nmapping = \"latlong\"",
        ),
    );
    assert_bad_input(&["render", &p, "--out", o], "nowhere.hdr", "cannot read", &out);
    std::fs::write(d.join("corrupt.hdr"), b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 64 +X 64\n\x02\x02\x00").unwrap();
    let p = w(
        "corrupt-env.toml",
        &GOOD.replace(
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"envmap\"\nfile = \"corrupt.hdr\"\nmapping = \"latlong\"",
        ),
    );
    assert_bad_input(&["render", &p, "--out", o], "corrupt.hdr", "corrupt", &out);
    std::fs::write(d.join("corrupt.exr"), b"v/1\x01 garbage that is not an exr").unwrap();
    let p = w(
        "corrupt-exr.toml",
        &GOOD.replace(
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"envmap\"\nfile = \"corrupt.exr\"\nmapping = \"latlong\"",
        ),
    );
    assert_bad_input(&["render", &p, "--out", o], "corrupt.exr", "", &out);
    write_nan_exr(&d.join("nan.exr"));
    let p = w(
        "nan-env.toml",
        &GOOD.replace(
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"envmap\"\nfile = \"nan.exr\"\nmapping = \"latlong\"",
        ),
    );
    assert_bad_input(&["render", &p, "--out", o], "nan.exr", "non-finite", &out);
    let p = w("neg.toml", &GOOD.replace("albedo = 0.5", "albedo = -0.5"));
    assert_bad_input(&["render", &p, "--out", o], "neg.toml", "albedo", &out);
    // The good scene does render, and writes the file.
    let p = w("good.toml", GOOD);
    let (code, err) = reflect(&["render", &p, "--out", o, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.exists());
}

/// A 8×4 lat-long float EXR with one NaN pixel.
fn write_nan_exr(path: &Path) {
    use exr::prelude::*;
    let mut v = vec![0.5f32; 32];
    v[5] = f32::NAN;
    let chans = AnyChannels::sort(smallvec::smallvec![
        AnyChannel::new("R", FlatSamples::F32(v.clone())),
        AnyChannel::new("G", FlatSamples::F32(v.clone())),
        AnyChannel::new("B", FlatSamples::F32(v)),
    ]);
    Image::from_channels((8, 4), chans).write().to_file(path).unwrap();
}

/// `reflect invert separate` / `invert factor` refuse what they cannot use, through the binary.
#[test]
fn invert_separate_and_factor_refuse_bad_input() {
    let d = temp_dir("cli-errors-invert");
    let w = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let render = |toml: &str, exr: &str| {
        let out = d.join(exr);
        let (code, err) =
            reflect(&["render", &w(&format!("{exr}.toml"), toml), "--out", out.to_str().unwrap(), "--quiet"]);
        assert_eq!(code, 0, "{err}");
        out.to_str().unwrap().to_string()
    };
    let ortho = render(GOOD, "ortho.exr");
    // Normal-probe views at θ_o = 60° (the one ring of a 1 × 4 rule: μ = 1/2), φ_o = 0, 90, 180.
    let probe = |phi: u32| {
        let toml = GOOD
            .replace("width = 8", "width = 16")
            .replace(
                "type = \"orthographic\"",
                &format!("type = \"normal-probe\"\ntheta_o_deg = 60.0\nphi_o_deg = {phi}.0"),
            )
            .replace("from = [3.0, 0.0, 0.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05\n", "");
        render(&toml, &format!("p{phi}.exr"))
    };
    let (p0, p90, p180) = (probe(0), probe(90), probe(180));
    let env = d.join("env.exr");
    let e = env.to_str().unwrap();
    assert_bad_input(&["invert", "separate", &ortho, &p0, "--output", e], "ortho.exr", "normal-probe", &env);
    assert_bad_input(
        &["invert", "separate", d.join("gone.exr").to_str().unwrap(), &p0, "--output", e],
        "gone.exr",
        "cannot read",
        &env,
    );
    assert_bad_input(&["invert", "factor", &ortho, "--lmax", "1"], "ortho.exr", "normal-probe", &env);
    assert_bad_input(
        &["invert", "factor", &p0, &p90, &p180, "--nodes", "1x4", "--lmax", "1"],
        "270",
        "missing node",
        &env,
    );
    assert_bad_input(&["invert", "factor", &p0, &p90, &p180, &p180, "--lmax", "1"], "p180.exr", "", &env);
}

/// Mesh files of the kinds in `../shared/cases` (issue 9): forbidden glTF index types, node graphs
/// that are not trees, and a malformed OBJ. Exit 2, one line naming the mesh file, no output file,
/// no panic and no hang.
#[test]
fn bad_mesh_files_exit_2_with_one_line() {
    let d = temp_dir("cli-errors-mesh");
    let out = d.join("out.exr");
    let o = out.to_str().unwrap();
    let cases = root().join("../shared/cases");
    for (scene, file, mentions) in [
        (
            "gltf-index-types/i8_invalid.toml",
            "i8_invalid.gltf",
            "accessor 1 (indices of mesh 0 primitive 0) has component type signed byte",
        ),
        (
            "gltf-index-types/i16_invalid.toml",
            "i16_invalid.gltf",
            "accessor 1 (indices of mesh 0 primitive 0) has component type signed short",
        ),
        (
            "gltf-index-types/f32_invalid.toml",
            "f32_invalid.gltf",
            "accessor 1 (indices of mesh 0 primitive 0) has component type float",
        ),
        ("gltf-node-graph/c_duplicate_child_chain.toml", "c_duplicate_child_chain.gltf", "node 1 is listed twice"),
        ("gltf-node-graph/d_two_parent_dag.toml", "d_two_parent_dag.gltf", "more than one parent"),
    ] {
        assert_bad_input(&["render", cases.join(scene).to_str().unwrap(), "--out", o], file, mentions, &out);
    }
    // A malformed OBJ next to a scene that uses it.
    let scene =
        std::fs::read_to_string(cases.join("obj-bom/reference.toml")).unwrap().replace("reference.obj", "bad.obj");
    std::fs::write(d.join("bad.toml"), scene).unwrap();
    std::fs::write(d.join("bad.obj"), "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 0\r\n").unwrap();
    assert_bad_input(&["render", d.join("bad.toml").to_str().unwrap(), "--out", o], "bad.obj", "line 4", &out);
}
