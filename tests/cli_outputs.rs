//! The numbers the analysis commands print, through the binary, against closed forms: `analyze`,
//! `sh transfer`, `sh project` (docs/src/conventions.md §7 JSON). Inputs are synthesised here from the
//! docs/src/conventions.md §3 check values of Y_lm (l ≤ 2), not from the analysis crate's basis.

mod common;
use analysis::image::{Image, write_exr};
use common::*;
use serde_json::Value;
use std::f64::consts::PI;
use std::path::Path;
use std::process::Command;

/// Y_lm, l ≤ 2, from the check values of docs/src/conventions.md §3 (k = l(l+1) + m).
fn y9(d: [f64; 3]) -> [f64; 9] {
    let [x, y, z] = d;
    [
        0.282_094_791_773_878_1,
        0.488_602_511_902_919_9 * y,
        0.488_602_511_902_919_9 * z,
        0.488_602_511_902_919_9 * x,
        1.092_548_430_592_079_2 * x * y,
        1.092_548_430_592_079_2 * y * z,
        0.315_391_565_252_520_05 * (3.0 * z * z - 1.0),
        1.092_548_430_592_079_2 * x * z,
        0.546_274_215_296_039_6 * (x * x - y * y),
    ]
}

fn latlong_dir(r: usize, c: usize, w: usize, h: usize) -> [f64; 3] {
    let (t, p) = (PI * (r as f64 + 0.5) / h as f64, 2.0 * PI * (c as f64 + 0.5) / w as f64);
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// A lat-long image of Σ_k coef_k Y_k (RGB), W × H.
fn sh_image(coef: &[[f64; 3]; 9], w: usize, h: usize) -> Image {
    let mut img = Image { width: w, height: h, ..Default::default() };
    for (ch, name) in ["R", "G", "B"].iter().enumerate() {
        let v = (0..w * h)
            .map(|i| {
                let y = y9(latlong_dir(i / w, i % w, w, h));
                (0..9).map(|k| coef[k][ch] * y[k]).sum::<f64>() as f32
            })
            .collect();
        img.channels.insert(name.to_string(), v);
    }
    img
}

fn arr(v: &Value) -> Vec<f64> {
    v.as_array().unwrap_or_else(|| panic!("not an array: {v}")).iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Lambert Λ_l ρ̂_l (albedo 1), docs/src/conventions.md §4.
const LAMBERT: [f64; 9] = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0, 0.0, 1.0 / 64.0, 0.0, -1.0 / 128.0];

/// `reflect analyze` of a Lambertian normal-probe image under SH lighting: B_lm = albedo Λ_l ρ̂_l L_lm
/// (eq. 15) exactly. Every number in its JSON is checked: the lighting (from the header, exact), the
/// analytic filter (exact), the prediction (exact), and the projected B_lm and measured filter, whose
/// only error is the lat-long quadrature of the 64 × 32 image. That error is O(h²); it is stated as
/// the difference between the 64 × 32 and 128 × 64 results (Richardson: the finer one's error is about
/// a third of it), and the 128 × 64 result must lie within it.
#[test]
fn analyze_normal_probe_numbers_against_closed_forms() {
    let d = temp_dir("cli-outputs-analyze");
    let l: [[f64; 3]; 9] = std::array::from_fn(|k| {
        if k == 0 { [2.0, 1.5, 1.0] } else { [0.2, -0.1, 0.05].map(|v| v * (1.0 + k as f64 / 4.0)) }
    });
    let albedo = [0.5, 0.4, 0.3];
    let lam_l =
        [LAMBERT[0], LAMBERT[1], LAMBERT[1], LAMBERT[1], LAMBERT[2], LAMBERT[2], LAMBERT[2], LAMBERT[2], LAMBERT[2]];
    let b: [[f64; 3]; 9] = std::array::from_fn(|k| [0, 1, 2].map(|ch| albedo[ch] * lam_l[k] * l[k][ch]));
    let run = |w: usize, h: usize| {
        let mut img = sh_image(&b, w, h);
        img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
        img.attributes.insert(
            "reflect:lighting".into(),
            serde_json::json!({"type": "sh", "coefficients": l.to_vec()}).to_string(),
        );
        img.attributes.insert(
            "reflect:objects".into(),
            r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"lambert","albedo":[0.5,0.4,0.3]}}]"#
                .into(),
        );
        let p = d.join(format!("probe-{w}.exr"));
        write_exr(&p, &img).unwrap();
        reflect_json(&["analyze", p.to_str().unwrap(), "--lmax", "2", "--json"])
    };
    let (coarse, fine) = (run(64, 32), run(128, 64));
    assert_eq!(fine["lmax"], 2);
    assert_eq!(fine["pixels_used"], 128 * 64);
    assert_eq!(fine["param"], "normal");
    for k in 0..9 {
        let lk = arr(&fine["lighting"]["coefficients"][k]);
        let pk = arr(&fine["predicted"][k]);
        let (bf, bc) = (arr(&fine["coefficients"][k]), arr(&coarse["coefficients"][k]));
        for ch in 0..3 {
            assert!((lk[ch] - l[k][ch]).abs() < 1e-12, "L_{k}: {} vs {}", lk[ch], l[k][ch]);
            assert!((pk[ch] - b[k][ch]).abs() < 1e-12, "predicted B_{k}: {} vs {}", pk[ch], b[k][ch]);
            // f32 pixels: + 1e-6 relative to the largest coefficient.
            let quad = (bf[ch] - bc[ch]).abs() + 1e-6 * b[0][ch];
            assert!((bf[ch] - b[k][ch]).abs() <= quad, "B_{k} ch{ch}: {} vs {} (± {quad:.1e})", bf[ch], b[k][ch]);
        }
    }
    for l_ in 0..=2 {
        let an = arr(&fine["lambda_rho_analytic"][l_]);
        let (ef, ec) = (arr(&fine["filter"][l_]["estimate"]), arr(&coarse["filter"][l_]["estimate"]));
        assert_eq!(fine["filter"][l_]["l"], l_);
        for ch in 0..3 {
            let expect = albedo[ch] * LAMBERT[l_];
            assert!((an[ch] - expect).abs() < 1e-12, "analytic l={l_}: {} vs {expect}", an[ch]);
            let quad = (ef[ch] - ec[ch]).abs() + 1e-6;
            assert!((ef[ch] - expect).abs() <= quad, "filter l={l_} ch{ch}: {} vs {expect} (± {quad:.1e})", ef[ch]);
        }
    }
    // The stated quadrature error is small (the tolerance is not vacuous): O(h²) ≈ (π/64)² relative.
    let (bf, bc) = (arr(&fine["coefficients"][6]), arr(&coarse["coefficients"][6]));
    assert!((bf[0] - bc[0]).abs() < 0.02 * b[6][0].abs(), "{} vs {}", bf[0], bc[0]);
}

