//! What `reflect render` prints at the end: the defined stats line, the times, and the noise
//! summary, whose numbers are recomputed here directly from the EXR it wrote.

mod common;
use common::*;
use std::process::Command;

fn render(dir: &std::path::Path, toml: &str, name: &str) -> (std::path::PathBuf, String) {
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, toml).unwrap();
    let out = dir.join(format!("{name}.exr"));
    let o = Command::new(env!("CARGO_BIN_EXE_reflect"))
        .args(["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--threads", "2"])
        .output()
        .expect("run reflect");
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "render failed: {err}");
    (out, err)
}

/// The number printed right after `key` in `line` (e.g. "median " → 1.234).
fn number_after(line: &str, key: &str) -> f64 {
    let rest = &line[line.find(key).unwrap_or_else(|| panic!("{key:?} not in {line:?}")) + key.len()..];
    let num: String = rest.chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect();
    num.parse().unwrap_or_else(|_| panic!("no number after {key:?} in {line:?}"))
}

const GLOSSY: &str = r#"
[render]
width = 24
height = 24
spp = 16
seed = 3
max_depth = 1
sampler = "independent"
[camera]
type = "orthographic"
from = [3.0, 0.0, 0.0]
to = [0.0, 0.0, 0.0]
extent = 1.1
[lighting]
type = "axial"
profile = [[0.0, 2.0, 1.5, 1.0], [90.0, 0.5, 0.6, 0.8], [180.0, 0.05, 0.05, 0.05]]
[[objects]]
shape = "sphere"
brdf = { type = "phong", ks = 0.9, s = 20 }
"#;

#[test]
fn noise_summary_matches_the_written_image() {
    let dir = temp_dir("render-summary");
    let (out, err) = render(&dir, GLOSSY, "glossy");
    let line = err.lines().find(|l| l.starts_with("noise over")).unwrap_or_else(|| panic!("no noise line: {err}"));

    // Direct computation from the EXR: worst-channel stderr/value over pixels with mask > 0.
    let img = analysis::image::read_image(&out).unwrap();
    let ch = |n: &str| img.channel(n).unwrap_or_else(|| panic!("no channel {n}"));
    let (mask, v, se) = (ch("mask.Y"), [ch("R"), ch("G"), ch("B")], [ch("stderr.R"), ch("stderr.G"), ch("stderr.B")]);
    let mut rel: Vec<f64> = (0..mask.len())
        .filter(|&i| mask[i] > 0.0)
        .filter_map(|i| (0..3).filter(|&c| v[c][i] > 0.0).map(|c| se[c][i] as f64 / v[c][i] as f64).reduce(f64::max))
        .collect();
    rel.sort_by(f64::total_cmp);
    let n = rel.len();
    assert!(n > 300, "the sphere covers most of the 24×24 image: {n} pixels");
    let (median, p95) = (rel[n.div_ceil(2) - 1], rel[(0.95 * n as f64).ceil() as usize - 1]);
    assert!(median > 0.0 && p95 >= median, "a glossy render is noisy: {median} {p95}");

    assert_eq!(number_after(line, "noise over ") as usize, n, "{line}");
    // Printed with 3 decimals in %: agree to the printed rounding.
    assert!((number_after(line, "median ") - 100.0 * median).abs() <= 6e-4, "{line} vs {median}");
    assert!((number_after(line, "95th percentile ") - 100.0 * p95).abs() <= 6e-4, "{line} vs {p95}");

    // The stats line defines its figures; samples = pixels × spp.
    let stats = err.lines().find(|l| l.starts_with("render loop")).unwrap_or_else(|| panic!("no stats: {err}"));
    assert!(stats.contains(&format!("{} samples (pixels × spp, misses included)", 24 * 24 * 16)), "{stats}");
    assert!(stats.contains("rays traced = ") && stats.contains("M rays/s"), "{stats}");
    let times = err.lines().find(|l| l.starts_with("time: load")).unwrap_or_else(|| panic!("no times: {err}"));
    assert!(times.contains("render loop") && times.contains("save") && times.contains("whole command"), "{times}");
}

