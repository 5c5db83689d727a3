//! Check "uniform-factorization" (sec. 3.3, eq. 18, 25–28; issue 19): factoring the light field of a
//! sphere under *uniform* lighting "will correctly determine that the illumination is indeed uniform,
//! but the factorization will remain ill-posed since further information regarding the BRDF cannot be
//! obtained".
//!
//! Renders: `normal-probe` images (docs/src/conventions.md §6) of spheres under uniform radiance [`RADIANCE`] at
//! every node (θ'_o, φ'_o) of [`analysis::inverse::factorization::hemisphere_nodes`], reduced by
//! [`LightField`] with Fejér's rule over the normals; the lighting is not told to the analysis.
//! BRDFs: a reciprocal glossy `microfacet` (Beckmann α 0.4, F = 1, as the `factorization` check), a
//! `lambert` (albedo [`ALBEDO`]) and a `mirror` (k_r = [`ALBEDO`]).
//!
//! What eq. 18 gives here, and the rows:
//! - The lighting, L_lm / P = M_lm / (Λ_l κ_l), 1 ≤ l ≤ [`LMAX`] (deciding, expected 0: every one of
//!   them, per BRDF, at orders the factorization returns). Its σ is propagated exactly from the
//!   renders' `stderr` layers through the linear exitance map, Var M_lm = Σ_p (w_p Y_lm(n_p))²
//!   Σ_j (w_j cos θ'_j σ_jp)²; the denominator's noise enters only at second order because the
//!   numerator is zero. Quadrature error: none (a constant image projects to 0 exactly on Fejér's
//!   grid); f32 floor [`F32_FLOOR`] / gain_l.
//! - What *can* be determined: ρ̃_0p0 — by reciprocity the same numbers as ρ̃_l00 — through
//!   κ_l = P k̂_l (the directional-albedo kernel k = a(θ) cos θ). Lambert and the mirror both have a
//!   constant albedo, so κ_l / κ_0 = (Λ_0/Λ_l)(A_l/A_0) with A_l of eq. 38 (deciding, l = 1, 2, 4, with
//!   σ by the delta method), and the two are equal (deciding). These are the "0-order coefficients".
//! - What cannot: every BRDF coefficient ρ̂_lpq with l ≥ 1 multiplies L_lm (eq. 16), and the data say
//!   L_lm = 0. An order l of the BRDF is *determined* when the lighting has energy there, i.e. when
//!   χ²_l = Σ_m (L_lm / σ_lm)² exceeds its 4σ noise threshold 2l+1 + 4√(2(2l+1)) (σ = 0: when
//!   Σ_m L_lm² exceeds the f32 floor). Row (deciding): the number of determined orders 1 ≤ l ≤ LMAX,
//!   expected 0, for each BRDF. The mirror (ρ̂_l = 1) and Lambert (Λ_l ρ̂_l = 2/3, 1/4, 0, −1/24) differ
//!   in every one of those orders yet factor to the same thing: that is the ill-posedness.
//!
//! Wrong prediction: the lighting predicted with a 2 % dipole, L_10 / P = 0.02 Y_10-norm, and κ_l/κ_0
//! of Lambert × 1.05.

use super::Ctx;
use super::check::{Check, F32_FLOOR, Legend, Plot, Row, Series};
use super::fit::Channel;
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Shape, Spec, render_spec};
use super::scenes::{lambert, mirror};
use analysis::inverse::factorization::{
    DEFAULT_MAX_AMPLIFICATION, Factorization, LightField, NormalRule, OutgoingNode, Status, hemisphere_nodes,
    row_weights,
};
use analysis::sh::{ShBasis, index, lambda, latlong_direction, num_coefficients};
use std::f64::consts::PI;
use vocab::scene::BrdfSection;

