//! The measured filter: per-order estimates of Λ_l ρ̂_l from measured B_lm and lighting L_lm.
//!
//! Eq. 15 says B_lm = f_l L_lm for every m of order l, so f_l is the least-squares slope over m:
//! f̂_l = Σ_m B_lm L_lm / Σ_m L_lm², i.e. each m weighted by the lighting's energy in it. Its
//! standard error propagates the B_lm standard errors, √(Σ_m L_lm² σ_lm²) / Σ_m L_lm², or, without
//! them, the scatter of the residuals over m (2l degrees of freedom; none at l = 0). An order is
//! unobservable when Σ_m L_lm² ≤ `rel_tol` × the largest order energy: L has no energy there, so
//! any f_l fits (the paper's factorization ambiguity, sec. 3.4).
//! Each RGB channel is estimated separately.

use crate::sh::index;

/// Estimate for one order l.
#[derive(Clone, Debug, PartialEq)]
pub struct OrderEstimate {
    pub l: usize,
    /// Σ_m L_lm² per channel.
    pub energy: [f64; 3],
    /// f̂_l per channel, `None` where the order is unobservable.
    pub estimate: [Option<f64>; 3],
    /// Standard error of f̂_l (`None` if unobservable or not estimable).
    pub stderr: [Option<f64>; 3],
}

impl OrderEstimate {
    pub fn observable(&self) -> bool {
        self.estimate.iter().any(|e| e.is_some())
    }
}

/// Per-order filter estimates for l = 0 … lmax (both inputs must have at least (lmax+1)² entries).
pub fn measured_filter(
    b: &[[f64; 3]],
    b_stderr: Option<&[[f64; 3]]>,
    lighting: &[[f64; 3]],
    lmax: usize,
    rel_tol: f64,
) -> Vec<OrderEstimate> {
    let energy: Vec<[f64; 3]> = (0..=lmax)
        .map(|l| {
            let mut e = [0.0; 3];
            for m in -(l as i64)..=(l as i64) {
                let c = lighting[index(l, m)];
                for ch in 0..3 {
                    e[ch] += c[ch] * c[ch];
                }
            }
            e
        })
        .collect();
    let emax: Vec<f64> = (0..3).map(|ch| energy.iter().map(|e| e[ch]).fold(0.0, f64::max)).collect();
    (0..=lmax)
        .map(|l| {
            let mut est = [None; 3];
            let mut se = [None; 3];
            for ch in 0..3 {
                let e = energy[l][ch];
                if !(e > rel_tol * emax[ch]) || e == 0.0 {
                    continue;
                }
                let mut num = 0.0;
                for m in -(l as i64)..=(l as i64) {
                    let k = index(l, m);
                    num += b[k][ch] * lighting[k][ch];
                }
                let f = num / e;
                est[ch] = Some(f);
                se[ch] = match b_stderr {
                    Some(s) => {
                        let v: f64 = (-(l as i64)..=(l as i64))
                            .map(|m| {
                                let k = index(l, m);
                                (lighting[k][ch] * s[k][ch]).powi(2)
                            })
                            .sum();
                        Some(v.sqrt() / e)
                    }
                    None if l > 0 => {
                        let rss: f64 = (-(l as i64)..=(l as i64))
                            .map(|m| {
                                let k = index(l, m);
                                (b[k][ch] - f * lighting[k][ch]).powi(2)
                            })
                            .sum();
                        Some((rss / (2 * l) as f64 / e).sqrt())
                    }
                    None => None,
                };
            }
            OrderEstimate { l, energy: energy[l], estimate: est, stderr: se }
        })
        .collect()
}

/// Largest noise amplification √((C⁻¹)_ll) (C the design's Gram matrix normalized to unit
/// diagonal; 1 for orthogonal orders, as on the full sphere) at which an order of
/// [`fit_filter_pixels`] still counts as determined.
pub const MAX_AMPLIFICATION: f64 = 30.0;

/// Robust χ²/ν ([`crate::fit::robust_chi2`]) above which [`fit_filter_pixels`] warns that the model
/// does not describe the image. A right model gives ≈ 1 (the plain χ²/ν, 1 ± √(2/ν) with honest σ,
/// reaches 2–4 on 32-spp renders under Grace, whose per-pixel σ of a heavy-tailed estimator is
/// itself noisy: that only scales the error bars); a lighting rotated by 90° gives several.
pub const MISMATCH_CHI2: f64 = 2.0;

