//! Check "inverse-lighting" (eq. 17, 38; issue 5): recover the Grace lighting from a render of a
//! Lambertian sphere (albedo 1, `normal-probe` at normal exitance) by L_lm = B_lm / (Λ_l ρ̂_l).
//!
//! B_lm ± σ comes from the lat-long quadrature of the render ([`super::fit::project_probe`]); the
//! inversion and its conditioning from `analysis::inverse::lighting`. Rows:
//! - l ≤ 2 (recovered, amplification ≤ 4): L_lm ± σ_B/|Λ_l ρ̂_l| against the Grace L_lm — to be
//!   exact, against the same quadrature applied to the predicted image B(n) = Σ_{l ≤ 16} Λ_l ρ̂_l
//!   L_lm Y_lm(n) at the pixel centres, divided by Λ_l ρ̂_l, so that the grid's own quadrature error
//!   is not counted as a failure (it is reported in a note);
//! - odd l = 3, 5 (unobservable, the filter is 0): B_lm itself must be 0 (its predicted quadrature)
//!   within noise — the image carries no information on L_lm there;
//! - even l = 4, 6 (ill-conditioned): informative rows; their amplification (24, 64) and the
//!   resulting standard errors are reported.
//!
//! Wrong prediction: the Grace L_lm × 1.05.

use super::Ctx;
use super::check::{Check, Legend, Plot, Row, Series};
use super::fit::{Channel, latlong_dir, order_rms, project_probe};
use super::grace;
use super::picture::Picture;
use super::scenes::lambert;
use super::scenes::{Lighting, Spec, render_spec};
use analysis::inverse::lighting::{DEFAULT_MAX_AMPLIFICATION, Status, invert_lighting};
use analysis::sh::{ShBasis, index, lm, num_coefficients};

pub const NAME: &str = "inverse-lighting";
pub const EQUATION: &str = "eq. 17, 38";
/// Orders inverted.
pub const LMAX: usize = 6;

/// Quadrature of the predicted Lambertian image on a W × H probe grid, B_k for l ≤ LMAX.
pub fn predicted_quadrature(light: &[f64], w: usize, h: usize) -> Vec<f64> {
    let lmax_light = analysis::sh::lmax_of(light.len()).unwrap_or(0);
    predicted_quadrature_with(light, &analysis::transfer::lambert::lambert(lmax_light), w, h, LMAX)
}

/// Lat-long quadrature (to order `lmax`) of the predicted image B(n) = Σ_k f_l L_k Y_k(n) of a
/// radial filter `f` (Λ_l ρ̂_l, at least as many orders as `light`) sampled at the pixel centres of
/// a W × H normal probe: what the measured projection equals when the theory holds, including
/// the grid's own quadrature error.
pub fn predicted_quadrature_with(light: &[f64], f: &[f64], w: usize, h: usize, lmax: usize) -> Vec<f64> {
    let lmax_light = analysis::sh::lmax_of(light.len()).unwrap_or(0);
    let basis = ShBasis::new(lmax_light);
    let mut y = vec![0.0; light.len()];
    let mut ch = Channel { width: w, height: h, ..Default::default() };
    for r in 0..h {
        for c in 0..w {
            let n = latlong_dir(r, c, w, h);
            basis.eval_into(n, &mut y);
            let v: f64 = (0..light.len()).map(|k| f[lm(k).0] * light[k] * y[k]).sum();
            ch.value.push(v);
            ch.sigma.push(0.0);
            ch.normal.push(n);
            ch.mask.push(1.0);
        }
    }
    project_probe(&ch, lmax).0
}

