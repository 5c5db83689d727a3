//! Check "microfacet-ambiguity" (sec. 3.7.3; issue 19): "we may blur the illumination while sharpening
//! the BRDF. However, … these ambiguities are exact for Phong and mirror BRDFs, \[but\] only a good
//! approximation for microfacet BRDFs since equation 57 does not hold at grazing angles or for
//! high-frequency lighting distributions. In these cases, the ambiguity can be broken."
//!
//! The pair: (A) a Torrance–Sparrow sphere (σ = [`SIGMA`], k_s = 1, `horizon = "clamp"`) under a
//! lighting L; (B) a mirror sphere under L blurred by the Torrance–Sparrow *normal-exitance* kernel
//! ρ̂_0(θ) = exp(−θ²/4σ²)/(4πσ²) (θ < π/2; eq. 50), i.e. L'_lm = F(l) L_lm with F(l) = Λ_l ρ̂_l of
//! eq. 50 — the blur-the-lighting / sharpen-the-BRDF partner. At normal exitance the lobe is exactly
//! this radial kernel about R = n, so the two agree exactly; away from it the lobe is anisotropic
//! about R (eq. 58) and is divided by cos θ'_o, and they part.
//!
//! Two lightings: (a) low-frequency, a grey SH lighting with l ≤ [`LMAX_LOW`] (B: the mirror rendered
//! under L' as an SH light); (b) a directional source along [`SOURCE`] (its blur L'(ω) =
//! E ρ̂_0(angle(ω, s)) is no finite SH light; the mirror image is B'(n) = L'(R(n)), in closed form:
//! the `mirror` check verifies the renderer's mirror to f32 rounding). Renders: `normal-probe` at
//! θ_o ∈ [`THETA_O_DEG`].
//!
//! Measured per (lighting, θ_o): D² = Σ_p w_p \[(A_p − B'_p)² − σ_p²\] / Σ_p w_p B'_p², the squared
//! relative rms difference of the pair over the sphere's normals (w_p: pixel solid angle), with the
//! renders' noise σ_p² subtracted (E\[(d + n)²\] = d² + σ², unbiased; the directional and mirror renders
//! are deterministic, σ = 0). σ(D²) = √(Σ_p w_p² (4 d_p² σ_p² + 2 σ_p⁴)) / Σ_p w_p B'_p².
//! Expected: the same D² with the Torrance–Sparrow image predicted without any approximation — the
//! closed-form BRDF under the directional source; direct numerical integration of eq. 48
//! ([`super::oblique::predict_probe`]) under the SH lighting, with its quadrature error stated as
//! the change between two resolutions. Every row is deciding; the pair "holds" where the expected
//! D² is 0 within the row's tolerance, and "breaks" where it is not. Reported (informative): the
//! smallest θ_o at which the pair is broken — for the SH lighting, where D² exceeds 4σ(D²) of these
//! renders (detectable); for the directional source, where D exceeds 1 %.
//!
//! Wrong prediction: the ambiguity exact at every θ_o (D² = 0, as for Phong and the mirror).

use super::Ctx;
use super::check::{Check, F32_FLOOR, Legend, Plot, Row, Series};
use super::fit::{Channel, dot, latlong_omega, normalize};
use super::oblique::{LightTable, Resolution, predict_probe, probe_geometry};
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Shape, Spec, render_spec, sh_lighting};
use super::scenes::{mirror, torrance_sparrow};
use super::transfer;
use std::f64::consts::PI;
use vocab::Horizon;
use vocab::scene::BrdfSection;

pub const NAME: &str = "microfacet-ambiguity";
pub const EQUATION: &str = "sec. 3.7.3, eq. 50, 57-59";
pub const SIGMA: f64 = 0.1;
pub const LMAX_LOW: usize = 2;
pub const SOURCE: [f64; 3] = [0.3, -0.2, 0.93];
pub const THETA_O_DEG: [f64; 6] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0];
/// D above which the directional pair counts as broken (reported, not deciding).
pub const BREAK_D: f64 = 0.01;

fn ts_brdf() -> BrdfSection {
    torrance_sparrow(1.0, SIGMA, Horizon::Clamp)
}

/// Relative pair difference D² ± σ over a probe image; `pair` is the mirror-pair image B'.
#[derive(Clone, Copy, Debug, Default)]
pub struct PairDiff {
    pub d2: f64,
    pub sigma: f64,
}