/// Relative misfit ([`crate::fit::relative_misfit`]) above which, with a robust χ²/ν above
/// [`MISMATCH_CHI2`], a fit warns that its model does not describe the image. Measured on
/// 256², 64-spp renders under Grace (tests/partial_view_renders.rs): the right lighting gives 0
/// (its residual is within the noise on the quadrature-weighted average, though Phong's truncation
/// above l_max + 2 and a few heavy-tailed pixels raise the robust χ²/ν to 2–7); a lighting rotated
/// by 90° gives 0.31–0.62 (Lambert) and 0.77–0.88 (Phong s = 32).
pub const MISMATCH_RELATIVE: f64 = 0.05;

/// The mismatch rule of every pixel-space fit: robust χ²/ν > [`MISMATCH_CHI2`] (the residuals are
/// not noise) and relative misfit > [`MISMATCH_RELATIVE`] (they are a sizable part of the image).
pub fn mismatch(robust_chi2: f64, relative_misfit: f64) -> bool {
    robust_chi2 > MISMATCH_CHI2 && relative_misfit > MISMATCH_RELATIVE
}

/// Whether `warning` (one of [`fit_filter_pixels`]'s) is an order's "cannot be determined" or
/// "ill-conditioned" note about one of `orders` (e.g. orders the BRDF makes exactly zero, which a
/// front-end says as such instead).
pub fn is_order_note(warning: &str, orders: &[usize]) -> bool {
    (warning.contains("cannot be determined") || warning.contains("is ill-conditioned"))
        && orders.iter().any(|l| warning.contains(&format!("order l = {l} ")))
}

/// How well the pixels determine one order of the filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum OrderStatus {
    /// Noise amplification ≤ [`MAX_AMPLIFICATION`].
    Determined,
    /// Fitted, but the visible directions barely separate it from the other orders.
    IllConditioned,
    /// The lighting has no energy in this order over the visible directions: not fitted.
    Unobservable,
    /// Well conditioned, but its truncation bound (`truncation_bound`) reaches
    /// [`crate::truncation::UNDETERMINED_TRUNCATION`] of |Â_l|: the directions cannot tell it from
    /// the orders above l_max ([`crate::truncation::UNDETERMINED`], the same rule as `invert lighting`).
    Undetermined,
}

/// One order of a pixel-space filter fit, per RGB channel.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PixelOrder {
    pub l: usize,
    /// Â_l (albedo · Λ_l ρ̂_l); `None` where unobservable.
    pub estimate: [Option<f64>; 3],
    /// Noise part of the standard error: the per-pixel σ propagated (never scaled by χ²/ν, see
    /// [`crate::fit::noise_scale`]), or estimated from the residuals without a `stderr` layer.
    pub stderr_noise: [Option<f64>; 3],
    /// Estimated truncation bias (a standard deviation, [`crate::truncation`]): the larger of the
    /// nested sequence's |Â_l(L) − Â_l(H)| (noise of the difference removed) and the predicted
    /// truncation of the calibrated orders above L; `None` where the lighting has no orders above L.
    pub truncation: [Option<f64>; 3],
    /// The truncation bias with the first order above l_max aligned worst
    /// ([`crate::truncation::PredictedTruncation::bound`]); `None` where nothing above L could be
    /// fitted. |bound| ≥ [`crate::truncation::UNDETERMINED_TRUNCATION`] |Â_l| makes the order `undetermined`.
    pub truncation_bound: [Option<f64>; 3],
    /// Total: √(noise² + truncation²).
    pub stderr: [Option<f64>; 3],
    /// Noise amplification of the design √((C⁻¹)_ll) (1 for orthogonal orders).
    pub amplification: [Option<f64>; 3],
    pub status: [OrderStatus; 3],
}