#[test]
fn normal_probe_of_one_sphere_says_no_rays() {
    let dir = temp_dir("render-summary-probe");
    let toml = r#"
[render]
width = 16
height = 8
spp = 4
max_depth = 1
[camera]
type = "normal-probe"
[lighting]
type = "uniform"
radiance = 1.0
[[objects]]
shape = "sphere"
brdf = { type = "lambert", albedo = 0.5 }
"#;
    let (_, err) = render(&dir, toml, "probe");
    assert!(err.contains("no rays traced"), "{err}");
    assert!(!err.contains("0 rays") && !err.contains("0.00 M rays/s"), "{err}");
}

/// Issue 9, "flag where it cannot": at 1 spp one sample per pixel has no spread, the stderr layer is
/// +inf (unknown), and the summary must say there is no error estimate instead of printing a 0 % error (it
/// printed "median 0.000 %, 95th percentile 0.000 %").
#[test]
fn one_spp_has_no_error_estimate_and_says_so() {
    let dir = temp_dir("render-summary-1spp");
    let (_, err) = render(&dir, &GLOSSY.replace("spp = 16", "spp = 1"), "glossy1");
    assert!(!err.lines().any(|l| l.starts_with("noise over")), "a 0 % error printed at 1 spp: {err}");
    assert!(err.contains("noise: no error estimate at 1 spp"), "{err}");
}

/// The `progressive-low-spp` case scene, copied into `dir` with its map path made absolute.
fn low_spp_case(dir: &std::path::Path) -> String {
    let case = root().join("../shared/cases/progressive-low-spp/s.toml");
    let text = std::fs::read_to_string(&case).unwrap_or_else(|e| panic!("{}: {e}", case.display()));
    assert!(text.contains("\"../../data/"), "the case scene changed: {text}");
    let data = root().join("../shared/data/").display().to_string();
    let p = dir.join("s.toml");
    std::fs::write(&p, text.replace("../../data/", &data)).unwrap();
    p.display().to_string()
}

/// Case `progressive-low-spp`: a progressive render stopped after its 1-spp pass has no error
/// estimate. JSON `rel_error_p95` and `noise` are null with `rel_error_unknown` saying why, the text
/// prints no percentage, the stderr layer written is +inf (unknown, never 0), `png --layer stderr`
/// refuses it in one line, and `analyze` takes σ from the residuals instead of the layer.
#[test]
fn progressive_stop_at_one_spp_has_no_estimate() {
    let dir = temp_dir("no-estimate-case");
    let s = low_spp_case(&dir);
    let out = dir.join("o.exr").display().to_string();
    let (code, json, err) =
        reflect_out(&["render", &s, "--json", "--time-limit", "1e-9", "--spp", "16", "--out", &out]);
    assert_eq!(code, 0, "{err}");
    let doc: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(doc["spp"], 1, "{doc}");
    let p = &doc["progressive"];
    assert!(p["rel_error_p95"].is_null() && doc["noise"].is_null(), "{doc}");
    assert!(p["rel_error_unknown"].as_str().is_some_and(|w| w.contains("one sample per pixel")), "{doc}");
    let end = err.lines().find(|l| l.starts_with("progressive: ")).unwrap_or_else(|| panic!("{err}"));
    assert!(end.contains("unknown: one sample per pixel") && !end.contains('%'), "{end}");
    let img = analysis::image::read_image(&out).unwrap();
    for c in ["stderr.R", "stderr.G", "stderr.B"] {
        assert!(img.channel(c).unwrap().iter().all(|v| *v == f32::INFINITY), "{c} is not +inf everywhere");
    }
    let (code, err) = reflect(&["png", &out, "--layer", "stderr", "--out", &dir.join("se.png").display().to_string()]);
    assert_eq!((code, err.lines().count()), (2, 1), "{err}");
    assert!(err.contains("o.exr") && err.contains("no error estimate"), "{err}");
    assert!(!dir.join("se.png").exists());
    let a = reflect_json(&["analyze", &out, "--lmax", "2", "--json"]);
    assert_ne!(a["stderr_source"], "stderr-layer", "{}", a["stderr_source"]);
}

