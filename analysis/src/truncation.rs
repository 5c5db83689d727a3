//! The one truncation estimate of every pixel-space fit (issue 16): `invert lighting` from views
//! ([`crate::inverse::views`], unknowns L_lm) and the filter fits of `analyze` and `invert brdf`
//! ([`crate::filter::fit_filter_pixels`], unknowns A_l) share the definitions here.
//!
//! A fit to the orders l ≤ L of pixels whose signal has orders above L is biased: with A the
//! fitted columns and T those above L (coefficients h), the bias is (AᵀWA)⁻¹AᵀW T h = M h,
//! M = G_AA⁻¹ G_AT from one Gram matrix G of all columns up to [`truncation_lmax`]. Two estimates
//! of it, and the truncation part of an error bar is the larger:
//!
//! - the **nested sequence**: fits to l ≤ H, H = L + 2, L + 4, … ≤ [`sequence_lmax`] (while the views
//!   separate the orders), and the largest
//!   |x̂_L − x̂_H| with the noise of the difference removed (the module docs of
//!   [`crate::inverse::views`] say why and when it stops);
//! - the **predicted truncation** ([`predicted_truncation`]): a prior on the coefficients of each
//!   band b of orders above L, E(h_j²) = κ_b (l + 1)^−γ ([`PRIOR_GAMMA`]), gives the bias covariance
//!   Σ_b κ_b M_b Σ₀ M_bᵀ; κ_b is calibrated by the weighted residual sum of squares that adding band b
//!   to the fit removes, minus its noise expectation, over its expectation per unit κ (bands up to
//!   the highest whose design amplification stays ≤ [`PRIOR_CALIBRATION_MAX_AMPLIFICATION`];
//!   beyond, the last calibrated κ). A band is the 2l + 1 coefficients L_lm of an order for the
//!   lighting, the one A_l for a filter (there the calibration measures A_l² directly).
//!
//! The bound with the first band above L aligned worst with the fitted orders
//! ([`PredictedTruncation::bound`], JSON `truncation_bound`) classifies: an order whose RMS bound
//! reaches [`UNDETERMINED_TRUNCATION`] of its RMS value is [`UNDETERMINED`] ("cannot be determined
//! from these views").

/// Cap on the highest order of the truncation sequence ([`truncation_lmax`]): the Gram matrix of
/// (l + 1)² columns costs (l + 1)⁴ / 2 per pixel (289 columns at l = 16).
pub const TRUNCATION_LMAX_CAP: usize = 16;

/// Largest design amplification (unit-diagonal Gram, filter left out; the value of
/// [`crate::filter::MAX_AMPLIFICATION`]) at which a higher-order fit of the truncation sequence
/// beyond the first (H = L + 2, always used when solvable) is still used: beyond it the views
/// cannot separate the extra orders and the fit's differences are noise, not bias.
pub const TRUNCATION_MAX_DESIGN_AMPLIFICATION: f64 = 30.0;

/// Highest order of the truncation estimates of a fit to l ≤ `lmax` (the predicted truncation's
/// prior and its calibration; the sequence stops at [`sequence_lmax`]): [`TRUNCATION_LMAX_CAP`], at
/// least `lmax` + 2. Callers pass the filter (or lighting) up to this order.
pub fn truncation_lmax(lmax: usize) -> usize {
    TRUNCATION_LMAX_CAP.max(lmax + 2)
}

/// Highest order of the truncation sequence of a fit to l ≤ `lmax`: [`TRUNCATION_LMAX_CAP`], at
/// least `lmax` + 2 — as far as the estimates go; the sequence itself stops earlier where the views
/// cannot separate the extra orders ([`TRUNCATION_MAX_DESIGN_AMPLIFICATION`]) or the pixels run short.
/// It stopped at 2 `lmax` before: at `lmax` 2 that is one step (H = 4), which left the truncation part
/// of two opposite views of a Lambert sphere under Grace about 30 % short (mean z over 20 seeds +1.27
/// / +1.00 / +0.79 at l = 0, −1.26 at l = 2 R; 1σ coverage 47 %, tests/partial_view_coverage.rs).
pub fn sequence_lmax(lmax: usize) -> usize {
    TRUNCATION_LMAX_CAP.max(lmax + 2)
}

