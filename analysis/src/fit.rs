//! Linear analysis of rendered images in pixel space — the one implementation that `analyze`,
//! `invert` and `verify` share.
//!
//! - [`lsq`]: weighted linear least squares over pixels, with the sandwich covariance of the
//!   coefficients from per-pixel standard errors and the fit's χ²;
//! - [`fit_filter`]: the per-order filter A_l of B(d) = Σ_l A_l S_l(d), S_l(d) = Σ_m L_lm Y_lm(d)
//!   (eq. 15 written in pixel space) over any set of directions d — a `normal-probe` grid or the
//!   visible normals of orthographic views — for a known lighting;
//! - [`project_probe`], [`sh_design`]: the lat-long quadrature and the SH design of a `normal-probe`
//!   image (docs/src/conventions.md §2).
//!
//! Everything is linear in the pixel values, so independent per-pixel standard errors σ_p propagate
//! exactly: Var(Σ_p w_p B_p) = Σ_p w_p² σ_p². Fitting the filter in pixel space needs no quadrature
//! (so no quadrature error when the model is exact: band-limited lighting, radial BRDF) and, unlike
//! dividing fitted B_lm by L_lm, stays right when the directions cover only part of the sphere
//! (one view sees one hemisphere of normals, where the Y_lm are far from orthogonal).

use crate::sh::{ShBasis, index, latlong_direction, num_coefficients};
use crate::special::chi2_survival;
use std::f64::consts::PI;

/// Exact solid angle (sr) of a pixel of row `r` of a W × H lat-long grid (docs/src/conventions.md §2).
pub fn latlong_omega(r: usize, w: usize, h: usize) -> f64 {
    let t0 = PI * r as f64 / h as f64;
    let t1 = PI * (r as f64 + 1.0) / h as f64;
    2.0 * PI / w as f64 * (t0.cos() - t1.cos())
}

/// RMS over m of g(index(l, m)) at order l.
pub fn order_rms(l: usize, g: impl Fn(usize) -> f64) -> f64 {
    ((-(l as i64)..=(l as i64)).map(|m| g(index(l, m)).powi(2)).sum::<f64>() / (2 * l + 1) as f64).sqrt()
}

/// Order-l parts of a scalar SH lighting at `dir`: `out[l]` = S_l = Σ_m L_lm Y_lm(dir) for
/// l < `out.len()`; coefficients beyond `light.len()` count as 0. `y` is scratch of length
/// ≥ (basis.lmax + 1)².
pub fn order_parts(basis: &ShBasis, light: &[f64], dir: [f64; 3], y: &mut [f64], out: &mut [f64]) {
    basis.eval_into(dir, y);
    for (l, o) in out.iter_mut().enumerate() {
        let mut s = 0.0;
        for m in -(l as i64)..=(l as i64) {
            let k = index(l, m);
            if k < light.len() {
                s += light[k] * y[k];
            }
        }
        *o = s;
    }
}

/// Result of a weighted linear least-squares fit ([`lsq`]).
#[derive(Clone, Debug)]
pub struct Fit {
    /// Coefficients x_j, j < p.
    pub coef: Vec<f64>,
    /// Standard errors √cov_jj from the propagated per-pixel σ (sandwich covariance).
    pub sigma: Vec<f64>,
    /// The full sandwich covariance (p × p, row-major): non-uniform pixel noise correlates the
    /// coefficients even when the regressors are orthogonal.
    pub cov: Vec<f64>,
    /// Σ_p w_p (residual_p / σ_p)² / Σ_p w_p over pixels with σ_p > 0 (≈ 1 for a correct model
    /// with honest σ and unit weights); `None` when no pixel has σ > 0.
    pub reduced_chi2: Option<f64>,
    /// χ² = Σ_p (residual_p / σ_p)² over the used pixels with σ_p > 0 (unweighted).
    pub chi2: f64,
    /// Degrees of freedom of `chi2`: pixels with σ_p > 0 minus p (0 if that is negative).
    pub dof: usize,
    /// Number of pixels used (weight ≠ 0).
    pub pixels: usize,
}

