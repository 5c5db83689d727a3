//! Check 8, uniform lighting (eq. 25–28): under uniform radiance L, B is constant and equals
//! L ∫ ρ̂ dω_i (eq. 25: only B_00 survives). Lambert (albedo 0.8), mirror (k_r = 0.8) and Phong
//! (s = 8, k_s = 0.8, `ignore`) spheres through the `normal-probe` camera all give B = 0.8 L, so
//! a mirror sphere and a Lambertian sphere of the same albedo cannot be told apart.
//!
//! Constancy is tested in SH: a weighted least-squares fit of the image on Y_lm, l ≤ 4 (exact for
//! a constant: no quadrature error), requiring every l ≥ 1 coefficient to vanish within 4σ (the
//! worst one is shown) and B_00/√(4π) = 0.8 L within 4σ. The mirror is deterministic (σ = 0,
//! f32 floor 1e-5 relative).
//! Wrong prediction: ∫ ρ̂ = 0.84 (the albedo × 1.05).

use super::Ctx;
use super::check::{Check, F32_FLOOR, Row};
use super::fit::{Channel, lsq, sh_design};
use super::picture::Picture;
use super::scenes::{Lighting, Spec, render_spec};
use super::scenes::{lambert, mirror, phong};
use analysis::sh::{lm, num_coefficients};
use vocab::Horizon;

pub const NAME: &str = "uniform";
pub const EQUATION: &str = "eq. 25-28";
pub const RADIANCE: f64 = 1.5;
pub const ALBEDO: f64 = 0.8;
const LFIT: usize = 4;

/// Fit of a probe image on Y_k, k < (LFIT+1)²: (coefficients, σ).
pub fn fit_sh(ch: &Channel) -> Option<(Vec<f64>, Vec<f64>)> {
    let (w, h) = (ch.width, ch.height);
    let (rows, weight) = sh_design(w, h, LFIT);
    let sig: Vec<f64> = (0..w * h).map(|i| ch.sigma[i].hypot(F32_FLOOR * ch.value[i].abs())).collect();
    lsq(&rows, &ch.value, &sig, &weight).map(|f| (f.coef, f.sigma))
}

/// Rows of one BRDF: mean = expected, worst l ≥ 1 coefficient = 0. Returns the mean ± σ.
pub fn evaluate_into(c: &mut Check, label: &str, ch: &Channel, expected: f64) -> Option<(f64, f64)> {
    let (b, s) = fit_sh(ch)?;
    let y00 = 0.5 / std::f64::consts::PI.sqrt();
    let mean = b[0] * y00;
    c.push(Row::new(format!("{label}: B = L ∫ρ̂"), expected, mean, s[0] * y00).floor(F32_FLOOR * expected));
    let mut worst: Option<Row> = None;
    for k in 1..num_coefficients(LFIT) {
        let (l, m) = lm(k);
        let row = Row::new(format!("{label}: worst B_lm, 1 ≤ l ≤ {LFIT} (at l={l} m={m})"), 0.0, b[k], s[k]);
        if worst.as_ref().is_none_or(|x| row.ratio() > x.ratio()) {
            worst = Some(row);
        }
    }
    c.rows.extend(worst);
    Some((mean, s[0] * y00))
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let mut c = Check::new(NAME, EQUATION, "uniform lighting: B constant = L ∫ρ̂; mirror and Lambert indistinguishable");
    let expected = RADIANCE * ALBEDO * if ctx.wrong { 1.05 } else { 1.0 };
    let mut means = vec![];
    for (label, brdf) in
        [("lambert", lambert(ALBEDO)), ("mirror", mirror(ALBEDO)), ("phong s=8", phong(ALBEDO, 8.0, Horizon::Ignore))]
    {
        let spec = Spec::probe(ctx, ctx.spp(16, 64), Lighting::Uniform(RADIANCE), brdf.clone());
        let film = render_spec(ctx, &spec)?;
        let ch = Channel::from_film(&film, 0);
        let m = evaluate_into(&mut c, label, &ch, expected).ok_or("singular fit")?;
        let n = ch.width * ch.height;
        c.pictures.push(Picture::new(
            format!("uniform_{}", label.split(' ').next().unwrap_or(label)),
            format!(
                "{label} sphere under uniform radiance {RADIANCE}, normal probe {}×{}, {} spp",
                ch.width, ch.height, spec.spp
            ),
            format!("B = L ∫ρ̂ = {expected} everywhere; σ = the render's σ and the f32 floor in quadrature"),
            (ch.width, ch.height),
            ch.value.clone(),
            vec![expected; n],
            ch.sigma.iter().map(|s| s.hypot(F32_FLOOR * expected)).collect(),
        ));
        means.push((label, m));
    }
    let (_, (ml, sl)) = means[0];
    let (_, (mm, sm)) = means[1];
    c.push(Row::new("mirror − lambert (same albedo)", 0.0, mm - ml, sl.hypot(sm)).floor(F32_FLOOR * expected));
    c.note(format!(
        "normal-probe {}×{}, uniform radiance {RADIANCE}, albedo {ALBEDO}",
        2 * ctx.probe_height(),
        ctx.probe_height()
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_passes_wrong_albedo_and_structure_fail() {
        let e = RADIANCE * ALBEDO;
        let ch = Channel::synthetic_probe(96, 48, |_| e, 0.01, 2);
        let mut ok = Check::default();
        evaluate_into(&mut ok, "x", &ch, e);
        assert!(ok.passed(), "{:?}", ok.worst());
        let mut bad = Check::default();
        evaluate_into(&mut bad, "x", &ch, 1.05 * e);
        assert!(!bad.passed());
        // A 1 % gradient (a B that is not constant) fails.
        let ch = Channel::synthetic_probe(96, 48, |n| e * (1.0 + 0.01 * n[2]), 0.01, 3);
        let mut bad = Check::default();
        evaluate_into(&mut bad, "x", &ch, e);
        assert!(!bad.passed());
    }
}
