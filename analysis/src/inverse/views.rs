//! Inverse lighting from the pixels of views that see only part of the sphere (issue 16): the
//! lighting L_lm, l ≤ L, fitted directly in pixel space, B(d_p) = Σ_lm a Λ_l ρ̂_l L_lm Y_lm(d_p)
//! (eq. 15 and 17; a the albedo of the channel), with everything the views cannot tell said:
//!
//! - **conditioning from the actual design**: the amplification of coefficient k is
//!   a_k = (max_l |Λ_l ρ̂_l| / |Λ_l ρ̂_l|) · √((C⁻¹)_kk), the filter's amplification of eq. 17 (the
//!   module [`super::lighting`]) times the design's, C the Gram matrix of Y_lm over the used pixels
//!   (weights: their solid angles) normalized to unit diagonal — 1 on the whole sphere, large where
//!   one view's hemisphere of normals barely separates Y_lm from the others. An order is
//!   `recovered` when every m has a_k ≤ the threshold, `ill-conditioned` otherwise, `unobservable`
//!   where the filter is zero (not fitted); a design the pixels cannot solve is an error;
//! - **truncation in the error bars**: B has energy above L; on part of the sphere (and on one
//!   view's pixels, which are no orthogonal quadrature for the Y_lm even where they cover the
//!   whole sphere, as a mirror's do) it is not orthogonal to the fitted orders and biases them:
//!   bias = (AᵀWA)⁻¹AᵀW t, t the part of B above L. A fit to l ≤ H gives L̂_L − L̂_H =
//!   (AᵀWA)⁻¹AᵀW A_(L,H] L̂_(L,H], the aliasing operator applied to the fitted orders L < l ≤ H: the
//!   bias from those orders. One step (H = L + 2) misses the orders beyond, which can dominate (a
//!   mirror under Grace at L = 8: the error of L̂_00(R), +0.075, comes from l = 9 … 16 — their
//!   aliasing with the true L_lm reproduces the error to 10 %, while L + 2 gives 0.006). So the
//!   sequence H = L + 2, L + 4, … up to [`TRUNCATION_LMAX_CAP`] ([`sequence_lmax`];
//!   stopping after L + 2 where the design amplification exceeds [`TRUNCATION_MAX_DESIGN_AMPLIFICATION`] or the
//!   pixels are fewer than 4 per column) is fitted from one Gram matrix, and the truncation part
//!   is the largest |L̂_L − L̂_H| over it with the noise of each difference removed
//!   (Var(L̂_H) − Var(L̂_L), exact for nested least squares with the same weights up to the
//!   noise's heteroskedasticity). Why it covers: each difference estimates the aliasing of the
//!   orders up to H; the estimates move as each band of higher orders enters, and the largest
//!   bounds the converged value once the orders that alias most (those the pixels resolve least
//!   evenly, up to about 2L) are in. It does not see orders above the top fit: measured on one
//!   view of a mirror under Grace (tests/mirror_truncation.rs), the total bars cover at about the
//!   Gaussian rate. The truncation part is stated apart from the noise (`truncation`,
//!   `stderr_noise`);
//! - **predicted truncation** (the "predicted residual energy" of sec. 3.5's 9-term analysis): the
//!   sequence cannot see what a fit to l ≤ H absorbs itself, and on one view's hemisphere the
//!   orders just above L lie largely inside the fitted orders' span (a Lambert sphere at L = 2: the
//!   l = 4 band alone biases L̂_00(R) by −0.545 of Grace's 2.533, while the l ≤ 4 fit moves it by
//!   0.14). So a prior on the orders L < l ≤ [`truncation_lmax`] (where the filter is not zero),
//!   E(L_lm²) = κ_l (l + 1)^−γ, isotropic over m ([`PRIOR_GAMMA`]), gives the bias of L̂_L,
//!   (AᵀWA)⁻¹AᵀW T h = M h, the covariance Σ_b κ_b M_b Σ₀ M_bᵀ per order band b (from the blocks of
//!   one Gram matrix up to the top order); the truncation part is the larger of its standard
//!   deviation and the sequence's estimate. κ_b is calibrated by the data: the weighted residual sum
//!   of squares that adding band b to the fit removes, minus its noise expectation (tr(G⁻¹S)
//!   differences, × the noise scale²), over its expectation per unit κ (bands up to the highest
//!   whose design amplification stays ≤ [`PRIOR_CALIBRATION_MAX_AMPLIFICATION`]; beyond, the last
//!   band's κ) — and at least the natural spectrum through the fitted orders 1 … L, the mean of
//!   (L̂_lm² − σ²)(l + 1)^γ. The residual sees only the part of a band outside the fitted span, so
//!   where a lighting's band is aligned with the span (Grace's l = 4 on one view: its residual
//!   calibrates κ_4 = 1.1, its true power is 2.7) the standard deviation understates the bias; so
//!   the bias with the first band above L aligned worst (Cauchy–Schwarz on it, the other bands as
//!   the prior; `truncation_bound`) classifies: an order whose RMS bound reaches
//!   [`UNDETERMINED_TRUNCATION`] of its RMS value is reported [`UNDETERMINED`] ("cannot be
//!   determined from these views"), not `recovered`;
//! - **consistency**: χ²/ν and its p-value per channel from the per-pixel standard errors. The
//!   noise part is the propagated σ, never scaled by χ²/ν ([`crate::fit::noise_scale`]): an excess
//!   is signal the model does not carry (a mirror's near-noiseless pixels give 10⁶; a clamped
//!   horizon), which the truncation part and the warnings carry, or pixels whose σ missed a rare
//!   heavy sample, which the bound near flagged pixels applied at load carries; a warning states a
//!   χ²/ν of the highest-order fit above 2. Without a `stderr` layer σ² comes
//!   from the residuals of the highest-order fit (said in a warning): then it also holds what that
//!   fit leaves unexplained, an overestimate of the noise.