pub const NAME: &str = "uniform-factorization";
pub const EQUATION: &str = "sec. 3.3, eq. 18, 25-28";
pub const RADIANCE: f64 = 1.5;
pub const ALBEDO: f64 = 0.8;
/// Lighting orders factored.
pub const LMAX: usize = 4;
/// The BRDFs (label, table).
pub fn brdfs() -> [(&'static str, BrdfSection); 3] {
    [("microfacet", super::factorization::glossy()), ("lambert", lambert(ALBEDO)), ("mirror", mirror(ALBEDO))]
}

/// The light field of one BRDF reduced for eq. 18, plus what the error propagation needs.
#[derive(Clone, Debug)]
pub struct Measured {
    pub factor: Factorization,
    /// σ of L_lm / P (index order k, l ≤ LMAX; 0 for l = 0).
    pub sigma_light: Vec<f64>,
    /// κ_l / κ_0 and its σ (delta method), l ≤ LMAX.
    pub kappa_ratio: Vec<f64>,
    pub sigma_kappa_ratio: Vec<f64>,
    pub renders: usize,
}

/// Builds [`Measured`] from the images and per-pixel standard errors of every node (W × H row-major,
/// docs/src/conventions.md §2). Errors: the factorization's (no energy, wrong image size).
pub fn measure(w: usize, h: usize, images: &[(OutgoingNode, Vec<f64>, Vec<f64>)]) -> Result<Measured, String> {
    let e = |e: analysis::Error| e.to_string();
    let mut lf = LightField::new(w, h, NormalRule::Fejer).map_err(e)?;
    let rw = row_weights(w, h, NormalRule::Fejer);
    // Variance of the exitance map, V_p = Σ_j (w_j cos θ'_j σ_jp)², and of each node's normal sum
    // S_j = Σ_p w_p B_jp.
    let mut var_m = vec![0.0; w * h];
    let mut var_s = Vec::with_capacity(images.len());
    for (node, img, sd) in images {
        lf.add(*node, img).map_err(e)?;
        let wc = node.weight * node.theta_o.cos();
        let mut vs = 0.0;
        for (p, s) in sd.iter().enumerate() {
            var_m[p] += (wc * s).powi(2);
            vs += (rw[p / w] * s).powi(2);
        }
        var_s.push(vs);
    }
    let factor = lf.factorize(LMAX, DEFAULT_MAX_AMPLIFICATION).map_err(e)?;
    // σ(M_lm) = √(Σ_p (w_p Y_lm(n_p))² V_p).
    let basis = ShBasis::new(LMAX);
    let n = num_coefficients(LMAX);
    let mut y = vec![0.0; n];
    let mut var_mlm = vec![0.0; n];
    for p in 0..w * h {
        basis.eval_into(latlong_direction(p / w, p % w, w, h), &mut y);
        for k in 0..n {
            var_mlm[k] += (rw[p / w] * y[k]).powi(2) * var_m[p];
        }
    }
    let sigma_light = (0..n)
        .map(|k| {
            let l = analysis::sh::lm(k).0;
            if l == 0 { 0.0 } else { var_mlm[k].sqrt() / (lambda(l) * factor.kappa[l]).abs() }
        })
        .collect();
    // κ_l = Σ_j c_lj S_j, c_lj = w_j μ_j Y_l0(θ'_j); δ(κ_l/κ_0) = Σ_j (c_lj − r_l c_0j) δS_j / κ_0.
    let mut p_l = vec![0.0; LMAX + 1];
    let mut var_r = [0.0; LMAX + 1];
    let r: Vec<f64> = factor.kappa.iter().map(|k| k / factor.kappa[0]).collect();
    for ((node, _, _), vs) in images.iter().zip(&var_s) {
        let mu = node.theta_o.cos();
        analysis::quadrature::legendre_all(mu, &mut p_l);
        let c: Vec<f64> = (0..=LMAX).map(|l| node.weight * mu * p_l[l] / lambda(l)).collect();
        for l in 0..=LMAX {
            var_r[l] += ((c[l] - r[l] * c[0]) / factor.kappa[0]).powi(2) * vs;
        }
    }
    Ok(Measured {
        factor,
        sigma_light,
        kappa_ratio: r,
        sigma_kappa_ratio: var_r.iter().map(|v| v.sqrt()).collect(),
        renders: images.len(),
    })
}

/// χ²_l = Σ_m (L_lm/σ_lm)² is significant (the lighting has order-l energy, so ρ̂_l is determined).
/// With σ = 0 (deterministic renders) the test is Σ_m L_lm² against the f32 floor.
pub fn order_determined(m: &Measured, l: usize) -> Option<bool> {
    let ks: Vec<usize> = (-(l as i64)..=(l as i64)).map(|mm| index(l, mm)).collect();
    let vals: Option<Vec<f64>> = ks.iter().map(|&k| m.factor.lighting[k]).collect();
    let vals = vals?;
    let dof = (2 * l + 1) as f64;
    if ks.iter().all(|&k| m.sigma_light[k] > 0.0) {
        let chi2: f64 = vals.iter().zip(&ks).map(|(v, &k)| (v / m.sigma_light[k]).powi(2)).sum();
        Some(chi2 > dof + 4.0 * (2.0 * dof).sqrt())
    } else {
        let floor = F32_FLOOR / m.factor.orders[l].gain.max(1e-300);
        Some(vals.iter().map(|v| v * v).sum::<f64>().sqrt() > floor)
    }
}

/// κ_l/κ_0 of a constant-albedo BRDF: (Λ_0/Λ_l)(A_l/A_0), A_l of eq. 38 (unit albedo).
pub fn constant_albedo_kappa_ratio(l: usize) -> f64 {
    let a = analysis::transfer::lambert::lambert(l.max(1));
    lambda(0) / lambda(l) * a[l] / a[0]
}

/// The check from the measured light fields (microfacet, lambert, mirror).
pub fn evaluate(m: &[(&str, Measured)], wrong: bool) -> Check {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "factor the light field under uniform lighting: L_lm/P = δ_l0 recovered; BRDF orders l ≥ 1 undetermined",
    );
    let dipole = if wrong { 0.02 * (3.0 / (4.0 * PI)).sqrt() } else { 0.0 };
    for (name, x) in m {
        for k in 1..num_coefficients(LMAX) {
            let (l, mm) = analysis::sh::lm(k);
            let Some(v) = x.factor.lighting[k] else { continue };
            let expected = if (l, mm) == (1, 0) { dipole } else { 0.0 };
            let floor = F32_FLOOR / x.factor.orders[l].gain.max(1e-300) / (4.0 * PI).sqrt();
            c.push(Row::new(format!("{name}: L_{l},{mm}/P = 0"), expected, v, x.sigma_light[k]).floor(floor));
        }
        if let Some(v) = x.factor.lighting[0] {
            c.push(
                Row::new(format!("{name}: L_00/P = Λ_0⁻¹ (gauge, identity)"), 1.0 / lambda(0), v, 0.0).informative(),
            );
        }
        if let Some(s) = x.factor.source_direction() {
            c.push(Row::new(format!("{name}: directionality |L_1|/√(3/4π)"), 0.0, s.directionality, 0.0).informative());
        }
        let determined = (1..=LMAX).filter(|&l| order_determined(x, l) == Some(true)).count();
        c.push(Row::new(
            format!("{name}: BRDF orders 1 ≤ l ≤ {LMAX} determined (ρ̂_lpq, l ≥ 1)"),
            0.0,
            determined as f64,
            0.0,
        ));
        let status: Vec<String> = (1..=LMAX)
            .map(|l| match (x.factor.orders[l].status, order_determined(x, l)) {
                (Status::Ambiguous, _) => format!("l={l}: lighting 0/0 (κ_l = 0), ρ̂_l undetermined"),
                (_, Some(true)) => format!("l={l}: determined"),
                _ => format!("l={l}: undetermined (L_lm = 0 within noise)"),
            })
            .collect();
        c.note(format!(
            "{name}: BRDF ρ̂_0p0 (= ρ̃_0l0 ∝ κ_l) determined: κ_l/κ_0 = {}; ρ̂_lpq for {}",
            (1..=LMAX).map(|l| format!("{:.4}", x.kappa_ratio[l])).collect::<Vec<_>>().join(", "),
            status.join("; ")
        ));
    }
    // The determinable coefficients of the two constant-albedo BRDFs, and their equality.
    let find = |n: &str| m.iter().find(|(name, _)| *name == n).map(|(_, x)| x);
    if let (Some(lam), Some(mir)) = (find("lambert"), find("mirror")) {
        for l in [1usize, 2, 4] {
            let f = if wrong { 1.05 } else { 1.0 };
            let e = constant_albedo_kappa_ratio(l);
            for (name, x) in [("lambert", lam), ("mirror", mir)] {
                let ef = if name == "lambert" { f * e } else { e };
                c.push(
                    Row::new(
                        format!("{name}: κ_{l}/κ_0 = ρ̃_0{l}0/ρ̃_000 (constant albedo, eq. 38)"),
                        ef,
                        x.kappa_ratio[l],
                        x.sigma_kappa_ratio[l],
                    )
                    .floor(F32_FLOOR),
                );
            }
            c.push(
                Row::new(
                    format!(
                        "mirror − lambert: κ_{l}/κ_0 (same ρ̂_0p0, though Λ_{l}ρ̂_{l} = 1 vs {:.4})",
                        analysis::transfer::lambert::lambert(l)[l]
                    ),
                    0.0,
                    mir.kappa_ratio[l] - lam.kappa_ratio[l],
                    mir.sigma_kappa_ratio[l].hypot(lam.sigma_kappa_ratio[l]),
                )
                .floor(F32_FLOOR),
            );
        }
    }
    c.plots.push(plot(m));
    c
}