/// `reflect sh transfer --json`: Λ_l ρ̂_l of docs/src/conventions.md §4 in closed form (Lambert's series, mirror
/// 1, Phong eq. 43 for s = 1 (the Lambert values) and s = 2 (1, 3/4, 2/5, 0 at l = 4 and 6), and
/// Torrance–Sparrow eq. 50 by a Simpson rule written here (error < 1e-9 at 20 000 panels).
#[test]
fn sh_transfer_numbers_against_closed_forms() {
    let get = |args: &[&str]| {
        let mut a = vec!["sh", "transfer"];
        a.extend_from_slice(args);
        a.extend_from_slice(&["--lmax", "8", "--json"]);
        let v = reflect_json(&a);
        assert_eq!(v["lmax"], 8);
        arr(&v["lambda_rho"])
    };
    let close = |got: &[f64], want: &[f64], tol: f64, what: &str| {
        assert_eq!(got.len(), want.len(), "{what}");
        for (l, (g, w)) in got.iter().zip(want).enumerate() {
            assert!((g - w).abs() <= tol, "{what} l={l}: {g} vs {w}");
        }
    };
    close(&get(&["--brdf", "lambert"]), &LAMBERT, 1e-12, "lambert");
    close(&get(&["--brdf", "mirror"]), &[1.0; 9], 1e-12, "mirror");
    close(&get(&["--brdf", "phong", "--s", "1"]), &LAMBERT, 1e-12, "phong s=1");
    let p2 = get(&["--brdf", "phong", "--s", "2"]);
    close(&p2[..3], &[1.0, 0.75, 0.4], 1e-12, "phong s=2");
    assert!(p2[4].abs() < 1e-12 && p2[6].abs() < 1e-12 && p2[8].abs() < 1e-12, "{p2:?}");
    // Eq. 50: 2π ∫_0^{π/2} exp(−θ²/4σ²)/(4πσ²) P_l(cos θ) sin θ dθ.
    let sigma = 0.2;
    let n = 20_000;
    let h = 0.5 * PI / n as f64;
    let mut ts = [0.0; 9];
    for i in 0..=n {
        let t = i as f64 * h;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let f = (-(t * t) / (4.0 * sigma * sigma)).exp() / (2.0 * sigma * sigma) * t.sin() * w * h / 3.0;
        let x = t.cos();
        let (mut p0, mut p1) = (1.0, x);
        ts[0] += f;
        ts[1] += f * x;
        for l in 1..8 {
            let p2 = ((2 * l + 1) as f64 * x * p1 - l as f64 * p0) / (l + 1) as f64;
            ts[l + 1] += f * p2;
            (p0, p1) = (p1, p2);
        }
    }
    close(&get(&["--brdf", "torrance-sparrow", "--sigma", "0.2"]), &ts, 1e-6, "torrance-sparrow σ=0.2");
}