use super::lighting::{Status, ZERO_FILTER_REL};
use crate::error::{Error, Result};
use crate::filter::ChannelFit;
use crate::fit::{design_amplification, lsq, noise_scale};
use crate::projection::Sample;
use crate::sh::{ShBasis, lm, num_coefficients};
use crate::truncation::{NormalEquations, block, predicted_truncation, spectrum_kappa};
pub use crate::truncation::{
    PRIOR_CALIBRATION_MAX_AMPLIFICATION, PRIOR_GAMMA, TRUNCATION_LMAX_CAP, TRUNCATION_MAX_DESIGN_AMPLIFICATION,
    UNDETERMINED, UNDETERMINED_TRUNCATION, sequence_lmax, truncation_lmax,
};

/// The nested higher-order fits of the truncation estimate: L̂ for l ≤ H, H = l_max + 2, l_max + 4,
/// … up to `l_top`, from one Gram matrix.
struct TruncationSequence {
    /// Highest order fitted.
    l_top: usize,
    /// Per fit: its first p coefficients per channel (the orders ≤ l_max) and the ratio
    /// Var(L̂_H) / Var(L̂_L) − 1 per coefficient (≥ 0: the extra variance of the difference).
    fits: Vec<([Vec<f64>; 3], Vec<f64>)>,
    /// The l ≤ l_max fit from the same Gram (the differences use it, so both share their rounding).
    base: [Vec<f64>; 3],
    /// χ²/ν of the fit up to `l_top` per channel (σ = the samples' σ; `None` without dof).
    chi2_per_dof: [Option<f64>; 3],
    /// Robust χ²/ν ([`crate::fit::robust_chi2`]) of that fit per channel.
    robust_chi2: [Option<f64>; 3],
}

impl TruncationSequence {
    /// Bias estimate of coefficient i of channel `ch`: the largest over the sequence of
    /// |L̂_L − L̂_H| with the noise of the difference removed, √((Δ² − Var Δ)₊); `var_l` the
    /// (scaled) noise variance of L̂_L.
    fn bias(&self, ch: usize, i: usize, var_l: f64) -> f64 {
        self.fits
            .iter()
            .map(|(x, extra)| {
                let d = self.base[ch][i] - x[ch][i];
                (d * d - var_l * extra[i]).max(0.0).sqrt()
            })
            .fold(0.0, f64::max)
    }
}

/// Per channel R, G, B.
type Rgb = [Vec<f64>; 3];
/// G, S (q × q row-major), the right-hand sides and per channel (Σ w b², Σ w² σ²) of [`gram`].
type Gram = (Vec<f64>, Vec<f64>, Rgb, [[f64; 2]; 3]);
/// G⁻¹, the coefficients per channel and the noise-ratio diagonal of one nested fit.
type Solved = (Vec<f64>, Rgb, Vec<f64>);