/// Goodness of fit of one channel of [`fit_filter_pixels`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChannelFit {
    /// Σ_p (r_p / σ_p)² over pixels with σ_p > 0 (σ_p = 1 without a `stderr` layer).
    pub chi2: f64,
    /// Pixels with σ_p > 0 minus fitted orders.
    pub dof: usize,
    pub chi2_per_dof: Option<f64>,
    /// Robust χ²/ν ([`crate::fit::robust_chi2`]): the mismatch test, insensitive to the few pixels
    /// whose Monte Carlo σ underestimates a heavy-tailed error; `None` without a `stderr` layer.
    pub robust_chi2_per_dof: Option<f64>,
    /// P(χ²_ν ≥ χ²); `None` without a `stderr` layer (then χ² only estimates σ²).
    pub p_value: Option<f64>,
    /// Size of the misfit relative to the signal: √(Σ_p w_p (r_p² − σ_p²)₊ / Σ_p w_p B_p²) (the
    /// noise's share of the squared residual removed; w the quadrature weights). Unlike χ²/ν it does
    /// not grow as the noise shrinks: a model error of a fixed fraction of the image gives the same
    /// value at any sample count.
    pub relative_misfit: f64,
    /// Factor applied to the propagated standard errors: [`crate::fit::noise_scale`] (1 with a
    /// `stderr` layer, the residual σ √(χ²/ν) without), times √F for pixel noise correlated by a
    /// reconstruction filter ([`crate::noise`]).
    pub stderr_scale: f64,
    /// Orders fitted (in order), the index set of `covariance`.
    pub fitted_orders: Vec<usize>,
    /// Covariance of the fitted Â_l (noise part, scaled like the standard errors), row-major.
    pub covariance: Vec<Vec<f64>>,
    /// Highest order of the fits the truncation estimate compares with (`None`: no higher order
    /// could be fitted).
    pub truncation_lmax: Option<usize>,
    /// χ²/ν of that highest-order fit: what is left when the truncated orders up to
    /// `truncation_lmax` are fitted too (the noise scale comes from it, [`crate::fit::noise_scale`]).
    pub truncation_chi2_per_dof: Option<f64>,
}

/// The per-order filter fitted in pixel space ([`fit_filter_pixels`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PixelFilterFit {
    pub lmax: usize,
    /// Pixels used.
    pub pixels: usize,
    pub orders: Vec<PixelOrder>,
    /// R, G, B.
    pub channels: Vec<ChannelFit>,
    /// Said in words: scaled error bars, ill-conditioned or unobservable orders, model mismatch.
    pub warnings: Vec<String>,
}

const CHANNEL_NAMES: [&str; 3] = ["R", "G", "B"];