/// The check from measured B_lm ± σ and the predicted quadrature `q` (scaled by `scale`, 1.05 for
/// the wrong prediction).
pub fn evaluate(b: &[f64], b_se: &[f64], q: &[f64], scale: f64) -> Result<Check, String> {
    let n = num_coefficients(LMAX);
    let f = analysis::transfer::lambert::lambert(LMAX);
    let rgb = |v: &[f64]| v[..n].iter().map(|x| [*x; 3]).collect::<Vec<_>>();
    let inv = invert_lighting(&rgb(b), Some(&rgb(b_se)), &f, [1.0; 3], LMAX, DEFAULT_MAX_AMPLIFICATION, None)
        .map_err(|e| e.to_string())?;
    let mut c = Check::new(
        NAME,
        EQUATION,
        "inverse lighting from a Lambertian sphere under Grace: l ≤ 2 recovered, odd l ≥ 3 unobservable, even l ≥ 4 ill-conditioned",
    );
    for o in &inv.orders {
        for m in -(o.l as i64)..=(o.l as i64) {
            let k = index(o.l, m);
            match o.status {
                Status::Unobservable => {
                    c.push(Row::new(format!("B_{},{m} (filter 0: unobservable)", o.l), scale * q[k], b[k], b_se[k]))
                }
                status => {
                    let (Some(l), Some(se)) = (inv.coefficients[k], inv.stderr[k]) else { continue };
                    let mut row =
                        Row::new(format!("L_{},{m} ({})", o.l, status.name()), scale * q[k] / f[o.l], l[0], se[0]);
                    if status == Status::IllConditioned {
                        row = row.informative();
                    }
                    c.push(row);
                }
            }
        }
        if let Some(a) = o.amplification {
            c.note(format!(
                "l = {}: Λ_l ρ̂_l = {:.5}, noise amplification {:.1} → {}",
                o.l,
                o.filter,
                a,
                o.status.name()
            ));
        } else {
            c.note(format!("l = {}: Λ_l ρ̂_l = 0 → unobservable (eq. 38)", o.l));
        }
    }
    let lambda = inv.regularised.lambda[0];
    c.note(format!("Tikhonov (GCV) λ = {lambda:.3e}; regularised L_00 = {:.5}", inv.regularised.coefficients[0][0]));
    // Plots: recovered vs true, and error vs order against the predicted standard error.
    let obs: Vec<usize> = (0..n).filter(|&k| inv.coefficients[k].is_some()).collect();
    let truth = Series {
        name: "Grace L_lm".into(),
        x: (0..n).map(|k| k as f64).collect(),
        y: (0..n).map(|k| if f[lm(k).0] != 0.0 { scale * q[k] / f[lm(k).0] } else { 0.0 }).collect(),
        err: None,
        dashed: false,
    };
    let rec = Series {
        name: "recovered ± σ".into(),
        x: obs.iter().map(|&k| k as f64).collect(),
        y: obs.iter().map(|&k| inv.coefficients[k].map_or(0.0, |v| v[0])).collect(),
        err: Some(obs.iter().map(|&k| inv.stderr[k].map_or(0.0, |v| v[0])).collect()),
        dashed: false,
    };
    let reg = Series {
        name: "Tikhonov (GCV)".into(),
        x: (0..n).map(|k| k as f64).collect(),
        y: inv.regularised.coefficients.iter().map(|v| v[0]).collect(),
        err: None,
        dashed: true,
    };
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "inverse_lighting.svg".into(),
        title: "Inverse lighting, Lambertian sphere under Grace: L_lm vs k = l(l+1)+m".into(),
        x_label: "k".into(),
        y_label: "L_lm".into(),
        curves: vec![truth, reg],
        points: vec![rec],
    });
    let orders: Vec<usize> = inv.orders.iter().filter(|o| o.amplification.is_some()).map(|o| o.l).collect();
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "inverse_lighting_error.svg".into(),
        title: "Inverse lighting: RMS error per order vs predicted σ (amplification × σ_B)".into(),
        x_label: "l".into(),
        y_label: "RMS |L_lm − Grace|".into(),
        curves: vec![Series {
            name: "predicted σ".into(),
            x: orders.iter().map(|&l| l as f64).collect(),
            y: orders.iter().map(|&l| order_rms(l, |k| inv.stderr[k].map_or(0.0, |v| v[0]))).collect(),
            err: None,
            dashed: false,
        }],
        points: vec![Series {
            name: "measured".into(),
            x: orders.iter().map(|&l| l as f64).collect(),
            y: orders
                .iter()
                .map(|&l| order_rms(l, |k| inv.coefficients[k].map_or(0.0, |v| v[0]) - scale * q[k] / f[l]))
                .collect(),
            err: None,
            dashed: false,
        }],
    });
    Ok(c)
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let lg = grace::coefficients(ctx)?;
    let spec = Spec::probe(ctx, ctx.spp(128, 256), Lighting::Grace(1.0), lambert(1.0));
    let film = render_spec(ctx, &spec)?;
    let ch = Channel::from_film(&film, grace::CHANNEL);
    let (b, se) = project_probe(&ch, LMAX);
    let q = predicted_quadrature(&lg, ch.width, ch.height);
    let mut c = evaluate(&b, &se, &q, if ctx.wrong { 1.05 } else { 1.0 })?;
    c.pictures.push(Picture::probe_filter(
        "inverse_lighting",
        format!("Lambertian sphere under Grace (green), normal probe {}×{}, {} spp", ch.width, ch.height, spec.spp),
        format!("the forward model the inversion divides: eq. 38/π filter on the Grace L_lm, l ≤ {}", grace::LMAX),
        &ch,
        &lg,
        &analysis::transfer::lambert::lambert(grace::LMAX),
        |_| 0.0,
    ));
    // The grid's own quadrature error on the recovered orders, for the record.
    let f = analysis::transfer::lambert::lambert(LMAX);
    let worst = (0..9).map(|k| (q[k] / f[lm(k).0] - lg[k]).abs()).fold(0.0, f64::max);
    c.note(format!(
        "normal-probe {}×{}, {} spp, green channel; quadrature of the predicted image vs the Grace L_lm (l ≤ 2): max |Δ| = {worst:.2e}",
        spec.width, spec.height, spec.spp
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_the_right_prediction_and_fails_a_wrong_one() {
        // A synthetic render of the exact band-limited B of an SH lighting with noise σ = 0.05
        // per pixel (a quick run's), 96 × 48.
        let light: Vec<f64> =
            (0..num_coefficients(8)).map(|k| if k == 0 { 2.0 } else { 0.3 / (1.0 + lm(k).0 as f64) }).collect();
        let (w, h) = (96, 48);
        let q = predicted_quadrature(&light, w, h);
        let f8 = analysis::transfer::lambert::lambert(8);
        let basis = ShBasis::new(8);
        let image = |n| {
            let y = basis.eval(n);
            (0..light.len()).map(|k| f8[lm(k).0] * light[k] * y[k]).sum()
        };
        let ch = Channel::synthetic_probe(w, h, image, 0.05, 5);
        let (b, se) = project_probe(&ch, LMAX);
        let good = evaluate(&b, &se, &q, 1.0).unwrap();
        assert!(good.passed(), "{:?}", good.rows.iter().filter(|r| !r.passed()).map(|r| &r.label).collect::<Vec<_>>());
        assert!(good.rows.iter().any(|r| r.label.contains("unobservable")));
        assert!(good.rows.iter().any(|r| r.label.contains("ill-conditioned") && r.informative));
        assert!(!evaluate(&b, &se, &q, 1.05).unwrap().passed(), "L × 1.05 must fail");
        // An image with l = 3 content (a non-Lambertian response) must fail the unobservable rows.
        let mut b3 = b.clone();
        b3[index(3, 0)] += 10.0 * se[index(3, 0)];
        assert!(!evaluate(&b3, &se, &q, 1.0).unwrap().passed(), "B_30 ≠ 0 must fail");
    }
}