impl Fit {
    /// χ²/ν, `None` without degrees of freedom.
    pub fn chi2_per_dof(&self) -> Option<f64> {
        (self.dof > 0).then(|| self.chi2 / self.dof as f64)
    }

    /// P(χ²_ν ≥ χ²): the probability of a misfit at least this large if the model and the σ_p are
    /// right; `None` without degrees of freedom.
    pub fn p_value(&self) -> Option<f64> {
        (self.dof > 0).then(|| chi2_survival(self.chi2, self.dof as f64))
    }
}

/// Weighted least squares: minimises Σ_p w_p (v_p − Σ_j A_pj x_j)² over the rows A_p (each of
/// length p); rows with w_p = 0 are skipped. Covariance (AᵀWA)⁻¹ Aᵀ W Σ W A (AᵀWA)⁻¹ with
/// Σ = diag(σ_p²) (exact for any weights, so the weights may be quadrature weights, e.g. solid
/// angles, rather than 1/σ², which would bias the fit when σ_p is itself a noisy Monte Carlo
/// estimate correlated with v_p). `None` when AᵀWA is singular (see [`invert`]) or there are no rows.
pub fn lsq(rows: &[Vec<f64>], value: &[f64], sigma: &[f64], weight: &[f64]) -> Option<Fit> {
    let p = rows.first()?.len();
    let mut g = vec![0.0; p * p];
    let mut s = vec![0.0; p * p];
    let mut rhs = vec![0.0; p];
    for (i, a) in rows.iter().enumerate() {
        let w = weight[i];
        if w == 0.0 {
            continue;
        }
        let ws2 = w * w * sigma[i] * sigma[i];
        for j in 0..p {
            rhs[j] += w * a[j] * value[i];
            for k in 0..p {
                g[j * p + k] += w * a[j] * a[k];
                s[j * p + k] += ws2 * a[j] * a[k];
            }
        }
    }
    let ginv = invert(&g, p)?;
    let coef: Vec<f64> = (0..p).map(|j| (0..p).map(|k| ginv[j * p + k] * rhs[k]).sum()).collect();
    // cov = Ginv S Ginv (two p³ products).
    let mut gs = vec![0.0; p * p];
    for j in 0..p {
        for a in 0..p {
            let g = ginv[j * p + a];
            if g != 0.0 {
                for b in 0..p {
                    gs[j * p + b] += g * s[a * p + b];
                }
            }
        }
    }
    let mut cov = vec![0.0; p * p];
    for j in 0..p {
        for b in 0..p {
            let g = gs[j * p + b];
            if g != 0.0 {
                for k in 0..p {
                    cov[j * p + k] += g * ginv[b * p + k];
                }
            }
        }
    }
    let sig: Vec<f64> = (0..p).map(|j| cov[j * p + j].max(0.0).sqrt()).collect();
    let (mut chi, mut wsum, mut chi2, mut n_sigma, mut pixels) = (0.0, 0.0, 0.0, 0usize, 0usize);
    for (i, a) in rows.iter().enumerate() {
        if weight[i] == 0.0 {
            continue;
        }
        pixels += 1;
        let r = value[i] - (0..p).map(|j| a[j] * coef[j]).sum::<f64>();
        if sigma[i] > 0.0 {
            let z2 = (r / sigma[i]).powi(2);
            chi += weight[i] * z2;
            wsum += weight[i];
            chi2 += z2;
            n_sigma += 1;
        }
    }
    Some(Fit {
        coef,
        sigma: sig,
        cov,
        reduced_chi2: (wsum > 0.0).then(|| chi / wsum),
        chi2,
        dof: n_sigma.saturating_sub(p),
        pixels,
    })
}

/// P(χ²_ν ≥ χ²) below which every consistency test of a fit (`separate`'s two sides, `invert
/// brdf`'s model against the measured filter) says the model does not describe the data: one false
/// alarm in a thousand fits of a right model.
pub const MISMATCH_P: f64 = 1e-3;

/// P(χ²_ν ≥ χ²) below which (and at or above [`MISMATCH_P`]) a consistency test is called
/// "marginal" rather than "consistent": weak evidence against the model, worth a look, not a verdict.
pub const MARGINAL_P: f64 = 0.05;

