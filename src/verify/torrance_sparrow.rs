//! Check 4, Torrance–Sparrow (eq. 50–59), spheres with k_s = 1 for σ ∈ {0.05, 0.1, 0.2}.
//!
//! (a) Normal exitance: `normal-probe` at θ_o = 0 under an SH lighting with energy in every order
//! l ≤ 12; measured Λ_l ρ̂_l vs eq. 50 integrated numerically (deciding) and vs exp(−(σl)²) of
//! eq. 57 (informative, approximation error |eq. 57 − eq. 50| stated per row).
//! (b) Non-normal exitance θ_o ∈ {30°, 60°}, `normal-probe` renders at θ_o:
//! - the l = 0 term (the albedo ∫ ρ̂ dω_i) under uniform lighting vs its exact value from 2-D
//!   quadrature of eq. 48 (deciding), and its departure from normal exitance (informative);
//! - under an SH lighting l ≤ 8, the per-order filter measured about the reflection vector R
//!   (pixel-space least squares of B(n) on S_l(R(n))) vs the same fit applied to the image
//!   predicted by direct numerical integration of eq. 48 ([`super::oblique`]; deciding, with
//!   the quadrature error stated as the difference between two resolutions). The fit absorbs
//!   the q = 0 term plus the leakage of the q ≠ 0 terms; reported next to it (informative):
//!   the pure q = 0 term Λ_l ρ̂_l0(θ_o) by quadrature, eq. 59, and normal exitance eq. 50 —
//!   i.e. how far the q = 0 term departs from normal exitance, measured vs predicted.
//!
//! Wrong prediction: eq. 50 and the θ_o predictions with σ × 1.2, the θ_o albedo × 1.05.

use super::Ctx;
use super::check::{Check, Plot, Row};
use super::filter::{self, Measured};
use super::fit::{Channel, fit_filter_at, fit_filter_probe};
use super::oblique::{self, LightTable, Resolution};
use super::picture::Picture;
use super::scenes::torrance_sparrow;
use super::scenes::{Camera, Lighting, Spec, render_spec, sh_lighting};
use super::transfer;
use vocab::Horizon;

pub const NAME: &str = "torrance-sparrow";
pub const EQUATION: &str = "eq. 50-59";
pub const LMAX: usize = 12;
pub const SIGMAS: [f64; 3] = [0.05, 0.1, 0.2];
pub const THETA_O_DEG: [f64; 2] = [30.0, 60.0];
/// Eq. 59 keeps the first order of eq. 58's Taylor series in θ_o, and the paper states it (with
/// eq. 57) for "small outgoing angles" only (§3.7.2). Rows at θ_o above this angle are labelled as
/// outside that range: at 30° tan²θ_o is already 22 % above θ_o², at 60° it is 3 against 1.10.
pub const EQ59_MAX_THETA_O_DEG: f64 = 30.0;
/// The stated range of eq. 59, as the report prints it.
pub const EQ59_RANGE: &str = "eq. 59 is first order in θ_o, stated for small outgoing angles; here θ_o ≤ 30°";
/// Orders of the non-normal-exitance study (SH lighting l ≤ 8).
pub const LOBL: usize = 8;

/// Rows of the filter measured about R at θ_o vs the full numerical prediction.
pub fn evaluate_oblique_filter(
    c: &mut Check,
    sigma: f64,
    theta_o_deg: f64,
    m: &Measured,
    pred: &[f64],
    approx: &[f64],
) {
    filter::rows(c, &format!("σ={sigma} θo={theta_o_deg}° about R vs eq. 48 numerical"), m, pred, Some(approx), false);
}

pub fn prediction(sigma: f64, wrong: bool) -> Vec<f64> {
    transfer::torrance_sparrow(if wrong { 1.2 * sigma } else { sigma }, LMAX)
}

pub fn evaluate_normal(c: &mut Check, sigma: f64, m: &Measured, wrong: bool) {
    let exact = transfer::torrance_sparrow(sigma, LMAX);
    let gauss = transfer::torrance_sparrow_gaussian(sigma, LMAX);
    filter::rows(c, &format!("σ={sigma} vs eq. 50"), m, &prediction(sigma, wrong), None, false);
    let approx: Vec<f64> = (0..=LMAX).map(|l| (gauss[l] - exact[l]).abs()).collect();
    filter::rows(c, &format!("σ={sigma} vs eq. 57"), m, &gauss, Some(&approx), true);
}

