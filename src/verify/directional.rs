//! Check 6, directional source (eq. 19–22): the impulse response. Under a directional source of
//! irradiance E at +z, the `normal-probe` render (θ_o = 0) of each radially symmetric BRDF
//! (Lambert albedo 1, Phong s = 8 `ignore`, Torrance–Sparrow σ = 0.1) equals E·ρ̂(angle(n, z))
//! pixel by pixel, and its coefficients are B_lm = δ_m0 E ρ̂_l (L_lm = E Y_lm(z) = δ_m0 E/Λ_l).
//!
//! The render is deterministic (next-event estimation of a delta light), so σ = 0 and the pixel
//! tolerance is the f32 floor 1e-5·(|B| + 1e-3·max B) (rounding of E·ρ̂ and of the f32 angle).
//! B_l0 is obtained by lat-long quadrature of the render and compared with the same quadrature of
//! the predicted image E ρ̂(angle(n, z)) (so the grid's quadrature error cancels); that quadrature
//! vs the analytic E ρ̂_l = E Λ_l ρ̂_l / Λ_l is reported (informative) as the grid's error.
//! Wrong prediction: E × 1.05.

use super::Ctx;
use super::check::{Check, F32_FLOOR, Plot, Row, Series};
use super::fit::{Channel, dot, latlong_dir, project_probe};
use super::picture::Picture;
use super::scenes::{Lighting, Spec, render_spec};
use super::scenes::{lambert, phong, torrance_sparrow};
use super::transfer;
use analysis::sh::index;
use vocab::Horizon;
use vocab::scene::BrdfSection;

pub const NAME: &str = "directional";
pub const EQUATION: &str = "eq. 19-22";
pub const LMAX: usize = 8;
pub const IRRADIANCE: f64 = 2.0;