/// `reflect sh project --json` of a lat-long map of known SH content (l ≤ 2, from the check values of
/// docs/src/conventions.md §3): L_lm within the lat-long quadrature error, stated as the difference between the
/// 64 × 32 and 128 × 64 maps (the finer one must lie within it), and higher orders ≈ 0 likewise.
#[test]
fn sh_project_numbers_against_closed_forms() {
    let d = temp_dir("cli-outputs-project");
    let l: [[f64; 3]; 9] = std::array::from_fn(|k| [1.0 + 0.1 * k as f64, 0.5 - 0.07 * k as f64, 0.3 * (k % 3) as f64]);
    let run = |w: usize, h: usize| {
        let p = d.join(format!("env-{w}.exr"));
        write_exr(&p, &sh_image(&l, w, h)).unwrap();
        let v = reflect_json(&["sh", "project", p.to_str().unwrap(), "--lmax", "3", "--json"]);
        assert_eq!(v["lmax"], 3);
        let c: Vec<Vec<f64>> = v["coefficients"].as_array().unwrap().iter().map(arr).collect();
        assert_eq!(c.len(), 16);
        c
    };
    let (coarse, fine) = (run(64, 32), run(128, 64));
    for k in 0..16 {
        for ch in 0..3 {
            let expect = if k < 9 { l[k][ch] } else { 0.0 };
            let quad = (fine[k][ch] - coarse[k][ch]).abs() + 1e-6;
            assert!((fine[k][ch] - expect).abs() <= quad, "L_{k} ch{ch}: {} vs {expect} (± {quad:.1e})", fine[k][ch]);
        }
    }
}

#[allow(dead_code)]
fn exists_any_tmp(dir: &Path) -> bool {
    std::fs::read_dir(dir).unwrap().any(|e| e.unwrap().file_name().to_string_lossy().contains(".tmp"))
}