/// Albedo at θ_o: measured mean over the probe ± σ, vs the exact quadrature.
pub fn evaluate_oblique(c: &mut Check, sigma: f64, theta_o_deg: f64, measured: f64, sd: f64, wrong: bool) {
    let exact = transfer::ts_albedo(sigma, theta_o_deg.to_radians(), true);
    let pred = if wrong { 1.05 * exact } else { exact };
    c.push(Row::new(format!("σ={sigma} θo={theta_o_deg}° l=0 albedo"), pred, measured, sd));
    let normal = transfer::ts_albedo(sigma, 0.0, true);
    c.push(Row::new(format!("σ={sigma} θo={theta_o_deg}° l=0 vs normal exitance"), normal, measured, sd).informative());
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let light = sh_lighting(LMAX, 0.5, ctx.seed + 2);
    let mut c = Check::new(NAME, EQUATION, "Torrance–Sparrow: normal exitance vs eq. 50/57; θ_o ≠ 0 l = 0 term");
    let mut plots = vec![];
    for sigma in SIGMAS {
        if ctx.verbose {
            eprintln!("  torrance-sparrow σ = {sigma}");
        }
        let brdf = torrance_sparrow(1.0, sigma, Horizon::Clamp);
        let spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Sh(light.clone()), brdf.clone());
        let film = render_spec(ctx, &spec)?;
        let ch = Channel::from_film(&film, 0);
        let fit = fit_filter_probe(&ch, &light, LMAX).ok_or("singular fit")?;
        let m = Measured::from_fit(&fit, LMAX);
        c.pictures.push(Picture::probe_filter(
            format!("ts_sigma{sigma}"),
            format!(
                "Torrance–Sparrow sphere σ = {sigma}, normal exitance, probe {}×{}, {} spp, SH lighting l ≤ {LMAX}",
                spec.width, spec.height, spec.spp
            ),
            "eq. 50 filter (numerical) applied to the lighting's L_lm",
            &ch,
            &light,
            &prediction(sigma, ctx.wrong),
            |_| 0.0,
        ));
        evaluate_normal(&mut c, sigma, &m, ctx.wrong);
        if let Some(x) = fit.reduced_chi2 {
            c.note(format!("σ = {sigma}: normal-exitance fit reduced χ² = {x:.3}"));
        }
        let mut oblique = vec![];
        for t in THETA_O_DEG {
            let mut spec = Spec::probe(ctx, ctx.spp(16, 128), Lighting::Uniform(1.0), brdf.clone());
            spec.camera = Camera::Probe { theta_o_deg: t, phi_o_deg: 0.0 };
            let film = render_spec(ctx, &spec)?;
            let (mean, sd) = probe_mean(&Channel::from_film(&film, 0));
            evaluate_oblique(&mut c, sigma, t, mean, sd, ctx.wrong);
            oblique.push((t, mean, sd));
        }
        c.note(format!(
            "σ = {sigma}: albedo at θo = 0/30/60°: exact {:.4}/{:.4}/{:.4}, measured {}",
            transfer::ts_albedo(sigma, 0.0, true),
            transfer::ts_albedo(sigma, 30f64.to_radians(), true),
            transfer::ts_albedo(sigma, 60f64.to_radians(), true),
            oblique.iter().map(|(t, m, s)| format!("{t}°: {m:.4} ± {s:.4}")).collect::<Vec<_>>().join(", ")
        ));
        plots.push(Plot {
            legend: super::check::Legend::UpperRight,
            file: format!("ts_sigma_{sigma}.svg"),
            title: format!("Torrance–Sparrow σ = {sigma}: Λ_l ρ̂_l, normal exitance and θo = 30°, 60°"),
            x_label: "l".into(),
            y_label: "Λ_l ρ̂_l".into(),
            curves: vec![
                filter::curve("eq. 50 (numerical)", &transfer::torrance_sparrow(sigma, LMAX)),
                filter::dashed("eq. 57 exp(−(σl)²)", &transfer::torrance_sparrow_gaussian(sigma, LMAX)),
            ],
            points: vec![m.series("measured")],
        });
    }
    let olight = sh_lighting(LOBL, 0.5, ctx.seed + 6);
    let fine = LightTable::new(&olight, LOBL, 512);
    let coarse = LightTable::new(&olight, LOBL, 256);
    for (si, sigma) in SIGMAS.into_iter().enumerate() {
        let brdf = torrance_sparrow(1.0, sigma, Horizon::Clamp);
        let psig = if ctx.wrong { 1.2 * sigma } else { sigma };
        for t in THETA_O_DEG {
            if ctx.verbose {
                eprintln!("  torrance-sparrow σ = {sigma}, θo = {t}°");
            }
            let mut spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Sh(olight.clone()), brdf.clone());
            spec.camera = Camera::Probe { theta_o_deg: t, phi_o_deg: 0.0 };
            let ch = Channel::from_film(&render_spec(ctx, &spec)?, 0);
            let (w, h) = (ch.width, ch.height);
            let th = t.to_radians();
            let rdir = |r: usize, col: usize| oblique::probe_geometry(r, col, w, h, th).2;
            let m = Measured::from_fit(&fit_filter_at(&ch, &olight, LOBL, rdir).ok_or("singular fit")?, LOBL);
            let predict = |table: &LightTable, res: Resolution| -> Result<Vec<f64>, String> {
                let img = oblique::predict_probe(psig, th, w, h, table, res);
                let pc = Channel { value: img, sigma: vec![0.0; w * h], ..ch.clone() };
                Ok(fit_filter_at(&pc, &olight, LOBL, rdir).ok_or("singular fit")?.coef)
            };
            let pf = predict(&fine, Resolution { n_theta: 32, n_phi: 128 })?;
            let pco = predict(&coarse, Resolution { n_theta: 16, n_phi: 64 })?;
            let approx: Vec<f64> = pf.iter().zip(&pco).map(|(a, b)| (a - b).abs()).collect();
            evaluate_oblique_filter(&mut c, sigma, t, &m, &pf, &approx);
            let q0 = oblique::q0_term(sigma, th, LOBL);
            let e59 = oblique::eq59(sigma, th, LOBL);
            let e50 = transfer::torrance_sparrow(sigma, LOBL);
            for l in 0..=LOBL {
                c.push(
                    Row::new(format!("σ={sigma} θo={t}° l={l}: fit vs pure q=0 term"), q0[l], m.a[l], m.sigma[l])
                        .informative(),
                );
                c.push(
                    Row::new(
                        format!("σ={sigma} θo={t}° l={l}: q=0 term (measured column) vs eq. 50 at θo=0 (expected)"),
                        e50[l],
                        q0[l],
                        0.0,
                    )
                    .informative(),
                );
                let row = Row::new(
                    format!("σ={sigma} θo={t}° l={l}: eq. 59 (measured column) vs q=0 term by quadrature (expected)"),
                    q0[l],
                    e59[l],
                    0.0,
                );
                c.push(if t > EQ59_MAX_THETA_O_DEG { row.outside_range(EQ59_RANGE) } else { row.informative() });
            }
            let dep = (0..=LOBL).map(|l| q0[l] - e50[l]).fold(0.0f64, |a, b| if b.abs() > a.abs() { b } else { a });
            let d59 = (0..=LOBL).map(|l| (e59[l] - q0[l]).abs()).fold(0.0, f64::max);
            c.note(format!(
                "σ = {sigma}, θo = {t}°: q = 0 term departs from normal exitance by at most {dep:+.4} (l ≤ {LOBL}); eq. 59 is within {d59:.4} of it; measured l=4: {:.4} ± {:.4}, predicted (full) {:.4}, q = 0 term {:.4}",
                m.a[4], m.sigma[4], pf[4], q0[4]
            ));
            plots[si].points.push(m.series(&format!("measured about R, θo = {t}°")));
            plots[si].curves.push(filter::curve(&format!("q = 0 term, θo = {t}°"), &q0));
            plots[si]
                .curves
                .push(filter::dashed(&format!("fit of the eq. 48 image about R, θo = {t}° (decides)"), &pf));
        }
    }
    c.plots = plots;
    Ok(c)
}

