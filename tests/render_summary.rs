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
/// 0, and the summary must say there is no error estimate instead of printing a 0 % error (it
/// printed "median 0.000 %, 95th percentile 0.000 %").
#[test]
fn one_spp_has_no_error_estimate_and_says_so() {
    let dir = temp_dir("render-summary-1spp");
    let (_, err) = render(&dir, &GLOSSY.replace("spp = 16", "spp = 1"), "glossy1");
    assert!(!err.lines().any(|l| l.starts_with("noise over")), "a 0 % error printed at 1 spp: {err}");
    assert!(err.contains("noise: no error estimate at 1 spp"), "{err}");
}