/// Output into a pipe whose reader has gone (`reflect sh project … | head -1`) ends the process
/// quietly: no panic, nothing on stderr, killed by SIGPIPE (as `cat` or `yes` are) or exit 0. The
/// pipe's read end is closed before the child starts, so its first write fails with EPIPE.
#[cfg(unix)]
#[test]
fn closed_stdout_pipe_ends_quietly() {
    use std::os::unix::process::ExitStatusExt;
    let d = temp_dir("cli-outputs-pipe");
    let env = d.join("env.exr");
    let l: [[f64; 3]; 9] = std::array::from_fn(|k| [1.0 / (1 + k) as f64; 3]);
    write_exr(&env, &sh_image(&l, 32, 16)).unwrap();
    let e = env.to_str().unwrap();
    let runs: [&[&str]; 5] = [
        &["sh", "project", e, "--lmax", "4"],
        &["sh", "project", e, "--lmax", "4", "--json"],
        &["sh", "transfer", "--brdf", "lambert", "--lmax", "8"],
        &["sh", "transfer", "--brdf", "phong", "--s", "8", "--lmax", "20", "--json"],
        &["--help"],
    ];
    for args in runs {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).stdout(writer).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.is_empty(), "{args:?}: stderr {stderr:?}");
        assert!(out.status.success() || out.status.signal() == Some(13), "{args:?}: {:?} (SIGPIPE is 13)", out.status);
    }
}

/// The same scene and seed give the same file, byte for byte, from two processes (and with
/// different thread counts): the header's custom attributes used to come out in the `exr` crate's
/// hash-map order, which changes from one process to the next (`vocab::exr_order`).
#[test]
fn same_seed_same_file_bytes_from_two_processes() {
    let dir = temp_dir("same-bytes");
    let scene = root().join("scenes/lambert-grace.toml");
    let out = |name: &str, threads: &str| {
        let p = dir.join(name);
        let (code, err) = reflect(&[
            "render",
            scene.to_str().unwrap(),
            "--size",
            "16x16",
            "--spp",
            "4",
            "--threads",
            threads,
            "--quiet",
            "--out",
            p.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
        std::fs::read(p).unwrap()
    };
    let a = out("a.exr", "1");
    let b = out("b.exr", "2");
    assert!(a == b, "two renders of one seed differ in their bytes ({} vs {} bytes)", a.len(), b.len());
    let _ = std::fs::remove_dir_all(dir);
}

/// Every file under `dir` (symlinks as their targets' names, not followed) with its bytes.
fn snapshot(dir: &Path) -> std::collections::BTreeMap<std::path::PathBuf, Vec<u8>> {
    let mut m = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let meta = std::fs::symlink_metadata(&p).unwrap();
            if meta.file_type().is_symlink() {
                m.insert(p.clone(), std::fs::read_link(&p).unwrap().to_string_lossy().as_bytes().to_vec());
            } else if meta.is_dir() {
                m.insert(p.clone(), b"<dir>".to_vec());
                stack.push(p);
            } else {
                m.insert(p.clone(), std::fs::read(&p).unwrap());
            }
        }
    }
    m
}

/// Runs the binary in `dir`: exit 2, one `error:` line naming every string of `names`, and no file
/// under `dir` written, removed or changed.
fn refused_in(dir: &Path, args: &[&str], names: &[&str]) {
    let before = snapshot(dir);
    let out = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).current_dir(dir).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {:?}, stderr {err}", out.status);
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: one line expected, got {err}");
    assert!(lines[0].starts_with("error: "), "{args:?}: {err}");
    for n in names {
        assert!(lines[0].contains(n), "{args:?}: the error should name {n}: {err}");
    }
    assert!(out.stdout.is_empty(), "{args:?}: stdout {:?}", String::from_utf8_lossy(&out.stdout));
    assert!(snapshot(dir) == before, "{args:?}: files under {} changed", dir.display());
}

