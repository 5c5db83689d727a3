//! Check 5, mirror (eq. 30, 33): a mirror sphere (k_r = 1) through the `normal-probe` camera at
//! normal exitance (R = n) under an SH lighting l ≤ 8 shows the lighting itself: B(n) = L(n)
//! pixel by pixel, hence B_lm = L_lm, Λ_l ρ̂_l = 1 for every l.
//!
//! The render is deterministic (every sample of a pixel follows the same reflected ray), so its
//! σ is 0 and the tolerance is the f32 rounding floor: 1e-5 · Σ_k |L_k Y_k(n)| per pixel (the
//! renderer sums the series in f32), propagated through the fit for the coefficients.
//! Wrong prediction: B = 0.95 L (Λ_l ρ̂_l = 0.95).

use super::Ctx;
use super::check::{Check, F32_FLOOR, Row};
use super::filter::{self, Measured};
use super::fit::{Channel, latlong_dir, lsq, order_parts};
use super::picture::Picture;
use super::scenes::mirror;
use super::scenes::{Lighting, Spec, render_spec, sh_lighting};
use analysis::sh::{ShBasis, num_coefficients};

pub const NAME: &str = "mirror";
pub const EQUATION: &str = "eq. 30, 33";
pub const LMAX: usize = 8;

/// Pixel comparison and per-order fit of a mirror probe image against gain × L.
pub fn evaluate(ch: &Channel, light: &[f64], gain: f64) -> Check {
    let mut c = Check::new(NAME, EQUATION, "mirror sphere: B(n) = L(n), B_lm = L_lm");
    let (w, h) = (ch.width, ch.height);
    let basis = ShBasis::new(LMAX);
    let mut y = vec![0.0; num_coefficients(LMAX)];
    let mut rows = vec![];
    let mut floors = vec![];
    let mut weight = vec![];
    let mut worst: Option<Row> = None;
    let mut predicted = Vec::with_capacity(w * h);
    for r in 0..h {
        for col in 0..w {
            let i = r * w + col;
            let n = latlong_dir(r, col, w, h);
            let mut s = vec![0.0; LMAX + 1];
            order_parts(&basis, light, n, &mut y, &mut s);
            let l_n: f64 = s.iter().sum();
            let abs_sum: f64 = (0..light.len().min(y.len())).map(|k| (light[k] * y[k]).abs()).sum();
            let floor = F32_FLOOR * abs_sum;
            // The worst pixel's two radiances: expected gain·L(n), measured B(n) (their difference is
            // the row's |Δ|, compared with its f32 floor).
            let label = format!("B(n) at the pixel (row {r}, col {col}) with the largest |B − L|/floor, vs L(n)");
            let row = Row::new(label, gain * l_n, ch.value[i], ch.sigma[i]).floor(floor);
            predicted.push(gain * l_n);
            if worst.as_ref().is_none_or(|wr| row.ratio() > wr.ratio()) {
                worst = Some(row);
            }
            rows.push(s);
            floors.push((ch.sigma[i] * ch.sigma[i] + floor * floor).sqrt());
            weight.push(super::fit::latlong_omega(r, w, h));
        }
    }
    if let Some(wr) = worst {
        c.push(wr);
    }
    c.pictures.push(Picture::new(
        "mirror",
        format!("mirror sphere (k_r = 1), normal probe {w}×{h}"),
        format!("eq. 30/33: B(n) = {gain}·L(n); σ = f32 floor 1e-5·Σ_k |L_k Y_k(n)| (deterministic render)"),
        (w, h),
        ch.value.clone(),
        predicted,
        floors.clone(),
    ));
    if let Some(fit) = lsq(&rows, &ch.value, &floors, &weight) {
        let m = Measured::from_fit(&fit, LMAX);
        filter::rows(&mut c, "B_lm/L_lm", &m, &[gain; LMAX + 1], None, false);
        c.plots.push(super::check::Plot {
            legend: super::check::Legend::MiddleRight,
            file: "mirror.svg".into(),
            title: "Mirror: Λ_l ρ̂_l (eq. 33)".into(),
            x_label: "l".into(),
            y_label: "Λ_l ρ̂_l".into(),
            curves: vec![filter::curve("eq. 33", &[1.0; LMAX + 1])],
            points: vec![m.series("measured")],
        });
    }
    c
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let light = sh_lighting(LMAX, 0.5, ctx.seed + 3);
    let spec = Spec::probe(ctx, ctx.spp(4, 16), Lighting::Sh(light.clone()), mirror(1.0));
    let film = render_spec(ctx, &spec)?;
    let mut c = evaluate(&Channel::from_film(&film, 0), &light, if ctx.wrong { 0.95 } else { 1.0 });
    c.note(format!(
        "normal-probe {}×{}, {} spp; σ of the coefficients is the f32 floor propagated through the fit",
        spec.width, spec.height, spec.spp
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_image_passes_and_a_dimmer_prediction_fails() {
        let light = sh_lighting(LMAX, 0.5, 7);
        let basis = ShBasis::new(LMAX);
        let f = |n| {
            let mut y = vec![0.0; 81];
            let mut s = vec![0.0; LMAX + 1];
            order_parts(&basis, &light, n, &mut y, &mut s);
            // f32 rounding, as the renderer would.
            s.iter().sum::<f64>() as f32 as f64
        };
        let ch = Channel::synthetic_probe(32, 16, f, 0.0, 1);
        assert!(evaluate(&ch, &light, 1.0).passed());
        assert!(!evaluate(&ch, &light, 0.95).passed());
        // A slightly blurred image (a mirror that is not one) fails too.
        let g = |n: [f64; 3]| f(n) * 0.999 + 0.001 * light[0] * 0.2820948;
        let ch = Channel::synthetic_probe(32, 16, g, 0.0, 1);
        assert!(!evaluate(&ch, &light, 1.0).passed());
    }
}