/// Accumulates, over the samples, the Gram matrix G = Σ w a aᵀ, S = Σ w² σ̄² a aᵀ (σ̄² the mean of the
/// channels' variances: one matrix for the noise ratios), the right-hand sides Σ w a b / albedo and
/// per channel Σ w (b / albedo)² and Σ w² σ² / albedo² (the RSS and the channel's share of S), for
/// the columns `cols_hi` (filter × Y_k up to `l_hi`). Chunks in a fixed order: the same bits
/// at any thread count.
fn gram(samples: &[Sample], albedo: [f64; 3], filter: &[f64], cols_hi: &[usize], l_hi: usize) -> Gram {
    use rayon::prelude::*;
    let q = cols_hi.len();
    let parts: Vec<Gram> = samples
        .par_chunks(4096)
        .map(|chunk| {
            let basis = ShBasis::new(l_hi);
            let mut y = vec![0.0; num_coefficients(l_hi)];
            let mut a = vec![0.0; q];
            let (mut g, mut s) = (vec![0.0; q * q], vec![0.0; q * q]);
            let mut rhs = [vec![0.0; q], vec![0.0; q], vec![0.0; q]];
            let mut bb = [[0.0; 2]; 3];
            for smp in chunk {
                basis.eval_into(smp.dir, &mut y);
                for (j, &k) in cols_hi.iter().enumerate() {
                    a[j] = filter[lm(k).0] * y[k];
                }
                let w = smp.w;
                let v = (0..3).map(|c| smp.var[c] / (albedo[c] * albedo[c])).sum::<f64>() / 3.0;
                let b = [smp.b[0] / albedo[0], smp.b[1] / albedo[1], smp.b[2] / albedo[2]];
                for c in 0..3 {
                    bb[c][0] += w * b[c] * b[c];
                    bb[c][1] += w * w * smp.var[c] / (albedo[c] * albedo[c]);
                }
                for i in 0..q {
                    let (wa, sa) = (w * a[i], w * w * v * a[i]);
                    for j in i..q {
                        g[i * q + j] += wa * a[j];
                        s[i * q + j] += sa * a[j];
                    }
                    for c in 0..3 {
                        rhs[c][i] += wa * b[c];
                    }
                }
            }
            (g, s, rhs, bb)
        })
        .collect();
    let (mut g, mut s) = (vec![0.0; q * q], vec![0.0; q * q]);
    let mut rhs = [vec![0.0; q], vec![0.0; q], vec![0.0; q]];
    let mut bb = [[0.0; 2]; 3];
    for (pg, ps, pr, pb) in parts {
        for c in 0..3 {
            bb[c][0] += pb[c][0];
            bb[c][1] += pb[c][1];
        }
        g.iter_mut().zip(&pg).for_each(|(a, b)| *a += b);
        s.iter_mut().zip(&ps).for_each(|(a, b)| *a += b);
        for c in 0..3 {
            rhs[c].iter_mut().zip(&pr[c]).for_each(|(a, b)| *a += b);
        }
    }
    for i in 0..q {
        for j in 0..i {
            g[i * q + j] = g[j * q + i];
            s[i * q + j] = s[j * q + i];
        }
    }
    (g, s, rhs, bb)
}

/// (G⁻¹ S G⁻¹)_ii for i < p, G⁻¹ given (m × m).
fn sandwich_diag(ginv: &[f64], s: &[f64], m: usize, p: usize) -> Vec<f64> {
    (0..p)
        .map(|i| {
            let gi = &ginv[i * m..(i + 1) * m];
            (0..m).map(|a| gi[a] * (0..m).map(|b| s[a * m + b] * gi[b]).sum::<f64>()).sum()
        })
        .collect()
}