/// Robust χ²/ν ([`robust_chi2`], of the highest-order fit) above which a fit with per-pixel
/// standard errors says that its residual is signal the model does not carry (truncation above the
/// highest order fitted, a wrong model), not noise: the truncation part and the mismatch warning
/// report it (a near-noiseless mirror sphere gives χ²/ν ≈ 10⁶, robust 10⁵).
pub const NOISE_CHI2_MAX: f64 = 10.0;

/// Factor on the propagated noise standard errors given χ²/ν `x` of the highest-order fit: with
/// per-pixel σ (`have_sigma`) 1 — the noise part is the σ_p propagated, never scaled by √(χ²/ν);
/// without them (σ_p = 1) √x, the residual σ.
///
/// Why not scale with σ_p: a χ²/ν above 1 there is not noise the σ_p missed but (a) signal the fit
/// does not carry, which the truncation part of the bar and the mismatch warning carry, or (b) a few
/// pixels whose own σ missed a rare heavy sample, which the bound near flagged pixels applied when
/// a render is read (`reflect`'s `header::bound_near_flags`) carries. Scaling by it made Phong spheres
/// under Grace (χ²/ν ≈ 10⁴ at 16 spp, robust 2–7) cover 95 % at 1σ, bars 3–10× too wide
/// (tests/phong_coverage.rs, guide "Partial views").
pub fn noise_scale(have_sigma: bool, x: Option<f64>) -> f64 {
    match (have_sigma, x) {
        (false, Some(x)) => x.sqrt(),
        _ => 1.0,
    }
}

/// Robust χ²/ν: median over pixels with σ_p > 0 (and weight ≠ 0) of (residual_p / σ_p)², divided
/// by the median of χ²₁ (0.454936). ≈ 1 for a right model; unlike Σ z²/ν it is hardly moved by a
/// few pixels whose Monte Carlo σ_p underestimates a heavy-tailed error (a bright light source hit
/// by few samples), while a model mismatch (a rotated lighting, a wrong camera) shifts every
/// residual and raises it. `None` without such pixels.
pub fn robust_chi2(rows: &[Vec<f64>], value: &[f64], sigma: &[f64], weight: &[f64], coef: &[f64]) -> Option<f64> {
    let mut z2: Vec<f64> = rows
        .iter()
        .enumerate()
        .filter(|&(i, _)| weight[i] != 0.0 && sigma[i] > 0.0)
        .map(|(i, a)| {
            let r = value[i] - a.iter().zip(coef).map(|(x, c)| x * c).sum::<f64>();
            (r / sigma[i]).powi(2)
        })
        .collect();
    if z2.is_empty() {
        return None;
    }
    let mid = z2.len() / 2;
    let (_, m, _) = z2.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m / 0.454_936_423_119_572_8)
}

/// Misfit relative to the signal, √(Σ_p w_p (r_p² − σ_p²)₊ / Σ_p w_p v_p²) over rows with w_p ≠ 0,
/// r_p = v_p − Σ_j A_pj c_j (σ_p = 0 without `sigma`). 0 for a model that explains the pixels up to
/// their noise; about the relative size of a model error otherwise, independent of the sample count.
pub fn relative_misfit(rows: &[Vec<f64>], value: &[f64], sigma: Option<&[f64]>, weight: &[f64], coef: &[f64]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (i, a) in rows.iter().enumerate() {
        let w = weight[i];
        if w == 0.0 {
            continue;
        }
        let r = value[i] - a.iter().zip(coef).map(|(x, c)| x * c).sum::<f64>();
        let s = sigma.map_or(0.0, |s| s[i]);
        num += w * (r * r - s * s);
        den += w * value[i] * value[i];
    }
    if den > 0.0 { (num.max(0.0) / den).sqrt() } else { 0.0 }
}

