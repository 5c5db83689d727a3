//! Check "ambiguity" (eq. 32, 47; issue 5): the per-order scale ambiguity of factorization for
//! mirror and Phong BRDFs, shown by two *different* (lighting, BRDF) pairs that give the *same*
//! renders as a reference pair, at several exitance angles.
//!
//! With F_s(l) = Λ_l ρ̂_l(s) the exact Phong filter (eq. 43) and L a grey SH lighting band-limited
//! to l ≤ [`LMAX`] (so every statement below is exact, with known coefficients):
//! - (A) reference: Phong s = [`S`], k_s = 1, `horizon = "ignore"`, under L;
//! - (B) eq. 47, associativity of convolution: a mirror (k_r = 1) under L'_lm = F_s(l) L_lm — the
//!   lighting blurred by the BRDF filter, the BRDF sharpened to a mirror;
//! - (C) eq. 32, an arbitrary per-order scale f(l): Phong s = [`S2`] under
//!   L''_lm = L_lm F_s(l) / F_s2(l) (F_s2(l) ≠ 0 for l ≤ 8, s2 = 16: its zeros start at l = 18).
//!
//! After reparameterization by the reflection vector R the `ignore` Phong lobe is a radial filter
//! about R (sec. 3.6), so B(n, ω_o) = Σ_l F_s(l) S_l(R), S_l(R) = Σ_m L_lm Y_lm(R), at *every*
//! exitance angle: the three renders must agree pixel by pixel at θ_o ∈ [`THETA_O_DEG`]
//! (`normal-probe` camera, φ_o = 0).
//!
//! Comparison of two renders X, A per θ_o (independent renders: distinct render seeds):
//! - pixel statistic: d_p = X_p − A_p, σ̂_p² = σ̂_X,p² + σ̂_A,p² from the `stderr` layers,
//!   χ²/N = (1/N) Σ_p d_p²/σ̂_p². Because σ̂ is itself estimated from n samples, t_p = d_p/σ̂_p is a
//!   Student t with ν = n − 1 (one noisy image; Gaussian samples), or, for two noisy images,
//!   approximately with the Welch–Satterthwaite ν_p = (v_X + v_A)² / (v_X²/ν_X + v_A²/ν_A)
//!   (exact, ν = 2(n−1), when the two variances are equal). Then E\[t²\] = ν/(ν−2) and
//!   Var\[t²\] = E\[t⁴\] − E\[t²\]² = 3ν²/((ν−2)(ν−4)) − ν²/(ν−2)² = 2ν²(ν−1)/((ν−2)²(ν−4)), so the
//!   row expects mean_p E\[t_p²\] with σ = √(Σ_p Var\[t_p²\]) / N (independent pixels), 4σ rule.
//!   Non-Gaussian samples: to first order in 1/n, E\[t²\] = 1 + 2(1 + γ²)/n with γ the per-sample
//!   skewness (the kurtosis cancels between E\[x̄² s²\] and Var s²), i.e. an unmodelled excess
//!   2γ²/n — reported in a note, ≤ 0.021 (quick, 96 spp) and ≤ 0.006 (full, 320 spp)
//!   for |γ| ≤ 1, against 4σ ≈ 0.086 (N = 96 × 48 pixels).
//! - per-order content about R: weighted least squares of each image on S_l(R_p), l ≤ LMAX
//!   ([`super::fit::fit_filter_at`]): g_l ± σ, exact for band-limited light; the row is the worst
//!   |g_l^X − g_l^A| against 4·√(σ_X² + σ_A²) (linear in the pixels: the two fits are independent).
//!   This targeted test has far more power than the omnibus χ² against a per-order mismatch.
//!
//! The mirror render is deterministic (every sample follows the same reflected ray; pixel centres,
//! no jitter): its σ must be exactly 0 (a deciding row).
//! Informative: Phong with `horizon = "clamp"` at θ_o = 70° against the mirror pair B — the
//! ambiguity is exact only for the radial lobe (sec. 3.6, 3.7.3): the clamped lobe is cut by the
//! horizon and the χ² departs.
//! Wrong prediction: L' blurred with s = 1.2 × 8 (a different per-order scale than the BRDF's).

