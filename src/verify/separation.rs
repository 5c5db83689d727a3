//! Check "separation" (sec. 3.5, eq. 38–39; the algorithm of reference \[17\]; issue 5): recover the
//! Grace lighting at high angular resolution from a sphere with ρ̂ = k_d·lambert + k_s·mirror by
//! subtracting the 9-term diffuse part, and test the consistency of the low orders of both sides.
//!
//! Renders (green channel, `normal-probe`, `mix` of lambert (albedo 1, weight k_d) and mirror
//! (k_r = 1, weight k_s), independent sampler): a *diffuse view* at normal exitance (θ_o = 0, R = n)
//! gives L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2; two *specular views* at θ_o = [`THETA_O_DEG`],
//! φ_o = 0° and 180° (R = n turned by ∓θ_o along its meridian; each misses a polar cap of radius
//! θ_o, together they cover the sphere) give the lighting at R ≠ n after the subtraction, fitted to
//! SH by weighted least squares (weights: the pixels' solid angles in R). The algorithm and its
//! exact error propagation are `analysis::inverse::separation`. Using views with R ≠ n for the
//! specular side is what makes the consistency a test: from one normal-exitance image it holds
//! identically for any split.
//!
//! Rows (|Δ| ≤ 4σ + approx):
//! The grid: Grace has strong content far above the orders fitted, which the lat-long quadrature of
//! the diffuse view and the least squares at R alias into the low orders (several % at l = 0 on a
//! 96 × 48 grid). As in "inverse-lighting", the expectation is the same algorithm applied to the
//! noise-free predicted images (k_d D(n) + k_s G(n) and k_d D(n) + k_s G(R), D the Lambert image of
//! the Grace L_lm, l ≤ 16, G the Grace map at a direction, nearest pixel as the renderer). The
//! algorithm is linear, so that prediction is exactly (grid-equivalent Grace) + (9-term residual
//! fitted at R); the first part is the expectation, the second, computed from the Grace L_lm, is the
//! stated approximation error of the 9-term subtraction (the paper's claim under test).
//! - consistency d_lm = L̂_lm − c_lm, l ≤ 2 (deciding): expected = the grid part of the predicted d,
//!   σ from both renders' `stderr`, approx = |9-term residual fitted at R| for that coefficient;
//! - recovered lighting c_lm, l ≤ lmax (deciding): expected = the least squares of the Grace map at
//!   the same R directions (plus the subtracted 9 terms' grid error), approx = |the 9-term residual
//!   (k_d/k_s) Σ_{l≥3} Λ_l ρ̂_l L_lm Y_lm(n) (eq. 38–39) fitted at R|; the distance of that least
//!   squares from the full-resolution Grace L_lm (aliasing) is reported in a note;
//! - informative: the pure 9-term residual per order (RMS over m) against the measured RMS error,
//!   and the split scan: the diffuse fraction minimising the consistency χ² at fixed k_d + k_s.
//!
//! Wrong prediction: the algorithm is run (and its predicted bias computed) with the split
//! k_d : k_s = 0.6 : 0.4 instead of 0.5 : 0.5 — the consistency and the recovered scale then fail.

use super::Ctx;
use super::check::{Check, Legend, Plot, Row, Series};
use super::fit::{Channel, latlong_dir, order_rms};
use super::grace;
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Spec, grace_path, render_spec};
use super::scenes::{lambert, mirror, mix};
use super::transfer;
use analysis::inverse::separation::{
    LOW, Samples, Separated, Separation, best_split, nine_term_residual, probe_samples,
};
use analysis::sh::{ShBasis, lm, num_coefficients};
use std::f64::consts::PI;

pub const NAME: &str = "separation";
pub const EQUATION: &str = "sec. 3.5, eq. 38–39";
/// Exitance angle of the specular views (degrees).
pub const THETA_O_DEG: f64 = 50.0;
/// True weights of the mix.
pub const KD: f64 = 0.5;
pub const KS: f64 = 0.5;
/// Split assumed by the wrong prediction.
pub const KD_WRONG: f64 = 0.6;
pub const KS_WRONG: f64 = 0.4;

/// The same samples with other values and no noise.
fn with_values(s: &Samples, f: impl FnMut(usize) -> f64) -> Samples {
    Samples { value: (0..s.len()).map(f).collect(), sigma: vec![0.0; s.len()], ..s.clone() }
}

