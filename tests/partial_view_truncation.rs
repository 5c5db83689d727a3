//! Issue 16's first case on renders: `reflect invert lighting` on one orthographic view of
//! `scenes/lambert-grace.toml` as shipped (256², 64 spp, seed 0, from (3, 0, 1)) at `--lmax 2` and
//! `--lmax 3`, and on that view with the opposite one (from (−3, 0, −1), seed 100) at `--lmax 2`.
//! The truth is the map's L_lm (`Lighting::coefficients`, what `sh project` prints).
//!
//! Rule: every coefficient of an order reported `recovered` is within 3 of its printed standard
//! errors (noise ⊕ truncation) of the truth in every channel; an order that is not is reported
//! `undetermined` / `ill-conditioned` ("cannot be determined from these views", in the warnings).
//! Two opposite views see every normal: all orders must be `recovered` and within their bars.
//!
//! Measured (this render): one view, l = 0 R 1.969 ± 0.187 (truth 2.530, 3.0 bars), status
//! `undetermined` (its truncation bound, the bias with the band l = 4 aligned worst at its
//! calibrated energy, is 29 / 38 / 55 % of L̂_00 in R G B; the threshold is 35 %); l = 1, 2 `ill-conditioned` (amplification 16.3,
//! 15.6 > 10). Two views: L_00 R 2.5432 ± 0.0134 (truth 2.5298, 1.0 bars), all orders `recovered`, largest |z| 1.05.
//!
//! Planted error: the previous estimator (the truncation sequence capped at 2 l_max, no predicted
//! truncation, no `undetermined` status) gave l = 0 `recovered` with L_00 R 1.969 ± 0.142 — 3.9
//! bars off: it fails the rule above.

mod common;
use analysis::lighting::Lighting;
use common::*;
use serde_json::Value;

/// Checks the rule of the module docs; returns the statuses and the largest |z| of a recovered
/// coefficient.
fn check(doc: &Value, truth: &[[f64; 3]], case: &str) -> (Vec<String>, f64) {
    let status: Vec<String> =
        doc["orders"].as_array().unwrap().iter().map(|o| o["status"].as_str().unwrap().to_string()).collect();
    let mut worst = 0.0f64;
    for (k, t) in truth.iter().enumerate() {
        let l = (k as f64).sqrt() as usize;
        let (Some(est), Some(se)) = (doc["coefficients"][k].as_array(), doc["stderr"][k].as_array()) else { continue };
        assert!(doc["truncation_bound"][k].is_array(), "{case}: truncation_bound of coefficient {k}");
        for ch in 0..3 {
            let (e, s) = (est[ch].as_f64().unwrap(), se[ch].as_f64().unwrap());
            let z = (e - t[ch]).abs() / s;
            eprintln!("{case}: k {k} ch {ch}: {e:.4} ± {s:.4} vs {:.4} (|z| {z:.2}), l = {l} {}", t[ch], status[l]);
            if status[l] == "recovered" {
                assert!(
                    z <= 3.0,
                    "{case}: L_{k} ch{ch} = {e} ± {s}, truth {} ({z:.1} bars), reported recovered",
                    t[ch]
                );
                worst = worst.max(z);
            }
        }
    }
    let warnings = doc["warnings"].as_array().unwrap();
    for (l, s) in status.iter().enumerate() {
        if s == "undetermined" || s == "ill-conditioned" {
            let said = format!("order l = {l} cannot be determined from these views");
            assert!(warnings.iter().any(|w| w.as_str().unwrap().contains(&said)), "{case}: {said}");
        }
    }
    (status, worst)
}

#[test]
fn one_lambert_view_reports_l0_undetermined_and_two_views_recover_it() {
    let dir = temp_dir("partial-view-truncation");
    let front = render_view(&dir, "lambert", "front", "[3.0, 0.0, 1.0]", Some(0));
    let back = render_view(&dir, "lambert", "back", "[-3.0, 0.0, -1.0]", Some(100));
    let (f, b) = (front.to_str().unwrap(), back.to_str().unwrap());
    let truth = Lighting::from_scene_file(&root().join("scenes/lambert-grace.toml")).unwrap().coefficients(3).unwrap();
    for lmax in ["2", "3"] {
        let doc = reflect_json(&["invert", "lighting", f, "--lmax", lmax, "--json"]);
        let (status, _) =
            check(&doc, &truth[..doc["coefficients"].as_array().unwrap().len()], &format!("one view {lmax}"));
        // The first case of issue 16: l = 0 is 3 bars off, so it must not be called recovered.
        assert_ne!(status[0], "recovered", "one view, --lmax {lmax}: {status:?}");
    }
    // The regularised column: at --lmax 2 GCV's λ is the bottom of its grid, "no regularization
    // needed", and no note about it; at --lmax 8 it is the Tikhonov inverse of B_lm that alias the
    // orders above l_max — measured L_00 = −442 / −88 / −304 for the map's 2.53 / 1.40 / 1.73 — which
    // must be warned about as no lighting. (That inverse is noise: with the Sobol sampler's single
    // sequence --lmax 6 gave −7.30 / −10.20 / −7.32; with its replicates, 4.97 / 6.17 / 2.18.)
    let says = |doc: &Value, what: &str| {
        doc["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().contains(what))
    };
    let doc = reflect_json(&["invert", "lighting", f, "--lmax", "2", "--json"]);
    assert_eq!(doc["regularised"]["needed"], serde_json::json!([false, false, false]), "{}", doc["regularised"]);
    assert!(!says(&doc, "Tikhonov solution") && !says(&doc, "L_00 < 0"), "{}", doc["warnings"]);
    let doc = reflect_json(&["invert", "lighting", f, "--lmax", "8", "--json"]);
    let l00: Vec<f64> = (0..3).map(|c| doc["regularised"]["coefficients"][0][c].as_f64().unwrap()).collect();
    eprintln!("one view, --lmax 8: regularised L_00 {l00:?}");
    assert!(l00.iter().any(|&v| v < 0.0), "the measured case has a negative L_00: {l00:?}");
    assert!(says(&doc, "L_00 < 0") && says(&doc, "Tikhonov solution"), "{}", doc["warnings"]);
    let doc = reflect_json(&["invert", "lighting", f, b, "--lmax", "2", "--json"]);
    let (status, worst) = check(&doc, &truth[..9], "two views");
    assert!(status.iter().all(|s| s == "recovered"), "two views: {status:?}");
    eprintln!("two views: largest |z| {worst:.2}");
}