/// D² of image `a` (with per-pixel σ) against the pair image `b` (exact) on a W × H lat-long grid.
pub fn pair_diff(a: &[f64], sigma: &[f64], b: &[f64], w: usize, h: usize) -> PairDiff {
    let (mut num, mut var, mut den) = (0.0, 0.0, 0.0);
    for p in 0..w * h {
        let wp = latlong_omega(p / w, w, h);
        let d = a[p] - b[p];
        let s2 = sigma[p] * sigma[p];
        num += wp * (d * d - s2);
        var += wp * wp * (4.0 * d * d * s2 + 2.0 * s2 * s2);
        den += wp * b[p] * b[p];
    }
    PairDiff { d2: num / den, sigma: var.sqrt() / den }
}

/// The Torrance–Sparrow ρ̂ (unit k_s, clamped horizon, eq. 48 × cos θ'_i) for (n, ω_o, ω_i).
pub fn ts_rho_hat(n: [f64; 3], wo: [f64; 3], wi: [f64; 3]) -> f64 {
    let (ci, co) = (dot(n, wi), dot(n, wo));
    if ci <= 0.0 || co <= 0.0 {
        return 0.0;
    }
    let hv = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
    let th = dot(n, hv).clamp(-1.0, 1.0).acos();
    (-(th / SIGMA).powi(2)).exp() / (4.0 * PI * SIGMA * SIGMA * co)
}

/// Closed-form images at θ_o under a unit directional source: (Torrance–Sparrow, mirror pair).
pub fn directional_images(theta_o: f64, w: usize, h: usize) -> (Vec<f64>, Vec<f64>) {
    let s = normalize(SOURCE);
    (0..w * h)
        .map(|p| {
            let (n, wo, r) = probe_geometry(p / w, p % w, w, h, theta_o);
            let ts = ts_rho_hat(n, wo, s);
            let mirror = transfer::ts_lobe_normal(SIGMA, dot(r, s).clamp(-1.0, 1.0).acos());
            (ts, mirror)
        })
        .unzip()
}

/// Measured and predicted D² of one lighting over θ_o.
#[derive(Clone, Debug)]
pub struct Curve {
    pub name: String,
    pub theta_o_deg: Vec<f64>,
    pub measured: Vec<PairDiff>,
    pub predicted: Vec<f64>,
    /// Stated error of the prediction (quadrature), per θ_o.
    pub approx: Vec<f64>,
    /// Deterministic renders: the f32 floor applies.
    pub deterministic: bool,
}

/// First θ_o at which `broken(i)` holds.
fn first_broken(c: &Curve, broken: impl Fn(usize) -> bool) -> Option<f64> {
    (0..c.theta_o_deg.len()).find(|&i| broken(i)).map(|i| c.theta_o_deg[i])
}

pub fn evaluate(curves: &[Curve], wrong: bool) -> Check {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "Torrance–Sparrow under L vs mirror under L blurred by eq. 50: equal at normal exitance, apart at grazing",
    );
    for cv in curves {
        for (i, t) in cv.theta_o_deg.iter().enumerate() {
            let m = cv.measured[i];
            let expected = if wrong { 0.0 } else { cv.predicted[i] };
            // f32 rendering: a relative error ε per pixel moves D² by ≤ 2 D ε + ε².
            let floor = if cv.deterministic {
                2.0 * cv.predicted[i].max(0.0).sqrt() * F32_FLOOR + F32_FLOOR * F32_FLOOR
            } else {
                0.0
            };
            c.push(
                Row::new(format!("{}: D² at θo = {t}°", cv.name), expected, m.d2, m.sigma)
                    .approx(cv.approx[i])
                    .floor(floor),
            );
        }
        let (meas, pred) = if cv.deterministic {
            (
                first_broken(cv, |i| cv.measured[i].d2.max(0.0).sqrt() > BREAK_D),
                first_broken(cv, |i| cv.predicted[i].max(0.0).sqrt() > BREAK_D),
            )
        } else {
            (
                first_broken(cv, |i| cv.measured[i].d2 > 4.0 * cv.measured[i].sigma),
                first_broken(cv, |i| cv.predicted[i] > 4.0 * cv.measured[i].sigma),
            )
        };
        let how = if cv.deterministic { format!("D > {BREAK_D}") } else { "D² > 4σ(D²)".to_string() };
        c.push(
            Row::new(
                format!("{}: first θo where the pair breaks ({how}; NaN: never)", cv.name),
                pred.unwrap_or(f64::NAN),
                meas.unwrap_or(f64::NAN),
                0.0,
            )
            .informative(),
        );
        c.note(format!(
            "{}: D = {} at θo = {:?}° (predicted {}); broken ({how}) from θo = {} (predicted {})",
            cv.name,
            cv.measured.iter().map(|m| format!("{:.4}", m.d2.max(0.0).sqrt())).collect::<Vec<_>>().join(", "),
            cv.theta_o_deg,
            cv.predicted.iter().map(|p| format!("{:.4}", p.max(0.0).sqrt())).collect::<Vec<_>>().join(", "),
            meas.map_or("never".into(), |v| format!("{v}°")),
            pred.map_or("never".into(), |v| format!("{v}°")),
        ));
    }
    c.plots.push(plot(curves));
    c
}