/// A target is never reached on an estimate of zero: a black object (no object pixel > 0) has no
/// relative error, so `--target-rel-error` renders to the cap and says why (it used to stop at
/// 16 spp, "reached", on the 0 % of an empty summary).
#[test]
fn target_is_not_reached_without_an_estimate() {
    let dir = temp_dir("no-estimate-black");
    let s = low_spp_case(&dir);
    let text = std::fs::read_to_string(&s).unwrap().replace("albedo = 0.8", "albedo = 0.0");
    std::fs::write(&s, text).unwrap();
    let out = dir.join("o.exr").display().to_string();
    let args = ["render", &s, "--json", "--quiet", "--target-rel-error", "0.5", "--spp", "32", "--out", &out];
    let doc = reflect_json(&args);
    let p = &doc["progressive"];
    assert_eq!((p["stopped_by"].as_str(), p["target_reached"].as_bool()), (Some("spp-cap"), Some(false)), "{doc}");
    assert_eq!(doc["spp"], 32, "{doc}");
    assert!(p["rel_error_p95"].is_null(), "{doc}");
    assert!(p["rel_error_unknown"].as_str().is_some_and(|w| w.contains("no object pixel")), "{doc}");
}

/// Shards of one sample each merge into an image with an estimate (the merge joins the samples'
/// statistics, not their error bars): finite stderr everywhere, while a lone 1-spp shard merged
/// alone stays +inf.
#[test]
fn merged_one_spp_shards_have_an_estimate() {
    let dir = temp_dir("no-estimate-shards");
    let s = low_spp_case(&dir);
    let p = |n: &str| dir.join(n).display().to_string();
    for i in 0..2 {
        let (code, err) = reflect(&[
            "render",
            &s,
            "--spp",
            "2",
            "--shard",
            &format!("{i}/2"),
            "--quiet",
            "--out",
            &p(&format!("p{i}.exr")),
        ]);
        assert_eq!(code, 0, "{err}");
    }
    let (code, err) = reflect(&["merge", &p("p0.exr"), &p("p1.exr"), "--quiet", "--out", &p("m.exr")]);
    assert_eq!(code, 0, "{err}");
    let img = analysis::image::read_image(p("m.exr")).unwrap();
    assert!(img.channel("stderr.R").unwrap().iter().all(|v| v.is_finite()), "2 spp merged: finite stderr");
    assert!(img.stderr_layer().unwrap().is_some());
    let (code, err) = reflect(&["render", &s, "--spp", "1", "--shard", "0/1", "--quiet", "--out", &p("q.exr")]);
    assert_eq!(code, 0, "{err}");
    let (code, err) = reflect(&["merge", &p("q.exr"), "--quiet", "--out", &p("q1.exr")]);
    assert_eq!(code, 0, "{err}");
    let img = analysis::image::read_image(p("q1.exr")).unwrap();
    assert!(img.channel("stderr.R").unwrap().iter().all(|v| *v == f32::INFINITY), "1 spp merged: +inf");
    assert!(img.stderr_layer().unwrap().is_none());
}

/// +inf is read only where it means "no estimate": in an error layer (`stderr.*`, `stderr_own.*`),
/// which then counts as absent; +inf in radiance, and NaN or −inf in an error layer, stay refused.
#[test]
fn plus_inf_is_read_only_in_error_layers() {
    use analysis::image::{Image, read_image, write_exr};
    let dir = temp_dir("no-estimate-reader");
    let write = |name: &str, bad: (&str, f32)| {
        let mut img = Image { width: 2, height: 1, ..Default::default() };
        for c in ["R", "G", "B", "stderr.R", "stderr.G", "stderr.B"] {
            img.channels.insert(c.to_string(), vec![0.5, 0.25]);
        }
        img.channels.get_mut(bad.0).unwrap()[1] = bad.1;
        let p = dir.join(name);
        write_exr(&p, &img).unwrap();
        p
    };
    let img = read_image(write("unknown.exr", ("stderr.G", f32::INFINITY))).unwrap();
    assert!(img.stderr_layer().unwrap().is_none(), "a layer holding +inf is no error bar");
    assert!(read_image(write("ok.exr", ("stderr.G", 0.0))).unwrap().stderr_layer().unwrap().is_some());
    for (name, bad) in [
        ("r.exr", ("R", f32::INFINITY)),
        ("nan.exr", ("stderr.B", f32::NAN)),
        ("neg.exr", ("stderr.R", f32::NEG_INFINITY)),
    ] {
        let e = read_image(write(name, bad)).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(bad.0), "{e}");
    }
}
