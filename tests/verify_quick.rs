//! `reflect verify --quick` end to end (issue 4): every check passes on real renders, each one
//! fails when compared with a deliberately wrong prediction (the hidden `--wrong-prediction`
//! switch: Lambert × 1.05, Phong exponent × 1.2, TS σ × 1.2, mirror gain 0.95, E × 1.05, a 5°
//! tilted axial light, albedo × 1.05, a wrong blur, the ignore curve for clamp, …), the report
//! folder is complete, and bad input exits 2. Both runs are one process (`--then-wrong-prediction`:
//! the second pass reuses the first one's renders), so the test costs one run's renders.

mod common;

use serde_json::Value;

fn verify(args: &[&str]) -> (i32, String, String) {
    common::reflect_out(&[&["verify"], args].concat())
}

const NAMES: [&str; 24] = [
    "lambert",
    "irradiance9",
    "phong",
    "torrance-sparrow",
    "mirror",
    "directional",
    "axial",
    "uniform",
    "associativity",
    "convex-shape",
    "single-view",
    "partial-view",
    "horizon",
    "inverse-lighting",
    "inverse-lighting-specular",
    "inverse-brdf",
    "separation",
    "factorization",
    "ambiguity",
    "uniform-factorization",
    "microfacet-ambiguity",
    "subspace",
    "positive-bound",
    "texture-ambiguity",
];

#[test]
fn quick_run_passes_writes_the_report_and_every_check_can_fail() {
    let dir = common::temp_dir("verify-quick");
    let d = dir.to_str().unwrap();
    // One process runs the checks twice: as shipped, then against deliberately wrong predictions on
    // the same renders (kept in memory by `--then-wrong-prediction`), instead of a second full run.
    let wrong_json = dir.join("wrong.json");
    let (code, stdout, stderr) =
        verify(&["--quick", "--json", "--out", d, "--then-wrong-prediction", wrong_json.to_str().unwrap()]);
    let doc: Value = serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("bad JSON ({e}):\n{stdout}\n{stderr}"));
    let checks = doc["checks"].as_array().expect("checks array");
    let names: Vec<&str> = checks.iter().map(|c| c["name"].as_str().unwrap()).collect();
    assert_eq!(names, NAMES);
    for c in checks {
        for key in ["name", "equation", "passed", "measured", "expected", "tolerance"] {
            assert!(c.get(key).is_some(), "check {} lacks {key}", c["name"]);
        }
        assert!(!c["measured"].as_array().unwrap().is_empty(), "{} compared nothing", c["name"]);
    }
    let failed: Vec<&str> =
        checks.iter().filter(|c| c["passed"] != true).map(|c| c["name"].as_str().unwrap()).collect();
    assert!(failed.is_empty(), "failed checks {failed:?}\n{stderr}");
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("lambert") && stderr.contains("PASS"), "progress and table on stderr with --json");
    for f in [
        "report.md",
        "report.html",
        "fig2_clamped_cosine.svg",
        "fig3_lambert.svg",
        "fig4_phong.svg",
        "ts_sigma_0.05.svg",
        "ts_sigma_0.1.svg",
        "ts_sigma_0.2.svg",
        "horizon.svg",
        "inverse_lighting.svg",
        "inverse_brdf_profile.svg",
        "inverse_specular_error.svg",
        "lambert_sh_measured.png",
        "lambert_sh_predicted.png",
        "lambert_sh_z.png",
        "zscale.png",
        "uniform_factorization.svg",
        "microfacet_ambiguity.svg",
        "subspace_sphere.svg",
        "subspace_mesh.svg",
        "positive_bound.svg",
        "texture_ambiguity.svg",
        "texture_ambiguity_high_z.png",
        "subspace_mesh_z.png",
    ] {
        let p = dir.join(f);
        let meta = std::fs::metadata(&p).unwrap_or_else(|_| panic!("missing {}", p.display()));
        assert!(meta.len() > 200, "{} is empty", p.display());
    }
    // Every check shows its renders beside the prediction in the report.
    for c in checks {
        let pictures = c["pictures"].as_array().unwrap();
        let name = c["name"].as_str().unwrap();
        assert!(!pictures.is_empty(), "{name} shows no render");
        for p in pictures {
            // The z summary is a number (σ > 0 somewhere), not NaN.
            let rms = p["z"]["rms"].as_f64().unwrap();
            assert!(rms.is_finite(), "{}: {p}", c["name"]);
        }
    }
    let svg = std::fs::read_to_string(dir.join("fig3_lambert.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("measured"));

    // Every check must fail against a deliberately wrong prediction, on the same renders.
    let text =
        std::fs::read_to_string(&wrong_json).unwrap_or_else(|e| panic!("{}: {e}\n{stderr}", wrong_json.display()));
    let doc: Value = serde_json::from_str(&text).unwrap();
    assert!(stderr.contains("wrong prediction: lambert FAIL"), "{stderr}");
    // "Failed" must mean: it ran, and a deciding comparison with a finite measurement fell outside its
    // tolerance. An error (a crashed render, a refused input) would also read `passed = false` and
    // prove nothing about the check's power.
    for c in doc["checks"].as_array().unwrap() {
        let name = &c["name"];
        assert_eq!(c["errored"], false, "check {name} errored instead of running: {}", c["error"]);
        assert!(c["error"].is_null(), "check {name}: {}", c["error"]);
        assert_eq!(c["passed"], false, "check {name} did not detect the wrong prediction");
        let rows = c["rows"].as_array().unwrap();
        let decided = rows.iter().any(|r| {
            r["informative"] == false && r["passed"] == false && r["measured"].as_f64().is_some_and(f64::is_finite)
        });
        assert!(decided, "check {name} failed without a deciding row outside its tolerance: {rows:?}");
    }
}

#[test]
fn one_check_table_and_bad_input() {
    let dir = common::temp_dir("verify-one");
    let (code, stdout, _) = verify(&["--quick", "--check", "mirror", "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(stdout.contains("mirror") && stdout.contains("PASS") && !stdout.contains("lambert"), "{stdout}");
    for h in ["check", "equation", "expected", "measured", "tolerance", "result"] {
        assert!(stdout.lines().next().unwrap_or("").contains(h), "table header lacks {h}");
    }
    let (code, stdout, stderr) = verify(&["--check", "no-such-check"]);
    assert_eq!(code, 2);
    assert!(stdout.is_empty());
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("no-such-check") && stderr.contains("lambert"));
    // A report folder that cannot be created is bad input too (exit 2, one line naming it).
    let blocker = dir.join("a-file");
    std::fs::write(&blocker, "x").unwrap();
    let bad = blocker.join("sub");
    let (code, _, stderr) = verify(&["--quick", "--check", "mirror", "--out", bad.to_str().unwrap()]);
    assert_eq!(code, 2, "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("a-file"));
}