fn plot(curves: &[Curve]) -> Plot {
    let lg = |v: f64| v.max(1e-12).log10();
    Plot {
        legend: Legend::LowerLeft,
        file: "microfacet_ambiguity.svg".into(),
        title: "Torrance–Sparrow σ 0.1 vs mirror under blurred lighting: log10 D² vs θo".into(),
        x_label: "θo (degrees)".into(),
        y_label: "log10 D²".into(),
        curves: curves
            .iter()
            .map(|cv| Series {
                name: format!("{} predicted", cv.name),
                x: cv.theta_o_deg.clone(),
                y: cv.predicted.iter().map(|&v| lg(v)).collect(),
                err: None,
                dashed: false,
            })
            .collect(),
        points: curves
            .iter()
            .map(|cv| Series {
                name: format!("{} measured", cv.name),
                x: cv.theta_o_deg.clone(),
                y: cv.measured.iter().map(|m| lg(m.d2)).collect(),
                // log10 error bars: σ/(D² ln 10), clipped so a D² near 0 does not swamp the plot.
                err: Some(
                    cv.measured.iter().map(|m| (m.sigma / (m.d2.abs().max(1e-12) * 10f64.ln())).min(2.0)).collect(),
                ),
                dashed: false,
            })
            .collect(),
    }
}