/// Exponent γ of the prior per-coefficient power E(h_j²) ∝ (l + 1)^−γ of the predicted truncation
/// (module docs). Least-squares slopes of log(Σ_m L_lm² / (2l + 1)) on log(l + 1) over l = 1 … 16
/// (`reflect sh project … --lmax 16 --json`): Grace (grace_latlong.exr) 1.45 / 1.30 / 1.49 (R G B),
/// the sky map (sky_latlong.exr) 1.06. The smaller value is used: it puts more of the prior's energy
/// at the high orders that are extrapolated, not measured (for a filter A_l, which falls faster than
/// any lighting spectrum, it is conservative).
pub const PRIOR_GAMMA: f64 = 1.0;

/// Largest design amplification (unit-diagonal Gram, [`crate::fit::design_amplification`]) of the
/// fit whose residual calibrates the prior of the predicted truncation (module docs): beyond it the
/// Gram matrix's rounding (condition ≈ amplification²) would reach the residual differences measured.
pub const PRIOR_CALIBRATION_MAX_AMPLIFICATION: f64 = 1.0e3;

/// Status of an order whose amplification passes but whose truncation bound
/// ([`PredictedTruncation::bound`], RMS over m) reaches [`UNDETERMINED_TRUNCATION`] of its RMS
/// value in some channel: the views cannot tell it from the orders above l_max.
pub const UNDETERMINED: &str = "undetermined";

/// Fraction of an order's size at which its truncation bound makes it [`UNDETERMINED`]. Measured
/// (RMS over m, largest channel): one view of a Lambert sphere under Grace at l_max 2
/// (tests/partial_view_truncation.rs) gives 29 / 38 / 55 % (R G B) at l = 0; two opposite views
/// ≤ 13 % at every order; one view of a mirror (the Mitsuba 3 render of guide "Analysing another renderer's images", l_max 8) 3–6 % at
/// l = 0 and at most 24 % (l = 7, R), whose bars cover the truth.
pub const UNDETERMINED_TRUNCATION: f64 = 0.35;

/// The leading m × m block of a q × q row-major matrix.
pub fn block(a: &[f64], q: usize, m: usize) -> Vec<f64> {
    (0..m).flat_map(|i| a[i * q..i * q + m].iter().copied()).collect()
}

/// Largest √((C⁻¹)_ii) of the leading m × m block of the Gram `g` (q × q), C its unit-diagonal
/// form; `None` when singular.
pub fn block_amplification(g: &[f64], q: usize, m: usize) -> Option<f64> {
    let gm = block(g, q, m);
    let d: Vec<f64> = (0..m).map(|i| gm[i * m + i].sqrt()).collect();
    let c: Vec<f64> = (0..m * m).map(|ij| gm[ij] / (d[ij / m] * d[ij % m])).collect();
    let cinv = crate::fit::invert(&c, m)?;
    Some((0..m).map(|i| cinv[i * m + i].max(0.0).sqrt()).fold(0.0, f64::max))
}

/// The weighted normal equations of a fit and its extension above l_max, the input of
/// [`predicted_truncation`]: q columns, the first p fitted.
pub struct NormalEquations<'a> {
    /// G = Σ_p w_p a_p a_pᵀ (q × q, row-major).
    pub g: &'a [f64],
    /// S = Σ_p w_p² σ̄_p² a_p a_pᵀ (q × q), σ̄² a reference variance (e.g. the channels' mean).
    pub s: &'a [f64],
    /// Per channel the right-hand side Σ_p w_p a_p v_p (length q each).
    pub rhs: &'a [Vec<f64>],
    /// Per channel its noise variance as a multiple of S's (1 when S holds the channel's own σ²).
    pub share: &'a [f64],
    /// The order l of each column (non-decreasing; a band is the columns of one order).
    pub order: &'a [usize],
}

/// The predicted truncation of a fit to l ≤ L (module docs): per fitted coefficient i and band b
/// above L the bias variance per unit prior power, u_ib = Σ_(j in b) M_ij² Σ₀_jj, and per band the
/// calibration of its power from the weighted residual sum of squares that adding it removes.
pub struct PredictedTruncation {
    /// u_ib, i < p (row-major p × bands).
    u: Vec<f64>,
    /// The orders of the bands above L.
    bands: Vec<usize>,
    /// Per calibrated band (the first `steps.len()` bands): per channel ΔRSS_b, its noise
    /// expectation for the reference σ, and d_b, the truncation part of E[ΔRSS_b] per unit power.
    steps: Vec<(Vec<f64>, Vec<f64>, f64)>,
    /// Per band its number of coefficients n_b (the worst-case bound of `bound`).
    sizes: Vec<usize>,
}

impl PredictedTruncation {
    /// Highest order calibrated from the residuals (`None`: none could be).
    pub fn l_cal(&self) -> Option<usize> {
        self.steps.len().checked_sub(1).map(|b| self.bands[b])
    }

