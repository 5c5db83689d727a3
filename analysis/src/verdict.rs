//! The verdict of an analysis: does the image contradict what it was told (lighting, BRDF,
//! camera) beyond its noise and truncation, and if so, which assumption most likely is wrong.
//!
//! Test: the measured filter Â_l of a pixel-space fit ([`crate::filter::fit_filter_pixels`]) against
//! the analytic A_l = albedo · Λ_l ρ̂_l of the BRDF it was told. Per channel c,
//! χ²_c = (Â − A)ᵀ (C_noise + diag(t²))⁻¹ (Â − A) over the fitted orders (ν_c of them), with
//! C_noise the fit's noise covariance (the per-pixel σ propagated, or without a `stderr` layer σ
//! from the residuals of the fit, which cannot absorb a lighting or camera mismatch) and t_l the
//! estimated truncation bias ([`crate::truncation`]); p_c = P(χ²_ν ≥ χ²_c). The channels share
//! their paths, so they are combined by Šidák: p = 1 − (1 − min_c p_c)³, which holds the stated
//! false-alarm rate α for independent channels and is conservative for positively correlated ones.
//! The image contradicts its description when p < α ([`DEFAULT_ALPHA`]).
//!
//! Diagnosis (only when it does): every alternative is scored by the same χ², the one with the
//! largest p named:
//! - `scale`: one free factor k_c per channel, k̂_c = AᵀC⁻¹Â / AᵀC⁻¹A (ν_c − 1 left);
//! - `rotation`: the lighting rotated about the world +z axis (the pole of a lat-long map, docs/src/conventions.md §1–§2) by
//!   ψ, searched on a 5° grid over the circle refined to 0.25° around the best, then refined by full
//!   refits descending from the angle found in steps of 1°, 0.5° and 0.25°. The search ranks angles
//!   by a cheaper χ² of the same estimates (the fit to l_max alone, noise covariance only, at most
//!   [`SEARCH_PIXELS`] pixels taken evenly): a full refit (truncation sequence, conditioning,
//!   predicted truncation) at each of the 112 angles took minutes on two 256² views;
//! - `mapping`: an environment map read with the other mapping (lat-long ↔ angular);
//! - `mirrored`: the lighting mirrored (φ → −φ: a renderer whose azimuth runs the other way, or a
//!   map flipped left to right), at the best rotation about +z as above;
//! - anything else (the BRDF's parameters, the camera's extent or orientation) is named as
//!   untested when no alternative explains the residual.

use crate::error::Result;
use crate::filter::{ChannelFit, PixelOrder, fit_filter_pixels};
use crate::projection::Sample;
use crate::sh::{Rotation, ShBasis, index, num_coefficients, rotate_coefficients};
use crate::special::chi2_survival;

/// The most pixels the rotation search reads (module docs): taken evenly from the fit's pixels,
/// enough to place a rotation to a fraction of a degree, few enough that 112 angles cost seconds.
pub const SEARCH_PIXELS: usize = 8192;

/// The family-wise false-alarm rate of the verdict when none is given: 1 %.
pub const DEFAULT_ALPHA: f64 = 0.01;

/// One channel's χ² of the measured filter against the analytic one.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChannelTest {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
}

/// An alternative assumption and how well it explains the image.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Alternative {
    /// `scale`, `rotation`, `mapping` or `mirrored`.
    pub assumption: String,
    /// What the alternative is, in words (e.g. "the map rotated by +5.00° about +z").
    pub detail: String,
    /// Total χ² and ν over the channels, and the Šidák-combined p under this alternative.
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
}

/// The verdict of an analysis (module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Verdict {
    /// `consistent` or `contradicts`.
    pub status: String,
    /// The family-wise false-alarm rate α the decision is taken at.
    pub alpha: f64,
    /// Σ_c χ²_c and Σ_c ν_c (R, G, B).
    pub chi2: f64,
    pub dof: usize,
    /// Šidák-combined p over the channels.
    pub p_value: f64,
    pub channels: Vec<ChannelTest>,
    /// Where the noise part of the error bars comes from: `stderr-layer` or `residuals`.
    pub sigma_from: String,
    /// The alternative that explains the image best (only when it contradicts its description).
    pub suspect: Option<Alternative>,
    /// Every alternative tried, best first.
    pub alternatives: Vec<Alternative>,
    /// The verdict in one line.
    pub line: String,
}

