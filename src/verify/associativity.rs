//! Check 9, associativity of convolution (eq. 47): a Phong sphere (s = 8, `ignore`) under an SH
//! lighting L (l ≤ 8) equals a mirror sphere under the blurred lighting L'_lm = Λ_l ρ̂_l L_lm
//! (eq. 43). Both through the `normal-probe` camera; the difference image D = B_phong − B_mirror
//! (σ_D² = σ₁² + σ₂², the renders are independent) is fitted on Y_lm, l ≤ 8 (weighted least
//! squares; exact for a band-limited D), and every D_lm must vanish within 4σ (worst shown).
//! Wrong prediction: the lighting is blurred with the Phong filter of exponent 1.2 s.

use super::Ctx;
use super::check::{Check, F32_FLOOR, Row};
use super::fit::{Channel, latlong_dir, latlong_omega, lsq};
use super::picture::Picture;
use super::scenes::{Lighting, Spec, render_spec, sh_lighting};
use super::scenes::{mirror, phong};
use super::transfer;
use analysis::sh::{ShBasis, lm, num_coefficients};
use vocab::Horizon;

pub const NAME: &str = "associativity";
pub const EQUATION: &str = "eq. 47";
pub const LMAX: usize = 8;
pub const S: f64 = 8.0;

pub fn evaluate(a: &Channel, b: &Channel) -> Option<Check> {
    let mut c = Check::new(NAME, EQUATION, "Phong under L = mirror under L blurred by the Phong filter");
    let (w, h) = (a.width, a.height);
    let basis = ShBasis::new(LMAX);
    let mut rows = vec![];
    let mut weight = vec![];
    let mut d = vec![];
    let mut s = vec![];
    for r in 0..h {
        for col in 0..w {
            let i = r * w + col;
            rows.push(basis.eval(latlong_dir(r, col, w, h)));
            weight.push(latlong_omega(r, w, h));
            d.push(a.value[i] - b.value[i]);
            s.push(a.sigma[i].hypot(b.sigma[i]).hypot(F32_FLOOR * a.value[i].abs()));
        }
    }
    let fit = lsq(&rows, &d, &s, &weight)?;
    let mut worst: Option<Row> = None;
    for k in 0..num_coefficients(LMAX) {
        let (l, m) = lm(k);
        let row =
            Row::new(format!("worst D_lm = (B_phong − B_mirror)_lm (at l={l} m={m})"), 0.0, fit.coef[k], fit.sigma[k]);
        if worst.as_ref().is_none_or(|x| row.ratio() > x.ratio()) {
            worst = Some(row);
        }
    }
    c.rows.extend(worst);
    if let Some(x) = fit.reduced_chi2 {
        c.note(format!("difference fit reduced χ² = {x:.3}"));
    }
    Some(c)
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let light = sh_lighting(LMAX, 0.5, ctx.seed + 4);
    let filter = transfer::phong(if ctx.wrong { 1.2 * S } else { S }, LMAX);
    let blurred: Vec<f64> = light.iter().enumerate().map(|(k, v)| v * filter[lm(k).0]).collect();
    let spp = ctx.spp(128, 256);
    let pa = Spec::probe(ctx, spp, Lighting::Sh(light), phong(1.0, S, Horizon::Ignore));
    let pb = Spec::probe(ctx, 4, Lighting::Sh(blurred), mirror(1.0));
    let a = Channel::from_film(&render_spec(ctx, &pa)?, 0);
    let b = Channel::from_film(&render_spec(ctx, &pb)?, 0);
    let mut c = evaluate(&a, &b).ok_or("singular fit")?;
    // The mirror render under the blurred lighting is the prediction of the Phong render.
    c.pictures.push(Picture::new(
        "associativity",
        format!("Phong sphere s = {S} under L, normal probe {}×{}, {spp} spp", pa.width, pa.height),
        "eq. 47: the mirror sphere rendered under L blurred by the Phong filter (4 spp, deterministic); σ of both renders and the f32 floor in quadrature",
        (a.width, a.height),
        a.value.clone(),
        b.value.clone(),
        (0..a.value.len()).map(|i| a.sigma[i].hypot(b.sigma[i]).hypot(F32_FLOOR * a.value[i].abs())).collect(),
    ));
    c.note(format!("normal-probe {}×{}, Phong {spp} spp, mirror 4 spp (deterministic), s = {S}", pa.width, pa.height));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_images_pass_and_a_different_blur_fails() {
        let light = sh_lighting(LMAX, 0.5, 1);
        let basis = ShBasis::new(LMAX);
        let img = |s: f64| {
            let f = transfer::phong(s, LMAX);
            let basis = basis.clone();
            let light = light.clone();
            move |n| basis.eval(n).iter().enumerate().map(|(k, y)| y * light[k] * f[lm(k).0]).sum::<f64>()
        };
        let a = Channel::synthetic_probe(96, 48, img(S), 0.03, 1);
        let b = Channel::synthetic_probe(96, 48, img(S), 0.0, 2);
        assert!(evaluate(&a, &b).unwrap().passed());
        let b = Channel::synthetic_probe(96, 48, img(1.2 * S), 0.0, 2);
        assert!(!evaluate(&a, &b).unwrap().passed());
    }
}
