//! `reflect bench` end to end on a tiny run (16² pixels, one seed, no peers): the JSON document's
//! shape, the fits' sanity against Monte Carlo theory, and bad input. No figure is a timing
//! assertion: only the convergence exponent, which the spp ladder fixes whatever the machine.

mod common;
use common::*;

/// The tiny run's arguments (one scene at 16², one seed, no peers, work folder `out`), then `extra`.
fn tiny_bench<'a>(out: &'a std::path::Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["bench", "--scenes", "lambert-grace", "--size", "16", "--seeds", "1", "--peers", "none"];
    a.extend_from_slice(&["--out", out.to_str().unwrap()]);
    a.extend_from_slice(extra);
    a
}

#[test]
fn a_tiny_run_reports_every_figure_and_plain_monte_carlo_converges_at_one_half() {
    let dir = temp_dir("bench-tiny");
    let out = dir.join("work");
    let doc = reflect_json(&tiny_bench(&out, &["--threads", "2", "--json"]));
    assert!(out.join("bench.json").is_file(), "bench.json not written");
    common::json::assert_documented("bench", &doc);
    assert!(doc["host"]["cpu_features"].is_array() && doc["host"]["load_before"].is_array(), "{}", doc["host"]);
    let scene = &doc["scenes"][0];
    assert_eq!(scene["name"], "lambert-grace");
    assert!(scene["pixels"].as_u64().unwrap() > 100, "{scene}");
    let series = scene["series"].as_array().unwrap();
    let samplers: Vec<&str> = series.iter().map(|s| s["sampler"].as_str().unwrap()).collect();
    assert_eq!(samplers, ["sobol", "sobol-single", "independent"]);
    for s in series {
        assert_eq!(s["points"].as_array().unwrap().len(), 5, "{s}");
        let t = s["time_to_target"]["median"].as_f64().unwrap_or(f64::NAN);
        assert!(t.is_finite() && t > 0.0, "{}: time to target {t}", s["sampler"]);
        let n = s["target_spp"]["median"].as_f64().unwrap_or(f64::NAN);
        assert!(n.is_finite() && n > 0.0 && s["extrapolated"].is_boolean(), "{}: spp to target {n}", s["sampler"]);
        let ph = &s["phases"];
        assert!(ph["lighting_read"].as_f64().unwrap() > 0.0 && ph["render"].as_f64().unwrap() > 0.0, "{ph}");
    }
    // Independent samples: e ∝ n^(−½) (n: spp). Over the ladder's 2.4 decades of spp at 16² the
    // fitted slope's spread is a few hundredths; ±0.15 is a wide margin that still fails a wrong
    // abscissa (planted: spp², which halves the slope). The subtraction of the reference's noise is
    // checked by the unit test `error_subtracts_the_reference_noise` (here the 65,536-spp
    // reference's floor is too low to matter).
    let ind = series.iter().find(|s| s["sampler"] == "independent").unwrap();
    let b = ind["exponent"]["median"].as_f64().unwrap();
    assert!((b - 0.5).abs() < 0.15, "independent sampler's exponent {b}");
    // A second run reuses the reference (same size and spp): it is not rendered again.
    let (code, _, err) = reflect_out(&tiny_bench(&out, &[]));
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("reference at"), "the reference was rendered again: {err}");
    // Another scene text (here another data folder holding the same maps) is another key: the
    // reference is rendered anew.
    let data = dir.join("data");
    std::fs::create_dir_all(&data).unwrap();
    let shared = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    for map in ["grace_latlong.exr", "grace_probe.hdr", "sky_latlong.exr"] {
        std::fs::copy(shared.join(map), data.join(map)).unwrap();
    }
    let (code, _, err) = reflect_out(&tiny_bench(&out, &["--data", data.to_str().unwrap()]));
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("reference at"), "a reference of another scene text was reused: {err}");
    let refs = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().contains("-reference-"))
        .count();
    assert_eq!(refs, 2, "one reference per key");
}

#[test]
fn bench_refuses_bad_input_in_one_line() {
    let dir = temp_dir("bench-bad");
    let out = dir.join("w");
    let o = out.to_str().unwrap();
    assert_bad_input(&["bench", "--scenes", "lambert-grace,teapot", "--out", o], "teapot", "unknown bench scene", &out);
    assert_bad_input(&["bench", "--target-rel-error", "0", "--out", o], "--target-rel-error", "(0, 1)", &out);
    // A required peer that cannot run.
    assert_bad_input(
        &["bench", "--peers", "mitsuba", "--python", "/nonexistent/python", "--scenes", "lambert-grace", "--out", o],
        "--peers mitsuba",
        "/nonexistent/python",
        &out.join("bench.json"),
    );
}