impl Verdict {
    pub fn consistent(&self) -> bool {
        self.status == "consistent"
    }
}

/// Šidák's combination of `n` p-values given their minimum.
fn sidak(p_min: f64, n: usize) -> f64 {
    1.0 - (1.0 - p_min.clamp(0.0, 1.0)).powi(n.max(1) as i32)
}

/// The per-channel χ² tests of `orders`/`fits` (a pixel-space filter fit) against `analytic`
/// (A_l per order, RGB), and for `scale` the same with a free factor per channel (returned as
/// (k̂_c, σ(k̂_c)) per channel). Orders not fitted (unobservable) are left out; a channel whose
/// covariance cannot be inverted gives no test.
pub fn filter_tests(
    orders: &[PixelOrder],
    fits: &[ChannelFit],
    analytic: &[[f64; 3]],
    scale: bool,
) -> (Vec<ChannelTest>, Vec<Option<(f64, f64)>>) {
    let mut tests = Vec::new();
    let mut scales = Vec::new();
    for (c, fit) in fits.iter().enumerate().take(3) {
        let idx: Vec<usize> = fit
            .fitted_orders
            .iter()
            .copied()
            .filter(|&l| l < analytic.len() && orders.get(l).is_some_and(|o| o.estimate[c].is_some()))
            .collect();
        let pos: Vec<usize> = idx.iter().filter_map(|l| fit.fitted_orders.iter().position(|x| x == l)).collect();
        let p = idx.len();
        if p == 0 {
            scales.push(None);
            continue;
        }
        let mut cov = vec![0.0; p * p];
        for i in 0..p {
            for j in 0..p {
                cov[i * p + j] = fit.covariance.get(pos[i]).and_then(|r| r.get(pos[j])).copied().unwrap_or(0.0);
            }
            let o = &orders[idx[i]];
            let total = o.stderr[c].unwrap_or(0.0);
            let noise = o.stderr_noise[c].unwrap_or(0.0);
            // The truncation part of the total error bar (total² = noise² + truncation²).
            cov[i * p + i] += (total * total - noise * noise).max(0.0);
        }
        let Some(inv) = crate::fit::invert(&cov, p) else {
            scales.push(None);
            continue;
        };
        let est: Vec<f64> = idx.iter().map(|&l| orders[l].estimate[c].unwrap_or(0.0)).collect();
        let a: Vec<f64> = idx.iter().map(|&l| analytic[l][c]).collect();
        let quad = |x: &[f64], y: &[f64]| -> f64 {
            (0..p).map(|i| (0..p).map(|j| x[i] * inv[i * p + j] * y[j]).sum::<f64>()).sum()
        };
        let (k, dof) = if scale {
            let aa = quad(&a, &a);
            if aa > 0.0 {
                let k = quad(&a, &est) / aa;
                scales.push(Some((k, 1.0 / aa.sqrt())));
                (k, p.saturating_sub(1))
            } else {
                scales.push(None);
                (1.0, p)
            }
        } else {
            scales.push(None);
            (1.0, p)
        };
        let r: Vec<f64> = (0..p).map(|i| est[i] - k * a[i]).collect();
        let chi2 = quad(&r, &r).max(0.0);
        let p_value = if dof > 0 { chi2_survival(chi2, dof as f64) } else { 1.0 };
        tests.push(ChannelTest { chi2, dof, p_value });
    }
    (tests, scales)
}

/// SH coefficients of the lighting mirrored through the xz plane (y → −y, φ → −φ): the real
/// basis's m < 0 functions are odd in y (sin(|m|φ)), the others even.
pub fn mirrored(light: &[[f64; 3]]) -> Vec<[f64; 3]> {
    light.iter().enumerate().map(|(k, c)| if crate::sh::lm(k).1 < 0 { c.map(|v| -v) } else { *c }).collect()
}