/// What the check compares, computed from renders (or synthetic images in the tests).
pub struct Inputs {
    pub lmax: usize,
    /// Separation of the measured images with the assumed split.
    pub measured: Separated,
    /// Separation of the noise-free predicted images (assumed split): the method's own bias.
    pub predicted: Separated,
    /// Least squares of the lighting itself at the same R directions (no diffuse part).
    pub lighting_lsq: Vec<f64>,
    /// Least squares at R of the pure 9-term residual r(n) of eq. 38 (assumed split).
    pub residual_lsq: Vec<f64>,
    /// Consistency χ² scan over the diffuse fraction (fixed k_d + k_s).
    pub scan: Vec<(f64, f64)>,
    /// The true diffuse fraction.
    pub true_fraction: f64,
}

/// Runs the algorithm on measured diffuse / specular samples and on the predicted ones built from a
/// lighting `light_at(dir)` (the map at a direction) and its SH `light` (for D(n) and the residual).
#[allow(clippy::too_many_arguments)]
pub fn separate(
    dif: &Samples,
    spec: &Samples,
    light: &[f64],
    light_at: &dyn Fn([f64; 3]) -> f64,
    lmax: usize,
    kd: f64,
    ks: f64,
    true_fraction: f64,
) -> Result<Inputs, String> {
    let e = |e: analysis::Error| e.to_string();
    let measured = Separation::new(dif, spec, lmax).map_err(e)?;
    let scan_x: Vec<f64> = (0..=30).map(|i| 0.35 + 0.01 * i as f64).collect();
    let scan = measured.scan_split(kd + ks, &scan_x);
    let measured = measured.solve(kd, ks).map_err(e)?;
    let lmax_light = analysis::sh::lmax_of(light.len()).ok_or("lighting coefficients: not (L+1)² long")?;
    let basis = ShBasis::new(lmax_light);
    let f = analysis::transfer::lambert::lambert(lmax_light);
    let mut y = vec![0.0; light.len()];
    let mut diffuse_image = |n: [f64; 3]| {
        basis.eval_into(n, &mut y);
        (0..light.len()).map(|k| f[lm(k).0] * light[k] * y[k]).sum::<f64>()
    };
    let d_dif: Vec<f64> = dif.normal.iter().map(|&n| diffuse_image(n)).collect();
    let d_spec: Vec<f64> = spec.normal.iter().map(|&n| diffuse_image(n)).collect();
    let pd = with_values(dif, |q| kd * d_dif[q] + ks * light_at(dif.normal[q]));
    let ps = with_values(spec, |p| kd * d_spec[p] + ks * light_at(spec.reflected[p]));
    let predicted = Separation::new(&pd, &ps, lmax).map_err(e)?.solve(kd, ks).map_err(e)?;
    // The lighting alone at R, and the pure residual at n, through the same least squares
    // (k_d = 0: nothing subtracted, k_s = 1).
    let zero = with_values(dif, |_| 0.0);
    let lighting_lsq = Separation::new(&zero, &with_values(spec, |p| light_at(spec.reflected[p])), lmax)
        .map_err(e)?
        .solve(0.0, 1.0)
        .map_err(e)?
        .specular;
    let mut y2 = vec![0.0; light.len()];
    let res = with_values(spec, |p| nine_term_residual(light, kd, ks, &basis, spec.normal[p], &mut y2));
    let residual_lsq = Separation::new(&zero, &res, lmax).map_err(e)?.solve(0.0, 1.0).map_err(e)?.specular;
    Ok(Inputs { lmax, measured, predicted, lighting_lsq, residual_lsq, scan, true_fraction })
}