fn plot(m: &[(&str, Measured)]) -> Plot {
    let points = m
        .iter()
        .enumerate()
        .map(|(i, (name, x))| {
            let ks: Vec<usize> = (1..num_coefficients(LMAX)).filter(|&k| x.factor.lighting[k].is_some()).collect();
            Series {
                name: format!("{name} (L_lm/P ± σ)"),
                // Offset each BRDF a little in k so the error bars do not overlap.
                x: ks.iter().map(|&k| k as f64 + 0.2 * i as f64 - 0.2).collect(),
                y: ks.iter().map(|&k| x.factor.lighting[k].unwrap_or(f64::NAN)).collect(),
                err: Some(ks.iter().map(|&k| x.sigma_light[k]).collect()),
                dashed: false,
            }
        })
        .collect();
    let n = num_coefficients(LMAX);
    Plot {
        legend: Legend::UpperRight,
        file: "uniform_factorization.svg".into(),
        title: "Uniform lighting factored: L_lm/P vs k = l(l+1)+m, l ≥ 1 (expected 0)".into(),
        x_label: "k".into(),
        y_label: "L_lm / P".into(),
        curves: vec![Series {
            name: "uniform: L_lm = 0, l ≥ 1".into(),
            x: vec![1.0, (n - 1) as f64],
            y: vec![0.0, 0.0],
            err: None,
            dashed: false,
        }],
        points,
    }
}