/// Total χ², ν and the Šidák-combined p of channel tests.
fn combine(tests: &[ChannelTest]) -> (f64, usize, f64) {
    let chi2 = tests.iter().map(|t| t.chi2).sum();
    let dof = tests.iter().map(|t| t.dof).sum();
    let p_min = tests.iter().map(|t| t.p_value).fold(1.0, f64::min);
    (chi2, dof, sidak(p_min, tests.len()))
}

/// What [`verdict`] needs to refit the filter under an alternative lighting: the pixels, whether
/// their variances are standard errors, the noise inflation, and the lighting coefficients up to
/// the truncation order (as given to [`fit_filter_pixels`]).
pub struct Refit<'a> {
    pub samples: &'a [Sample],
    pub have_sigma: bool,
    pub inflation: f64,
    pub light: &'a [[f64; 3]],
    pub lmax: usize,
    /// Other lightings to try (e.g. the map read with the other mapping), named.
    pub other_lightings: Vec<(String, Vec<[f64; 3]>)>,
}

/// The verdict of a pixel-space filter fit (`orders`, `fits`) against `analytic` at family-wise
/// false-alarm rate `alpha` (module docs). With `refit`, the lighting alternatives (rotation,
/// mapping) are tried when the image contradicts its description; without it only the scale is.
/// Errors: only those of a refit that the original fit did not have (none in practice: a refit
/// that fails is skipped).
pub fn verdict(
    orders: &[PixelOrder],
    fits: &[ChannelFit],
    analytic: &[[f64; 3]],
    alpha: f64,
    have_sigma: bool,
    refit: Option<&Refit>,
) -> Result<Verdict> {
    let (channels, _) = filter_tests(orders, fits, analytic, false);
    let (chi2, dof, p_value) = combine(&channels);
    let sigma_from = if have_sigma { "stderr-layer" } else { "residuals" }.to_string();
    let consistent = p_value >= alpha;
    let mut alternatives = Vec::new();
    if !consistent {
        let (t, k) = filter_tests(orders, fits, analytic, true);
        let (c2, d, p) = combine(&t);
        let ks: Vec<String> = k.iter().map(|k| k.map_or("-".into(), |(k, s)| format!("{k:.4} ± {s:.4}"))).collect();
        alternatives.push(Alternative {
            assumption: "scale".into(),
            detail: format!("an overall scale k = {} (R, G, B) times the told albedo", ks.join(", ")),
            chi2: c2,
            dof: d,
            p_value: p,
        });
        if let Some(r) = refit {
            let score = |light: &[[f64; 3]]| -> Option<(f64, usize, f64)> {
                let f = fit_filter_pixels(r.samples, r.have_sigma, r.inflation, light, r.lmax).ok()?;
                let (t, _) = filter_tests(&f.orders, &f.channels, analytic, false);
                Some(combine(&t))
            };
            // The best rotation about +z of `light`: a 5° grid refined to 0.25° around its best
            // (the told angle 0 itself left out unless `with_zero`), ranked by the search's χ²,
            // then scored by the full refit.
            let search = RotationSearch::new(r, analytic);
            let scan = |light: &[[f64; 3]], with_zero: bool| -> Option<(f64, (f64, usize, f64))> {
                let rotated =
                    |deg: f64| rotate_coefficients(light, &Rotation::axis_angle([0.0, 0.0, 1.0], deg.to_radians()));
                let consider = |deg: f64, best: &mut Option<(f64, f64)>| {
                    if (deg != 0.0 || with_zero)
                        && let Some(s) = search.chi2(&rotated(deg))
                        && best.as_ref().is_none_or(|b| s < b.1)
                    {
                        *best = Some((deg, s));
                    }
                };
                let mut best = None;
                for i in 0..72 {
                    consider(i as f64 * 5.0 - if i > 36 { 360.0 } else { 0.0 }, &mut best);
                }
                if let Some((c, _)) = best {
                    for j in -20..=20 {
                        if j != 0 {
                            consider(c + j as f64 * 0.25, &mut best);
                        }
                    }
                }
                // The search's χ² leaves out the truncation that the full refit carries, which can
                // move its minimum by a degree: the full refit descends from the angle found, in
                // steps of 1°, 0.5° and 0.25° (a handful of refits, not one per angle).
                let (mut deg, _) = best?;
                let mut at = score(&rotated(deg))?;
                for step in [1.0, 0.5, 0.25] {
                    for _ in 0..8 {
                        let mut moved = false;
                        for next in [deg - step, deg + step] {
                            if (next != 0.0 || with_zero)
                                && let Some(s) = score(&rotated(next))
                                && s.0 < at.0
                            {
                                (deg, at, moved) = (next, s, true);
                            }
                        }
                        if !moved {
                            break;
                        }
                    }
                }
                Some((deg, at))
            };
            if let Some((deg, (c2, d, p))) = scan(r.light, false) {
                alternatives.push(Alternative {
                    assumption: "rotation".into(),
                    detail: format!("the lighting rotated by {deg:+.2}° about +z"),
                    chi2: c2,
                    dof: d,
                    p_value: p,
                });
            }
            // A renderer whose φ runs the other way sees the map mirrored (φ → −φ, y → −y, which
            // negates the sin(|m|φ) coefficients, m < 0), possibly also turned about +z.
            if let Some((deg, (c2, d, p))) = scan(&mirrored(r.light), true) {
                alternatives.push(Alternative {
                    assumption: "mirrored".into(),
                    detail: format!(
                        "the lighting mirrored (φ → −φ: a frame whose azimuth runs the other way) and rotated by \
                         {deg:+.2}° about +z"
                    ),
                    chi2: c2,
                    dof: d,
                    p_value: p,
                });
            }
            for (name, light) in &r.other_lightings {
                if let Some((c2, d, p)) = score(light) {
                    alternatives.push(Alternative {
                        assumption: "mapping".into(),
                        detail: name.clone(),
                        chi2: c2,
                        dof: d,
                        p_value: p,
                    });
                }
            }
        }
        alternatives.sort_by(|a, b| b.p_value.total_cmp(&a.p_value).then(a.chi2.total_cmp(&b.chi2)));
    }
    // Named only when it explains a clear part of the mismatch: χ² at most half of the told one.
    let suspect = alternatives.first().filter(|a| a.chi2 <= 0.5 * chi2).cloned();
    let head = format!(
        "χ² {chi2:.1} for ν {dof} (σ from the {}), p {p_value:.2e} (Šidák over R, G, B; α {alpha})",
        if have_sigma { "stderr layer" } else { "fit residuals" }
    );
    let line = if consistent {
        // The test is of the filter; scatter of the pixels beyond their σ that the filter absorbs
        // (heavy-tailed pixels, signal above the highest fitted order) is said beside it, so that a
        // χ²/ν of several is never printed next to a bare "consistent".
        let scatter: Vec<String> = fits
            .iter()
            .take(3)
            .zip(["R", "G", "B"])
            .filter_map(|(c, n)| {
                c.truncation_chi2_per_dof
                    .filter(|x| have_sigma && *x > crate::filter::MISMATCH_CHI2)
                    .map(|x| format!("{n} {x:.2}"))
            })
            .collect();
        let note = match fits.iter().filter_map(|c| c.truncation_lmax).max() {
            Some(top) if !scatter.is_empty() => format!(
                "; but the pixels scatter beyond their σ (χ²/ν {} with the orders up to l = {top}, above {}): \
                 the filter agrees, the pixels hold what it does not test (heavy-tailed pixels or signal above l = {top})",
                scatter.join(", "),
                crate::filter::MISMATCH_CHI2
            ),
            _ => String::new(),
        };
        format!("verdict: consistent with the lighting, BRDF and camera it was told — {head}{note}")
    } else {
        let why = match &suspect {
            Some(s) if s.p_value >= alpha => {
                format!("explained by {}: {} (χ² {:.1}, p {:.2e})", s.assumption, s.detail, s.chi2, s.p_value)
            }
            Some(s) => format!(
                "most likely the {}: {} lowers χ² to {:.1} (p {:.2e}), not all of it",
                s.assumption, s.detail, s.chi2, s.p_value
            ),
            None => format!(
                "no {} explains it: check the BRDF's parameters and the camera (extent, orientation)",
                if refit.is_some() { "scale, rotation, mirroring or mapping" } else { "overall scale" }
            ),
        };
        format!("verdict: the image CONTRADICTS what it was told — {head}; {why}")
    };
    Ok(Verdict {
        status: if consistent { "consistent" } else { "contradicts" }.into(),
        alpha,
        chi2,
        dof,
        p_value,
        channels,
        sigma_from,
        suspect,
        alternatives,
        line,
    })
}

