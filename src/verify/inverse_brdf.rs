//! Check "inverse-brdf" (eq. 16, 43; sec. 3.3; issue 5): fit the Phong exponent of a rendered
//! sphere (s = 32, k_s = 1, `horizon = "ignore"`, `normal-probe` at normal exitance) from its
//! measured Λ_l ρ̂_l, under (a) a directional source at the pole expanded to l ≤ 12
//! (L_lm = δ_m0 Y_l0(0)) and (b) its 9-term (l ≤ 2) truncation.
//!
//! Λ_l ρ̂_l ± σ per order come from the pixel-space fit of [`super::fit::fit_filter_probe`] (no
//! quadrature error), s and its Δχ² = 1 interval from `analysis::inverse::brdf::fit_model` (k_s
//! free). Rows: ŝ under each lighting against s with σ = the interval's half-width (the 9-term row
//! is informative when the interval is unbounded); and the conditioning claim itself: the 9-term
//! interval is at least [`WIDTH_RATIO`] × wider than the directional one (1 = holds).
//! Wrong prediction: s off by 20 % (1.2 s).
//!
//! NOT REGISTERED in [`super::CHECKS`] yet, because on real renders the conditioning row fails:
//! measured (seed 1) quick 96×48 / 128 spp: ŝ = 32.03 ± 0.15 (directional) and 31.30 ± 0.46
//! (9-term); full 192×96 / 256 spp: 32.04 ± 0.053 and 31.77 ± 0.165 — both consistent with s = 32
//! (the 9-term one at 1.4σ), but the 9-term interval is only 3.1× wider, not ≥ 10×. With equal
//! per-order noise the sensitivity ∂ln Λ_l ρ̂_l/∂ln s ≈ l²/2s predicts √(Σ_{l≤12} l⁴ / Σ_{l≤2} l⁴)
//! ≈ 60×, so the renders under the l ≤ 12 SH lighting carry ≈ 20× larger per-order σ (more
//! orders fitted, more sampling variance of the signed SH light). The claim needs a
//! noise-normalised conditioning figure (or a noise-free directional render with its quadrature
//! bias stated) before it can decide a check; the threshold was not lowered to make it pass.
#![allow(dead_code)] // run/evaluate are wired into CHECKS once the claim above is settled

use super::Ctx;
use super::check::{Check, Legend, Plot, Row, Series};
use super::fit::{Channel, fit_filter_probe};
use super::scenes::{Lighting, Spec, render_spec};
use analysis::filter::OrderEstimate;
use analysis::inverse::brdf::{BrdfFit, Model, fit_model};
use analysis::sh::{index, lambda, num_coefficients};

pub const NAME: &str = "inverse-brdf";
pub const EQUATION: &str = "eq. 16, 43; sec. 3.3";
/// Orders of the directional lighting.
pub const LMAX: usize = 12;
/// The exponent rendered.
pub const S: f64 = 32.0;
/// The stated conditioning claim: 9-term interval ≥ this × the directional one.
pub const WIDTH_RATIO: f64 = 10.0;

/// L_lm = δ_m0 Y_l0(0) for l ≤ l_light.
pub fn directional(l_light: usize) -> Vec<f64> {
    let mut c = vec![0.0; num_coefficients(l_light)];
    for l in 0..=l_light {
        c[index(l, 0)] = 1.0 / lambda(l);
    }
    c
}

/// Per-order estimates (one channel) as the library's type.
pub fn estimates(a: &[f64], sigma: &[f64]) -> Vec<OrderEstimate> {
    (0..a.len())
        .map(|l| OrderEstimate { l, energy: [1.0; 3], estimate: [Some(a[l]), None, None], stderr: [Some(sigma[l]), None, None] })
        .collect()
}

fn half_width(f: &BrdfFit) -> Option<f64> {
    match f.interval {
        (Some(lo), Some(hi)) => Some(0.5 * (hi - lo)),
        _ => None,
    }
}

