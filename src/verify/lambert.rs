//! Check 1, Lambertian filter (eq. 34, 38, 39): a Lambertian sphere (albedo 1) through the
//! `normal-probe` camera at normal exitance, (a) under an SH-defined lighting with energy in every
//! order l ≤ 8 (L_lm exact), (b) under the Grace probe (L_lm by quadrature of the map). The
//! measured Λ_l ρ̂_l (pixel-space least squares, [`super::fit`]) must equal eq. 38 / π:
//! 1, 2/3, 1/4, 0, −1/24, 0, 1/64, 0, −1/128, so odd l > 1 vanish within noise.
//! Wrong prediction (`--wrong-prediction`): the coefficients × 1.05.

use super::Ctx;
use super::check::{Check, Plot};
use super::filter::{self, Measured};
use super::fit::{Channel, fit_filter_probe};
use super::picture::Picture;
use super::scenes::lambert;
use super::scenes::{Lighting, Spec, render_spec, sh_lighting};
use super::{grace, transfer};

pub const NAME: &str = "lambert";
pub const EQUATION: &str = "eq. 34, 38, 39";
/// Orders reported.
pub const LMAX: usize = 8;

/// The prediction (optionally the deliberately wrong one).
pub fn prediction(wrong: bool) -> Vec<f64> {
    let s = if wrong { 1.05 } else { 1.0 };
    transfer::lambert(LMAX).into_iter().map(|v| v * s).collect()
}

/// Turns the measured filters into the check.
pub fn evaluate(sh: &Measured, grace: Option<&Measured>, pred: &[f64]) -> Check {
    let mut c = Check::new(NAME, EQUATION, "Lambertian transfer coefficients Λ_l ρ̂_l = eq. 38/π, odd l > 1 zero");
    filter::rows(&mut c, "SH light", sh, pred, None, false);
    if let Some(g) = grace {
        filter::rows(&mut c, "Grace", g, pred, None, false);
    }
    c
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let light = sh_lighting(LMAX, 0.5, ctx.seed);
    let spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Sh(light.clone()), lambert(1.0));
    let film = render_spec(ctx, &spec)?;
    let sh_ch = Channel::from_film(&film, 0);
    let fit = fit_filter_probe(&sh_ch, &light, LMAX).ok_or("singular fit")?;
    let sh = Measured::from_fit(&fit, LMAX);

    // Grace: fit orders up to grace::LMAX so the (small) l > 8 content is modelled, report l ≤ 8.
    let lg = grace::coefficients(ctx)?;
    let spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Grace(1.0), lambert(1.0));
    let film = render_spec(ctx, &spec)?;
    let g_ch = Channel::from_film(&film, grace::CHANNEL);
    let gfit = fit_filter_probe(&g_ch, &lg, grace::LMAX).ok_or("singular fit")?;
    let gm = Measured::from_fit(&gfit, LMAX);

    let pred = prediction(ctx.wrong);
    let mut c = evaluate(&sh, Some(&gm), &pred);
    c.note(format!(
        "normal-probe {}×{}, {} spp, independent sampler; SH lighting l ≤ {LMAX} with Σ_m L_lm² = 0.25 per order; \
         Grace fit with orders l ≤ {} (modelled), green channel",
        spec.width,
        spec.height,
        spec.spp,
        grace::LMAX
    ));
    if let Some(x) = fit.reduced_chi2 {
        c.note(format!("SH fit reduced χ² = {x:.3} (≈ 1 when the model and the σ are right)"));
    }
    if let Some(x) = gfit.reduced_chi2 {
        c.note(format!(
            "Grace fit reduced χ² = {x:.3}: the excess over 1 halves when the samples double (1.12 at 128 spp, 1.06 at 256 spp \
             measured), so it comes from the per-pixel stderr of a heavy-tailed estimator being itself noisy, not from the \
             model; the Grace σ(a_l) may be low by ≈ √χ² (a few %). They are not rescaled."
        ));
    }
    let what = format!("Lambertian sphere (albedo 1), normal probe {}×{}, {} spp", spec.width, spec.height, spec.spp);
    c.pictures.push(Picture::probe_filter(
        "lambert_sh",
        format!("{what}, SH lighting l ≤ {LMAX}"),
        "eq. 38/π filter applied to the lighting's L_lm, l ≤ 8",
        &sh_ch,
        &light,
        &prediction(ctx.wrong),
        |_| 0.0,
    ));
    c.pictures.push(Picture::probe_filter(
        "lambert_grace",
        format!("{what}, Grace probe (green channel)"),
        format!("eq. 38/π filter applied to the Grace L_lm, l ≤ {}", grace::LMAX),
        &g_ch,
        &lg,
        &transfer::lambert(grace::LMAX).into_iter().map(|v| if ctx.wrong { 1.05 * v } else { v }).collect::<Vec<_>>(),
        |_| 0.0,
    ));
    c.plots.push(Plot {
        legend: super::check::Legend::UpperRight,
        file: "fig3_lambert.svg".into(),
        title: "Figure 3: Lambertian Λ_l ρ̂_l vs l".into(),
        x_label: "l".into(),
        y_label: "Λ_l ρ̂_l".into(),
        curves: vec![filter::curve("eq. 38 / π", &transfer::lambert(LMAX))],
        points: vec![sh.series("measured, SH lighting"), gm.series("measured, Grace")],
    });
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verify::fit::order_parts;
    use analysis::sh::ShBasis;

    /// A synthetic render with the σ of a quick run (≈ 0.05 per pixel on 96 × 48).
    fn synthetic(a: &[f64], seed: u64) -> Measured {
        let light = sh_lighting(LMAX, 0.5, 0);
        let basis = ShBasis::new(LMAX);
        let f = |n| {
            let mut y = vec![0.0; 81];
            let mut s = vec![0.0; LMAX + 1];
            order_parts(&basis, &light, n, &mut y, &mut s);
            (0..=LMAX).map(|l| a[l] * s[l]).sum::<f64>()
        };
        let ch = Channel::synthetic_probe(96, 48, f, 0.05, seed);
        Measured::from_fit(&fit_filter_probe(&ch, &light, LMAX).unwrap(), LMAX)
    }

    #[test]
    fn passes_the_right_prediction_and_fails_a_wrong_one() {
        let truth = transfer::lambert(LMAX);
        let m = synthetic(&truth, 3);
        assert!(evaluate(&m, None, &prediction(false)).passed());
        assert!(!evaluate(&m, None, &prediction(true)).passed(), "Lambert × 1.05 must fail");
        // A filter with a non-zero l = 3 (what a wrong BRDF would give) must fail too.
        let mut bad = truth.clone();
        bad[3] = 0.05;
        let m = synthetic(&bad, 4);
        assert!(!evaluate(&m, None, &prediction(false)).passed(), "odd l = 3 ≠ 0 must fail");
    }
}
