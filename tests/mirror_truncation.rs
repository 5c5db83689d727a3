//! Truncation in the error bars of a single-view mirror sphere (issue 16): `invert lighting --lmax 8`
//! on one orthographic render of `scenes/mirror-grace.toml` (256², 16 spp, seed 7). Grace has much
//! energy above l = 8, and one view's pixels are not an orthogonal quadrature for the Y_lm, so the
//! fit is biased; the printed bars (noise ⊕ the truncation estimate from the fits up to l = 16) must
//! cover the map's L_lm (`Lighting::coefficients`, the exact per-pixel integrals `sh project`
//! prints) at the nominal rate, both with the render's per-pixel `stderr` layer (the noise part must
//! not be inflated by the χ² the truncation explains) and without it (σ from the residuals, as for
//! another renderer's image).
//!
//! Tolerance: the coverage of the 81 coefficients × 3 channels = 243 |z| values is a binomial
//! proportion; at 1σ, 2σ and 3σ it must not fall more than 3 binomial standard errors below the
//! Gaussian rate (0.683 − 0.090, 0.954 − 0.040, 0.997 − 0.010; √(p(1 − p)/243)). The truncation
//! part is the largest estimate over the sequence of higher-order fits, so it is conservative by
//! design (measured: 0.844 / 0.988 / 1.000 with the stderr layer, bounded near flags at load); bars inflated beyond use are caught
//! by the median |z|, 0.674 for honest Gaussian bars, which must stay above 0.674 / 3 (bars at most
//! 3 × too wide). Without the stderr layer the noise σ comes from the residuals of the l ≤ 16 fit,
//! which hold the signal above l = 16 too: the bars are conservative (measured 0.97 / 1.00 / 1.00,
//! median |z| 0.16), and only the lower bounds apply. The coefficients of one image are correlated, so the binomial error understates
//! the spread; the bands are not widened for it.
//!
//! Planted errors, checked on this render (the estimators recomputed outside the crate from the same
//! pixels): with the stderr layer, the previous truncation estimate (the l ≤ 10 fit alone) gives
//! 51 / 72 / 83 % and fails the 1σ, 2σ and 3σ bounds; scaling the noise by √(χ²/ν) (≈ 10⁶, of the
//! l ≤ 8 or the l ≤ 16 fit) gives median |z| 0.00 and fails the width bound. Without the layer the
//! previous estimator (residual σ of the l ≤ 8 fit, l ≤ 10 truncation) passes here (80 / 98 / 100 %:
//! at 256² the residual σ alone is wide); on the 512² Mitsuba 3 render of the same kind of scene it
//! gave 52 / 63 / 73 % in red (the guide), which this test cannot load.

mod common;
use analysis::image::{Image, read_image, write_exr};
use analysis::lighting::Lighting;
use common::*;
use serde_json::Value;

const LMAX: usize = 8;

fn ok_json(args: &[&str]) -> Value {
    let (code, out, err) = reflect_out(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{args:?}: bad JSON ({e}): {out}"))
}

/// Fractions of |z| within 1, 2, 3 σ over every coefficient and channel, the median and the
/// largest |z|, and their number.
fn coverage(doc: &Value, truth: &[[f64; 3]]) -> ([f64; 3], f64, f64, usize) {
    let mut z = Vec::new();
    for (k, t) in truth.iter().enumerate() {
        let (Some(est), Some(se)) = (doc["coefficients"][k].as_array(), doc["stderr"][k].as_array()) else { continue };
        for ch in 0..3 {
            let (e, s) = (est[ch].as_f64().unwrap(), se[ch].as_f64().unwrap());
            z.push((e - t[ch]).abs() / s);
        }
    }
    z.sort_by(f64::total_cmp);
    let frac = |t: f64| z.iter().filter(|&&v| v <= t).count() as f64 / z.len() as f64;
    ([frac(1.0), frac(2.0), frac(3.0)], z[z.len() / 2], z[z.len() - 1], z.len())
}

fn check(case: &str, doc: &Value, truth: &[[f64; 3]], max_width: bool) {
    let (c, median, max_z, n) = coverage(doc, truth);
    eprintln!(
        "{case}: coverage 1σ {:.3}, 2σ {:.3}, 3σ {:.3}, median |z| {median:.2}, largest {max_z:.2} over {n}",
        c[0], c[1], c[2]
    );
    assert_eq!(n, 243, "{case}: every coefficient of l ≤ 8 is recovered from one view of a mirror");
    let se = |p: f64| (p * (1.0 - p) / n as f64).sqrt();
    for (got, p, k) in [(c[0], 0.683, 1), (c[1], 0.954, 2), (c[2], 0.997, 3)] {
        assert!(got >= p - 3.0 * se(p), "{case}: {k}σ coverage {got:.3} < {p} − 3 × {:.4}", se(p));
    }
    assert!(
        !max_width || median >= 0.674 / 3.0,
        "{case}: median |z| {median:.3}: the bars are too wide to be error bars"
    );
}

#[test]
fn single_view_mirror_bars_cover_grace_with_and_without_a_stderr_layer() {
    let dir = temp_dir("mirror-truncation");
    let img = dir.join("mirror.exr");
    let scene = root().join("scenes/mirror-grace.toml");
    let (code, err) = reflect(&[
        "render",
        scene.to_str().unwrap(),
        "--out",
        img.to_str().unwrap(),
        "--spp",
        "16",
        "--seed",
        "7",
        "-q",
    ]);
    assert_eq!(code, 0, "{err}");
    let truth = Lighting::from_scene_file(&scene).unwrap().coefficients(LMAX).unwrap();
    let lmax = LMAX.to_string();

    let doc = ok_json(&["invert", "lighting", img.to_str().unwrap(), "--lmax", &lmax, "--json"]);
    for c in doc["channel_fits"].as_array().unwrap() {
        assert_eq!(c["truncation_lmax"], 16, "{c}");
        assert_eq!(c["stderr_scale"], 1.0, "χ²/ν is truncation, not noise: {c}");
    }
    check("with the stderr layer", &doc, &truth, true);

    // The radiance alone, as another renderer writes it: σ from the residuals.
    let ours = read_image(&img).unwrap();
    let mut bare = Image { width: ours.width, height: ours.height, ..Default::default() };
    for n in ["R", "G", "B"] {
        bare.channels.insert(n.to_string(), ours.channel(n).unwrap().to_vec());
    }
    let plain = dir.join("plain.exr");
    write_exr(&plain, &bare).unwrap();
    let doc = ok_json(&[
        "invert",
        "lighting",
        plain.to_str().unwrap(),
        "--brdf",
        "mirror",
        "--from",
        "3,0,1",
        "--extent",
        "1.05",
        "--lmax",
        &lmax,
        "--json",
    ]);
    assert!(doc["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().contains("from the residuals")));
    check("without it", &doc, &truth, false);
}