/// The check from the two fits; `s_pred` is the predicted exponent.
pub fn evaluate(dir: &BrdfFit, nine: &BrdfFit, s_pred: f64) -> Check {
    let mut c = Check::new(NAME, EQUATION, "Phong s from Λ_l ρ̂_l: sharp under a directional source, ill-conditioned under 9-term lighting");
    c.push(Row::new("s, directional (l ≤ 12)", s_pred, dir.parameter, half_width(dir).unwrap_or(f64::INFINITY)));
    match half_width(nine) {
        Some(h) => c.push(Row::new("s, 9-term (l ≤ 2)", s_pred, nine.parameter, h)),
        None => c.push(Row::new("s, 9-term (l ≤ 2), interval unbounded", s_pred, nine.parameter, 0.0).informative()),
    }
    let ratio = nine.relative_width() / dir.relative_width();
    c.push(Row::new(format!("9-term interval ≥ {WIDTH_RATIO}× directional (1 = holds)"), 1.0, if ratio >= WIDTH_RATIO { 1.0 } else { 0.0 }, 0.0));
    let iv = |f: &BrdfFit| format!("{:?} … {:?}", f.interval.0, f.interval.1);
    c.note(format!("directional: ŝ = {:.3}, Δχ² = 1 interval {}, relative width {:.4}", dir.parameter, iv(dir), dir.relative_width()));
    c.note(format!("9-term: ŝ = {:.3}, Δχ² = 1 interval {}, relative width {:.4} ({ratio:.1}× the directional)", nine.parameter, iv(nine), nine.relative_width()));
    let profile = |name: &str, f: &BrdfFit| Series {
        name: name.into(),
        x: f.profile.iter().map(|p| p.0.log10()).collect(),
        y: f.profile.iter().map(|p| p.1.min(50.0)).collect(),
        err: None,
        dashed: false,
    };
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "inverse_brdf_profile.svg".into(),
        title: "Inverse BRDF: χ²(s) − χ²_min (clipped at 50) vs log10 s".into(),
        x_label: "log10 s".into(),
        y_label: "Δχ²".into(),
        curves: vec![profile("directional, l ≤ 12", dir), profile("9-term, l ≤ 2", nine)],
        points: vec![],
    });
    c
}

fn fit_one(ctx: &Ctx, l_light: usize) -> Result<BrdfFit, String> {
    let light = directional(l_light);
    let brdf = format!("{{ type = \"phong\", ks = 1.0, s = {S:?}, horizon = \"ignore\" }}");
    let spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Sh(light.clone()), &brdf);
    let film = render_spec(ctx, &spec)?;
    let fit = fit_filter_probe(&Channel::from_film(&film, 0), &light, l_light).ok_or("singular fit")?;
    fit_model(&estimates(&fit.coef, &fit.sigma), Model::Phong, None).map_err(|e| e.to_string())
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let dir = fit_one(ctx, LMAX)?;
    let nine = fit_one(ctx, 2)?;
    let mut c = evaluate(&dir, &nine, if ctx.wrong { 1.2 * S } else { S });
    c.note(format!("normal-probe {}×{}, {} spp, channel R", 2 * ctx.probe_height(), ctx.probe_height(), ctx.spp(128, 256)));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Estimates a_l = Λ_l ρ̂_l(s) + noise σ_l (deterministic pseudo-noise of ±1σ).
    fn synthetic(l_light: usize, sigma: f64) -> BrdfFit {
        let f = analysis::transfer::phong::phong(S, l_light);
        let a: Vec<f64> = f.iter().enumerate().map(|(l, v)| v + if l % 2 == 0 { sigma } else { -sigma }).collect();
        fit_model(&estimates(&a, &vec![sigma; l_light + 1]), Model::Phong, None).unwrap()
    }

    #[test]
    fn passes_the_right_prediction_and_fails_a_wrong_one() {
        let (dir, nine) = (synthetic(LMAX, 2e-3), synthetic(2, 2e-3));
        assert!(evaluate(&dir, &nine, S).passed(), "{:?}", evaluate(&dir, &nine, S).rows);
        assert!(!evaluate(&dir, &nine, 1.2 * S).passed(), "s × 1.2 must fail");
        // Two equally sharp fits violate the conditioning claim.
        assert!(!evaluate(&dir, &dir, S).passed());
    }
}