/// Probe height and samples per pixel of the SH renders.
pub fn plan(quick: bool) -> (usize, u32) {
    if quick { (32, 64) } else { (48, 256) }
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let (h, spp) = plan(ctx.quick);
    let w = 2 * h;
    let light = sh_lighting(LMAX_LOW, 0.4, ctx.seed + 19);
    let f = transfer::torrance_sparrow(SIGMA, LMAX_LOW);
    let blurred: Vec<f64> = light.iter().enumerate().map(|(k, v)| v * f[analysis::sh::lm(k).0]).collect();
    // Two prediction resolutions: the quadrature error of the SH prediction is their difference.
    let fine = (LightTable::new(&light, LMAX_LOW, 256), Resolution { n_theta: 24, n_phi: 64 });
    let coarse = (LightTable::new(&light, LMAX_LOW, 128), Resolution { n_theta: 16, n_phi: 40 });
    let mut sh = Curve {
        name: format!("SH l ≤ {LMAX_LOW}"),
        theta_o_deg: THETA_O_DEG.to_vec(),
        measured: vec![],
        predicted: vec![],
        approx: vec![],
        deterministic: false,
    };
    let mut dir = Curve { name: "directional".into(), deterministic: true, ..sh.clone() };
    let mut pictures = vec![];
    for (i, &t) in THETA_O_DEG.iter().enumerate() {
        let camera = Camera::Probe { theta_o_deg: t, phi_o_deg: 0.0 };
        let base = Spec {
            width: w as u32,
            height: h as u32,
            spp,
            seed: ctx.seed + 190 + i as u64,
            camera,
            lighting: Lighting::Sh(light.clone()),
            shape: Shape::Sphere,
            brdf: ts_brdf(),
        };
        let a = Channel::from_film(&render_spec(ctx, &base)?, 0);
        let mirror = Spec { spp: 2, lighting: Lighting::Sh(blurred.clone()), brdf: mirror(1.0), ..base.clone() };
        let b = Channel::from_film(&render_spec(ctx, &mirror)?, 0);
        let theta_o = t.to_radians();
        sh.measured.push(pair_diff(&a.value, &a.sigma, &b.value, w, h));
        if i == 0 {
            pictures.push(Picture::new(
                "microfacet_ambiguity_sh",
                format!("Torrance–Sparrow σ = {SIGMA} under SH light l ≤ {LMAX_LOW}, θ_o = {t}° (normal probe)"),
                "mirror sphere under the lighting blurred by the Torrance–Sparrow filter (the ambiguous pair)",
                (w, h),
                a.value.clone(),
                b.value.clone(),
                a.sigma.iter().zip(&b.value).map(|(s, v)| s.hypot(F32_FLOOR * v.abs())).collect(),
            ));
        }
        let zero = vec![0.0; w * h];
        let pf = pair_diff(&predict_probe(SIGMA, theta_o, w, h, &fine.0, fine.1), &zero, &b.value, w, h).d2;
        let pc = pair_diff(&predict_probe(SIGMA, theta_o, w, h, &coarse.0, coarse.1), &zero, &b.value, w, h).d2;
        sh.predicted.push(pf);
        sh.approx.push((pf - pc).abs());
        // The directional source: deterministic (a delta light is sampled by next-event estimation
        // only, and the camera looks through pixel centres), 2 spp (deterministic; two samples so that the stderr layer is defined, 0).
        let d = Spec { spp: 2, lighting: Lighting::Directional { direction: SOURCE, irradiance: 1.0 }, ..base.clone() };
        let dch = Channel::from_film(&render_spec(ctx, &d)?, 0);
        let (ts, pair) = directional_images(theta_o, w, h);
        dir.measured.push(pair_diff(&dch.value, &dch.sigma, &pair, w, h));
        if i + 1 == THETA_O_DEG.len() {
            pictures.push(Picture::new(
                "microfacet_ambiguity_directional",
                format!(
                    "Torrance–Sparrow σ = {SIGMA} under a directional source, θ_o = {t}° (normal probe, 2 spp, exact)"
                ),
                "the Phong-like pair (blurred lighting, sharpened BRDF) where the ambiguity breaks; the render is \
                 exact, so z saturates wherever the two differ",
                (w, h),
                dch.value.clone(),
                pair.clone(),
                dch.sigma.iter().zip(&pair).map(|(s, v)| s.hypot(F32_FLOOR * v.abs())).collect(),
            ));
        }
        dir.predicted.push(pair_diff(&ts, &zero, &pair, w, h).d2);
        dir.approx.push(0.0);
    }
    let mut c = evaluate(&[sh, dir], ctx.wrong);
    c.pictures = pictures;
    c.note(format!(
        "normal-probe {w}×{h}; SH lighting l ≤ {LMAX_LOW}: Torrance–Sparrow {spp} spp, mirror under L' 2 spp; directional {:?}: 2 spp (deterministic)",
        normalize(SOURCE)
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pair_is_exact_at_normal_exitance_and_breaks_at_grazing() {
        let (w, h) = (64, 32);
        let (ts, pair) = directional_images(0.0, w, h);
        let zero = vec![0.0; w * h];
        assert!(pair_diff(&ts, &zero, &pair, w, h).d2.abs() < 1e-20, "θo = 0: same image");
        let (ts, pair) = directional_images(75f64.to_radians(), w, h);
        assert!(pair_diff(&ts, &zero, &pair, w, h).d2.sqrt() > 0.1, "θo = 75°: far apart");
    }

    #[test]
    fn right_prediction_passes_and_wrong_fails() {
        let mk = |d2: Vec<f64>, det: bool| Curve {
            name: "x".into(),
            theta_o_deg: vec![0.0, 45.0, 75.0],
            measured: d2.iter().map(|&v| PairDiff { d2: v + if det { 0.0 } else { 1e-5 }, sigma: 1e-5 }).collect(),
            predicted: d2.clone(),
            approx: vec![0.0; 3],
            deterministic: det,
        };
        let curves = [mk(vec![0.0, 1e-4, 1e-2], false), mk(vec![0.0, 0.02, 0.3], true)];
        assert!(evaluate(&curves, false).passed());
        assert!(!evaluate(&curves, true).passed());
    }

    #[test]
    fn pair_diff_debiases_noise() {
        // Pure noise of known σ around the pair: E[D²] = 0, and the scatter matches σ(D²).
        let (w, h) = (64, 32);
        let b = vec![1.0; w * h];
        let mut rng = renderer::sampling::chi2::TestRng::new(5);
        let mut u = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let a: Vec<f64> = (0..w * h)
            .map(|_| {
                let (u1, u2) = (u().max(1e-300), u());
                1.0 + 0.05 * (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
            })
            .collect();
        let d = pair_diff(&a, &vec![0.05; w * h], &b, w, h);
        assert!(d.d2.abs() < 4.0 * d.sigma, "{d:?}");
    }
}