/// The rotation search's χ² (module docs): the filter fitted to l_max alone on at most
/// [`SEARCH_PIXELS`] of the pixels, its estimates tested against the analytic filter with their
/// noise covariance, summed over R, G, B. It ranks candidate lightings; it is not the verdict's
/// test (no truncation part), so the angle it finds is scored again by the full refit.
struct RotationSearch<'a> {
    /// The SH basis to l_max at each searched pixel, `coefficients` values per pixel.
    y: Vec<f64>,
    coefficients: usize,
    pixels: Vec<&'a Sample>,
    lmax: usize,
    have_sigma: bool,
    analytic: &'a [[f64; 3]],
}

impl<'a> RotationSearch<'a> {
    fn new(r: &Refit<'a>, analytic: &'a [[f64; 3]]) -> Self {
        let used: Vec<&Sample> = r.samples.iter().filter(|s| s.w != 0.0).collect();
        let stride = used.len().div_ceil(SEARCH_PIXELS).max(1);
        let pixels: Vec<&Sample> = used.into_iter().step_by(stride).collect();
        let coefficients = num_coefficients(r.lmax);
        let basis = ShBasis::new(r.lmax);
        let mut y = vec![0.0; pixels.len() * coefficients];
        for (s, out) in pixels.iter().zip(y.chunks_exact_mut(coefficients)) {
            basis.eval_into(s.dir, out);
        }
        RotationSearch { y, coefficients, pixels, lmax: r.lmax, have_sigma: r.have_sigma, analytic }
    }