/// Noise amplification of each column of a weighted design: √((C⁻¹)_ii), where C = D^-1/2 G D^-1/2 is the
/// unit-diagonal Gram matrix of `rows` (G = Σ_r w_r x_r x_rᵀ over the first `p` entries of each row, D its
/// diagonal). 1 for orthogonal columns; large where the sampled directions cannot tell a column from the others.
/// `None` when C is singular ([`invert`]).
pub fn design_amplification(rows: &[Vec<f64>], weight: &[f64], p: usize) -> Option<Vec<f64>> {
    let mut c = vec![0.0; p * p];
    for (r, w) in rows.iter().zip(weight) {
        for i in 0..p {
            for j in 0..p {
                c[i * p + j] += w * r[i] * r[j];
            }
        }
    }
    let d: Vec<f64> = (0..p).map(|i| c[i * p + i].sqrt()).collect();
    for i in 0..p {
        for j in 0..p {
            c[i * p + j] /= d[i] * d[j];
        }
    }
    let cinv = invert(&c, p)?;
    Some((0..p).map(|i| cinv[i * p + i].max(0.0).sqrt()).collect())
}

/// Inverse of a small p × p row-major matrix by LU with partial pivoting (nalgebra); `None` when a
/// pivot falls below 1e-13 × the largest diagonal entry (singular for practical purposes).
pub fn invert(a: &[f64], p: usize) -> Option<Vec<f64>> {
    let scale = (0..p).map(|i| a[i * p + i].abs()).fold(0.0, f64::max);
    let lu = nalgebra::DMatrix::from_row_slice(p, p, a).lu();
    let u = lu.u();
    if (0..p).any(|i| !(u[(i, i)].abs() > 1e-13 * scale.max(1e-300))) {
        return None;
    }
    // Column-major storage of the transpose is the row-major storage of the inverse.
    Some(lu.try_inverse()?.transpose().as_slice().to_vec())
}

/// SH projection of one channel of a W × H `normal-probe` image by lat-long quadrature with exact
/// pixel solid angles: (B_k, σ(B_k)) for k < (lmax+1)². `value` and `sigma` are row-major W × H.
pub fn project_probe(value: &[f64], sigma: &[f64], w: usize, h: usize, lmax: usize) -> (Vec<f64>, Vec<f64>) {
    let n = num_coefficients(lmax);
    let basis = ShBasis::new(lmax);
    let mut y = vec![0.0; n];
    let mut b = vec![0.0; n];
    let mut var = vec![0.0; n];
    for r in 0..h {
        let om = latlong_omega(r, w, h);
        for c in 0..w {
            let i = r * w + c;
            basis.eval_into(latlong_direction(r, c, w, h), &mut y);
            for k in 0..n {
                let wk = om * y[k];
                b[k] += wk * value[i];
                var[k] += wk * wk * sigma[i] * sigma[i];
            }
        }
    }
    (b, var.into_iter().map(f64::sqrt).collect())
}

/// The pixel-space design of an SH fit of a W × H normal-probe image: rows Y_k(n_p),
/// k < (lmax+1)², and the pixels' solid angles as weights (for [`lsq`]).
pub fn sh_design(w: usize, h: usize, lmax: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
    let basis = ShBasis::new(lmax);
    let mut rows = Vec::with_capacity(w * h);
    let mut weight = Vec::with_capacity(w * h);
    for r in 0..h {
        let om = latlong_omega(r, w, h);
        for c in 0..w {
            rows.push(basis.eval(latlong_direction(r, c, w, h)));
            weight.push(om);
        }
    }
    (rows, weight)
}

/// The filter design: one row (S_0(d), …, S_lmax(d)) per direction d, S_l the order-l part of the
/// scalar lighting `light` ([`order_parts`]).
pub fn filter_design(dirs: impl IntoIterator<Item = [f64; 3]>, light: &[f64], lmax_fit: usize) -> Vec<Vec<f64>> {
    let basis = ShBasis::new(lmax_fit);
    let mut y = vec![0.0; num_coefficients(lmax_fit)];
    dirs.into_iter()
        .map(|d| {
            let mut s = vec![0.0; lmax_fit + 1];
            order_parts(&basis, light, d, &mut y, &mut s);
            s
        })
        .collect()
}

