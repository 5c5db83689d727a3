//! Bad input through the real binary: exit code 2, one line on stderr naming the file and the
//! problem, and no output file.

mod common;
use common::*;
use std::path::Path;
use std::process::Command;

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
    // Environment maps that cannot be read, each named by the error.
    std::fs::write(d.join("corrupt.hdr"), b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 64 +X 64\n\x02\x02\x00").unwrap();
    std::fs::write(d.join("corrupt.exr"), b"v/1\x01 garbage that is not an exr").unwrap();
    write_nan_exr(&d.join("nan.exr"));
    for (i, (map, mentions)) in [
        ("nowhere.hdr", "cannot read"),
        ("corrupt.hdr", "corrupt"),
        ("corrupt.exr", "corrupt OpenEXR"),
        ("nan.exr", "non-finite"),
    ]
    .into_iter()
    .enumerate()
    {
        let lighting = format!("type = \"envmap\"\nfile = \"{map}\"\nmapping = \"latlong\"");
        let p = w(&format!("env-{i}.toml"), &GOOD.replace("type = \"uniform\"\nradiance = 1.0", &lighting));
        assert_bad_input(&["render", &p, "--out", o], map, mentions, &out);
    }
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
    let render = |toml: &str, exr: &str| render_to(&d, exr, toml);
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
    // Two files at one node (a copy: the same file twice is refused before, as any repeated image).
    let copy = d.join("p180-copy.exr");
    std::fs::copy(&p180, &copy).unwrap();
    let c = copy.to_str().unwrap();
    assert_bad_input(&["invert", "factor", &p0, &p90, &p180, c, "--lmax", "1"], "p180", "same node", &env);
    assert_bad_input(
        &["invert", "factor", &p0, &p90, &p180, &p180, "--lmax", "1"],
        "p180.exr",
        "given more than once",
        &env,
    );
}

/// Files in `dir` whose name marks a temporary output.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect()
}

/// Renders `toml` (GOOD with replacements) to `dir/name`, through the binary.
/// A render of a sphere with an albedo texture is refused by analyze and invert (which assume a
/// uniform albedo), not analysed as uniform. Planted: without the check `analyze` exits 0 and
/// prints a filter of the uniform model.
#[test]
fn textured_sphere_is_refused_by_analyze_and_invert() {
    let d = temp_dir("cli-textured");
    let none = d.join("no-output.exr");
    let tex = "{ type = \"lambert\", albedo = 0.5 }\ntexture = { type = \"sh\", coefficients = [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0], [0.3, 0.3, 0.3], [0.0, 0.0, 0.0]] }";
    let p = render_to(&d, "textured.exr", &probe_toml(0.0, 0.0, tex));
    assert_bad_input(&["analyze", &p, "--lmax", "2"], "textured.exr", "texture", &none);
    assert_bad_input(&["invert", "lighting", &p, "--lmax", "2"], "textured.exr", "texture", &none);
}

fn probe_toml(theta_o: f64, phi_o: f64, brdf: &str) -> String {
    GOOD.replace("width = 8", "width = 32")
        .replace("height = 8", "height = 16")
        .replace(
            "type = \"orthographic\"",
            &format!("type = \"normal-probe\"\ntheta_o_deg = {theta_o:?}\nphi_o_deg = {phi_o:?}"),
        )
        .replace("from = [3.0, 0.0, 0.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05\n", "")
        .replace("brdf = { type = \"lambert\", albedo = 0.5 }", &format!("brdf = {brdf}"))
}

