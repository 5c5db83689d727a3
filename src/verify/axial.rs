//! Check 7, axially symmetric lighting (eq. 24): under lighting symmetric about +z, the
//! reflected light field of a radially symmetric BRDF is symmetric too: every m ≠ 0 coefficient of
//! B vanishes. Lambert (albedo 1) and Phong (s = 8, `ignore`) spheres through the `normal-probe`
//! camera under an `axial` lighting; B_lm by weighted least squares on Y_lm, l ≤ 6 (solid-angle
//! weights; the lat-long grid is symmetric about z, so a symmetric B gives exactly zero); the
//! worst |B_lm|/σ over m ≠ 0 must be within 4σ. The m = 0 terms are reported.
//! Wrong prediction: the render's lighting axis is tilted by 5° while the prediction (m ≠ 0 = 0)
//! is kept, which the check must detect.

use super::Ctx;
use super::check::{Check, Row};
use super::fit::{Channel, latlong_dir, latlong_omega, lsq};
use super::picture::Picture;
use super::scenes::{Lighting, Spec, render_spec};
use super::scenes::{lambert, phong};
use analysis::sh::{ShBasis, lm, num_coefficients};
use vocab::Horizon;

pub const NAME: &str = "axial";
pub const EQUATION: &str = "eq. 24";
const LFIT: usize = 6;

/// The lighting profile: [θ (degrees), radiance] — a bright cap, a dark band, a bright ring.
pub fn profile() -> Vec<[f64; 2]> {
    vec![[0.0, 3.0], [25.0, 2.0], [50.0, 0.4], [80.0, 1.5], [100.0, 1.8], [130.0, 0.5], [180.0, 0.2]]
}

pub fn evaluate_into(c: &mut Check, label: &str, ch: &Channel) -> Option<()> {
    let (w, h) = (ch.width, ch.height);
    let basis = ShBasis::new(LFIT);
    let mut rows = vec![];
    let mut weight = vec![];
    for r in 0..h {
        for col in 0..w {
            rows.push(basis.eval(latlong_dir(r, col, w, h)));
            weight.push(latlong_omega(r, w, h));
        }
    }
    let fit = lsq(&rows, &ch.value, &ch.sigma, &weight)?;
    let mut worst: Option<Row> = None;
    for k in 0..num_coefficients(LFIT) {
        let (l, m) = lm(k);
        if m == 0 {
            // No prediction for the m = 0 terms: the row reports the fitted value in both columns.
            c.push(
                Row::new(
                    format!("{label}: B_{l}0 as fitted (no prediction; shown in both columns)"),
                    fit.coef[k],
                    fit.coef[k],
                    fit.sigma[k],
                )
                .informative(),
            );
            continue;
        }
        let row = Row::new(format!("{label}: worst B_lm, m ≠ 0 (at l={l} m={m})"), 0.0, fit.coef[k], fit.sigma[k]);
        if worst.as_ref().is_none_or(|x| row.ratio() > x.ratio()) {
            worst = Some(row);
        }
    }
    c.rows.extend(worst);
    Some(())
}

/// The render beside its azimuthal mean: eq. 24 predicts a B symmetric about z, i.e. constant
/// along each row of the lat-long probe, so the prediction of pixel (r, c) is the mean of row r
/// (whose own error, σ/√W, is neglected in the z map).
fn symmetric_picture(stem: &str, title: &str, ch: &Channel) -> Picture {
    let (w, h) = (ch.width, ch.height);
    let mean: Vec<f64> = (0..h).map(|r| ch.value[r * w..(r + 1) * w].iter().sum::<f64>() / w as f64).collect();
    Picture::new(
        stem,
        title,
        "eq. 24: B symmetric about the lighting axis z, i.e. the azimuthal mean of each row of the probe",
        (w, h),
        ch.value.clone(),
        (0..w * h).map(|i| mean[i / w]).collect(),
        ch.sigma.clone(),
    )
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let mut c = Check::new(NAME, EQUATION, "axially symmetric lighting: B_lm = 0 for m ≠ 0");
    let tilt = if ctx.wrong { 5f64.to_radians() } else { 0.0 };
    let axis = [tilt.sin(), 0.0, tilt.cos()];
    for (label, brdf) in [("lambert", lambert(1.0)), ("phong s=8", phong(1.0, 8.0, Horizon::Ignore))] {
        let spec = Spec::probe(ctx, ctx.spp(32, 256), Lighting::Axial { axis, profile: profile() }, brdf);
        let film = render_spec(ctx, &spec)?;
        let ch = Channel::from_film(&film, 0);
        evaluate_into(&mut c, label, &ch).ok_or("singular fit")?;
        c.pictures.push(symmetric_picture(
            &format!("axial_{}", label.split(' ').next().unwrap_or(label)),
            &format!("{label} sphere under axial lighting, normal probe {}×{}, {} spp", ch.width, ch.height, spec.spp),
            &ch,
        ));
    }
    c.note(format!("normal-probe {}×{}; axial profile {:?}", 2 * ctx.probe_height(), ctx.probe_height(), profile()));
    if ctx.wrong {
        c.note("WRONG-PREDICTION MODE: the lighting axis was tilted by 5°");
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_passes_tilted_fails() {
        let f = |n: [f64; 3]| 1.0 + 0.5 * n[2] + 0.3 * n[2] * n[2];
        let ch = Channel::synthetic_probe(96, 48, f, 0.01, 5);
        let mut ok = Check::default();
        evaluate_into(&mut ok, "x", &ch).unwrap();
        assert!(ok.passed(), "{:?}", ok.worst());
        let t = 5f64.to_radians();
        let g = |n: [f64; 3]| f([0.0, 0.0, n[2] * t.cos() + n[0] * t.sin()]);
        let ch = Channel::synthetic_probe(96, 48, g, 0.01, 6);
        let mut bad = Check::default();
        evaluate_into(&mut bad, "x", &ch).unwrap();
        assert!(!bad.passed());
    }
}