/// Per-order filter A_l, l ≤ `lmax_fit`, of pixels with values `value` (standard errors `sigma`,
/// weights `weight`) at directions `dirs` under the known scalar lighting `light`: weighted least
/// squares of B(d_p) on S_l(d_p) ([`lsq`]). The model is eq. 15 in pixel space; it is exact when
/// the lighting is band-limited to `lmax_fit` and the BRDF radial about `d`. `None` when the
/// directions and the lighting do not determine every A_l (e.g. an order with no lighting energy).
pub fn fit_filter(
    dirs: impl IntoIterator<Item = [f64; 3]>,
    value: &[f64],
    sigma: &[f64],
    weight: &[f64],
    light: &[f64],
    lmax_fit: usize,
) -> Option<Fit> {
    lsq(&filter_design(dirs, light, lmax_fit), value, sigma, weight)
}

/// [`fit_filter`] over a W × H `normal-probe` grid with solid-angle weights, the order parts
/// evaluated at `dir(row, col)` (the pixel's normal, or e.g. its reflection vector at non-normal
/// exitance).
pub fn fit_filter_grid(
    value: &[f64],
    sigma: &[f64],
    w: usize,
    h: usize,
    light: &[f64],
    lmax_fit: usize,
    dir: impl Fn(usize, usize) -> [f64; 3],
) -> Option<Fit> {
    let dirs = (0..h).flat_map(|r| (0..w).map(move |c| (r, c))).map(|(r, c)| dir(r, c));
    let weight: Vec<f64> = (0..h).flat_map(|r| std::iter::repeat_n(latlong_omega(r, w, h), w)).collect();
    fit_filter(dirs, value, sigma, &weight, light, lmax_fit)
}

/// 9-term relative error statistics of a probe image.
#[derive(Clone, Copy, Debug)]
pub struct NineTerm {
    /// Solid-angle mean of e² = ((B − B₉)/B)², with the noise's contribution σ_p²/B² subtracted
    /// (E[(e + n)²] = e² + σ², so this is unbiased), and its standard error.
    pub mean_sq: f64,
    pub sigma_mean_sq: f64,
    /// Solid-angle mean of |e| and max |e| (biased upward by noise: informative).
    pub mean_abs: f64,
    pub max_abs: f64,
}

impl NineTerm {
    pub fn rms(&self) -> f64 {
        self.mean_sq.max(0.0).sqrt()
    }
    /// σ(rms) = σ(mean_sq) / (2 rms).
    pub fn sigma_rms(&self) -> f64 {
        self.sigma_mean_sq / (2.0 * self.rms().max(1e-12))
    }
}