/// Solid-angle-weighted mean of a probe image (its l = 0 term / √(4π)) and its standard error.
pub fn probe_mean(ch: &Channel) -> (f64, f64) {
    let (w, h) = (ch.width, ch.height);
    let (mut s, mut v, mut tot) = (0.0, 0.0, 0.0);
    for r in 0..h {
        let om = super::fit::latlong_omega(r, w, h);
        for cidx in 0..w {
            let i = r * w + cidx;
            s += om * ch.value[i];
            v += om * om * ch.sigma[i] * ch.sigma[i];
            tot += om;
        }
    }
    (s / tot, v.sqrt() / tot)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigma_off_by_20_percent_and_albedo_off_by_5_percent_fail() {
        for sigma in SIGMAS {
            // Measured: eq. 50's integrand by an independent Simpson rule, with ±σ scatter.
            let a = super::super::testutil::scatter(
                &super::super::testutil::torrance_sparrow_by_quadrature(sigma, LMAX),
                0.01,
            );
            let m = Measured { sigma: vec![0.01; a.len()], a };
            let mut ok = Check::default();
            evaluate_normal(&mut ok, sigma, &m, false);
            assert!(ok.passed());
            let mut bad = Check::default();
            evaluate_normal(&mut bad, sigma, &m, true);
            assert!(!bad.passed(), "σ = {sigma}");
        }
        let exact = transfer::ts_albedo(0.1, 60f64.to_radians(), true);
        let mut ok = Check::default();
        evaluate_oblique(&mut ok, 0.1, 60.0, exact + 0.002, 0.002, false);
        assert!(ok.passed());
        let mut bad = Check::default();
        evaluate_oblique(&mut bad, 0.1, 60.0, exact + 0.002, 0.002, true);
        assert!(!bad.passed());
    }
}