use super::Ctx;
use super::check::{Check, F32_FLOOR, Legend, Plot, Row, Series};
use super::fit::{Channel, Fit, fit_filter_at, order_rms};
use super::oblique::probe_geometry;
use super::picture::Picture;
use super::scenes::{Camera, Lighting, Spec, render_spec, sh_lighting};
use super::scenes::{mirror, phong};
use super::transfer;
use analysis::sh::lm;
use vocab::Horizon;
use vocab::scene::BrdfSection;

pub const NAME: &str = "ambiguity";
pub const EQUATION: &str = "eq. 32, 47";
/// Band limit of the lighting.
pub const LMAX: usize = 8;
/// Phong exponent of the reference pair A.
pub const S: f64 = 8.0;
/// Phong exponent of pair C.
pub const S2: f64 = 16.0;
/// Exitance angles (degrees) of the `normal-probe` renders.
pub const THETA_O_DEG: [f64; 3] = [0.0, 40.0, 70.0];
/// Height of the `normal-probe` renders (W = 2H) in both modes. The χ² row's σ shrinks as 1/√N
/// with the pixel count N, while the unmodelled non-Gaussian excess 2γ²/n (module doc) shrinks
/// only with the samples per pixel n: the full mode therefore spends its budget on n, not on N.
pub const PROBE_HEIGHT: u32 = 48;
/// Samples per pixel of the Phong renders, quick and full mode.
pub const QUICK_SPP: u32 = 96;
pub const FULL_SPP: u32 = 320;
/// Exponent factor of the deliberately wrong blur.
pub const WRONG_FACTOR: f64 = 1.2;

/// The three lightings: L (pair A), L' (pair B, eq. 47), L'' (pair C, eq. 32).
#[derive(Clone, Debug)]
pub struct Lightings {
    pub l: Vec<f64>,
    pub blurred: Vec<f64>,
    pub rescaled: Vec<f64>,
}

/// L, L'_lm = F_{s_blur}(l) L_lm and L''_lm = F_S(l)/F_S2(l) L_lm.
pub fn lightings(light: Vec<f64>, s_blur: f64) -> Lightings {
    let fb = transfer::phong(s_blur, LMAX);
    let (f8, f16) = (transfer::phong(S, LMAX), transfer::phong(S2, LMAX));
    let blurred = light.iter().enumerate().map(|(k, v)| v * fb[lm(k).0]).collect();
    let rescaled = light.iter().enumerate().map(|(k, v)| v * f8[lm(k).0] / f16[lm(k).0]).collect();
    Lightings { l: light, blurred, rescaled }
}

/// E\[t²\] and Var\[t²\] of a Student t with ν degrees of freedom (ν = ∞: the normal, 1 and 2).
pub fn t2_moments(nu: f64) -> (f64, f64) {
    if nu.is_infinite() {
        (1.0, 2.0)
    } else {
        (nu / (nu - 2.0), 2.0 * nu * nu * (nu - 1.0) / ((nu - 2.0).powi(2) * (nu - 4.0)))
    }
}

/// Pixel χ² of the difference of two renders.
#[derive(Clone, Copy, Debug)]
pub struct PixelChi2 {
    /// Pixels compared (σ̂_p > 0).
    pub n: usize,
    /// Pixels skipped because both images are deterministic there (σ̂_p = 0).
    pub skipped: usize,
    /// (1/N) Σ d_p²/σ̂_p².
    pub chi2: f64,
    /// (1/N) Σ E\[t_p²\].
    pub expected: f64,
    /// √(Σ Var\[t_p²\]) / N.
    pub sd: f64,
}