/// The case scene of `output-collisions`, copied into `dir` with its environment map copied beside it
/// (`env.exr`), so that the scene would render if the command were not refused.
fn case_scene(dir: &Path) -> (String, String) {
    let case = root().join("../shared/cases/output-collisions/s.toml");
    let text = std::fs::read_to_string(&case).unwrap_or_else(|e| panic!("{}: {e}", case.display()));
    assert!(text.contains("../../data/sky_latlong.exr"), "the case scene changed: {text}");
    std::fs::copy(root().join("../shared/data/sky_latlong.exr"), dir.join("env.exr")).unwrap();
    std::fs::write(dir.join("s.toml"), text.replace("../../data/sky_latlong.exr", "env.exr")).unwrap();
    (dir.join("s.toml").display().to_string(), dir.join("env.exr").display().to_string())
}

/// The three commands of the `output-collisions` case: each refused before any work, one line
/// naming both paths (or the extension), and nothing written over (the scene stays a scene, no
/// `out/` folder appears for the built-in scene's default output).
#[test]
fn output_collisions_case_commands_are_refused() {
    let d = temp_dir("outputs-case");
    let (s, _) = case_scene(&d);
    let same = d.join("same.exr").display().to_string();
    refused_in(&d, &["render", &s, "--checkpoint", &same, "--out", &same], &[&same, "--checkpoint", "--out"]);
    // The same file named two ways: `./same.exr` beside `same.exr`, with the file already there.
    std::fs::write(d.join("same.exr"), b"an earlier image").unwrap();
    refused_in(&d, &["render", &s, "--checkpoint", "./same.exr", "--out", "same.exr"], &["./same.exr", "same.exr"]);
    let img = d.join("img.exr").display().to_string();
    refused_in(&d, &["render", &s, "--out", &img, "--png", &img], &[&img, "--png", ".png"]);
    refused_in(&d, &["render", "--png", &s], &[&s, "--png", ".png", ".toml"]);
    refused_in(&d, &["render", "--png", "s.toml"], &["s.toml", ".png"]);
}