    /// The prior power scale κ_b of each band for channel `ch` (noise variance scale `s2`):
    /// (ΔRSS_b − s² · noise_b)₊ / d_b for the calibrated bands, the last calibrated value beyond.
    pub fn kappa(&self, ch: usize, s2: f64) -> Vec<f64> {
        let mut k: Vec<f64> = self.steps.iter().map(|(r, n, d)| (r[ch] - s2 * n[ch]).max(0.0) / d).collect();
        let last = k.last().copied().unwrap_or(0.0);
        k.resize(self.bands.len(), last);
        k
    }

    /// The bias of coefficient i when the first band above L (the one that aliases most) is
    /// aligned worst with the fitted orders, the others as the prior: √(n_1 κ_1 u_i1) +
    /// √(Σ_(b>1) κ_b u_ib) (Cauchy–Schwarz on the first band: |Σ_(j in b) M_ij h_j| ≤ ‖M_ib‖ ‖h_b‖,
    /// E‖h_b‖² = n_b κ_b Σ₀_b). The worst case of every band at once (Σ_b √(n_b κ_b u_ib)) called
    /// every order of a one-view mirror at L = 8 undetermined (17–118 % of its size) whose bars
    /// cover the truth (tests/mirror_truncation.rs).
    pub fn bound(&self, kappa: &[f64], i: usize) -> f64 {
        let nb = self.bands.len();
        let rest: f64 = (1..nb).map(|b| kappa[b] * self.u[i * nb + b]).sum();
        (self.sizes[0] as f64 * kappa[0] * self.u[i * nb]).max(0.0).sqrt() + rest.max(0.0).sqrt()
    }

    /// The predicted bias standard deviation of coefficient i, √(Σ_b κ_b u_ib).
    pub fn bias(&self, kappa: &[f64], i: usize) -> f64 {
        let nb = self.bands.len();
        (0..nb).map(|b| kappa[b] * self.u[i * nb + b]).sum::<f64>().max(0.0).sqrt()
    }
}

/// The prior power scale κ of the natural spectrum E(L_lm²) = κ (l + 1)^−γ ([`PRIOR_GAMMA`]) through
/// the fitted coefficients of orders 1 … l_max (l = 0, the mean, is no part of the spectrum's
/// slope): the mean over them of (x̂_i² − σ_i²)(l + 1)^γ, σ the noise standard error (`sigma` ×
/// `scale`), `order[i]` the order of coefficient i; 0 without such orders. A floor for lighting
/// (whose spectrum is smooth), not for a filter.
pub fn spectrum_kappa(order: &[usize], coef: &[f64], sigma: &[f64], scale: f64) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (i, &l) in order.iter().enumerate() {
        if l >= 1 {
            sum += (coef[i].powi(2) - (sigma[i] * scale).powi(2)) * ((l + 1) as f64).powf(PRIOR_GAMMA);
            n += 1;
        }
    }
    if n > 0 { (sum / n as f64).max(0.0) } else { 0.0 }
}