/// Compares two images whose σ̂ were estimated with ν_a, ν_b degrees of freedom (spp − 1; ∞ for a
/// known σ). Returns None when the images differ in size, no pixel has σ̂ > 0, or some ν ≤ 4
/// (Var\[t²\] is infinite).
pub fn compare(a: &Channel, nu_a: f64, b: &Channel, nu_b: f64) -> Option<PixelChi2> {
    if a.value.len() != b.value.len() || nu_a <= 4.0 || nu_b <= 4.0 {
        return None;
    }
    let (mut n, mut skipped, mut chi, mut e, mut var) = (0usize, 0usize, 0.0, 0.0, 0.0);
    for i in 0..a.value.len() {
        let (va, vb) = (a.sigma[i] * a.sigma[i], b.sigma[i] * b.sigma[i]);
        let v = va + vb;
        if v <= 0.0 {
            skipped += 1;
            continue;
        }
        // Welch–Satterthwaite; a deterministic image (v = 0) adds no term.
        let den = va * va / nu_a + vb * vb / nu_b;
        let nu = if den > 0.0 { v * v / den } else { f64::INFINITY };
        let (m1, m2) = t2_moments(nu.max(nu_a.min(nu_b)));
        let d = a.value[i] - b.value[i];
        chi += d * d / v;
        e += m1;
        var += m2;
        n += 1;
    }
    (n > 0).then(|| PixelChi2 { n, skipped, chi2: chi / n as f64, expected: e / n as f64, sd: var.sqrt() / n as f64 })
}

/// Per-order content g_l ± σ of a probe image at θ_o about R, on the order parts of `light`.
pub fn order_gains(ch: &Channel, light: &[f64], theta_o_deg: f64) -> Option<Fit> {
    let (w, h) = (ch.width, ch.height);
    let t = theta_o_deg.to_radians();
    fit_filter_at(ch, light, LMAX, |r, c| probe_geometry(r, c, w, h, t).2)
}

/// One compared image: its label, its render, the degrees of freedom of its σ̂ and its gains.
pub struct Image {
    pub label: String,
    pub ch: Channel,
    pub nu: f64,
    pub gains: Fit,
}

/// Rows comparing image `x` with the reference `a` at θ_o: the pixel χ² and the worst per-order
/// gain difference. `informative` for the clamp study.
pub fn compare_rows(c: &mut Check, theta_o: f64, a: &Image, x: &Image, informative: bool) -> Option<PixelChi2> {
    let chi = compare(&x.ch, x.nu, &a.ch, a.nu)?;
    let mut row = Row::new(format!("χ²/N, {} vs {}, θo={theta_o}°", x.label, a.label), chi.expected, chi.chi2, chi.sd);
    if informative {
        row = row.informative();
    }
    c.push(row);
    let mut worst: Option<Row> = None;
    for l in 0..=LMAX {
        let (gx, ga) = (&x.gains, &a.gains);
        let mut r = Row::new(
            format!("worst g_l {} − g_l {}, θo={theta_o}° (at l={l})", x.label, a.label),
            0.0,
            gx.coef[l] - ga.coef[l],
            gx.sigma[l].hypot(ga.sigma[l]),
        )
        .floor(F32_FLOOR * gx.coef[l].abs().max(ga.coef[l].abs()));
        if informative {
            r = r.informative();
        }
        if worst.as_ref().is_none_or(|w| r.ratio() > w.ratio()) {
            worst = Some(r);
        }
    }
    c.rows.extend(worst);
    Some(chi)
}