/// Every command that writes a file writes it whole or not at all: an output path that cannot be
/// written (here an existing directory, so the temporary file can be written and only the final
/// rename fails) gives exit 2, one line naming it, no output, and no temporary file left behind; a
/// `--png` that cannot be written leaves no EXR either.
#[test]
fn outputs_are_atomic() {
    let d = temp_dir("cli-atomic");
    let blocker = d.join("a-directory");
    std::fs::create_dir(&blocker).unwrap();
    std::fs::write(blocker.join("keep"), "x").unwrap();
    let b = blocker.to_str().unwrap();
    let scene = d.join("good.toml");
    std::fs::write(&scene, GOOD).unwrap();
    let s = scene.to_str().unwrap();
    let exr = d.join("out.exr");
    let e = exr.to_str().unwrap();

    // render --png to an unwritable path: the EXR must not be left behind.
    let (code, out, err) = reflect_out(&["render", s, "--out", e, "--png", b, "--quiet"]);
    assert_eq!(code, 2, "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("a-directory"), "{err}");
    assert!(out.is_empty() && !exr.exists(), "the EXR was written although the PNG failed");
    assert!(temporaries(&d).is_empty(), "temporaries left: {:?}", temporaries(&d));
    // render --out onto a directory.
    let bexr = d.join("b.exr");
    std::fs::create_dir(&bexr).unwrap();
    std::fs::write(bexr.join("keep"), "x").unwrap();
    let (code, _, err) = reflect_out(&["render", s, "--out", bexr.to_str().unwrap(), "--quiet"]);
    assert_eq!((code, err.trim().lines().count()), (2, 1), "{err}");
    assert!(temporaries(&d).is_empty(), "temporaries left: {:?}", temporaries(&d));

    // invert lighting / invert separate --output onto a directory.
    let probe = render_to(&d, "probe.exr", &probe_toml(0.0, 0.0, "{ type = \"lambert\", albedo = 0.5 }"));
    let (code, out, err) = reflect_out(&["invert", "lighting", &probe, "--lmax", "2", "--output", b]);
    assert_eq!((code, err.trim().lines().count()), (2, 1), "{err}");
    assert!(err.contains("a-directory") && out.is_empty(), "{err}");
    assert!(temporaries(&d).is_empty(), "temporaries left: {:?}", temporaries(&d));
    let mix = "{ type = \"mix\", layers = [ { weight = 0.5, brdf = { type = \"lambert\", albedo = 1.0 } }, { weight = 0.5, brdf = { type = \"mirror\" } } ] }";
    let v0 = render_to(&d, "s0.exr", &probe_toml(0.0, 0.0, mix));
    let v1 = render_to(&d, "s1.exr", &probe_toml(50.0, 0.0, mix));
    let v2 = render_to(&d, "s2.exr", &probe_toml(50.0, 180.0, mix));
    // The same command with a writable output succeeds (so the failure above is the output's).
    let ok = d.join("sep.exr");
    let (code, _, err) =
        reflect_out(&["invert", "separate", &v0, &v1, &v2, "--lmax", "2", "--output", ok.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(ok.exists());
    let (code, out, err) = reflect_out(&["invert", "separate", &v0, &v1, &v2, "--lmax", "2", "--output", b]);
    assert_eq!((code, err.trim().lines().count()), (2, 1), "{err}");
    assert!(err.contains("a-directory") && out.is_empty(), "{err}");
    assert!(temporaries(&d).is_empty(), "temporaries left: {:?}", temporaries(&d));
}

/// Bad input to the analysis commands, through the binary: exit 2, one line naming the file or the
/// argument, nothing on stdout.
#[test]
fn analysis_commands_refuse_bad_input() {
    let d = temp_dir("cli-errors-analysis");
    let missing = d.join("missing.exr");
    let m = missing.to_str().unwrap();
    let junk = d.join("junk.exr");
    std::fs::write(&junk, b"v/1\x01 not an exr at all").unwrap();
    let j = junk.to_str().unwrap();
    let oblong = d.join("oblong.exr");
    write_nan_exr(&oblong); // 8 × 4 with a NaN
    let o = oblong.to_str().unwrap();
    let probe = render_to(&d, "probe.exr", &probe_toml(0.0, 0.0, "{ type = \"lambert\", albedo = 0.5 }"));
    let probe_other_path = d.join(".").join("probe.exr").to_str().unwrap().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["analyze", m, "--lmax", "2"], "missing.exr"),
        (vec!["analyze", j, "--lmax", "2"], "junk.exr"),
        (vec!["analyze", &probe, "--lmax", "100000"], "lmax"),
        (vec!["analyze", &probe, "--lmax", "2", "--lighting", m], "missing.exr"),
        (vec!["sh", "project", m, "--lmax", "2"], "missing.exr"),
        (vec!["sh", "project", j, "--lmax", "2"], "junk.exr"),
        (vec!["sh", "project", o, "--lmax", "2"], "oblong.exr"),
        (vec!["sh", "project", &probe, "--lmax", "2", "--mapping", "mercator"], "mercator"),
        (vec!["sh", "transfer", "--brdf", "velvet", "--lmax", "2"], "velvet"),
        (vec!["sh", "transfer", "--brdf", "phong", "--lmax", "2"], "--s"),
        (vec!["sh", "transfer", "--brdf", "mix", "--lmax", "2"], "no transfer model"),
        (vec!["sh", "transfer", "--brdf", "microfacet", "--lmax", "2"], "needs --brdf-param alpha"),
        (
            vec![
                "sh",
                "transfer",
                "--brdf",
                "microfacet",
                "--brdf-param",
                "alpha=0.3",
                "--brdf-param",
                "distribution=phong",
                "--lmax",
                "2",
            ],
            "unknown distribution \"phong\"",
        ),
        (vec!["sh", "transfer", "--brdf", "phong", "--s", "-1", "--lmax", "2"], "-1"),
        (vec!["invert", "lighting", m, "--lmax", "2"], "missing.exr"),
        (vec!["invert", "lighting", j, "--lmax", "2"], "junk.exr"),
        (vec!["invert", "lighting", &probe, "--lmax", "2", "--brdf", "velvet"], "velvet"),
        (vec!["invert", "brdf", m, "--model", "phong", "--lmax", "4"], "missing.exr"),
        (vec!["invert", "brdf", &probe, "--model", "velvet", "--lmax", "4"], "velvet"),
        (vec!["invert", "brdf", &probe, "--model", "phong", "--lmax", "4", "--lighting", m], "missing.exr"),
        // One image twice (by the same or another path to it) would count its pixels twice.
        (vec!["analyze", &probe, &probe, "--lmax", "2"], "given more than once"),
        (vec!["analyze", &probe, &probe_other_path, "--lmax", "2"], "given more than once"),
        (vec!["invert", "lighting", &probe, &probe, "--lmax", "2"], "given more than once"),
        (vec!["invert", "brdf", &probe, &probe, "--model", "phong", "--lmax", "4"], "given more than once"),
        (vec!["invert", "separate", &probe, &probe, "--lmax", "2"], "given more than once"),
        (vec!["invert", "factor", &probe, &probe, "--lmax", "2"], "given more than once"),
    ];
    for (args, names) in cases {
        let (code, out, err) = reflect_out(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(names), "{args:?} should name {names}: {err}");
        assert!(out.is_empty(), "{args:?} printed {out}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// clap's own usage errors and --threads 0 are bad input like any other: one line, exit 2.
#[test]
fn usage_errors_are_one_line() {
    let d = temp_dir("cli-usage");
    let scene = d.join("good.toml");
    std::fs::write(&scene, GOOD).unwrap();
    let s = scene.to_str().unwrap();
    let out = d.join("o.exr");
    let o = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["render", s, "--out", o, "--no-such-flag"], "--no-such-flag"),
        (vec!["render", s, "--out", o, "--spp", "many"], "many"),
        (vec!["render", s, "--out", o, "--size", "37by23"], "37by23"),
        (vec!["render", s, "--out", o, "--threads", "0"], "--threads"),
        (vec!["verify", "--threads", "0", "--check", "mirror", "--out", o], "--threads"),
        (vec!["sh", "transfer", "--brdf", "lambert"], "--lmax"),
        (vec!["sh", "project"], "ENV"),
        (vec!["analyze", "--lmax", "2"], "IMAGES"),
        (vec!["no-such-command"], "no-such-command"),
        (vec!["invert", "brdf", s, "--lmax", "2"], "--model"),
        // Closed sets are clap value enums, refused by name; `--rule` is gone (it meant two things).
        (vec!["invert", "lighting", s, "--lmax", "2", "--rule", "gcv"], "--rule"),
        (vec!["invert", "lighting", s, "--lmax", "2", "--lambda-rule", "magic"], "magic"),
        (vec!["invert", "factor", s, "--lmax", "2", "--quadrature", "simpson"], "simpson"),
        (vec!["invert", "separate", s, "--channel", "alpha"], "alpha"),
        (vec!["analyze", s, "--lmax", "2", "--param", "sideways"], "sideways"),
    ];
    for (args, names) in cases {
        let (code, stdout, err) = reflect_out(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(names), "{args:?} should name {names}: {err}");
        assert!(stdout.is_empty() && !out.exists(), "{args:?}");
    }
    // --help is not an error.
    let (code, stdout, _) = reflect_out(&["render", "--help"]);
    assert_eq!(code, 0);
    assert!(stdout.contains("--threads"));
}

/// The same seed gives the same image bits whatever the thread count, through `reflect render`, on a
/// size that is not a multiple of the tile (37 × 23), for the three samplers and the jittered
/// normal-probe camera; the EXR files' pixel layers are compared.
#[test]
fn same_bits_for_1_3_7_threads_through_the_binary() {
    let d = temp_dir("cli-threads");
    let env = format!("type = \"envmap\"\nfile = \"{}\"\nmapping = \"angular\"", grace().display());
    let ts = "{ type = \"torrance-sparrow\", sigma = 0.2 }";
    let scenes = [
        (
            "sobol",
            GOOD.replace("spp = 2", "spp = 4\nsampler = \"sobol\"").replace("type = \"uniform\"\nradiance = 1.0", &env),
        ),
        (
            "independent",
            GOOD.replace("spp = 2", "spp = 4\nsampler = \"independent\"")
                .replace("type = \"uniform\"\nradiance = 1.0", &env),
        ),
        (
            "sobol-single",
            GOOD.replace("spp = 2", "spp = 4\nsampler = \"sobol-single\"")
                .replace("type = \"uniform\"\nradiance = 1.0", &env),
        ),
        (
            "probe-jitter",
            probe_toml(30.0, 90.0, ts)
                .replace("phi_o_deg = 90.0", "phi_o_deg = 90.0\njitter = true")
                .replace("type = \"uniform\"\nradiance = 1.0", &env),
        ),
    ];
    for (name, toml) in scenes {
        let scene = d.join(format!("{name}.toml"));
        std::fs::write(&scene, &toml).unwrap();
        let images: Vec<analysis::image::Image> = ["1", "3", "7"]
            .iter()
            .map(|t| {
                let out = d.join(format!("{name}-{t}.exr"));
                let (code, err) = reflect(&[
                    "render",
                    scene.to_str().unwrap(),
                    "--out",
                    out.to_str().unwrap(),
                    "--threads",
                    t,
                    "--size",
                    "37x23",
                    "--quiet",
                ]);
                assert_eq!(code, 0, "{err}");
                analysis::image::read_image(&out).unwrap()
            })
            .collect();
        assert_eq!((images[0].width, images[0].height), (37, 23));
        assert!(images[0].channels.len() >= 10, "{:?}", images[0].channels.keys());
        for img in &images[1..] {
            assert_eq!(img.channels.keys().collect::<Vec<_>>(), images[0].channels.keys().collect::<Vec<_>>());
            for (k, v) in &images[0].channels {
                let same = v.iter().zip(&img.channels[k]).all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "{name}: channel {k} differs between thread counts");
            }
        }
        // Not vacuous: the image has content and another seed changes it.
        let out = d.join(format!("{name}-seed.exr"));
        let (code, err) = reflect(&[
            "render",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--size",
            "37x23",
            "--seed",
            "9",
            "--quiet",
        ]);
        assert_eq!(code, 0, "{err}");
        let other = analysis::image::read_image(&out).unwrap();
        assert!(images[0].channels["R"].iter().zip(&other.channels["R"]).any(|(a, b)| a != b), "{name}");
    }
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

/// Issue 33, kind 6 (`sphere-huge`): a ground sphere of radius 1e19 beside a unit sphere panicked
/// inside obvhs (its surface-area costs overflow f32), a lone sphere of radius 1e30 rendered
/// nothing (r² overflows): both exit 2 with one line naming the scene, the object and the limit.
#[test]
fn huge_spheres_exit_2_naming_the_object_and_the_limit() {
    let d = temp_dir("cli-errors-huge");
    let out = d.join("out.exr");
    let o = out.to_str().unwrap();
    let cases = root().join("../shared/cases/sphere-huge");
    for (scene, mentions) in [
        ("ground_1e19.toml", "objects[0]: sphere (centre [0.0, 0.0, -1e19], radius 1e19) reaches 2.000e19"),
        ("alone_1e30.toml", "objects[0]: sphere (centre [0.0, 0.0, -1e30], radius 1e30) reaches 2.000e30"),
    ] {
        assert_bad_input(&["render", cases.join(scene).to_str().unwrap(), "--out", o], scene, mentions, &out);
        assert_bad_input(&["render", cases.join(scene).to_str().unwrap(), "--out", o], scene, "limit is 1e10", &out);
    }
}

/// glTF features that change the geometry and cannot be honoured (issue 33): a morph weight count
/// that does not match the targets, a skin, a required extension reflect does not implement.
/// Each is refused through the binary: exit 2, one line naming the file and the feature, no output.
#[test]
fn gltf_geometry_features_refused_by_name() {
    let d = temp_dir("cli-errors-gltf-geometry");
    let out = d.join("out.exr");
    let o = out.to_str().unwrap();
    let cases = root().join("../shared/cases/gltf-morph-targets");
    let gltf = std::fs::read_to_string(cases.join("mesh_weights_1.gltf")).unwrap();
    let toml = std::fs::read_to_string(cases.join("mesh_weights_1.toml")).unwrap();
    let edits = [
        (
            "weights.gltf",
            gltf.replace(r#""weights": [1.0]"#, r#""weights": [1.0, 0.5]"#),
            "mesh 0: 2 morph weights for 1 morph targets",
        ),
        (
            "skinned.gltf",
            gltf.replace(
                r#""nodes": [{"mesh": 0}]"#,
                r#""skins": [{"joints": [0]}], "nodes": [{"mesh": 0, "skin": 0}]"#,
            ),
            "node 0 uses skin 0",
        ),
        (
            "required.gltf",
            gltf.replacen(
                '{',
                r#"{"extensionsUsed": ["EXT_foo_geometry"], "extensionsRequired": ["EXT_foo_geometry"], "#,
                1,
            ),
            "requires the extension EXT_foo_geometry",
        ),
    ];
    for (file, text, mentions) in edits {
        assert!(text != gltf, "{file}: the edit applies");
        std::fs::write(d.join(file), text).unwrap();
        let scene = d.join(format!("{file}.toml"));
        std::fs::write(&scene, toml.replace("mesh_weights_1.gltf", file)).unwrap();
        assert_bad_input(&["render", scene.to_str().unwrap(), "--out", o], file, mentions, &out);
    }
}

/// `reflect … --json` on good input: exit 0 and the JSON document.
/// Issue 18, analysis at the edges: orders the input cannot carry, transfer coefficients at the
/// limits of their parameters, exitance angles and BRDF parameters from headers, and degenerate
/// `stderr` layers — each refused through the binary (exit 2, one line naming the file) or given
/// its right value.
#[test]
fn analysis_at_the_edges() {
    use analysis::image::{read_image, write_exr};
    let d = temp_dir("cli-edges");
    let render = |toml: &str, exr: &str| render_to(&d, exr, toml);
    let probe_toml = |w: u32, h: u32| {
        GOOD.replace("width = 8\nheight = 8", &format!("width = {w}\nheight = {h}")).replace(
            "type = \"orthographic\"\nfrom = [3.0, 0.0, 0.0]\nto = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nextent = 1.05",
            "type = \"normal-probe\"",
        )
    };
    let none = d.join("no-output.exr");

    // Orders the data cannot carry. A 16 × 8 normal-probe grid carries l ≤ 7 (|m| < W/2, l < H);
    // at --lmax 20 it once reported all 21 orders "recovered" with L_16,0 = −4.43 (exact 0).
    let p16 = render(&probe_toml(16, 8), "p16.exr");
    assert_bad_input(&["invert", "lighting", &p16, "--lmax", "20"], "p16.exr", "l = 7", &none);
    assert_bad_input(&["analyze", &p16, "--lmax", "8"], "p16.exr", "l = 7", &none);
    assert_bad_input(&["invert", "brdf", &p16, "--model", "phong", "--lmax", "8"], "p16.exr", "l = 7", &none);
    // At the limit it is accepted and says so; uniform radiance 1 on a lambert sphere: L_00 = √(4π)
    // within 4 of its reported standard errors (2 spp: σ ≈ 2 % of L_00).
    let doc = reflect_json(&["invert", "lighting", &p16, "--lmax", "7", "--json"]);
    assert_eq!(doc["lmax_carried"], 7);
    let (l00, se) = (doc["coefficients"][0][0].as_f64().unwrap(), doc["stderr"][0][0].as_f64().unwrap());
    assert!((l00 - (4.0 * std::f64::consts::PI).sqrt()).abs() < 4.0 * se, "L_00 = {l00} ± {se}");
    assert_eq!(reflect_json(&["analyze", &p16, "--lmax", "7", "--json"])["lmax_carried"], 7);
    // Synthesis: a 4 × 2 map carries l ≤ 1, so --lmax 8 is refused (it once wrote a map that
    // projected back 260 % off its own coefficients), naming the output file, which is not written.
    let p32 = render(&probe_toml(32, 16), "p32.exr");
    let env = d.join("env.exr");
    let e = env.to_str().unwrap();
    assert_bad_input(
        &["invert", "lighting", &p32, "--lmax", "8", "--output", e, "--width", "4"],
        "env.exr",
        "l = 1",
        &env,
    );
    // Orthographic views: the sphere is 8/1.05 = 7.6 pixels across, so l ≤ 6 in the normal
    // parameterization and l ≤ 2 in the reflection one (which --lmax 3 once fitted from 32 pixels).
    let ortho = render(GOOD, "ortho.exr");
    assert_bad_input(&["analyze", &ortho, "--lmax", "7"], "ortho.exr", "l = 6", &none);
    assert_bad_input(&["analyze", &ortho, "--param", "reflection", "--lmax", "3"], "ortho.exr", "l = 2", &none);

    // Transfer coefficients at the ends of the parameter range: σ → 0 is the mirror (Λ_l ρ̂_l = 1);
    // σ = 1e-160 once printed NaN/inf.
    for theta in ["0", "45"] {
        let doc = reflect_json(&[
            "sh",
            "transfer",
            "--brdf",
            "torrance-sparrow",
            "--sigma",
            "1e-160",
            "--theta-o",
            theta,
            "--lmax",
            "16",
            "--json",
        ]);
        for v in doc["lambda_rho"].as_array().unwrap() {
            assert!((v.as_f64().unwrap() - 1.0).abs() < 1e-12, "θ_o {theta}: {v}");
        }
    }
    // And no fit accepts a non-finite objective: `invert brdf --min 1e-200` on a σ = 0.1 render
    // once returned σ̂ = 1e-200 with a null χ²; now the whole range gives the default range's fit.
    let ts = GOOD
        .replace("width = 8\nheight = 8\nspp = 2", "width = 48\nheight = 48\nspp = 8")
        .replace(
            "type = \"uniform\"\nradiance = 1.0",
            &format!("type = \"envmap\"\nfile = \"{}\"\nmapping = \"angular\"", grace().display()),
        )
        .replace(
            "brdf = { type = \"lambert\", albedo = 0.5 }",
            "brdf = { type = \"torrance-sparrow\", ks = 1.0, sigma = 0.1, horizon = \"ignore\" }",
        );
    let ts = render(&ts, "ts.exr");
    let fit = |range: &[&str]| {
        let mut args = vec!["invert", "brdf", &ts, "--model", "torrance-sparrow", "--lmax", "8", "--json"];
        args.extend_from_slice(range);
        reflect_json(&args)
    };
    let (default, wide) = (fit(&[]), fit(&["--min", "1e-200", "--max", "1"]));
    let (s0, s1) = (default["estimate"].as_f64().unwrap(), wide["estimate"].as_f64().unwrap());
    assert!(wide["chi2_min"].as_f64().is_some_and(f64::is_finite), "{}", wide["chi2_min"]);
    assert!((s1 / s0 - 1.0).abs() < 1e-6, "σ̂ {s1} over [1e-200, 1] vs {s0} over the default range");
    assert!((s0 - 0.1).abs() < 0.03, "σ̂ = {s0}");

    // Exitance angles and BRDF parameters from a header go through the same checks as flags.
    let mut img = read_image(&p16).unwrap();
    for (theta, name) in [("90", "theta90.exr"), ("120", "theta120.exr")] {
        img.attributes.insert("reflect:camera".into(), format!(r#"{{"type":"normal-probe","theta_o_deg":{theta}}}"#));
        let p = d.join(name);
        write_exr(&p, &img).unwrap();
        let p = p.to_str().unwrap();
        assert_bad_input(&["analyze", p, "--lmax", "2"], name, "theta_o", &none);
        assert_bad_input(&["invert", "lighting", p, "--lmax", "2"], name, "theta_o", &none);
    }
    img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
    img.attributes.insert(
        "reflect:objects".into(),
        r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"torrance-sparrow","sigma":-0.1,"ks":1}}]"#
            .into(),
    );
    let bad_sigma = d.join("bad-sigma.exr");
    write_exr(&bad_sigma, &img).unwrap();
    let bs = bad_sigma.to_str().unwrap();
    assert_bad_input(&["analyze", bs, "--lmax", "2"], "bad-sigma.exr", "sigma", &none);
    assert_bad_input(&["invert", "lighting", bs, "--lmax", "2"], "bad-sigma.exr", "sigma", &none);

    // `stderr` layers: a negative value is refused (it was squared silently) ...
    let mut img = read_image(&ts).unwrap();
    img.channels.get_mut("stderr.G").unwrap()[5] = -0.1;
    let neg = d.join("negative-stderr.exr");
    write_exr(&neg, &img).unwrap();
    let n = neg.to_str().unwrap();
    assert_bad_input(&["analyze", n, "--lmax", "2"], "negative-stderr.exr", "stderr.G", &none);
    // ... and a layer that is zero everywhere cannot weight a fit: a pixel-centre normal probe
    // under a directional source is deterministic, so reflect itself writes σ = 0 there. It once
    // failed with "least-squares system is singular … unknown 0 of 7", naming neither file nor cause.
    let det = probe_toml(64, 32)
        .replace(
            "type = \"uniform\"\nradiance = 1.0",
            "type = \"directional\"\ndirection = [0.3, 0.2, 1.0]\nirradiance = 3.0",
        )
        .replace(
            "brdf = { type = \"lambert\", albedo = 0.5 }",
            "brdf = { type = \"torrance-sparrow\", ks = 1.0, sigma = 0.1, horizon = \"ignore\" }",
        );
    let det = render(&det, "deterministic.exr");
    assert_bad_input(
        &["invert", "brdf", &det, "--model", "torrance-sparrow", "--lmax", "8"],
        "deterministic.exr",
        "stderr.R is zero at every pixel",
        &none,
    );
    // Where σ is only propagated, zero is an exact pixel: analyze reports B ± 0.
    let doc = reflect_json(&["analyze", &det, "--lmax", "4", "--json"]);
    assert_eq!(doc["stderr"][0][0].as_f64(), Some(0.0));
}

/// Issue 17: a flag that means one value per image (`analyze --from/--to/--up/--extent`) is given
/// not at all (`--to`/`--up` then default to 0,0,0 / 0,0,1) or once per image, in the order of the
/// images, and refuses a second image without its own; repeating a
/// flag that means one value (`--albedo`, `--kd`, `--center`, `--lmax`, `--model`, …) is refused by
/// clap as repeated, never concatenated into a wrong-length list with a misleading message. Every
/// refusal: exit 2, one line naming the flag.
#[test]
fn per_image_and_repeated_flags() {
    use analysis::image::{Image, write_exr};
    let d = temp_dir("cli-per-image");
    // Two headerless views of a sphere of constant radiance 1 (no camera in the header: the flags
    // give it), 32 × 32 and 16 × 16.
    let view = |name: &str, n: usize| {
        let mut img = Image { width: n, height: n, ..Default::default() };
        for ch in ["R", "G", "B"] {
            img.channels.insert(ch.to_string(), vec![1.0; n * n]);
        }
        let p = d.join(name);
        write_exr(&p, &img).unwrap();
        p.to_str().unwrap().to_string()
    };
    let (a, b) = (view("a.exr", 32), view("b.exr", 16));
    // Pixels whose whole footprint is on the unit sphere (centre distance + half diagonal < 1) in
    // an n × n view of half-width e looking at its centre: the analysis's rule, in closed form.
    let covered = |n: usize, e: f64| {
        let h = e / n as f64;
        (0..n * n)
            .filter(|i| {
                let (x, y) = (
                    e * (2.0 * ((i % n) as f64 + 0.5) / n as f64 - 1.0),
                    e * (1.0 - 2.0 * ((i / n) as f64 + 0.5) / n as f64),
                );
                x.hypot(y) + h * 2f64.sqrt() < 1.0
            })
            .count() as u64
    };
    let analyze = |extra: &[&str]| {
        let mut args = vec!["analyze", &a, &b, "--lmax", "2", "--json"];
        args.extend_from_slice(extra);
        let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(&args).output().unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    // One value per image, in order: the first image is seen at extent 1.05, the second at 2.
    let (code, stdout, stderr) = analyze(&[
        "--from", "3,0,0", "--extent", "1.05", "--from", "0,3,0", "--extent", "2", "--to", "0,0,0", "--to", "0,0,0",
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let doc: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let (right, swapped) = (covered(32, 1.05) + covered(16, 2.0), covered(32, 2.0) + covered(16, 1.05));
    assert_ne!(right, swapped);
    assert_eq!(doc["pixels_used"].as_u64(), Some(right), "pixels used (swapped flags would give {swapped})");

    // Not given at all, --to is 0,0,0 and --up 0,0,1 (world +z) for every image, as the guide and --help
    // say; given for some images only, they are refused like --from (below). A view whose radiance
    // varies by row tells a rotated up from the default; a shifted target moves the sphere.
    let grad = {
        let n = 24;
        let mut img = Image { width: n, height: n, ..Default::default() };
        for ch in ["R", "G", "B"] {
            img.channels.insert(ch.to_string(), (0..n * n).map(|i| 1.0 + (i / n) as f32 / n as f32).collect());
        }
        let p = d.join("grad.exr");
        write_exr(&p, &img).unwrap();
        p.to_str().unwrap().to_string()
    };
    let one = |extra: &[&str]| {
        let mut args = vec!["analyze", &grad, "--lmax", "2", "--json", "--from", "3,0,0", "--extent", "1.05"];
        args.extend_from_slice(extra);
        let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(0), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let default = one(&[]);
    assert_eq!(default, one(&["--to", "0,0,0", "--up", "0,0,1"]), "defaults --to 0,0,0 --up 0,0,1");
    assert_ne!(default, one(&["--up", "0,1,0"]), "--up changes the analysis of this view");
    assert_ne!(default, one(&["--to", "0,0.2,0"]), "--to changes the analysis of this view");

    let out = d.join("never.exr");
    let lam = view("probe.exr", 16);
    let cases: Vec<(Vec<&str>, &str, &str)> = vec![
        // A second image without its own value.
        (
            vec!["analyze", &a, &b, "--lmax", "2", "--from", "3,0,0", "--extent", "1.05"],
            "--from",
            "1 time for 2 images",
        ),
        (
            vec!["analyze", &a, &b, "--lmax", "2", "--from", "3,0,0", "--from", "0,3,0", "--extent", "1.05"],
            "--extent",
            "1 time for 2 images",
        ),
        (
            vec!["analyze", &a, "--lmax", "2", "--from", "3,0,0", "--from", "0,3,0", "--extent", "1"],
            "--from",
            "2 times for 1 image",
        ),
        // --to / --up have defaults only when absent for every image: given for one of two, refused.
        (
            vec![
                "analyze", &a, &b, "--lmax", "2", "--from", "3,0,0", "--from", "0,3,0", "--extent", "1", "--extent",
                "1", "--to", "0,0,0",
            ],
            "--to",
            "1 time for 2 images",
        ),
        (
            vec![
                "analyze", &a, &b, "--lmax", "2", "--from", "3,0,0", "--from", "0,3,0", "--extent", "1", "--extent",
                "1", "--up", "0,0,1",
            ],
            "--up",
            "1 time for 2 images",
        ),
        // Repeated one-value flags: refused as repeated.
        (vec!["analyze", &a, "--lmax", "2", "--center", "0,0,0", "--center", "1,0,0"], "--center", "multiple times"),
        (vec!["analyze", &a, "--lmax", "2", "--lmax", "3"], "--lmax", "multiple times"),
        (
            vec!["invert", "lighting", &lam, "--lmax", "2", "--albedo", "0.5", "--albedo", "0.6"],
            "--albedo",
            "multiple times",
        ),
        (
            vec!["invert", "brdf", &lam, "--lmax", "2", "--model", "phong", "--model", "phong"],
            "--model",
            "multiple times",
        ),
        (vec!["invert", "separate", &lam, "--kd", "0.5", "--kd", "0.6"], "--kd", "multiple times"),
        (vec!["invert", "separate", &lam, "--ks", "0.5", "--ks", "0.6"], "--ks", "multiple times"),
        (vec!["invert", "factor", &lam, "--channel", "r", "--channel", "g"], "--channel", "multiple times"),
        // A value of the wrong length is named as such.
        (vec!["invert", "lighting", &lam, "--lmax", "2", "--albedo", "0.5,0.5"], "--albedo", "one number or r,g,b"),
        (vec!["analyze", &a, "--lmax", "2", "--from", "3,0", "--extent", "1"], "--from", "three numbers"),
    ];
    for (args, names, mentions) in cases {
        assert_bad_input(&args, names, mentions, &out);
    }
}