/// The 9-term (l ≤ 2) approximation's relative error e = (B − B₉)/B over a W × H `normal-probe`
/// channel (`value`, `sigma` row-major), B₉ the solid-angle weighted least-squares fit on Y_lm,
/// l ≤ 2 ([`sh_design`], [`lsq`]) — the quantity of sec. 3.5 (eq. 38–39). `None` when a pixel is
/// ≤ 0 (e is undefined) or the fit is singular.
pub fn nine_term_error(value: &[f64], sigma: &[f64], w: usize, h: usize) -> Option<NineTerm> {
    let (rows, weight) = sh_design(w, h, 2);
    let fit = lsq(&rows, value, sigma, &weight)?;
    let (mut ms, mut var, mut tot, mut mabs, mut max) = (0.0, 0.0, 0.0, 0.0, 0.0f64);
    for i in 0..w * h {
        let b9: f64 = (0..9).map(|k| rows[i][k] * fit.coef[k]).sum();
        let b = value[i];
        if b <= 0.0 {
            return None;
        }
        let e = (b - b9) / b;
        // Relative noise of e (delta method: de/db = b9/b²).
        let s = b9.abs() / (b * b) * sigma[i];
        ms += weight[i] * (e * e - s * s);
        // Var((e+n)²) = 4e²s² + 2s⁴.
        var += weight[i] * weight[i] * (4.0 * e * e * s * s + 2.0 * s.powi(4));
        mabs += weight[i] * e.abs();
        tot += weight[i];
        max = max.max(e.abs());
    }
    Some(NineTerm { mean_sq: ms / tot, sigma_mean_sq: var.sqrt() / tot, mean_abs: mabs / tot, max_abs: max })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic W × H normal-probe channel: f(n) + N(0, σ²) noise (Box–Muller on a fixed LCG).
    fn synthetic_probe(w: usize, h: usize, f: impl Fn([f64; 3]) -> f64, sigma: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut u = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
        };
        let mut v = Vec::with_capacity(w * h);
        for r in 0..h {
            for c in 0..w {
                let (u1, u2) = (u().max(1e-300), u());
                let g = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                v.push(f(latlong_direction(r, c, w, h)) + sigma * g);
            }
        }
        (v, vec![sigma; w * h])
    }

    #[test]
    fn inverts_a_general_matrix_and_refuses_a_singular_one() {
        // Not symmetric, so a row/column-major mix-up fails; a zero leading entry needs pivoting.
        let a = [0.0, 1.0, 0.5, 2.0, 3.0, -0.2, 0.7, 0.1, 2.0];
        let inv = invert(&a, 3).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| a[i * 3 + k] * inv[k * 3 + j]).sum();
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
        assert!(invert(&[1.0, 2.0, 2.0, 4.0], 2).is_none());
    }

    #[test]
    fn filter_fit_recovers_a_known_filter_and_its_error_bar() {
        // B = Σ a_l S_l exactly plus noise σ: the fit returns a_l within 4.5σ(a_l), σ(a_l) matches
        // the spread over 40 seeds (ratio within 30 %: the sd of a 40-sample sd is ≈ 11 %), and
        // χ²/ν is within 4 sd (√(2/ν)) of 1.
        let lmax = 4;
        let light: Vec<f64> =
            (0..25).map(|k| if k == 0 { 3.0 } else { 0.3 * ((k * 7 % 11) as f64 / 11.0 - 0.5) }).collect();
        let a_true = [1.0, 0.6, 0.3, -0.1, 0.05];
        let basis = ShBasis::new(lmax);
        let f = |n: [f64; 3]| {
            let mut y = vec![0.0; 25];
            let mut s = vec![0.0; 5];
            order_parts(&basis, &light, n, &mut y, &mut s);
            (0..5).map(|l| a_true[l] * s[l]).sum::<f64>()
        };
        let (w, h) = (32, 16);
        let mut est = vec![];
        let mut sig = 0.0;
        for seed in 0..40 {
            let (v, s) = synthetic_probe(w, h, f, 0.05, seed);
            let fit = fit_filter_grid(&v, &s, w, h, &light, lmax, |r, c| latlong_direction(r, c, w, h)).unwrap();
            for (l, &a) in a_true.iter().enumerate() {
                assert!((fit.coef[l] - a).abs() < 4.5 * fit.sigma[l], "seed {seed} l {l}");
            }
            est.push(fit.coef[2]);
            sig = fit.sigma[2];
            assert_eq!(fit.dof, w * h - 5);
            let x = fit.chi2_per_dof().unwrap();
            assert!((x - 1.0).abs() < 4.0 * (2.0 / fit.dof as f64).sqrt(), "chi2/dof {x}");
            assert!(fit.p_value().unwrap() > 1e-5);
        }
        let mean = est.iter().sum::<f64>() / est.len() as f64;
        let sd = (est.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (est.len() - 1) as f64).sqrt();
        assert!((sd / sig - 1.0).abs() < 0.3, "spread {sd} vs propagated {sig}");
    }

    #[test]
    fn projection_of_a_constant() {
        // Exact solid angles make B_00 exact; the higher m = 0 terms carry the midpoint rule's
        // O((π/H)² l²) error in θ (≈ 4e-4 for l = 2, H = 128).
        let (v, s) = synthetic_probe(256, 128, |_| 2.0, 0.0, 1);
        let (b, se) = project_probe(&v, &s, 256, 128, 2);
        assert!((b[0] - 2.0 * (4.0 * PI).sqrt()).abs() < 1e-9);
        assert!(b[1..].iter().all(|v| v.abs() < 1e-3), "{b:?}");
        assert!(se.iter().all(|&v| v == 0.0));
    }
}