/// The check from the renders: per θ_o, the reference A and the pairs (B, C) compared with it;
/// `clamp` optionally (θ_o, clamped Phong image) for the informative row; the lightings for the
/// informative rows and the plot.
pub fn evaluate(
    per_angle: &[(f64, Image, Vec<Image>)],
    clamp: Option<(f64, &Image, &Image)>,
    lights: &Lightings,
) -> Option<Check> {
    let mut c = Check::new(
        NAME,
        EQUATION,
        "different (lighting, BRDF) pairs give the same renders: Phong s=8 under L = mirror under L blurred by F_8 (eq. 47) = Phong s=16 under L·F_8/F_16 (eq. 32), at every θ_o",
    );
    // The lightings differ (informative: "expected" = the reference lighting's RMS).
    for l in [2, 4, 8] {
        let r0 = order_rms(l, |k| lights.l[k]);
        c.push(
            Row::new(
                format!("RMS_m L'_lm / L_lm, l={l} (lightings differ)"),
                1.0,
                order_rms(l, |k| lights.blurred[k]) / r0,
                0.0,
            )
            .informative(),
        );
        c.push(
            Row::new(
                format!("RMS_m L''_lm / L_lm, l={l} (lightings differ)"),
                1.0,
                order_rms(l, |k| lights.rescaled[k]) / r0,
                0.0,
            )
            .informative(),
        );
    }
    let mut chi_series: Vec<Series> = vec![];
    let (mut exp_x, mut exp_y, mut band_lo, mut band_hi) = (vec![], vec![], vec![], vec![]);
    for (theta, a, others) in per_angle {
        for (i, x) in others.iter().enumerate() {
            let chi = compare_rows(&mut c, *theta, a, x, false)?;
            if chi_series.len() <= i {
                chi_series.push(Series { name: format!("χ²/N {} vs {}", x.label, a.label), ..Default::default() });
            }
            chi_series[i].x.push(*theta + 1.5 * i as f64);
            chi_series[i].y.push(chi.chi2);
            if i == 0 {
                exp_x.push(*theta);
                exp_y.push(chi.expected);
                band_lo.push(chi.expected - 4.0 * chi.sd);
                band_hi.push(chi.expected + 4.0 * chi.sd);
            }
            c.note(format!(
                "θo = {theta}°: {} vs {}: χ²/N = {:.4} over N = {} pixels (expected {:.4} ± {:.4}); skipped (σ̂ = 0) {}",
                x.label, a.label, chi.chi2, chi.n, chi.expected, chi.sd, chi.skipped
            ));
        }
    }
    if let Some((theta, a, x)) = clamp {
        let chi = compare_rows(&mut c, theta, a, x, true)?;
        c.note(format!(
            "informative, θo = {theta}°: {} vs {}: χ²/N = {:.3} (a radial lobe would give {:.4} ± {:.4}): the horizon breaks the ambiguity",
            x.label, a.label, chi.chi2, chi.expected, chi.sd
        ));
        // Not in the χ² plot: at χ²/N ≫ 1 it would flatten the ±4σ band of the exact pairs.
    }
    // Plot 1: the lightings differ, order by order (l ≥ 1: L_00 is common and dominates).
    let ls: Vec<f64> = (1..=LMAX).map(|l| l as f64).collect();
    let rms = |v: &[f64]| (1..=LMAX).map(|l| order_rms(l, |k| v[k])).collect::<Vec<_>>();
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "ambiguity_lightings.svg".into(),
        title: "Three lightings, same renders: per-order RMS_m |L_lm|".into(),
        x_label: "l".into(),
        y_label: "RMS_m |L_lm|".into(),
        curves: vec![
            Series { name: "L (Phong s=8)".into(), x: ls.clone(), y: rms(&lights.l), ..Default::default() },
            Series {
                name: "L' = F_8 L (mirror, eq. 47)".into(),
                x: ls.clone(),
                y: rms(&lights.blurred),
                ..Default::default()
            },
            Series {
                name: "L'' = F_8/F_16 L (Phong s=16, eq. 32)".into(),
                x: ls.clone(),
                y: rms(&lights.rescaled),
                ..Default::default()
            },
        ],
        points: vec![],
    });
    // Plot 2: the renders agree: χ²/N per θ_o against its expectation and 4σ band.
    c.plots.push(Plot {
        legend: Legend::UpperRight,
        file: "ambiguity_chi2.svg".into(),
        title: "Same renders: pixel χ²/N of the difference vs θ_o (expected ± 4σ)".into(),
        x_label: "θ_o (degrees)".into(),
        y_label: "χ²/N".into(),
        curves: vec![
            Series { name: "expected (Student t)".into(), x: exp_x.clone(), y: exp_y, ..Default::default() },
            Series {
                name: "expected − 4σ".into(), x: exp_x.clone(), y: band_lo, dashed: true, ..Default::default()
            },
            Series { name: "expected + 4σ".into(), x: exp_x, y: band_hi, dashed: true, ..Default::default() },
        ],
        points: chi_series,
    });
    // Plot 3: per-order content about R of every image at the largest θ_o (identical: F_8(l)).
    if let Some((theta, a, others)) = per_angle.last() {
        let f8 = transfer::phong(S, LMAX);
        let mut points = vec![];
        for x in std::iter::once(a).chain(others) {
            points.push(Series {
                name: x.label.clone(),
                x: (0..=LMAX).map(|l| l as f64).collect(),
                y: x.gains.coef[..=LMAX].to_vec(),
                err: Some(x.gains.sigma[..=LMAX].to_vec()),
                dashed: false,
            });
        }
        c.plots.push(Plot {
            legend: Legend::UpperRight,
            file: "ambiguity_orders.svg".into(),
            title: format!("Per-order content g_l about R of the three renders, θo = {theta}° (rel. to L)"),
            x_label: "l".into(),
            y_label: "g_l".into(),
            curves: vec![Series {
                name: "F_8(l), eq. 43".into(),
                x: (0..=LMAX).map(|l| l as f64).collect(),
                y: f8,
                ..Default::default()
            }],
            points,
        });
    }
    Some(c)
}