/// The predicted truncation of the module docs from the normal equations `ne` of q columns, the
/// first `p` fitted; `n_samples` pixels. `None` when no column lies above the fit or G_AA is
/// singular.
pub fn predicted_truncation(ne: &NormalEquations, p: usize, n_samples: usize) -> Option<PredictedTruncation> {
    let (g, s, rhs) = (ne.g, ne.s, ne.rhs);
    let q = ne.order.len();
    if q <= p {
        return None;
    }
    let nch = rhs.len();
    let prior: Vec<f64> = ne.order.iter().map(|&l| ((l + 1) as f64).powf(-PRIOR_GAMMA)).collect();
    let mut bands: Vec<usize> = ne.order[p..].to_vec();
    bands.dedup();
    let nb = bands.len();
    let band_of = |j: usize| bands.iter().position(|&l| l == ne.order[j]).expect("a band per order");
    let gpp_inv = crate::fit::invert(&block(g, q, p), p)?;
    // M = G_AA⁻¹ G_AT (p × t, T = columns p … q) and u_ib.
    let t = q - p;
    let mut mm = vec![0.0; p * t];
    for i in 0..p {
        for a in 0..p {
            let gi = gpp_inv[i * p + a];
            for j in 0..t {
                mm[i * t + j] += gi * g[a * q + p + j];
            }
        }
    }
    let mut u = vec![0.0; p * nb];
    for j in 0..t {
        let b = band_of(p + j);
        for i in 0..p {
            u[i * nb + b] += mm[i * t + j].powi(2) * prior[p + j];
        }
    }
    // Weighted RSS removed by a fit on the first m columns, rhsᵀ G⁻¹ rhs, and its noise
    // expectation tr(G⁻¹ S) (E[RSS] = tr(WΣ) − tr(G⁻¹S)).
    let fitted = |ginv: &[f64], m: usize| -> (Vec<f64>, f64) {
        let r = (0..nch)
            .map(|c| (0..m).map(|a| rhs[c][a] * (0..m).map(|b| ginv[a * m + b] * rhs[c][b]).sum::<f64>()).sum::<f64>())
            .collect();
        let n = (0..m).map(|a| (0..m).map(|b| ginv[a * m + b] * s[b * q + a]).sum::<f64>()).sum();
        (r, n)
    };
    let (mut prev_inv, mut prev_m) = (gpp_inv, p);
    let mut prev_fit = fitted(&prev_inv, p);
    let mut steps = Vec::new();
    for &l in &bands {
        let m = ne.order.iter().take_while(|&&k| k <= l).count();
        if n_samples < 4 * m || !block_amplification(g, q, m).is_some_and(|a| a <= PRIOR_CALIBRATION_MAX_AMPLIFICATION)
        {
            break;
        }
        let Some(inv) = crate::fit::invert(&block(g, q, m), m) else { break };
        // d_b = Σ_(j in b) Σ₀_jj (G_jj − G_jP G_PP⁻¹ G_Pj), P the previous fit's columns.
        let d: f64 = (prev_m..m)
            .map(|j| {
                let row = &g[j * q..j * q + prev_m];
                let proj: f64 = (0..prev_m)
                    .map(|a| row[a] * (0..prev_m).map(|b| prev_inv[a * prev_m + b] * row[b]).sum::<f64>())
                    .sum();
                prior[j] * (g[j * q + j] - proj)
            })
            .sum();
        if !(d > 0.0) {
            break;
        }
        let fit = fitted(&inv, m);
        let delta = (0..nch).map(|c| fit.0[c] - prev_fit.0[c]).collect();
        let noise = (0..nch).map(|c| (fit.1 - prev_fit.1) * ne.share[c]).collect();
        steps.push((delta, noise, d));
        (prev_inv, prev_m, prev_fit) = (inv, m, fit);
    }
    let sizes = bands.iter().map(|&l| ne.order[p..].iter().filter(|&&k| k == l).count()).collect();
    Some(PredictedTruncation { u, bands, steps, sizes })
}

/// The truncation part of an error bar: the larger of the sequence's and the predicted estimate
/// (`None` when neither exists).
pub fn combine(sequence: Option<f64>, predicted: Option<f64>) -> Option<f64> {
    match (sequence, predicted) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_single_column_band_calibrates_its_coefficient_and_predicts_its_bias() {
        // Two columns x, x² on [0, 1] (unit weights, no noise): v = 1 + 0.5 x² fitted by the
        // constant alone. The band {x²} is calibrated exactly (ΔRSS = h² × its residual norm), so
        // the predicted bias of the constant equals the true one, |M| h.
        let n = 200;
        let xs: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64).collect();
        let rows: Vec<[f64; 2]> = xs.iter().map(|&x| [1.0, x * x]).collect();
        let v: Vec<f64> = xs.iter().map(|&x| 1.0 + 0.5 * x * x).collect();
        let mut g = vec![0.0; 4];
        let mut rhs = vec![0.0; 2];
        for (r, &y) in rows.iter().zip(&v) {
            for a in 0..2 {
                rhs[a] += r[a] * y;
                for b in 0..2 {
                    g[a * 2 + b] += r[a] * r[b];
                }
            }
        }
        let s = vec![0.0; 4];
        let rhs = vec![rhs];
        let ne = NormalEquations { g: &g, s: &s, rhs: &rhs, share: &[1.0], order: &[0, 1] };
        let pt = predicted_truncation(&ne, 1, n).unwrap();
        assert_eq!(pt.l_cal(), Some(1));
        let kappa = pt.kappa(0, 0.0);
        let fit0 = rhs[0][0] / g[0];
        let want = fit0 - 1.0;
        assert!((pt.bias(&kappa, 0) - want.abs()).abs() < 1e-9, "{} vs {want}", pt.bias(&kappa, 0));
        assert!((pt.bound(&kappa, 0) - want.abs()).abs() < 1e-9);
        assert_eq!(combine(Some(0.1), Some(0.2)), Some(0.2));
        assert_eq!(combine(None, Some(0.2)), Some(0.2));
        assert_eq!(combine(None, None), None);
    }
}