    /// Σ_c χ²_c of `light` (coefficients to at least l_max; higher orders are not read), `None`
    /// when no channel can be fitted.
    fn chi2(&self, light: &[[f64; 3]]) -> Option<f64> {
        let weight: Vec<f64> = self.pixels.iter().map(|s| s.w).collect();
        let mut total = None;
        for c in 0..3 {
            // S_l(d_p) = Σ_m L_lm Y_lm(d_p): the design of eq. 15 in pixel space.
            let full: Vec<Vec<f64>> = self
                .y
                .chunks_exact(self.coefficients)
                .map(|y| {
                    (0..=self.lmax)
                        .map(|l| {
                            let l_i = l as i64;
                            (-l_i..=l_i).map(|m| light[index(l, m)][c] * y[index(l, m)]).sum::<f64>()
                        })
                        .collect()
                })
                .collect();
            // The orders with lighting energy over these pixels, as the full fit keeps them.
            let energy: Vec<f64> =
                (0..=self.lmax).map(|l| full.iter().zip(&weight).map(|(r, w)| w * r[l] * r[l]).sum::<f64>()).collect();
            let emax = energy.iter().copied().fold(0.0, f64::max);
            let cols: Vec<usize> = (0..=self.lmax)
                .filter(|&l| emax > 0.0 && energy[l] > 1e-10 * emax && l < self.analytic.len())
                .collect();
            if cols.is_empty() {
                continue;
            }
            let rows: Vec<Vec<f64>> = full.iter().map(|r| cols.iter().map(|&l| r[l]).collect()).collect();
            let value: Vec<f64> = self.pixels.iter().map(|s| s.b[c]).collect();
            // Without a stderr layer: unit σ, the covariance scaled by the residuals' χ²/ν.
            let sigma: Vec<f64> =
                self.pixels.iter().map(|s| if self.have_sigma { s.var[c].sqrt() } else { 1.0 }).collect();
            let Some(fit) = crate::fit::lsq(&rows, &value, &sigma, &weight) else { continue };
            let p = cols.len();
            let scale = if self.have_sigma { 1.0 } else { fit.chi2_per_dof().unwrap_or(1.0) };
            let cov: Vec<f64> = fit.cov.iter().map(|v| v * scale).collect();
            let Some(inv) = crate::fit::invert(&cov, p) else { continue };
            let d: Vec<f64> = cols.iter().zip(&fit.coef).map(|(&l, x)| x - self.analytic[l][c]).collect();
            let q: f64 = (0..p).map(|i| (0..p).map(|j| d[i] * inv[i * p + j] * d[j]).sum::<f64>()).sum();
            *total.get_or_insert(0.0) += q.max(0.0);
        }
        total
    }
}