/// Every other command and output flag of the CLI against an input (by symlink, hard link, `./`
/// and `..` spellings) or another output. Commands without an output file (`analyze`, `sh project`,
/// `sh transfer`, `invert brdf`, `invert factor`) write only to stdout.
#[test]
fn no_command_writes_over_an_input_or_another_output() {
    let d = temp_dir("outputs-all");
    let (s, env) = case_scene(&d);
    let p = |n: &str| d.join(n).display().to_string();
    #[cfg(unix)]
    {
        // An .exr / .png name that is the scene file (the extension check alone would pass).
        std::os::unix::fs::symlink(d.join("s.toml"), d.join("scene-link.exr")).unwrap();
        std::os::unix::fs::symlink(d.join("s.toml"), d.join("scene-link.png")).unwrap();
        let (l_exr, l_png) = (p("scene-link.exr"), p("scene-link.png"));
        refused_in(&d, &["render", &s, "--out", &l_exr], &[&l_exr, &s, "--out"]);
        refused_in(&d, &["render", &s, "--png", &l_png, "--out", &p("o.exr")], &[&l_png, &s, "--png"]);
        refused_in(&d, &["render", &s, "--checkpoint", &l_exr, "--out", &p("o.exr")], &[&l_exr, &s]);
        refused_in(&d, &["slurm", "render", &s, "--tasks", "1", "--out", &l_exr, "--dry-run"], &[&l_exr, &s]);
        let sub = d.join("sub");
        std::fs::create_dir_all(&sub).unwrap();
        let inv = [&p("img.exr"), "--lmax", "2", "--output"];
        std::fs::write(d.join("img.exr"), b"not read").unwrap();
        let args = [&["invert", "lighting", "--scene", &s][..], &inv, &[&l_exr]].concat();
        refused_in(&d, &args, &[&l_exr, &s, "--output"]);
    }
    // The scene's environment map is an input too: as --out, --checkpoint, a shard's --out.
    refused_in(&d, &["render", &s, "--out", &env], &[&env, "--out"]);
    refused_in(&d, &["render", &s, "--checkpoint", &env, "--out", &p("o.exr")], &[&env, "--checkpoint"]);
    refused_in(&d, &["render", &s, "--shard", "0/2", "--out", "env.exr"], &["env.exr"]);
    refused_in(&d, &["slurm", "render", &s, "--tasks", "1", "--out", "./env.exr", "--dry-run"], &["./env.exr"]);
    // Two outputs that do not exist yet, spelled differently.
    std::fs::create_dir_all(d.join("sub")).unwrap();
    refused_in(&d, &["render", &s, "--out", "o.exr", "--checkpoint", "sub/../o.exr"], &["o.exr", "sub/../o.exr"]);
    // merge: a part as --out (same spelling, `./`, a hard link); a wrong extension.
    std::fs::write(d.join("part0.exr"), b"a part").unwrap();
    std::fs::write(d.join("part1.exr"), b"another part").unwrap();
    std::fs::hard_link(d.join("part1.exr"), d.join("merged.exr")).unwrap();
    let (p0, p1, m) = (p("part0.exr"), p("part1.exr"), p("merged.exr"));
    refused_in(&d, &["merge", &p0, &p1, "--out", &p1], &[&p1, "--out"]);
    refused_in(&d, &["merge", "part0.exr", "part1.exr", "--out", "./part0.exr"], &["./part0.exr", "part0.exr"]);
    refused_in(&d, &["merge", &p0, &p1, "--out", &m], &[&m, &p1]);
    refused_in(&d, &["merge", &p0, &p1, "--partial", "--out", &p("m.png")], &["m.png", ".exr"]);
    // png: the image as --out (through `..`), a wrong extension.
    refused_in(&d, &["png", &p0, "--out", &p("m.exr")], &["m.exr", ".png"]);
    refused_in(&d, &["png", "part0.exr", "--out", "part0.exr"], &["part0.exr", ".png"]);
    std::fs::hard_link(d.join("part0.exr"), d.join("part0-link.png")).unwrap();
    refused_in(&d, &["png", "part0.exr", "--out", "sub/../part0-link.png"], &["sub/../part0-link.png", "part0.exr"]);
    // invert lighting / separate: --output onto an image, or without .exr.
    refused_in(&d, &["invert", "lighting", &p0, "--lmax", "2", "--output", &p0], &[&p0, "--output"]);
    refused_in(&d, &["invert", "lighting", &p0, "--lmax", "2", "--output", &p("l.hdr")], &["l.hdr", ".exr"]);
    refused_in(&d, &["invert", "separate", &p0, &p1, "--output", "./part1.exr"], &["./part1.exr", "part1.exr"]);
    refused_in(&d, &["invert", "separate", &p0, &p1, "--output", &p("sep.png")], &["sep.png", ".exr"]);
    // verify: the second run's JSON onto the report's own JSON, or not .json.
    let data = root().join("../shared/data").display().to_string();
    let rep = p("rep");
    let json = p("rep/report.json");
    let v = ["verify", "--quick", "--data", &data, "--out", &rep, "--then-wrong-prediction"];
    refused_in(&d, &[&v[..], &[&json]].concat(), &[&json, "--then-wrong-prediction"]);
    refused_in(&d, &[&v[..], &[&p("wrong.txt")]].concat(), &["wrong.txt", ".json"]);
    // The checks pass ordinary distinct files (no false refusal): a real render with all three outputs.
    let (code, err) = reflect(&[
        "render",
        &s,
        "--spp",
        "2",
        "--quiet",
        "--out",
        &p("ok.exr"),
        "--png",
        &p("ok.png"),
        "--checkpoint",
        &p("ok-ck.exr"),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(d.join("ok.exr").exists() && d.join("ok.png").exists() && !d.join("ok-ck.exr").exists());
}