/// The check from its inputs; `truth` = the full-resolution lighting coefficients (for the
/// informative aliasing note and the plot).
pub fn evaluate(inp: &Inputs, truth: &[f64]) -> Check {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "diffuse + specular separation ([17]): 9-term diffuse subtraction, lighting recovered from the specular part, low-order consistency",
    );
    let (m, p) = (&inp.measured, &inp.predicted);
    // By linearity the predicted separation is exactly (grid-equivalent lighting) + (9-term
    // residual): expected = predicted − residual, approx = |residual| (eq. 38–39).
    for j in 0..LOW {
        let (l, mm) = lm(j);
        let r = inp.residual_lsq[j];
        c.push(
            Row::new(
                format!("consistency L̂_{l},{mm} − c_{l},{mm}"),
                p.consistency[j] + r,
                m.consistency[j],
                m.consistency_se[j],
            )
            .approx(r),
        );
    }
    let n = num_coefficients(inp.lmax);
    for k in 0..n {
        let (l, mm) = lm(k);
        let r = inp.residual_lsq[k];
        c.push(Row::new(format!("recovered L_{l},{mm}"), p.specular[k] - r, m.specular[k], m.specular_se[k]).approx(r));
    }
    for l in 0..=inp.lmax {
        c.push(
            Row::new(
                format!("order {l}: RMS |c − c_G| vs the 9-term residual (eq. 38)"),
                order_rms(l, |k| inp.residual_lsq[k]),
                order_rms(l, |k| m.specular[k] - inp.lighting_lsq[k]),
                order_rms(l, |k| m.specular_se[k]),
            )
            .informative(),
        );
    }
    if let Some((x, chi)) = best_split(&inp.scan) {
        c.push(
            Row::new("split scan: k_d/(k_d+k_s) minimising the consistency χ²", inp.true_fraction, x, 0.01)
                .informative(),
        );
        c.note(format!("split scan over k_d/(k_d+k_s) ∈ [0.35, 0.65] (step 0.01, k_d + k_s fixed): minimum χ² = {chi:.1} (9 dof) at {x:.2}; true {:.2}", inp.true_fraction));
    }
    let grid: Vec<f64> = (0..LOW).map(|j| p.consistency[j] + inp.residual_lsq[j]).collect();
    c.note(format!(
        "consistency expected from the grid alone (diffuse-view quadrature and least-squares aliasing of Grace's high orders, computed from the map): {}; stated 9-term residual of these 9 (approx): {}",
        grid.iter().map(|v| format!("{v:+.4}")).collect::<Vec<_>>().join(", "),
        inp.residual_lsq[..LOW].iter().map(|v| format!("{v:+.4}")).collect::<Vec<_>>().join(", ")
    ));
    if let Some(chi) = m.chi2 {
        c.note(format!("consistency χ² = {chi:.1} for 9 coefficients at the assumed split k_d = {:.2}, k_s = {:.2} (includes the stated bias)", m.kd, m.ks));
    }
    let alias: Vec<f64> =
        (0..=inp.lmax).map(|l| order_rms(l, |k| inp.lighting_lsq[k] - truth.get(k).copied().unwrap_or(0.0))).collect();
    c.note(format!(
        "least squares of the lighting at the R directions vs its full-resolution L_lm (aliasing of orders > {}), RMS per order: {}",
        inp.lmax,
        alias.iter().map(|v| format!("{v:.2e}")).collect::<Vec<_>>().join(", ")
    ));
    // Plots.
    let ks: Vec<f64> = (0..n).map(|k| k as f64).collect();
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "separation.svg".into(),
        title: "Separation ([17]): lighting recovered from the specular part vs Grace, k = l(l+1)+m".into(),
        x_label: "k".into(),
        y_label: "L_lm".into(),
        curves: vec![
            Series {
                name: "Grace (least squares at R)".into(),
                x: ks.clone(),
                y: inp.lighting_lsq.clone(),
                err: None,
                dashed: false,
            },
            Series {
                name: "Grace (full resolution)".into(),
                x: ks.clone(),
                y: (0..n).map(|k| truth.get(k).copied().unwrap_or(0.0)).collect(),
                err: None,
                dashed: true,
            },
        ],
        points: vec![
            Series {
                name: "recovered ± σ".into(),
                x: ks.clone(),
                y: m.specular.clone(),
                err: Some(m.specular_se.clone()),
                dashed: false,
            },
            Series {
                name: "diffuse side L̂ (l ≤ 2) ± σ".into(),
                x: ks[..LOW].to_vec(),
                y: m.diffuse.clone(),
                err: Some(m.diffuse_se.clone()),
                dashed: false,
            },
        ],
    });
    let ls: Vec<f64> = (0..=inp.lmax).map(|l| l as f64).collect();
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "separation_error.svg".into(),
        title: "Separation: RMS error per order vs the 9-term residual (eq. 38) and σ".into(),
        x_label: "l".into(),
        y_label: "RMS over m".into(),
        curves: vec![
            Series {
                name: "9-term residual at R".into(),
                x: ls.clone(),
                y: (0..=inp.lmax).map(|l| order_rms(l, |k| inp.residual_lsq[k])).collect(),
                err: None,
                dashed: false,
            },
            Series {
                name: "σ (propagated)".into(),
                x: ls.clone(),
                y: (0..=inp.lmax).map(|l| order_rms(l, |k| m.specular_se[k])).collect(),
                err: None,
                dashed: true,
            },
        ],
        points: vec![Series {
            name: "measured |c − c_G|".into(),
            x: ls,
            y: (0..=inp.lmax).map(|l| order_rms(l, |k| m.specular[k] - inp.lighting_lsq[k])).collect(),
            err: None,
            dashed: false,
        }],
    });
    if !inp.scan.is_empty() {
        c.plots.push(Plot {
            legend: Legend::UpperRight,
            file: "separation_scan.svg".into(),
            title: "Separation: consistency χ² (9 dof) vs assumed diffuse fraction".into(),
            x_label: "k_d / (k_d + k_s)".into(),
            y_label: "χ²".into(),
            curves: vec![],
            points: vec![Series {
                name: "χ²".into(),
                x: inp.scan.iter().map(|s| s.0).collect(),
                y: inp.scan.iter().map(|s| s.1).collect(),
                err: None,
                dashed: false,
            }],
        });
    }
    c
}