/// The verdict of a model fitted to the measured filter (`invert brdf`): the image against the
/// re-prediction from the recovered quantities. `fits` holds, per channel, its name, the fit's
/// minimum χ² (the measured filter against the model at the fitted parameter and scale, weighted
/// by the filter's covariance ⊕ truncation²) and its ν (orders minus fitted parameters);
/// p_c = P(χ²_ν ≥ χ²_c), combined over the channels by Šidák as in [`verdict`]. `model` names the
/// model in the line ("phong at s = 31.8"), `have_sigma` where the σ came from. `None` when no
/// channel has ν > 0.
pub fn of_model_fit(fits: &[(&str, f64, i64)], model: &str, alpha: f64, have_sigma: bool) -> Option<Verdict> {
    let channels: Vec<ChannelTest> = fits
        .iter()
        .filter(|f| f.2 > 0 && f.1.is_finite())
        .map(|&(_, chi2, dof)| ChannelTest { chi2, dof: dof as usize, p_value: chi2_survival(chi2, dof as f64) })
        .collect();
    if channels.is_empty() {
        return None;
    }
    let (chi2, dof, p_value) = combine(&channels);
    let consistent = p_value >= alpha;
    let head = format!(
        "χ² {chi2:.1} for ν {dof} of the measured filter against {model} (σ from the {}), p {p_value:.2e} (Šidák over \
         {} channels; α {alpha})",
        if have_sigma { "stderr layer" } else { "fit residuals" },
        channels.len()
    );
    let line = if consistent {
        format!("verdict: consistent with the recovered model and the lighting and camera it was told — {head}")
    } else {
        format!(
            "verdict: the image CONTRADICTS the recovered model — {head}; no value of the parameter makes this model \
             describe the image: check the model (another BRDF), the lighting and the camera"
        )
    };
    Some(Verdict {
        status: if consistent { "consistent" } else { "contradicts" }.into(),
        alpha,
        chi2,
        dof,
        p_value,
        channels,
        sigma_from: if have_sigma { "stderr-layer" } else { "residuals" }.into(),
        suspect: None,
        alternatives: Vec::new(),
        line,
    })
}