/// Fits the filter A_l, l ≤ `lmax`, of B(d) = Σ_l A_l Σ_m L_lm Y_lm(d) to the pixels `samples`
/// (direction d, quadrature weight, RGB value and variance; e.g. from
/// [`crate::projection::ortho_samples`] or [`crate::projection::probe_samples`]) for the known
/// RGB lighting `light` — eq. 15 in pixel space, by [`crate::fit::fit_filter`] per channel, so
/// it stays right when the directions cover only part of the sphere (one view: one hemisphere of
/// normals), where dividing fitted B_lm by L_lm is not.
///
/// `have_sigma`: the variances are per-pixel standard errors (else they are 1, and σ² is
/// estimated from the residuals). Error bars are the propagated noise ([`crate::fit::noise_scale`];
/// a χ²/ν well above 1 is said in `warnings`, not folded into the noise) and, when `light` has orders above `lmax`, the truncation bias
/// estimated as [`crate::truncation`] defines it for every fit (stated apart; `light` up to
/// [`crate::truncation::truncation_lmax`] lets it calibrate the orders up to there). An order whose lighting energy over the
/// visible directions is below 1e-10 of the largest is unobservable (not fitted).
///
/// `noise_inflation`: the variance inflation F ≥ 1 of noise correlated between neighbouring pixels
/// by a reconstruction filter ([`crate::noise`]; 1 for independent pixels): the noise covariance
/// (and the noise part of every error bar, squared) is multiplied by it, on top of the χ²/ν scale.
///
/// Errors: fewer pixels than twice the orders, or a design the directions cannot determine
/// (singular after dropping unobservable orders), naming the orders.
pub fn fit_filter_pixels(
    samples: &[crate::projection::Sample],
    have_sigma: bool,
    noise_inflation: f64,
    light: &[[f64; 3]],
    lmax: usize,
) -> crate::error::Result<PixelFilterFit> {
    use crate::error::Error;
    use crate::fit::{filter_design, lsq};
    let light_lmax = crate::sh::lmax_of(light.len())
        .ok_or_else(|| Error::new("lighting coefficients are not a whole number of orders"))?;
    if light_lmax < lmax {
        return Err(Error::new(format!("lighting given to l = {light_lmax}, the filter fit needs l = {lmax}")));
    }
    if samples.len() < 2 * (lmax + 1) {
        return Err(Error::new(format!(
            "only {} pixels to fit {} filter orders; check the camera and sphere",
            samples.len(),
            lmax + 1
        )));
    }
    let l_hi = light_lmax.min(crate::truncation::truncation_lmax(lmax));
    let l_seq = l_hi.min(crate::truncation::sequence_lmax(lmax));
    let dirs: Vec<[f64; 3]> = samples.iter().map(|s| s.dir).collect();
    let weight: Vec<f64> = samples.iter().map(|s| s.w).collect();
    let mut orders: Vec<PixelOrder> = (0..=lmax)
        .map(|l| PixelOrder {
            l,
            estimate: [None; 3],
            stderr_noise: [None; 3],
            truncation: [None; 3],
            truncation_bound: [None; 3],
            stderr: [None; 3],
            amplification: [None; 3],
            status: [OrderStatus::Unobservable; 3],
        })
        .collect();
    let mut channels = Vec::with_capacity(3);
    let mut warnings = Vec::new();
    for ch in 0..3 {
        let name = CHANNEL_NAMES[ch];
        let l_scalar: Vec<f64> = light.iter().map(|c| c[ch]).collect();
        let full = filter_design(dirs.iter().copied(), &l_scalar, l_hi);
        // Visible lighting energy per order: the diagonal of the Gram matrix.
        let energy: Vec<f64> =
            (0..=l_hi).map(|l| full.iter().zip(&weight).map(|(r, w)| w * r[l] * r[l]).sum::<f64>()).collect();
        let emax = energy[..=lmax].iter().copied().fold(0.0, f64::max);
        let observable = |l: usize| energy[l] > 1e-10 * emax && emax > 0.0;
        let cols: Vec<usize> = (0..=lmax).filter(|&l| observable(l)).collect();
        if cols.is_empty() {
            warnings
                .push(format!("filter fit, channel {name}: the lighting has no energy over the visible directions"));
            channels.push(ChannelFit {
                chi2: 0.0,
                dof: 0,
                chi2_per_dof: None,
                robust_chi2_per_dof: None,
                p_value: None,
                relative_misfit: 0.0,
                stderr_scale: 1.0,
                fitted_orders: vec![],
                covariance: vec![],
                truncation_lmax: None,
                truncation_chi2_per_dof: None,
            });
            continue;
        }
        let value: Vec<f64> = samples.iter().map(|s| s.b[ch]).collect();
        let sigma: Vec<f64> = samples.iter().map(|s| s.var[ch].sqrt()).collect();
        let pick = |c: &[usize]| full.iter().map(|r| c.iter().map(|&l| r[l]).collect::<Vec<f64>>()).collect::<Vec<_>>();
        let rows = pick(&cols);
        let fit = lsq(&rows, &value, &sigma, &weight).ok_or_else(|| {
            Error::new(format!(
                "the visible directions cannot separate the filter orders {cols:?} (channel {name}): \
                 add views (e.g. the opposite one), use a normal-probe render or lower --lmax"
            ))
        })?;
        // Conditioning from the actual design: C = D^-1/2 G D^-1/2, amplification √((C⁻¹)_ll).
        let p = cols.len();
        let amplification = crate::fit::design_amplification(&rows, &weight, p);
        let chi2_per_dof = fit.chi2_per_dof();
        // Truncation: the same fit with orders up to H = lmax + 2, lmax + 4, … ≤ l_hi while the
        // directions separate them (the module docs of `crate::inverse::views`).
        let mut seq: Vec<(Vec<usize>, crate::fit::Fit)> = Vec::new();
        let mut hs: Vec<usize> = (lmax + 2..=l_seq).step_by(2).collect();
        if l_seq > lmax && hs.last() != Some(&l_seq) {
            hs.push(l_seq);
        }
        for h in hs {
            let c: Vec<usize> = (0..=h).filter(|&l| observable(l)).collect();
            if c.len() <= seq.last().map_or(p, |s| s.0.len()) {
                continue;
            }
            if samples.len() < 4 * c.len() {
                break;
            }
            let r = pick(&c);
            let ok = seq.is_empty()
                || crate::fit::design_amplification(&r, &weight, c.len())
                    .is_some_and(|a| a.iter().all(|&v| v <= crate::truncation::TRUNCATION_MAX_DESIGN_AMPLIFICATION));
            match lsq(&r, &value, &sigma, &weight).filter(|_| ok) {
                Some(f) => seq.push((c, f)),
                None => break,
            }
        }
        let x_top = seq.last().and_then(|s| s.1.chi2_per_dof()).or(chi2_per_dof);
        let robust_top = match seq.last() {
            Some((c, f)) if have_sigma => crate::fit::robust_chi2(&pick(c), &value, &sigma, &weight, &f.coef),
            _ => None,
        };
        let scale = crate::fit::noise_scale(have_sigma, x_top) * noise_inflation.max(1.0).sqrt();
        let p_value = if have_sigma { fit.p_value() } else { None };
        // The predicted truncation (crate::truncation) from the normal equations of every
        // observable order up to l_hi; each order above l_max is a band of one coefficient A_l.
        let cols_hi: Vec<usize> = (0..=l_hi).filter(|&l| observable(l)).collect();
        let predicted = (cols_hi.len() > p).then(|| {
            let q = cols_hi.len();
            let (mut g, mut s, mut rhs) = (vec![0.0; q * q], vec![0.0; q * q], vec![0.0; q]);
            for (i, r) in full.iter().enumerate() {
                let (w, v) = (weight[i], sigma[i] * sigma[i]);
                if w == 0.0 {
                    continue;
                }
                for (a, &la) in cols_hi.iter().enumerate() {
                    rhs[a] += w * r[la] * value[i];
                    for (b, &lb) in cols_hi.iter().enumerate() {
                        g[a * q + b] += w * r[la] * r[lb];
                        s[a * q + b] += w * w * v * r[la] * r[lb];
                    }
                }
            }
            let rhs = [rhs];
            let ne = crate::truncation::NormalEquations { g: &g, s: &s, rhs: &rhs, share: &[1.0], order: &cols_hi };
            crate::truncation::predicted_truncation(&ne, p, samples.len())
        });
        let predicted = predicted.flatten();
        let kappa = predicted.as_ref().map(|q| q.kappa(0, scale * scale));
        let robust = if have_sigma { crate::fit::robust_chi2(&rows, &value, &sigma, &weight, &fit.coef) } else { None };
        let relative_misfit =
            crate::fit::relative_misfit(&rows, &value, have_sigma.then_some(&sigma[..]), &weight, &fit.coef);
        if have_sigma && let Some(x) = chi2_per_dof {
            // A reported mismatch says what the excess χ² is; the notes below would only give it other
            // causes (a rare heavy sample, signal above the fitted orders) and mislead.
            let mismatched = robust.is_some_and(|r| mismatch(r, relative_misfit));
            if let Some(r) = robust.filter(|_| mismatched) {
                warnings.push(format!(
                    "filter fit, channel {name}: robust χ²/ν = {r:.3} (χ²/ν = {x:.3}): the model B = Σ_l A_l Σ_m L_lm \
                     Y_lm does not describe the image (misfit {:.0} % of the signal) — a mismatched or rotated \
                     lighting, a wrong camera, extent or sphere, or a BRDF that is not radially symmetric about the \
                     fitted direction",
                    100.0 * relative_misfit
                ));
            }
            let top = seq.last().and_then(|s| s.0.last().copied()).unwrap_or(lmax);
            match (x_top, robust_top) {
                _ if mismatched => {}
                (Some(xt), Some(rt)) if rt > crate::fit::NOISE_CHI2_MAX => warnings.push(format!(
                    "filter fit, channel {name}: robust χ²/ν = {rt:.3e} (χ²/ν = {xt:.3e}) even with the orders up to \
                     l = {top}: the residual is signal the model does not carry, not noise; the truncation part of \
                     the error bars carries the orders up to l = {top}"
                )),
                (Some(xt), _) if xt > MISMATCH_CHI2 => warnings.push(format!(
                    "filter fit, channel {name}: χ²/ν = {xt:.3} with the orders up to l = {top}: more scatter than the \
                     per-pixel σ (pixels whose σ missed a rare heavy sample, or signal above l = {top}); the noise \
                     part of the error bars is the propagated σ, not scaled by it"
                )),
                _ => {}
            }
        }
        for (i, &l) in cols.iter().enumerate() {
            let o = &mut orders[l];
            let noise = fit.sigma[i] * scale;
            o.estimate[ch] = Some(fit.coef[i]);
            o.stderr_noise[ch] = Some(noise);
            let amp = amplification.as_ref().map(|a| a[i]);
            o.amplification[ch] = amp;
            o.status[ch] = match amp {
                Some(a) if a <= MAX_AMPLIFICATION => OrderStatus::Determined,
                _ => OrderStatus::IllConditioned,
            };
            // The largest noise-corrected difference over the sequence (the bias estimate).
            let trunc = (!seq.is_empty()).then(|| {
                seq.iter()
                    .map(|(c, h)| {
                        let j = c.iter().position(|&x| x == l).expect("fitted orders are a prefix");
                        let delta = fit.coef[i] - h.coef[j];
                        let var_delta = ((h.sigma[j] * scale).powi(2) - noise * noise).max(0.0);
                        (delta * delta - var_delta).max(0.0).sqrt()
                    })
                    .fold(0.0, f64::max)
            });
            let pair = kappa.as_ref().zip(predicted.as_ref());
            let trunc = crate::truncation::combine(trunc, pair.map(|(k, q)| q.bias(k, i)));
            let bound = pair.map(|(k, q)| q.bound(k, i));
            o.truncation[ch] = trunc;
            o.truncation_bound[ch] = bound;
            o.stderr[ch] = Some((noise * noise + trunc.unwrap_or(0.0).powi(2)).sqrt());
            if o.status[ch] == OrderStatus::Determined
                && bound.is_some_and(|b| b >= crate::truncation::UNDETERMINED_TRUNCATION * fit.coef[i].abs())
            {
                o.status[ch] = OrderStatus::Undetermined;
            }
        }
        for l in 0..=lmax {
            match orders[l].status[ch] {
                OrderStatus::Unobservable => warnings.push(format!(
                    "channel {name}: order l = {l} is unobservable (no lighting energy over the visible directions)"
                )),
                OrderStatus::IllConditioned => warnings.push(format!(
                    "filter fit, channel {name}: order l = {l} is ill-conditioned on these directions (noise amplification {:.1} > {MAX_AMPLIFICATION}): \
                     add views or lower --lmax",
                    orders[l].amplification[ch].unwrap_or(f64::INFINITY)
                )),
                OrderStatus::Undetermined => warnings.push(format!(
                    "filter fit, channel {name}: order l = {l} cannot be determined from these views: the orders above l_max \
                     {lmax} can move it by {:.0} % of its size (`truncation_bound`, ≥ {:.0} %) — add views (e.g. the \
                     opposite one)",
                    100.0 * orders[l].truncation_bound[ch].unwrap_or(0.0)
                        / orders[l].estimate[ch].map_or(f64::INFINITY, f64::abs),
                    100.0 * crate::truncation::UNDETERMINED_TRUNCATION
                )),
                OrderStatus::Determined => {}
            }
        }
        let s2 = scale * scale;
        channels.push(ChannelFit {
            chi2: fit.chi2,
            dof: fit.dof,
            chi2_per_dof,
            robust_chi2_per_dof: robust,
            p_value,
            relative_misfit,
            stderr_scale: scale,
            fitted_orders: cols.clone(),
            covariance: (0..p).map(|i| (0..p).map(|j| fit.cov[i * p + j] * s2).collect()).collect(),
            truncation_lmax: seq
                .last()
                .and_then(|s| s.0.last().copied())
                .max(predicted.as_ref().and_then(|q| q.l_cal())),
            truncation_chi2_per_dof: seq.last().and_then(|s| s.1.chi2_per_dof()),
        });
    }
    Ok(PixelFilterFit { lmax, pixels: samples.len(), orders, channels, warnings })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_filter_and_flags_empty_orders() {
        let lmax = 4;
        let n = (lmax + 1) * (lmax + 1);
        // Lighting with no energy at l = 3.
        let lighting: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let (l, m) = crate::sh::lm(k);
                if l == 3 { [0.0; 3] } else { [1.0 + 0.1 * m as f64, 0.5, -0.3 * (k as f64).cos()] }
            })
            .collect();
        let f = crate::transfer::phong::phong(8.0, lmax);
        let b = crate::predict::predict(&lighting, &f, [1.0, 1.0, 1.0]);
        let est = measured_filter(&b, None, &lighting, lmax, 1e-12);
        for e in &est {
            if e.l == 3 {
                assert!(!e.observable());
                continue;
            }
            for ch in 0..3 {
                let v = e.estimate[ch].expect("observable");
                assert!((v - f[e.l]).abs() < 1e-14, "l={} ch={ch}", e.l);
            }
        }
    }
}