fn brdf_phong(s: f64, horizon: Horizon) -> BrdfSection {
    phong(1.0, s, horizon)
}

pub fn run(ctx: &Ctx) -> Result<Check, String> {
    let lights = lightings(sh_lighting(LMAX, 0.5, ctx.seed + 7), if ctx.wrong { WRONG_FACTOR * S } else { S });
    let spp = ctx.spp(QUICK_SPP, FULL_SPP);
    let mirror_spp = 2; // deterministic: 2 samples so that the stderr layer is defined (and must be 0)
    let mut seed = ctx.seed.wrapping_mul(1000) + 700; // distinct render seeds: independent noise
    let mut render = |theta: f64, spp: u32, light: &[f64], brdf: BrdfSection, label: &str| -> Result<Image, String> {
        let mut spec = Spec::probe(ctx, spp, Lighting::Sh(light.to_vec()), brdf);
        (spec.width, spec.height) = (2 * PROBE_HEIGHT, PROBE_HEIGHT);
        spec.camera = Camera::Probe { theta_o_deg: theta, phi_o_deg: 0.0 };
        spec.seed = seed;
        seed += 1;
        let ch = Channel::from_film(&render_spec(ctx, &spec)?, 0);
        let gains = order_gains(&ch, &lights.l, theta).ok_or("singular fit")?;
        Ok(Image { label: label.into(), ch, nu: spp as f64 - 1.0, gains })
    };
    let mut per_angle = vec![];
    let mut mirror_sigma: f64 = 0.0;
    let mut mirror_max: f64 = 0.0;
    for theta in THETA_O_DEG {
        if ctx.verbose {
            eprintln!("  θo = {theta}°");
        }
        let a = render(theta, spp, &lights.l, brdf_phong(S, Horizon::Ignore), "A: Phong s=8 | L")?;
        let b = render(theta, mirror_spp, &lights.blurred, mirror(1.0), "B: mirror | L'")?;
        let cc = render(theta, spp, &lights.rescaled, brdf_phong(S2, Horizon::Ignore), "C: Phong s=16 | L''")?;
        mirror_sigma = b.ch.sigma.iter().fold(mirror_sigma, |m, &v| m.max(v));
        mirror_max = b.ch.value.iter().fold(mirror_max, |m, &v| m.max(v.abs()));
        // The mirror's σ̂ is 0 everywhere: its ν never enters; ∞ keeps `compare` valid.
        let b = Image { nu: f64::INFINITY, ..b };
        per_angle.push((theta, a, vec![b, cc]));
    }
    let theta_c = THETA_O_DEG[THETA_O_DEG.len() - 1];
    let clamp = render(theta_c, spp, &lights.l, brdf_phong(S, Horizon::Clamp), "Phong s=8 clamp | L")?;
    let mut c = {
        let (_, _, others) = per_angle.last().ok_or("no angle")?;
        let clamp_pair = Some((theta_c, &others[0], &clamp));
        evaluate(&per_angle, clamp_pair, &lights).ok_or("comparison failed (sizes or ν)")?
    };
    if let Some((theta, a, others)) = per_angle.last() {
        // The claim: A (Phong s = 8 under L) and B (mirror under L blurred by the Phong filter) are
        // the same image; B is A's prediction.
        let b = &others[0];
        let n = a.ch.value.len();
        c.pictures.push(Picture::new(
            "ambiguity",
            format!(
                "{} vs {} at θ_o = {theta}°, normal probe {}×{}, {spp} spp",
                a.label, b.label, a.ch.width, a.ch.height
            ),
            format!("{}: the mirror under the blurred lighting (deterministic), eq. 47", b.label),
            (a.ch.width, a.ch.height),
            a.ch.value.clone(),
            b.ch.value.clone(),
            (0..n).map(|i| a.ch.sigma[i].hypot(b.ch.sigma[i]).hypot(F32_FLOOR * a.ch.value[i].abs())).collect(),
        ));
    }
    c.push(
        Row::new("max σ̂ of the mirror renders (deterministic)", 0.0, mirror_sigma, 0.0).floor(F32_FLOOR * mirror_max),
    );
    let h = PROBE_HEIGHT;
    c.note(format!(
        "normal-probe {}×{h}, Phong {spp} spp, mirror {mirror_spp} spp; {} renders ({} angles × 3 pairs + 1 clamp); SH lighting l ≤ {LMAX}; filters F_s = eq. 43 (exact){}",
        2 * h,
        3 * THETA_O_DEG.len() + 1,
        THETA_O_DEG.len(),
        if ctx.wrong { "; WRONG: L' blurred with s = 9.6" } else { "" }
    ));
    let n = spp as f64;
    c.note(format!(
        "non-Gaussian samples: E[t²] ≈ 1 + 2(1+γ²)/n to first order (kurtosis cancels): unmodelled excess 2γ²/n ≤ {:.4} for |γ| ≤ 1 at n = {spp}",
        2.0 / n
    ));
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::super::fit::latlong_dir;
    use super::*;
    use analysis::sh::ShBasis;
    use renderer::sampling::chi2::TestRng;

    /// A probe image whose pixels are means of `n` Gaussian samples of sd `sd` about f(n), with the
    /// estimated standard error √(s²/n) — what the renderer's `stderr` layer is for Gaussian samples.
    fn sampled_probe(w: usize, h: usize, f: impl Fn([f64; 3]) -> f64, sd: f64, n: usize, seed: u64) -> Channel {
        let mut rng = TestRng::new(seed);
        let mut ch = Channel { width: w, height: h, ..Default::default() };
        let mut u = move || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        for r in 0..h {
            for c in 0..w {
                let dir = latlong_dir(r, c, w, h);
                let (mut s1, mut s2) = (0.0, 0.0);
                for _ in 0..n {
                    let (u1, u2) = (u().max(1e-300), u());
                    let g = sd * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
                    s1 += g;
                    s2 += g * g;
                }
                let mean = s1 / n as f64;
                let var = (s2 - n as f64 * mean * mean) / (n as f64 - 1.0);
                ch.value.push(f(dir) + mean);
                ch.sigma.push(if sd > 0.0 { (var / n as f64).sqrt() } else { 0.0 });
                ch.normal.push(dir);
                ch.mask.push(1.0);
            }
        }
        ch
    }

    fn image(light: &[f64], filter: &[f64]) -> impl Fn([f64; 3]) -> f64 {
        let basis = ShBasis::new(LMAX);
        let (light, filter) = (light.to_vec(), filter.to_vec());
        move |n| basis.eval(n).iter().enumerate().map(|(k, y)| y * light[k] * filter[lm(k).0]).sum::<f64>()
    }

    #[test]
    fn student_t_moments() {
        // ν = 10: E[t²] = 10/8, E[t⁴] = 3·100/(8·6) = 6.25, Var = 6.25 − 1.5625.
        let (m, v) = t2_moments(10.0);
        assert!((m - 1.25).abs() < 1e-12 && (v - 4.6875).abs() < 1e-12);
        assert_eq!(t2_moments(f64::INFINITY), (1.0, 2.0));
    }

    #[test]
    fn chi2_of_identical_means_matches_the_student_t_expectation() {
        // Two noisy images of the same function (n = 16 samples each, different sd so Welch's ν
        // is exercised), and a noisy one against an exact one: χ²/N within 4σ of the derived
        // expectation — and the Gaussian value 1 (known σ) would be wrong by many σ at n = 16.
        let f = |n: [f64; 3]| 1.0 + n[2];
        let (w, h) = (96, 48);
        let a = sampled_probe(w, h, f, 0.05, 16, 1);
        let b = sampled_probe(w, h, f, 0.02, 16, 2);
        let exact = sampled_probe(w, h, f, 0.0, 16, 3);
        for (x, nx) in [(&b, 15.0), (&exact, f64::INFINITY)] {
            let chi = compare(&a, 15.0, x, nx).unwrap();
            assert!((chi.chi2 - chi.expected).abs() < 4.0 * chi.sd, "{chi:?}");
            assert!((chi.chi2 - 1.0).abs() > 4.0 * chi.sd, "bias ν/(ν−2) must be visible: {chi:?}");
        }
        assert_eq!(
            compare(&exact, f64::INFINITY, &exact, f64::INFINITY).map(|c| c.n),
            None,
            "nothing noisy to compare"
        );
        assert!(compare(&a, 3.0, &b, 15.0).is_none(), "ν ≤ 4: Var[t²] infinite");
    }

    #[test]
    fn right_pairs_pass_and_a_wrong_blur_fails() {
        // Synthetic renders at normal exitance (R = n): A = Phong s=8 under L (noisy), B = mirror
        // under L' (exact), C = Phong s=16 under L'' (noisy).
        let (w, h, n) = (96, 48, 64);
        let mk = |s_blur: f64| {
            let lights = lightings(sh_lighting(LMAX, 0.5, 11), s_blur);
            let f8 = transfer::phong(S, LMAX);
            let f16 = transfer::phong(S2, LMAX);
            let one = vec![1.0; LMAX + 1];
            let img = |label: &str, ch: Channel, nu: f64| {
                let gains = order_gains(&ch, &lights.l, 0.0).unwrap();
                Image { label: label.into(), ch, nu, gains }
            };
            let a = img("A", sampled_probe(w, h, image(&lights.l, &f8), 0.3, n, 1), n as f64 - 1.0);
            let b = img("B", sampled_probe(w, h, image(&lights.blurred, &one), 0.0, n, 2), f64::INFINITY);
            let c = img("C", sampled_probe(w, h, image(&lights.rescaled, &f16), 0.2, n, 3), n as f64 - 1.0);
            (lights, vec![(0.0, a, vec![b, c])])
        };
        let (lights, per_angle) = mk(S);
        let good = evaluate(&per_angle, None, &lights).unwrap();
        assert!(
            good.passed(),
            "{:?}",
            good.rows.iter().filter(|r| !r.passed()).map(|r| (&r.label, r.measured, r.tolerance())).collect::<Vec<_>>()
        );
        // The lightings really differ: L'/L at l = 8 is F_8(8) = 384/36465.
        let r8 = good.rows.iter().find(|r| r.label.starts_with("RMS_m L'_lm / L_lm, l=8")).unwrap();
        assert!((r8.measured - 384.0 / 36465.0).abs() < 1e-12 && r8.informative);
        let (lights, per_angle) = mk(WRONG_FACTOR * S);
        let bad = evaluate(&per_angle, None, &lights).unwrap();
        assert!(!bad.passed(), "a blur with s = 9.6 must be detected");
    }
}