/// One lobe: (label, BRDF table, ρ̂(γ), Λ_l ρ̂_l).
pub type Lobe = (&'static str, BrdfSection, fn(f64) -> f64, Vec<f64>);

/// The three lobes.
pub fn lobes() -> Vec<Lobe> {
    vec![
        ("lambert", lambert(1.0), transfer::lambert_lobe as fn(f64) -> f64, transfer::lambert(LMAX)),
        ("phong s=8", phong(1.0, 8.0, Horizon::Ignore), |g| transfer::phong_lobe(8.0, g), transfer::phong(8.0, LMAX)),
        (
            "torrance-sparrow σ=0.1",
            torrance_sparrow(1.0, 0.1, Horizon::Clamp),
            |g| transfer::ts_lobe_normal(0.1, g),
            transfer::torrance_sparrow(0.1, LMAX),
        ),
    ]
}

/// Rows for one lobe: worst pixel, B_l0 vs E ρ̂_l, max |B_lm| over m ≠ 0.
pub fn evaluate_into(c: &mut Check, label: &str, ch: &Channel, e: f64, rho: fn(f64) -> f64, a: &[f64]) {
    let (w, h) = (ch.width, ch.height);
    let z = [0.0, 0.0, 1.0];
    let pred: Vec<f64> =
        (0..w * h).map(|i| e * rho(dot(latlong_dir(i / w, i % w, w, h), z).clamp(-1.0, 1.0).acos())).collect();
    let pmax = pred.iter().cloned().fold(0.0, f64::max);
    let mut worst: Option<Row> = None;
    for (i, &p) in pred.iter().enumerate() {
        let row = Row::new(format!("{label}: worst pixel B vs E ρ̂"), p, ch.value[i], ch.sigma[i])
            .floor(F32_FLOOR * (p.abs() + 1e-3 * pmax));
        if worst.as_ref().is_none_or(|wr| row.ratio() > wr.ratio()) {
            worst = Some(row);
        }
    }
    c.rows.extend(worst);
    c.pictures.push(Picture::new(
        format!("directional_{}", label.split([' ', '=']).next().unwrap_or(label)),
        format!("{label} sphere under a directional source at +z (E = {e}), normal probe {w}×{h}"),
        "eq. 19–22: B(n) = E ρ̂(angle(n, z)); σ = the render's σ and the f32 floor in quadrature",
        (w, h),
        ch.value.clone(),
        pred.clone(),
        (0..w * h).map(|i| ch.sigma[i].hypot(F32_FLOOR * (pred[i].abs() + 1e-3 * pmax))).collect(),
    ));
    // Coefficients: quadrature of the render (σ: the pixel floor propagated) vs E ρ̂_l, with the
    // quadrature error of the same projection of the predicted image stated as approximation.
    let floor_ch = Channel { sigma: pred.iter().map(|p| F32_FLOOR * (p.abs() + 1e-3 * pmax)).collect(), ..ch.clone() };
    let (b, sb) = project_probe(
        &Channel { sigma: (0..w * h).map(|i| ch.sigma[i].hypot(floor_ch.sigma[i])).collect(), ..ch.clone() },
        LMAX,
    );
    let (bp, _) = project_probe(&Channel { value: pred.clone(), ..floor_ch.clone() }, LMAX);
    for (l, &al) in a.iter().enumerate().take(LMAX + 1) {
        let k = index(l, 0);
        let lam = (4.0 * std::f64::consts::PI / (2 * l + 1) as f64).sqrt();
        let expect = e * al / lam;
        // Deciding: the render's projection equals the same projection of E ρ̂(angle(n, z)) (the
        // grid's quadrature error cancels exactly). Informative: that projection vs the analytic
        // E ρ̂_l, i.e. the quadrature error of this grid.
        c.push(Row::new(format!("{label}: B_{l}0 vs quadrature of E ρ̂"), bp[k], b[k], sb[k]));
        c.push(
            Row::new(format!("{label}: quadrature of E ρ̂ vs E ρ̂_{l} (grid error)"), expect, bp[k], 0.0).informative(),
        );
    }
    let mut wm: Option<Row> = None;
    for l in 1..=LMAX {
        for m in -(l as i64)..=(l as i64) {
            if m == 0 {
                continue;
            }
            let k = index(l, m);
            let row = Row::new(format!("{label}: max |B_lm|, m ≠ 0"), 0.0, b[k], sb[k]).approx(bp[k]);
            if wm.as_ref().is_none_or(|x| row.ratio() > x.ratio()) {
                wm = Some(row);
            }
        }
    }
    c.rows.extend(wm);
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let mut c = Check::new(NAME, EQUATION, "impulse response: B(n) = E ρ̂(angle(n, z)), B_lm = δ_m0 E ρ̂_l");
    let e_pred = if ctx.wrong { 1.05 * IRRADIANCE } else { IRRADIANCE };
    let mut fig2 = None;
    for (label, brdf, rho, a) in lobes() {
        let spec =
            Spec::probe(ctx, 4, Lighting::Directional { direction: [0.0, 0.0, 1.0], irradiance: IRRADIANCE }, brdf);
        let film = render_spec(ctx, &spec)?;
        let ch = Channel::from_film(&film, 0);
        evaluate_into(&mut c, label, &ch, e_pred, rho, &a);
        if label == "lambert" {
            fig2 = Some(ch);
        }
    }
    c.note(format!(
        "normal-probe {}×{}, 4 spp (deterministic), E = {IRRADIANCE}",
        2 * ctx.probe_height(),
        ctx.probe_height()
    ));
    c.note("the mirror is not included: a delta BRDF under a delta light has no pixel-wise image to compare (its impulse response is checked through check 5, Λ_l ρ̂_l = 1)");
    if let Some(ch) = fig2 {
        c.plots.push(figure2(&ch));
    }
    Ok(c)
}

/// Figure 2: the clamped cosine max(cos θ, 0) and its SH approximations up to order 0, 1, 2, 4
/// (Σ_{l≤N} (2l+1)/4 · (Λ_l ρ̂_l) P_l(cos θ) with the Lambert coefficients), with the measured
/// impulse response π B / E of the Lambertian render (one column of the probe) as points.
pub fn figure2(ch: &Channel) -> Plot {
    let a = transfer::lambert(4);
    let n = 181;
    let thetas: Vec<f64> = (0..n).map(|i| std::f64::consts::PI * i as f64 / (n - 1) as f64).collect();
    let mut curves = vec![Series {
        name: "max(cos θ, 0)".into(),
        x: thetas.iter().map(|t| t.to_degrees()).collect(),
        y: thetas.iter().map(|t| t.cos().max(0.0)).collect(),
        err: None,
        dashed: false,
    }];
    for order in [0usize, 1, 2, 4] {
        let mut p = vec![0.0; order + 1];
        let y = thetas
            .iter()
            .map(|t| {
                transfer::legendre_all(t.cos(), &mut p);
                (0..=order).map(|l| (2 * l + 1) as f64 / 4.0 * a[l] * p[l]).sum()
            })
            .collect();
        curves.push(Series { name: format!("order ≤ {order}"), x: curves[0].x.clone(), y, err: None, dashed: false });
    }
    let (w, h) = (ch.width, ch.height);
    let pts = Series {
        name: "measured π B/E (directional render)".into(),
        x: (0..h).map(|r| (std::f64::consts::PI * (r as f64 + 0.5) / h as f64).to_degrees()).collect(),
        y: (0..h).map(|r| std::f64::consts::PI * ch.value[r * w] / IRRADIANCE).collect(),
        err: Some((0..h).map(|r| std::f64::consts::PI * ch.sigma[r * w] / IRRADIANCE).collect()),
        dashed: false,
    };
    Plot {
        legend: super::check::Legend::UpperRight,
        file: "fig2_clamped_cosine.svg".into(),
        title: "Figure 2: clamped cosine and its SH approximations".into(),
        x_label: "θ (degrees)".into(),
        y_label: "max(cos θ, 0)".into(),
        curves,
        points: vec![pts],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_impulse_response_passes_and_wrong_irradiance_fails() {
        for (label, _, rho, a) in lobes() {
            let ch = Channel::synthetic_probe(
                64,
                32,
                |n| (IRRADIANCE * rho(n[2].clamp(-1.0, 1.0).acos())) as f32 as f64,
                0.0,
                1,
            );
            let mut ok = Check::default();
            evaluate_into(&mut ok, label, &ch, IRRADIANCE, rho, &a);
            assert!(ok.passed(), "{label}: {:?}", ok.worst());
            let mut bad = Check::default();
            evaluate_into(&mut bad, label, &ch, 1.05 * IRRADIANCE, rho, &a);
            assert!(!bad.passed(), "{label}");
        }
        // A source 2° off the axis breaks the impulse response.
        let (label, _, rho, a) = lobes().remove(0);
        let d = [2f64.to_radians().sin(), 0.0, 2f64.to_radians().cos()];
        let ch = Channel::synthetic_probe(64, 32, |n| IRRADIANCE * rho(dot(n, d).clamp(-1.0, 1.0).acos()), 0.0, 1);
        let mut bad = Check::default();
        evaluate_into(&mut bad, label, &ch, IRRADIANCE, rho, &a);
        assert!(!bad.passed());
    }
}