/// The truncation sequence of the module docs: the first `p` of `cols_hi` are the fitted
/// columns (l ≤ `lmax`); fits up to H = lmax + 2, lmax + 4, … ≤ `l_hi` while the design stays
/// solvable, (after the first) its amplification ≤ [`TRUNCATION_MAX_DESIGN_AMPLIFICATION`] and the pixels ≥ 4 × the
/// columns. `None` when no higher order can be fitted.
#[allow(clippy::too_many_arguments)]
fn truncation_sequence(
    samples: &[Sample],
    albedo: [f64; 3],
    filter: &[f64],
    cols_hi: &[usize],
    p: usize,
    lmax: usize,
    l_seq: usize,
    gram: &Gram,
) -> Option<TruncationSequence> {
    if cols_hi.len() <= p {
        return None;
    }
    let q = cols_hi.len();
    let (g, s, rhs, _) = gram;
    let solve = |m: usize| -> Option<Solved> {
        let gm = block(g, q, m);
        let ginv = crate::fit::invert(&gm, m)?;
        let x = [0, 1, 2].map(|c| (0..m).map(|i| (0..m).map(|j| ginv[i * m + j] * rhs[c][j]).sum()).collect());
        let v = sandwich_diag(&ginv, &block(s, q, m), m, p);
        Some((ginv, x, v))
    };
    let (_, base, v_l) = solve(p)?;
    let mut hs: Vec<usize> = (lmax + 2..=l_seq).step_by(2).collect();
    if hs.last() != Some(&l_seq) {
        hs.push(l_seq);
    }
    let mut fits = Vec::new();
    let mut top: Option<(usize, usize, [Vec<f64>; 3])> = None;
    for h in hs {
        let m = cols_hi.iter().take_while(|&&k| lm(k).0 <= h).count();
        if m <= top.as_ref().map_or(p, |t| t.1) {
            continue;
        }
        if samples.len() < 4 * m {
            break;
        }
        // Design amplification of the extended fit, the filter left out.
        let gm = block(g, q, m);
        let d: Vec<f64> = (0..m).map(|i| gm[i * m + i].sqrt()).collect();
        let c: Vec<f64> = (0..m * m).map(|ij| gm[ij] / (d[ij / m] * d[ij % m])).collect();
        let Some(cinv) = crate::fit::invert(&c, m) else { break };
        if !fits.is_empty() && (0..m).any(|i| !(cinv[i * m + i].sqrt() <= TRUNCATION_MAX_DESIGN_AMPLIFICATION)) {
            break;
        }
        let Some((_, x, v)) = solve(m) else { break };
        let extra: Vec<f64> = (0..p).map(|i| if v_l[i] > 0.0 { (v[i] / v_l[i] - 1.0).max(0.0) } else { 0.0 }).collect();
        fits.push(([0, 1, 2].map(|c| x[c][..p].to_vec()), extra));
        top = Some((h, m, x));
    }
    let (l_top, m, x_top) = top?;
    // χ² of the top fit per channel: one more pass over the pixels.
    let basis = ShBasis::new(l_top);
    let mut y = vec![0.0; num_coefficients(l_top)];
    let (mut chi2, mut count) = ([0.0; 3], [0usize; 3]);
    let mut z2: [Vec<f64>; 3] = Default::default();
    for smp in samples {
        if smp.w == 0.0 {
            continue;
        }
        basis.eval_into(smp.dir, &mut y);
        for c in 0..3 {
            let sd = smp.var[c].sqrt() / albedo[c];
            if sd > 0.0 {
                let model: f64 = cols_hi[..m].iter().zip(&x_top[c]).map(|(&k, x)| filter[lm(k).0] * y[k] * x).sum();
                let z = ((smp.b[c] / albedo[c] - model) / sd).powi(2);
                chi2[c] += z;
                z2[c].push(z);
                count[c] += 1;
            }
        }
    }
    let chi2_per_dof = [0, 1, 2].map(|c| (count[c] > m).then(|| chi2[c] / (count[c] - m) as f64));
    let robust_chi2 = z2.map(|mut z| {
        (!z.is_empty()).then(|| {
            let mid = z.len() / 2;
            *z.select_nth_unstable_by(mid, f64::total_cmp).1 / 0.454_936_423_119_572_8
        })
    });
    Some(TruncationSequence { l_top, fits, base, chi2_per_dof, robust_chi2 })
}

/// One order of [`invert_lighting_views`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewOrder {
    pub l: usize,
    /// Λ_l ρ̂_l (unit albedo).
    pub lambda_rho: f64,
    /// Largest amplification a_k over the order's m (filter × design); `None` if unobservable.
    pub amplification: Option<f64>,
    /// `recovered`, `ill-conditioned`, `unobservable` or [`UNDETERMINED`].
    pub status: String,
}

/// Result of [`invert_lighting_views`]; per coefficient k (index order), RGB.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewsLighting {
    pub lmax: usize,
    pub orders: Vec<ViewOrder>,
    /// L̂_lm; `None` at unobservable orders.
    pub coefficients: Vec<Option<[f64; 3]>>,
    /// Total standard error √(noise² + truncation²).
    pub stderr: Vec<Option<[f64; 3]>>,
    /// Noise part: the per-pixel σ propagated ([`crate::fit::noise_scale`]; the residual σ without them).
    pub stderr_noise: Vec<Option<[f64; 3]>>,
    /// Estimated truncation bias (a standard deviation): the larger of the sequence's and the
    /// predicted one (module docs); `None` where no higher orders could be fitted.
    pub truncation: Vec<Option<[f64; 3]>>,
    /// The truncation bias with the first band above l_max aligned worst with the fitted orders
    /// (calibrated band energies, module docs); `None` where no higher orders could be fitted. An order whose RMS bound reaches
    /// [`UNDETERMINED_TRUNCATION`] of its RMS value is [`UNDETERMINED`].
    pub truncation_bound: Vec<Option<[f64; 3]>>,
    /// a_k per coefficient (the same for every channel).
    pub amplification: Vec<Option<f64>>,
    /// χ², ν, χ²/ν, p-value, error scale, covariance per channel (R, G, B).
    pub channels: Vec<ChannelFit>,
    pub warnings: Vec<String>,
}