/// The Grace map (green) at a direction, nearest pixel of the angular map (as the renderer's
/// `angular_lookup`, docs/src/conventions.md §2).
pub fn grace_lookup(img: &analysis::image::RgbImage) -> impl Fn([f64; 3]) -> f64 + '_ {
    move |d: [f64; 3]| {
        let s = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let rho = s.atan2(d[2]) / PI;
        let (a, b) = if s > 0.0 { (rho * d[0] / s, rho * d[1] / s) } else { (rho, 0.0) };
        let w = img.width;
        let half = 0.5 * w as f64;
        let c = (((a + 1.0) * half).max(0.0) as usize).min(w - 1);
        let r = (((1.0 - b) * half).max(0.0) as usize).min(w - 1);
        // Outside the disc the renderer's map is black.
        let (u, v) = ((c as f64 + 0.5 - half) / half, (half - r as f64 - 0.5) / half);
        if u * u + v * v > 1.0 { 0.0 } else { img.get(r, c)[grace::CHANNEL] as f64 }
    }
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let lg = grace::coefficients(ctx)?;
    let img = analysis::image::read_rgb(grace_path(ctx)).map_err(|e| e.to_string())?;
    let lmax = if ctx.quick { 8 } else { 12 };
    let brdf = mix(vec![(KD, lambert(1.0)), (KS, mirror(1.0))]);
    let spp = ctx.spp(256, 256);
    let mut films = vec![];
    for (theta_o_deg, phi_o_deg) in [(0.0, 0.0), (THETA_O_DEG, 0.0), (THETA_O_DEG, 180.0)] {
        let mut spec = Spec::probe(ctx, spp, Lighting::Grace(1.0), brdf.clone());
        spec.camera = Camera::Probe { theta_o_deg, phi_o_deg };
        films.push((render_spec(ctx, &spec)?, spec));
    }
    let to = THETA_O_DEG.to_radians();
    let samples: Vec<Samples> = films
        .iter()
        .zip([(0.0, false), (to, false), (to, true)])
        .map(|((film, _), (t, flip))| {
            let ch = Channel::from_film(film, grace::CHANNEL);
            probe_samples(&ch.value, &ch.sigma, ch.width, ch.height, t, flip)
        })
        .collect();
    let mut it = samples.into_iter();
    let (Some(dif), Some(s0), Some(s1)) = (it.next(), it.next(), it.next()) else {
        return Err("renders missing".into());
    };
    let mut spec = s0;
    spec.append(s1);
    let (kd, ks) = if ctx.wrong { (KD_WRONG, KS_WRONG) } else { (KD, KS) };
    let lookup = grace_lookup(&img);
    let inp = separate(&dif, &spec, &lg, &lookup, lmax, kd, ks, KD / (KD + KS))?;
    let mut c = evaluate(&inp, &lg);
    // The θ_o = 0 render beside the forward model the separation inverts: at normal exitance R = n,
    // so B(n) = k_d Σ_l (Λ_l ρ̂_l)_Lambert Σ_m L_lm Y_lm(n) + k_s L(n) (the map's nearest pixel).
    {
        let ch = Channel::from_film(&films[0].0, grace::CHANNEL);
        let diffuse = Picture::probe_filter("", "", "", &ch, &lg, &transfer::lambert(grace::LMAX), |_| 0.0);
        let (w, h) = (ch.width, ch.height);
        let predicted =
            (0..w * h).map(|i| kd * diffuse.predicted[i] + ks * lookup(latlong_dir(i / w, i % w, w, h))).collect();
        c.pictures.push(Picture::new(
            "separation",
            format!("{KD} Lambert + {KS} mirror sphere under Grace (green), θ_o = 0, normal probe {w}×{h}, {spp} spp"),
            format!(
                "k_d·(eq. 38/π filter on the Grace L_lm, l ≤ {}) + k_s·L(n) from the map (the forward model the separation inverts)",
                grace::LMAX
            ),
            (w, h),
            ch.value.clone(),
            predicted,
            ch.sigma.clone(),
        ));
    }
    let s = &films[0].1;
    c.note(format!(
        "three normal-probe renders {}×{}, {spp} spp, green: θ_o = 0 (diffuse side), θ_o = {THETA_O_DEG}° at φ_o = 0° and 180° (specular side); mix {KD} lambert + {KS} mirror; recovered to l = {lmax}",
        s.width, s.height
    ));
    c.note("not counted: Grace's content above l = 16 in the Lambert image D(n) of the prediction (|Λ_l ρ̂_l| < 2e-3 there), and f32 rounding of R in the renderer's nearest-pixel lookup".to_string());
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A band-limited grey lighting with strong low orders (as Grace's).
    fn light() -> Vec<f64> {
        (0..num_coefficients(6))
            .map(|k| {
                let (l, m) = lm(k);
                if k == 0 {
                    3.0
                } else {
                    1.2 / (1.0 + l as f64 * l as f64) * (((5 * k + 3 * (m + 9) as usize) % 11) as f64 / 11.0 - 0.45)
                }
            })
            .collect()
    }

    /// Synthetic renders of the mix under `light` on a W × H probe grid, noise σ per pixel.
    fn synthetic(light: &[f64], w: usize, h: usize, sigma: f64, seed: u64) -> (Samples, Samples) {
        let basis = ShBasis::new(6);
        let f = analysis::transfer::lambert::lambert(6);
        let eval = |d: [f64; 3], filt: bool| {
            let y = basis.eval(d);
            (0..light.len()).map(|k| light[k] * y[k] * if filt { f[lm(k).0] } else { 1.0 }).sum::<f64>()
        };
        let to = THETA_O_DEG.to_radians();
        let mut out = vec![];
        for (i, (t, flip)) in [(0.0, false), (to, false), (to, true)].into_iter().enumerate() {
            let geo = probe_samples(&vec![0.0; w * h], &vec![0.0; w * h], w, h, t, flip);
            let ch = Channel::synthetic_probe(w, h, |_| 0.0, sigma, seed * 3 + i as u64);
            let v: Vec<f64> = (0..w * h)
                .map(|p| KD * eval(geo.normal[p], true) + KS * eval(geo.reflected[p], false) + ch.value[p])
                .collect();
            out.push(Samples { value: v, sigma: ch.sigma.clone(), ..geo });
        }
        let mut it = out.into_iter();
        let (a, b, c) = (it.next().unwrap(), it.next().unwrap(), it.next().unwrap());
        let mut spec = b;
        spec.append(c);
        (a, spec)
    }

    #[test]
    fn passes_the_right_split_and_fails_a_wrong_one() {
        // Synthetic renders (band-limited lighting to l = 6, σ = 0.01 per pixel, 96 × 48 as quick).
        let lt = light();
        let basis = ShBasis::new(6);
        let at = |d: [f64; 3]| basis.eval(d).iter().zip(&lt).map(|(y, l)| y * l).sum::<f64>();
        let (dif, spec) = synthetic(&lt, 96, 48, 0.01, 3);
        let good = evaluate(&separate(&dif, &spec, &lt, &at, 8, KD, KS, 0.5).unwrap(), &lt);
        assert!(
            good.passed(),
            "{:?}",
            good.rows
                .iter()
                .filter(|r| !r.informative && !r.passed())
                .map(|r| (&r.label, r.measured, r.expected, r.tolerance()))
                .collect::<Vec<_>>()
        );
        // The 9-term residual is real here (l = 4, 6 content) and stated, not zero.
        assert!(good.rows.iter().any(|r| !r.informative && r.label.starts_with("recovered L_4") && r.approx > 1e-4));
        let wrong = separate(&dif, &spec, &lt, &at, 8, KD_WRONG, KS_WRONG, 0.5).unwrap();
        let bad = evaluate(&wrong, &lt);
        assert!(!bad.passed());
        // The consistency rows alone must fail at the wrong split (not only the recovered scale).
        assert!(bad.rows.iter().any(|r| r.label.starts_with("consistency") && !r.passed()), "consistency must break");
        // The scan finds the true split within one step.
        let (x, _) = best_split(&wrong.scan).unwrap();
        assert!((x - 0.5).abs() <= 0.011, "scan minimum {x}");
    }
}