/// The verdict of `invert lighting` on a projection that is one (a normal-probe quadrature): the
/// orders the BRDF does not pass (`unpassed`: Λ_l ρ̂_l = 0, e.g. a Lambertian sphere's odd l ≥ 3)
/// must be 0 in the image's B_lm (eq. 15), whatever the lighting; everywhere else the lighting
/// absorbs any B_lm, so nothing else can contradict it. Per channel χ²_c = Σ (B_lm / σ_lm)² over
/// those orders (`b`, `stderr` in index order k), ν = Σ (2l + 1); p combined over the channels by
/// Šidák as in [`verdict`]. `brdf` names the BRDF in the line. `None` when no order is unpassed or
/// no channel has an error bar there.
pub fn of_unpassed_orders(
    b: &[[f64; 3]],
    stderr: &[[f64; 3]],
    unpassed: &[usize],
    brdf: &str,
    alpha: f64,
) -> Option<Verdict> {
    let channels: Vec<ChannelTest> = (0..3)
        .filter_map(|c| {
            let (mut chi2, mut dof) = (0.0, 0usize);
            for &l in unpassed {
                for k in l * l..(l + 1) * (l + 1) {
                    let (v, s) = (b.get(k)?[c], stderr.get(k)?[c]);
                    if s > 0.0 && s.is_finite() && v.is_finite() {
                        chi2 += (v / s).powi(2);
                        dof += 1;
                    }
                }
            }
            (dof > 0).then(|| ChannelTest { chi2, dof, p_value: chi2_survival(chi2, dof as f64) })
        })
        .collect();
    if channels.is_empty() {
        return None;
    }
    let (chi2, dof, p_value) = combine(&channels);
    let consistent = p_value >= alpha;
    let orders = unpassed.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(", ");
    let head = format!(
        "the orders a {brdf} BRDF does not pass (l = {orders}) hold χ² {chi2:.1} for ν {dof} (σ from the stderr \
         layer), p {p_value:.2e} (Šidák over {} channels; α {alpha})",
        channels.len()
    );
    let line = if consistent {
        format!("verdict: consistent with the {brdf} BRDF it was told — {head}")
    } else {
        format!(
            "verdict: the image CONTRADICTS the {brdf} BRDF it was told — {head}: light reached orders this BRDF \
             blocks, so the sphere's BRDF is another (a glossy one passes them) or the camera is not the one described"
        )
    };
    Some(Verdict {
        status: if consistent { "consistent" } else { "contradicts" }.into(),
        alpha,
        chi2,
        dof,
        p_value,
        channels,
        sigma_from: "stderr-layer".into(),
        suspect: None,
        alternatives: Vec::new(),
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unpassed_orders_must_be_zero_within_their_errors() {
        // l ≤ 3, σ = 0.1 everywhere; the 7 coefficients of l = 3 at ±0.1 (χ² 7 per channel, p 0.43)
        // are consistent, at ±1 (χ² 700) a contradiction; no unpassed order, or no error bar there:
        // no verdict.
        let stderr = vec![[0.1; 3]; 16];
        let mut b = vec![[5.0; 3]; 16];
        b[9..16].iter_mut().enumerate().for_each(|(i, v)| *v = [if i % 2 == 0 { 0.1 } else { -0.1 }; 3]);
        let v = of_unpassed_orders(&b, &stderr, &[3], "lambert", DEFAULT_ALPHA).unwrap();
        assert!(v.consistent() && v.dof == 21 && (v.chi2 - 21.0).abs() < 1e-9, "{}", v.line);
        b[9..16].iter_mut().for_each(|v| *v = [1.0; 3]);
        let v = of_unpassed_orders(&b, &stderr, &[3], "lambert", DEFAULT_ALPHA).unwrap();
        assert!(!v.consistent() && v.line.contains("CONTRADICTS the lambert BRDF"), "{}", v.line);
        assert!(of_unpassed_orders(&b, &stderr, &[], "lambert", DEFAULT_ALPHA).is_none());
        assert!(of_unpassed_orders(&b, &[[0.0; 3]; 16], &[3], "lambert", DEFAULT_ALPHA).is_none());
    }

    #[test]
    fn sidak_holds_the_family_rate() {
        // Three independent channels at per-channel p = 1 − (1 − α)^{1/3} combine to exactly α.
        let alpha = 0.01;
        let per = 1.0 - (1.0f64 - alpha).powf(1.0 / 3.0);
        assert!((sidak(per, 3) - alpha).abs() < 1e-12);
        assert_eq!(sidak(1.0, 3), 1.0);
    }

    #[test]
    fn mirrored_coefficients_are_the_function_at_minus_y() {
        // A lighting with every coefficient to l = 4 nonzero: the mirrored coefficients evaluated at
        // (x, y, z) give the original at (x, −y, z). Planted error (the m > 0 terms negated instead)
        // fails this.
        let light: Vec<[f64; 3]> = (0..25).map(|k| [1.0 + 0.3 * k as f64, (k as f64).sin(), 0.1]).collect();
        let m = mirrored(&light);
        let mut rec = crate::sh::Reconstructor::new(4);
        for d in [[0.3f64, 0.5, 0.81], [-0.6, 0.7, -0.39], [0.0, -1.0, 0.0]] {
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|v| v / n);
            let a = rec.eval(&m, d);
            let b = rec.eval(&light, [d[0], -d[1], d[2]]);
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() < 1e-12, "{d:?}: {a:?} {b:?}");
            }
        }
    }
}