/// Fits L_lm, l ≤ `lmax`, to `samples` (see the module docs). `filter` = Λ_l ρ̂_l (unit albedo)
/// for l ≤ at least `lmax` (orders up to `lmax` + 2 are used for the truncation estimate when
/// given), `albedo` per channel, `have_sigma` whether the sample variances are per-pixel
/// standard errors, `noise_inflation` the variance inflation F ≥ 1 of pixel noise correlated by a
/// reconstruction filter ([`crate::noise`]; 1 for independent pixels: noise error bars × √F),
/// `max_amplification` the threshold of `recovered` (the CLI's default is
/// [`super::lighting::DEFAULT_MAX_AMPLIFICATION`]).
///
/// Errors: a filter shorter than `lmax` + 1 or all zero, a non-positive albedo, a threshold < 1,
/// too few pixels, or views that cannot determine the coefficients at all (singular design).
pub fn invert_lighting_views(
    samples: &[Sample],
    have_sigma: bool,
    noise_inflation: f64,
    filter: &[f64],
    albedo: [f64; 3],
    lmax: usize,
    max_amplification: f64,
) -> Result<ViewsLighting> {
    if filter.len() < lmax + 1 || filter.iter().any(|f| !f.is_finite()) {
        return Err(Error::new(format!("inverse lighting needs finite Λ_l ρ̂_l for l = 0 … {lmax}")));
    }
    if albedo.iter().any(|a| !(a.is_finite() && *a > 0.0)) {
        return Err(Error::new(format!("albedo must be > 0 in every channel, got {albedo:?}")));
    }
    if !(max_amplification >= 1.0) {
        return Err(Error::new(format!("the amplification threshold must be ≥ 1, got {max_amplification}")));
    }
    let fmax = filter[..=lmax].iter().fold(0.0f64, |a, f| a.max(f.abs()));
    if !(fmax > 0.0) {
        return Err(Error::new("the BRDF's transfer coefficients are all zero"));
    }
    let observable = |l: usize| filter[l].abs() > ZERO_FILTER_REL * fmax;
    let l_hi = (filter.len() - 1).min(truncation_lmax(lmax));
    let n = num_coefficients(lmax);
    let cols: Vec<usize> = (0..n).filter(|&k| observable(lm(k).0)).collect();
    let cols_hi: Vec<usize> = (0..num_coefficients(l_hi)).filter(|&k| observable(lm(k).0)).collect();
    if samples.len() < 2 * cols.len() {
        return Err(Error::new(format!(
            "only {} pixels for {} lighting coefficients (l_max {lmax}); check the camera and sphere or lower --lmax",
            samples.len(),
            cols.len()
        )));
    }
    let basis = ShBasis::new(lmax);
    let weight: Vec<f64> = samples.iter().map(|s| s.w).collect();
    let rows: Vec<Vec<f64>> = samples
        .iter()
        .map(|s| {
            let y = basis.eval(s.dir);
            cols.iter().map(|&k| filter[lm(k).0] * y[k]).collect()
        })
        .collect();
    let p = cols.len();
    // Design amplification: √((C⁻¹)_kk), C the unit-diagonal Gram of the (unscaled) Y columns.
    let amp = design_amplification(&rows, &weight, p).ok_or_else(|| {
        Error::new(format!(
            "these views cannot determine the lighting up to l_max {lmax} (the visible directions do not separate \
             its coefficients): add views (e.g. the opposite one), use a normal-probe render or lower --lmax"
        ))
    })?;
    let mut amplification = vec![None; n];
    for (i, &k) in cols.iter().enumerate() {
        amplification[k] = Some(fmax / filter[lm(k).0].abs() * amp[i]);
    }
    let gram_hi = (cols_hi.len() > p).then(|| gram(samples, albedo, filter, &cols_hi, l_hi));
    let seq = gram_hi.as_ref().and_then(|gr| {
        truncation_sequence(samples, albedo, filter, &cols_hi, p, lmax, l_hi.min(sequence_lmax(lmax)), gr)
    });
    let order_hi: Vec<usize> = cols_hi.iter().map(|&k| lm(k).0).collect();
    let predicted = gram_hi.as_ref().and_then(|(g, s, rhs, bb)| {
        // S holds the channels' mean variance: each channel's noise is its share of it.
        let total: f64 = bb.iter().map(|b| b[1]).sum::<f64>() / 3.0;
        let share = [0, 1, 2].map(|c| if total > 0.0 { bb[c][1] / total } else { 0.0 });
        let ne = NormalEquations { g, s, rhs, share: &share, order: &order_hi };
        predicted_truncation(&ne, p, samples.len())
    });
    let mut coefficients = vec![None; n];
    let mut stderr = vec![None; n];
    let mut stderr_noise = vec![None; n];
    let mut truncation = vec![None; n];
    let mut truncation_bound = vec![None; n];
    let mut channels = Vec::with_capacity(3);
    let mut warnings = Vec::new();
    for ch in 0..3 {
        let name = ["R", "G", "B"][ch];
        let value: Vec<f64> = samples.iter().map(|s| s.b[ch] / albedo[ch]).collect();
        let sigma: Vec<f64> = samples.iter().map(|s| s.var[ch].sqrt() / albedo[ch]).collect();
        let fit = lsq(&rows, &value, &sigma, &weight).ok_or_else(|| {
            Error::new(format!("these views cannot determine the lighting up to l_max {lmax} (channel {name})"))
        })?;
        let x = fit.chi2_per_dof();
        // The noise scale comes from the highest-order fit: the χ² that orders above l_max explain
        // is truncation (carried by the truncation part), not noise.
        let robust = if have_sigma { crate::fit::robust_chi2(&rows, &value, &sigma, &weight, &fit.coef) } else { None };
        let x_top = seq.as_ref().and_then(|q| q.chi2_per_dof[ch]).or(x);
        let robust_top = seq.as_ref().map_or(robust, |q| q.robust_chi2[ch]);
        let scale = noise_scale(have_sigma, x_top) * noise_inflation.max(1.0).sqrt();
        let p_value = if have_sigma { fit.p_value() } else { None };
        let relative_misfit =
            crate::fit::relative_misfit(&rows, &value, have_sigma.then_some(&sigma[..]), &weight, &fit.coef);
        let top = seq.as_ref().map_or(lmax, |q| q.l_top);
        if have_sigma && let Some(x) = x {
            // A reported mismatch says what the excess χ² is; the notes below would only give it other
            // causes (a rare heavy sample, signal above the fitted orders) and mislead.
            let mismatched = robust.is_some_and(|r| crate::filter::mismatch(r, relative_misfit));
            if let Some(r) = robust.filter(|_| mismatched) {
                warnings.push(format!(
                    "lighting fit, channel {name}: robust χ²/ν = {r:.3} (χ²/ν = {x:.3}, misfit {:.0} % of the signal): the BRDF and \
                     l_max do not describe the image — lighting above l_max (a mirror under a detailed map: then the \
                     truncation part of the error bars, from fits up to l = {top}, carries it), or a wrong BRDF, \
                     albedo, camera, extent or sphere",
                    100.0 * relative_misfit
                ));
            }
            match (x_top, robust_top) {
                _ if mismatched => {}
                (Some(xt), Some(rt)) if rt > crate::fit::NOISE_CHI2_MAX => warnings.push(format!(
                    "lighting fit, channel {name}: robust χ²/ν = {rt:.3e} (χ²/ν = {xt:.3e}) even with orders up to \
                     l = {top}: the residual is signal the fit does not carry (lighting above l = {top}, or a wrong \
                     model), not noise — the noise part is the propagated per-pixel σ; the truncation part carries \
                     the orders up to l = {top}"
                )),
                (Some(xt), _) if xt > crate::filter::MISMATCH_CHI2 => warnings.push(format!(
                    "lighting fit, channel {name}: χ²/ν = {xt:.3} with orders up to l = {top}: more scatter than the \
                     per-pixel σ (pixels whose σ missed a rare heavy sample, or lighting above l = {top}); the noise \
                     part of the error bars is the propagated σ, not scaled by it"
                )),
                _ => {}
            }
        } else if !have_sigma && ch == 0 {
            warnings.push(format!(
                "lighting fit: no per-pixel standard errors (stderr layer): the noise σ is estimated from the residuals of the fit \
                 up to l = {top}, and so also holds whatever that fit leaves unexplained"
            ));
        }
        // The prior's power per band: the larger of the residual's calibration and the natural
        // spectrum through the fitted orders 1 … l_max (module docs).
        let kappa = predicted.as_ref().map(|q| {
            let spectrum = spectrum_kappa(&order_hi[..p], &fit.coef, &fit.sigma, scale);
            q.kappa(ch, scale * scale).into_iter().map(|k| k.max(spectrum)).collect::<Vec<f64>>()
        });
        for (i, &k) in cols.iter().enumerate() {
            let noise = fit.sigma[i] * scale;
            let t_seq = seq.as_ref().map(|q| q.bias(ch, i, fit.sigma[i] * fit.sigma[i] * scale * scale));
            let t_pred = kappa.as_ref().zip(predicted.as_ref()).map(|(kp, q)| q.bias(kp, i));
            if let Some(b) = kappa.as_ref().zip(predicted.as_ref()).map(|(kp, q)| q.bound(kp, i)) {
                truncation_bound[k].get_or_insert([0.0; 3])[ch] = b;
            }
            let t = crate::truncation::combine(t_seq, t_pred);
            coefficients[k].get_or_insert([0.0; 3])[ch] = fit.coef[i];
            stderr_noise[k].get_or_insert([0.0; 3])[ch] = noise;
            if let Some(t) = t {
                truncation[k].get_or_insert([0.0; 3])[ch] = t;
            }
            stderr[k].get_or_insert([0.0; 3])[ch] = (noise * noise + t.unwrap_or(0.0).powi(2)).sqrt();
        }
        let s2 = scale * scale;
        channels.push(ChannelFit {
            chi2: fit.chi2,
            dof: fit.dof,
            chi2_per_dof: x,
            robust_chi2_per_dof: robust,
            p_value,
            relative_misfit,
            stderr_scale: scale,
            fitted_orders: (0..=lmax).filter(|&l| observable(l)).collect(),
            covariance: (0..p).map(|i| (0..p).map(|j| fit.cov[i * p + j] * s2).collect()).collect(),
            truncation_lmax: seq.as_ref().map(|q| q.l_top).max(predicted.as_ref().and_then(|q| q.l_cal())),
            truncation_chi2_per_dof: seq.as_ref().and_then(|q| q.chi2_per_dof[ch]),
        });
    }
    // Per order the largest over channels of RMS_m(truncation bound) / RMS_m(|L̂_lm|).
    let truncation_share = |l: usize| -> Option<f64> {
        let ks = l * l..(l + 1) * (l + 1);
        (0..3)
            .filter_map(|ch| {
                let bound: f64 = ks.clone().filter_map(|k| truncation_bound[k].map(|b: [f64; 3]| b[ch].powi(2))).sum();
                let value: f64 = ks.clone().filter_map(|k| coefficients[k].map(|c: [f64; 3]| c[ch].powi(2))).sum();
                (value > 0.0).then(|| (bound / value).sqrt())
            })
            .reduce(f64::max)
    };
    let orders: Vec<ViewOrder> = (0..=lmax)
        .map(|l| {
            let amp = (0..2 * l + 1)
                .filter_map(|i| amplification[l * l + i])
                .fold(None, |a: Option<f64>, v| Some(a.map_or(v, |a| a.max(v))));
            let status = match amp {
                None => Status::Unobservable.name(),
                Some(a) if a > max_amplification => Status::IllConditioned.name(),
                Some(_) if truncation_share(l).is_some_and(|r| r >= UNDETERMINED_TRUNCATION) => UNDETERMINED,
                Some(_) => Status::Recovered.name(),
            };
            ViewOrder { l, lambda_rho: filter[l], amplification: amp, status: status.to_string() }
        })
        .collect();
    for o in &orders {
        if o.status == UNDETERMINED {
            warnings.push(format!(
                "lighting fit: order l = {} cannot be determined from these views: the orders above l_max {lmax} (fitted to \
                 calibrate the predicted truncation up to l = {}) can move it by {:.0} % of its size (worst case of \
                 the calibrated energies, `truncation_bound`; ≥ {:.0} %) — add views (e.g. the opposite one)",
                o.l,
                predicted.as_ref().and_then(|q| q.l_cal()).unwrap_or(l_hi),
                100.0 * truncation_share(o.l).unwrap_or(0.0),
                100.0 * UNDETERMINED_TRUNCATION
            ));
        }
        if o.status == Status::IllConditioned.name() {
            warnings.push(format!(
                "lighting fit: order l = {} cannot be determined from these views: amplification {:.1} > {max_amplification} \
                 (filter × design; add views or lower --lmax)",
                o.l,
                o.amplification.unwrap_or(f64::INFINITY)
            ));
        }
    }
    Ok(ViewsLighting {
        lmax,
        orders,
        coefficients,
        stderr,
        stderr_noise,
        truncation,
        truncation_bound,
        amplification,
        channels,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::latlong_direction;

    /// Pixels of a W × H lat-long grid restricted by `keep`, B = a Σ f_l L_lm Y_lm exactly.
    fn samples(light: &[f64], f: &[f64], keep: impl Fn([f64; 3]) -> bool) -> Vec<Sample> {
        let (w, h) = (64, 32);
        let lmax = f.len() - 1;
        let basis = ShBasis::new(lmax);
        (0..w * h)
            .map(|i| (i / w, i % w))
            .map(|(r, c)| (r, latlong_direction(r, c, w, h)))
            .filter(|(_, d)| keep(*d))
            .map(|(r, d)| {
                let y = basis.eval(d);
                let b: f64 = (0..y.len()).map(|k| f[lm(k).0] * light.get(k).copied().unwrap_or(0.0) * y[k]).sum();
                Sample { dir: d, w: crate::fit::latlong_omega(r, w, h), b: [b, 0.5 * b, 2.0 * b], var: [1e-6; 3] }
            })
            .collect()
    }

    #[test]
    fn exact_on_the_sphere_and_conditioning_grows_on_a_hemisphere() {
        let light: Vec<f64> =
            (0..16).map(|k| if k == 0 { 2.0 } else { 0.3 * ((k * 5 % 7) as f64 / 7.0 - 0.4) }).collect();
        // Band-limited: lighting l ≤ 3, Lambert filter (l = 3 is a zero: unobservable).
        let f = crate::transfer::lambert::lambert(3);
        let full = samples(&light, &f, |_| true);
        let r = invert_lighting_views(&full, true, 1.0, &f, [1.0, 0.5, 2.0], 2, 10.0).unwrap();
        for k in 0..9 {
            let c = r.coefficients[k].unwrap();
            for ch in 0..3 {
                assert!((c[ch] - light[k]).abs() < 1e-6, "k={k} ch{ch}: {} vs {}", c[ch], light[k]);
            }
            // The whole sphere's design is orthogonal up to quadrature: a_k ≈ the filter's.
            let want = 1.0 / f[lm(k).0];
            assert!((r.amplification[k].unwrap() / want - 1.0).abs() < 0.05, "k={k}");
        }
        assert!(r.orders.iter().all(|o| o.status == "recovered"));
        // One hemisphere (x > 0): still exact for band-limited B, but the amplification grows.
        let half = samples(&light, &f, |d| d[0] > 0.0);
        let h = invert_lighting_views(&half, true, 1.0, &f, [1.0, 0.5, 2.0], 2, 10.0).unwrap();
        for k in 0..9 {
            assert!((h.coefficients[k].unwrap()[0] - light[k]).abs() < 1e-5, "k={k}");
            // Never better than the whole sphere (yz stays orthogonal to the rest on x > 0).
            assert!(h.amplification[k].unwrap() > r.amplification[k].unwrap() * 0.99, "k={k}");
        }
        let worst = |v: &ViewsLighting| (0..9).map(|k| v.amplification[k].unwrap() * f[lm(k).0]).fold(0.0, f64::max);
        assert!(worst(&h) > 1.5 * worst(&r), "{} vs {}", worst(&h), worst(&r));
    }

    #[test]
    fn truncation_is_estimated_and_a_cap_is_refused() {
        // Lighting with energy at l = 4: a Lambert fit to l ≤ 2 on a hemisphere is biased; the
        // truncation estimate must cover the error.
        let light: Vec<f64> = (0..25)
            .map(|k| {
                if k == 0 {
                    2.0
                } else if lm(k).0 == 4 {
                    0.4
                } else {
                    0.1
                }
            })
            .collect();
        let f = crate::transfer::lambert::lambert(4);
        let half = samples(&light, &f, |d| d[0] > 0.0);
        let h = invert_lighting_views(&half, true, 1.0, &f, [1.0; 3], 2, 100.0).unwrap();
        for k in 0..9 {
            let (c, s) = (h.coefficients[k].unwrap()[0], h.stderr[k].unwrap()[0]);
            assert!((c - light[k]).abs() <= 1.5 * s + 1e-6, "k={k}: {c} ± {s} vs {}", light[k]);
        }
        assert!(h.truncation.iter().flatten().any(|t| t[0] > 1e-4), "a bias to estimate");
        // A tiny cap sees too little to separate 9 coefficients well: ill-conditioned orders said.
        let cap = samples(&light, &f, |d| d[2] > 0.95);
        match invert_lighting_views(&cap, true, 1.0, &f, [1.0; 3], 2, 10.0) {
            Ok(r) => assert!(r.orders.iter().any(|o| o.status == "ill-conditioned"), "{:?}", r.orders),
            Err(e) => assert!(e.message.contains("cannot determine"), "{e}"),
        }
    }
}