/// (n_μ, n_φ) outgoing nodes and the probe height per mode.
pub fn plan(quick: bool) -> ((usize, usize), usize) {
    if quick { ((5, 4), 24) } else { ((6, 8), 48) }
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let ((n_mu, n_phi), h) = plan(ctx.quick);
    let w = 2 * h;
    let nodes = hemisphere_nodes(n_mu, n_phi).map_err(|e| e.to_string())?;
    let mut measured = vec![];
    let mut pictures = vec![];
    for (i, (name, brdf)) in brdfs().into_iter().enumerate() {
        let mut images = vec![];
        for (j, node) in nodes.iter().enumerate() {
            let spec = Spec {
                width: w as u32,
                height: h as u32,
                spp: ctx.spp(16, 32),
                seed: ctx.seed + 1000 * i as u64 + j as u64,
                camera: Camera::Probe { theta_o_deg: node.theta_o.to_degrees(), phi_o_deg: node.phi_o.to_degrees() },
                lighting: Lighting::Uniform(RADIANCE),
                shape: Shape::Sphere,
                brdf: brdf.clone(),
            };
            let ch = Channel::from_film(&render_spec(ctx, &spec)?, 0);
            if j == 0 && name != "mirror" {
                // Uniform light makes every normal look alike: Lambert's image is the white-furnace
                // constant ρ·L, the microfacet's a constant set by its directional albedo at θ_o
                // (drawn at the image's mean, which has no closed form here).
                let (level, model) = if name == "lambert" {
                    (ALBEDO * RADIANCE, format!("the constant ρ L = {ALBEDO} × {RADIANCE} (white furnace)"))
                } else {
                    let mean = ch.value.iter().sum::<f64>() / ch.value.len() as f64;
                    (mean, "a constant image at the render's mean (uniform light: every normal alike)".to_string())
                };
                pictures.push(Picture::new(
                    format!("uniform_factorization_{name}"),
                    format!(
                        "{name} sphere under uniform radiance {RADIANCE}, θ_o = {:.1}° (normal probe, {} spp)",
                        node.theta_o.to_degrees(),
                        spec.spp
                    ),
                    model,
                    (w, h),
                    ch.value.clone(),
                    vec![level; w * h],
                    ch.sigma.iter().map(|s| s.hypot(F32_FLOOR * level)).collect(),
                ));
            }
            images.push((*node, ch.value, ch.sigma));
        }
        measured.push((name, measure(w, h, &images)?));
    }
    let mut c = evaluate(&measured, ctx.wrong);
    c.pictures = pictures;
    c.note(format!(
        "normal-probe {w}×{h}, {n_mu} μ × {n_phi} φ outgoing nodes per BRDF, {} spp, uniform radiance {RADIANCE}; renders: {}",
        ctx.spp(16, 32),
        measured.iter().map(|(_, m)| m.renders).sum::<usize>()
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verify::fit::latlong_dir;

    /// Synthetic light field of a constant-albedo BRDF under uniform light (+ an optional dipole in
    /// the lighting, which a Lambertian sphere turns into A_1 L_1m Y_1m(n)), with Gaussian noise σ.
    fn images(sigma: f64, dipole: f64, seed: u64) -> Vec<(OutgoingNode, Vec<f64>, Vec<f64>)> {
        let (w, h) = (48, 24);
        let mut rng = renderer::sampling::chi2::TestRng::new(seed);
        hemisphere_nodes(4, 3)
            .unwrap()
            .into_iter()
            .map(|node| {
                let img: Vec<f64> = (0..w * h)
                    .map(|p| {
                        let n = latlong_dir(p / w, p % w, w, h);
                        let mut u = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
                        let (u1, u2) = (u().max(1e-300), u());
                        let g = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                        ALBEDO * RADIANCE * (1.0 + dipole * n[2]) + sigma * g
                    })
                    .collect();
                (node, img, vec![sigma; w * h])
            })
            .collect()
    }

    #[test]
    fn uniform_light_factors_to_delta_and_leaves_the_brdf_undetermined() {
        let m = measure(48, 24, &images(0.01, 0.0, 1)).unwrap();
        for l in 1..=LMAX {
            assert_ne!(order_determined(&m, l), Some(true), "l {l}");
        }
        // Constant albedo: κ_l/κ_0 from eq. 38 (2/√3·(2/3)… within σ).
        for l in [1, 2, 4] {
            let d = (m.kappa_ratio[l] - constant_albedo_kappa_ratio(l)).abs();
            assert!(d <= 4.0 * m.sigma_kappa_ratio[l] + 1e-9, "l {l}: {d} vs σ {}", m.sigma_kappa_ratio[l]);
        }
        let good = evaluate(&[("lambert", m.clone()), ("mirror", m.clone())], false);
        assert!(good.passed(), "{:?}", good.rows.iter().filter(|r| !r.passed()).collect::<Vec<_>>());
        assert!(!evaluate(&[("lambert", m.clone()), ("mirror", m)], true).passed(), "wrong prediction must fail");
    }

    #[test]
    fn a_dipole_in_the_lighting_is_seen_and_determines_order_one() {
        // A 5 % gradient over the sphere: L_1 ≠ 0, so ρ̂_1 becomes determined and the check fails.
        let m = measure(48, 24, &images(0.01, 0.05, 2)).unwrap();
        assert_eq!(order_determined(&m, 1), Some(true));
        assert!(!evaluate(&[("lambert", m)], false).passed());
    }

    #[test]
    fn the_propagated_sigma_matches_the_scatter() {
        // σ of L_10/P over 40 noise draws agrees with the propagated value within 25 % (the sample
        // s.d. of 40 draws has a relative s.e. of 1/√80 ≈ 11 %).
        let vals: Vec<f64> = (0..40)
            .map(|s| measure(48, 24, &images(0.01, 0.0, 100 + s)).unwrap().factor.lighting[2].unwrap())
            .collect();
        let mean = vals.iter().sum::<f64>() / 40.0;
        let sd = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 39.0).sqrt();
        let prop = measure(48, 24, &images(0.01, 0.0, 7)).unwrap().sigma_light[2];
        assert!((sd / prop - 1.0).abs() < 0.25, "scatter {sd} vs propagated {prop}");
    }
}
