//! Diffuse + specular separation (sec. 3.5, the algorithm of reference \[17\]): recover the lighting
//! at high angular resolution from a surface ρ̂ = k_d · lambert + k_s · mirror, by subtracting the
//! 9-term diffuse part (eq. 38–39: Λ_l ρ̂_l ≈ 0 beyond l = 2) and treating the rest as a gazing
//! sphere, with the consistency condition between the low orders of both sides.
//!
//! Inputs (one channel, sampled data with per-sample standard errors; no renderer involved):
//! - a *diffuse view* at normal exitance (R = n): samples B(n_q) = k_d D(n_q) + k_s L(n_q), with
//!   D(n) = Σ_lm Λ_l ρ̂_l L_lm Y_lm(n) (unit albedo) and quadrature weights w_q (solid angles). Its
//!   projection gives B_lm = (k_d Λ_l ρ̂_l + k_s) L_lm for every l, so the 9 low-order lighting
//!   coefficients are L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2 (eq. 15 for the mixture);
//! - *specular views* at other exitance: samples B(n_p) = k_d D(n_p) + k_s L(R_p) with the
//!   reflection vector R_p = 2(n_p·ω_o)n_p − ω_o ≠ n_p and weights w_p (solid angles in R).
//!
//! Algorithm: s_p = (B_p − k_d Σ_{l≤2} Λ_l ρ̂_l L̂_lm Y_lm(n_p)) / k_s is the lighting at R_p up to
//! the 9-term residual r(n_p) = (k_d/k_s) Σ_{l≥3} Λ_l ρ̂_l L_lm Y_lm(n_p) ([`nine_term_residual`];
//! |Λ_4 ρ̂_4| = 1/24 of order 0, eq. 39). The recovered lighting is the weighted least-squares fit
//! c = argmin Σ_p w_p (s_p − Σ_k c_k Y_k(R_p))², k < (lmax+1)². The consistency condition of \[17\]
//! is d_j = L̂_j − c_j ≈ 0 for the 9 coefficients j of l ≤ 2.
//!
//! Why two views: on one view at normal exitance d ≡ 0 whatever the split (the subtraction and the
//! projection are both at n), so the condition would be vacuous. With R ≠ n the subtracted diffuse
//! part, a function of n, is sampled at other directions than the lighting, and a wrong
//! k_d : k_s leaves a mis-registered diffuse remainder in c that does not match L̂: the condition
//! then measures the split ([`Separation::scan_split`]).
//!
//! Error propagation: everything is linear in the samples of both views, which are independent,
//! so with M = (AᵀWA)⁻¹AᵀW (A_pk = Y_k(R_p)), H = M Y_9(n) and T = I + (k_d/k_s) H_9 F:
//! d = T L̂ − (M B)_9 / k_s, Cov(d) = T Σ_L̂ Tᵀ + Cov(M B)_9 / k_s², Cov(M B) = G⁻¹ S G⁻¹ with
//! G = AᵀWA, S = Σ_p w_p² σ_p² a_p a_pᵀ, and Σ_L̂ the quadrature's exact covariance. The consistency
//! χ² = dᵀ Cov(d)⁻¹ d follows χ²_9 for a correct split when the bias (9-term residual, grid
//! aliasing) is below the noise.
//!
//! Sampling: [`probe_samples`] turns a `normal-probe` image (docs/src/conventions.md §6) at θ_o and φ_o ∈ {0°,
//! 180°} into [`Samples`] with exact R-space pixel solid angles; the views at φ_o = 0° and 180°
//! each miss a polar cap of R of radius θ_o, and together ([`Samples::append`]) cover the sphere.
//!
//! Parameters: `lmax` (order of the recovered lighting), `k_d`, `k_s` (> 0; unit-albedo lambert
//! and unit-k_r mirror weights, docs/src/conventions.md §4).

use crate::error::{Error, Result};
use crate::lsq::Cholesky;
use crate::sh::{ShBasis, latlong_direction, lm, num_coefficients};
use crate::transfer::lambert::lambert;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Number of low-order coefficients (l ≤ 2) of the 9-term approximation.
pub const LOW: usize = 9;

/// Samples of one view of a sphere (one channel).
#[derive(Clone, Debug, Default)]
pub struct Samples {
    pub value: Vec<f64>,
    /// Standard error of each value (0 for exact data).
    pub sigma: Vec<f64>,
    /// Surface normal n of the sample (unit).
    pub normal: Vec<[f64; 3]>,
    /// Reflection vector R = 2(n·ω_o)n − ω_o (unit); equal to n at normal exitance.
    pub reflected: Vec<[f64; 3]>,
    /// Quadrature weight: solid angle of the sample (about n for the diffuse view, about R for a
    /// specular view).
    pub weight: Vec<f64>,
}

impl Samples {
    pub fn len(&self) -> usize {
        self.value.len()
    }
    pub fn is_empty(&self) -> bool {
        self.value.is_empty()
    }
    fn validate(&self, what: &str) -> Result<()> {
        let n = self.value.len();
        if n == 0 {
            return Err(Error::new(format!("{what}: no samples")));
        }
        if self.sigma.len() != n || self.normal.len() != n || self.reflected.len() != n || self.weight.len() != n {
            return Err(Error::new(format!(
                "{what}: value, sigma, normal, reflected and weight must have the same length"
            )));
        }
        if self.value.iter().chain(&self.sigma).chain(&self.weight).any(|v| !v.is_finite())
            || self.sigma.iter().chain(&self.weight).any(|&v| v < 0.0)
        {
            return Err(Error::new(format!("{what}: values must be finite, standard errors and weights non-negative")));
        }
        Ok(())
    }
}

impl Samples {
    /// Appends the samples of another view (e.g. the specular views at φ_o = 0° and 180°, which
    /// together cover the sphere of reflection directions).
    pub fn append(&mut self, other: Samples) {
        self.value.extend(other.value);
        self.sigma.extend(other.sigma);
        self.normal.extend(other.normal);
        self.reflected.extend(other.reflected);
        self.weight.extend(other.weight);
    }
}

/// How well the lighting's spherical harmonics up to `lmax` at each sample's reflection vector R
/// describe a set of samples ([`fit_residuals`]): the weighted least-squares fit of the separation
/// (weights w_p, solid angles about R), its residuals r_p = B_p − Σ_k c_k Y_k(R_p) over the samples
/// with w_p > 0, their χ² against the samples' σ_p and their sum of squares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResidualFit {
    /// χ² = Σ_p (r_p / σ_p)² over the samples with w_p > 0 and σ_p > 0.
    pub chi2: f64,
    /// Σ_p r_p² over the samples with w_p > 0.
    pub rss: f64,
    /// Samples with w_p > 0.
    pub samples: usize,
    /// ν = samples − columns ((lmax + 1)², plus 8 with the normal terms; 0 if that is negative).
    pub dof: usize,
}

impl ResidualFit {
    /// σ̂² = Σ_p r_p² / ν: the residual variance, the noise estimate of samples without standard
    /// errors (homoscedastic; it holds the lighting's power above `lmax` as well, so it is an upper
    /// estimate of the noise). `None` without degrees of freedom.
    pub fn residual_variance(&self) -> Option<f64> {
        (self.dof > 0).then(|| self.rss / self.dof as f64)
    }

    /// χ²/ν; `None` without degrees of freedom.
    pub fn chi2_per_dof(&self) -> Option<f64> {
        (self.dof > 0).then(|| self.chi2 / self.dof as f64)
    }

    /// P(χ²_ν ≥ χ²); `None` without degrees of freedom.
    pub fn p_value(&self) -> Option<f64> {
        (self.dof > 0).then(|| crate::special::chi2_survival(self.chi2, self.dof as f64))
    }
}

/// The least-squares fit of `samples` by the spherical harmonics up to `lmax` at their reflection
/// vectors R (at the normals for a view at normal exitance), weighted by their solid angles as in
/// [`Separation::new`], and its residuals ([`ResidualFit`]). With `normal_terms` the harmonics
/// 1 ≤ l ≤ 2 at the normals n are fitted as well (l = 0 is the constant already fitted at R): on the specular views they take up the diffuse part
/// k_d Σ Λ_l ρ̂_l L_lm Y_lm(n) whatever the split, so the residuals are noise (plus what lies beyond
/// both models) for any k_d : k_s, and a wrong split cannot inflate the noise estimate. On a set of
/// views covering the sphere of R (the diffuse view; the specular views at φ_o = 0° and 180°
/// together) the orders above `lmax` are orthogonal to the fitted ones up to the grid's aliasing:
/// they add to the residuals, not a bias to the coefficients. Errors: a set whose directions do not
/// determine the columns.
pub fn fit_residuals(samples: &Samples, lmax: usize, normal_terms: bool) -> Result<ResidualFit> {
    samples.validate("residual fit")?;
    let nr = num_coefficients(lmax);
    // Y_00(n) is the constant Y_00(R): the normal terms are the 8 harmonics 1 ≤ l ≤ 2.
    let nfit = nr + if normal_terms { LOW - 1 } else { 0 };
    let (basis, basis9) = (ShBasis::new(lmax), ShBasis::new(2));
    // The design row of sample p: Y_k(R_p), k < nr, then Y_j(n_p), j < 9, with the normal terms.
    let row = |p: usize, a: &mut [f64]| {
        basis.eval_into(samples.reflected[p], &mut a[..nr]);
        if normal_terms {
            let mut y9 = [0.0; LOW];
            basis9.eval_into(samples.normal[p], &mut y9);
            a[nr..].copy_from_slice(&y9[1..]);
        }
    };
    let chunk = 512;
    let starts: Vec<usize> = (0..samples.len()).step_by(chunk).collect();
    // G = Σ w a aᵀ (lower triangle) and Σ w a B, rayon partial sums in a fixed order.
    let partial: Vec<Vec<f64>> = starts
        .par_iter()
        .map(|&start| {
            let mut acc = vec![0.0; nfit * nfit + nfit];
            let mut a = vec![0.0; nfit];
            for p in start..(start + chunk).min(samples.len()) {
                let w = samples.weight[p];
                if w == 0.0 {
                    continue;
                }
                row(p, &mut a);
                let (g, rhs) = acc.split_at_mut(nfit * nfit);
                for i in 0..nfit {
                    let wa = w * a[i];
                    for j in 0..=i {
                        g[i * nfit + j] += wa * a[j];
                    }
                    rhs[i] += wa * samples.value[p];
                }
            }
            acc
        })
        .collect();
    let mut acc = vec![0.0; nfit * nfit + nfit];
    for part in &partial {
        acc.iter_mut().zip(part).for_each(|(a, b)| *a += b);
    }
    let (g, rhs) = acc.split_at(nfit * nfit);
    let mut g = g.to_vec();
    for i in 0..nfit {
        for j in 0..i {
            g[j * nfit + i] = g[i * nfit + j];
        }
    }
    let chol = Cholesky::new(&g, nfit, 1e-12).map_err(|e| {
        Error::new(format!(
            "the directions do not determine the residual fit's lighting up to l = {lmax}: {}",
            e.message
        ))
    })?;
    let mut c = rhs.to_vec();
    chol.solve(&mut c);
    let (mut chi2, mut rss, mut n) = (0.0, 0.0, 0usize);
    let mut a = vec![0.0; nfit];
    for p in 0..samples.len() {
        if samples.weight[p] == 0.0 {
            continue;
        }
        row(p, &mut a);
        let r = samples.value[p] - a.iter().zip(&c).map(|(x, y)| x * y).sum::<f64>();
        n += 1;
        rss += r * r;
        if samples.sigma[p] > 0.0 {
            chi2 += (r / samples.sigma[p]).powi(2);
        }
    }
    Ok(ResidualFit { chi2, rss, samples: n, dof: n.saturating_sub(nfit) })
}

/// ∫_0^x |sin t| dt for x ∈ [−π, 2π]: the R-space solid angle per unit azimuth of a band of polar
/// angle x (crossing a pole folds the band onto the opposite azimuth, |sin| takes care of it).
pub fn abs_sin_integral(x: f64) -> f64 {
    let k = (x / PI).floor();
    2.0 * k + 1.0 - (x - k * PI).cos()
}

/// Samples of a W × H `normal-probe` image (docs/src/conventions.md §6, row-major values and standard errors)
/// at exitance θ_o (radians) and azimuth φ_o ∈ {0, π} (`flip` = φ_o = π): normals (the lat-long
/// pixel centres), reflection vectors and the pixels' solid angles about R (about n at θ_o = 0).
/// At φ_o ∈ {0, π} ω_o lies in the meridian plane of n, so R = cos θ_o n − sin θ_o (±t) stays on
/// the pixel's meridian at polar angle θ ∓ θ_o: a pixel row maps onto a band of R whose solid
/// angle is exact ([`abs_sin_integral`]). Other azimuths move R off the meridian and have no such
/// closed form, hence the restriction.
pub fn probe_samples(value: &[f64], sigma: &[f64], w: usize, h: usize, theta_o: f64, flip: bool) -> Samples {
    let sign = if flip { -1.0 } else { 1.0 };
    let mut s = Samples::default();
    for r in 0..h {
        let (t0, t1) = (PI * r as f64 / h as f64, PI * (r + 1) as f64 / h as f64);
        let om = if theta_o == 0.0 {
            2.0 * PI / w as f64 * (t0.cos() - t1.cos())
        } else {
            2.0 * PI / w as f64 * (abs_sin_integral(t1 - sign * theta_o) - abs_sin_integral(t0 - sign * theta_o)).abs()
        };
        let theta = PI * (r as f64 + 0.5) / h as f64;
        for c in 0..w {
            let n = latlong_direction(r, c, w, h);
            let phi = 2.0 * PI * (c as f64 + 0.5) / w as f64;
            let t = [theta.cos() * phi.cos(), theta.cos() * phi.sin(), -theta.sin()];
            let wo = [0, 1, 2].map(|i| theta_o.cos() * n[i] + sign * theta_o.sin() * t[i]);
            let i = r * w + c;
            s.value.push(value[i]);
            s.sigma.push(sigma[i]);
            s.normal.push(n);
            s.reflected.push(if theta_o == 0.0 { n } else { reflect(n, wo) });
            s.weight.push(om);
        }
    }
    s
}

/// The reflection vector R = 2(n·ω_o)n − ω_o (docs/src/conventions.md §1).
#[inline]
pub fn reflect(n: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
    let d = 2.0 * (n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2]);
    [d * n[0] - wo[0], d * n[1] - wo[1], d * n[2] - wo[2]]
}

/// What subtracting only the 9-term diffuse part leaves in a specular sample at normal n:
/// (k_d/k_s) Σ_{3 ≤ l ≤ L} Λ_l ρ̂_l L_lm Y_lm(n) (unit albedo, eq. 38), for a lighting `light` of
/// order L. `y` is scratch of (L+1)² entries.
pub fn nine_term_residual(light: &[f64], kd: f64, ks: f64, basis: &ShBasis, n: [f64; 3], y: &mut [f64]) -> f64 {
    let lmax = basis.lmax();
    let f = lambert(lmax);
    basis.eval_into(n, y);
    let s: f64 = (LOW..light.len().min(num_coefficients(lmax))).map(|k| f[lm(k).0] * light[k] * y[k]).sum();
    kd / ks * s
}

/// The split-independent part of the separation: the diffuse view's quadrature and the specular
/// views' least-squares operator applied to the data, with their covariances. Build once, then
/// [`Separation::solve`] for any k_d, k_s (e.g. a scan of the split) costs O(lmax⁴).
#[derive(Clone, Debug)]
pub struct Separation {
    pub lmax: usize,
    /// Λ_l ρ̂_l of unit-albedo Lambert, l ≤ 2.
    f: [f64; 3],
    /// Raw quadrature B_j = Σ_q w_q Y_j(n_q) B_q of the diffuse view, j < 9.
    b_low: [f64; LOW],
    /// Its covariance Σ_q w_q² σ_q² Y_i Y_j (9 × 9).
    b_low_cov: [f64; LOW * LOW],
    /// M B of the specular samples (nfit).
    mb: Vec<f64>,
    /// Cov(M B) (nfit × nfit).
    mb_cov: Vec<f64>,
    /// H = M Y_9(n): the fit of the 9 low-order SH evaluated at the normals (nfit × 9).
    h: Vec<f64>,
    /// Number of specular samples used.
    pub n_specular: usize,
}

/// Result of one split.
#[derive(Clone, Debug)]
pub struct Separated {
    pub kd: f64,
    pub ks: f64,
    /// Diffuse side: L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2, and standard errors.
    pub diffuse: Vec<f64>,
    pub diffuse_se: Vec<f64>,
    /// Specular side: the recovered lighting c_k, k < (lmax+1)², and standard errors.
    pub specular: Vec<f64>,
    pub specular_se: Vec<f64>,
    /// Consistency d_j = L̂_j − c_j, j < 9, its standard errors and its χ² = dᵀ Cov(d)⁻¹ d
    /// (None when the covariance is singular, e.g. noise-free data).
    pub consistency: Vec<f64>,
    pub consistency_se: Vec<f64>,
    pub chi2: Option<f64>,
    /// Cov(d) (9 × 9, row-major).
    pub consistency_cov: Vec<f64>,
}

impl Separated {
    /// χ² = xᵀ Cov(d)⁻¹ x of a 9-vector x against the consistency covariance (e.g. d minus a
    /// predicted bias); None when the covariance is singular.
    pub fn chi2_of(&self, x: &[f64]) -> Option<f64> {
        if x.len() != LOW {
            return None;
        }
        Cholesky::new(&self.consistency_cov, LOW, 1e-12).ok().map(|c| {
            let mut y = x.to_vec();
            c.solve(&mut y);
            y.iter().zip(x).map(|(a, b)| a * b).sum::<f64>()
        })
    }
}

impl Separation {
    /// Builds the operators. `diffuse` must be at normal exitance (R = n); `specular` samples must
    /// cover the sphere of directions R well enough to determine the SH up to `lmax`.
    pub fn new(diffuse: &Samples, specular: &Samples, lmax: usize) -> Result<Separation> {
        diffuse.validate("diffuse view")?;
        specular.validate("specular view")?;
        let off = diffuse
            .normal
            .iter()
            .zip(&diffuse.reflected)
            .map(|(n, r)| (n[0] - r[0]).abs() + (n[1] - r[1]).abs() + (n[2] - r[2]).abs())
            .fold(0.0, f64::max);
        if off > 1e-6 {
            return Err(Error::new(
                "diffuse view: it must be at normal exitance (R = n); use an oblique view only as a specular view",
            ));
        }
        let fl = lambert(2);
        let basis9 = ShBasis::new(2);
        // Diffuse view: quadrature of the 9 low orders and its exact covariance.
        let mut b_low = [0.0; LOW];
        let mut b_low_cov = [0.0; LOW * LOW];
        let mut y9 = [0.0; LOW];
        for q in 0..diffuse.len() {
            basis9.eval_into(diffuse.normal[q], &mut y9);
            let (w, s2) = (diffuse.weight[q], diffuse.sigma[q] * diffuse.sigma[q]);
            for i in 0..LOW {
                b_low[i] += w * y9[i] * diffuse.value[q];
                for j in 0..LOW {
                    b_low_cov[i * LOW + j] += w * w * s2 * y9[i] * y9[j];
                }
            }
        }
        // Specular views: normal equations G = Σ w a aᵀ, S = Σ w² σ² a aᵀ, right-hand sides
        // Σ w a B and Σ w a Y_9(n) (lower triangles; rayon partial sums, deterministic order).
        let nfit = num_coefficients(lmax);
        let basis = ShBasis::new(lmax);
        let width = 2 * nfit * nfit + nfit * (1 + LOW);
        let chunk = 512;
        let idx: Vec<usize> = (0..specular.len()).step_by(chunk).collect();
        let partial: Vec<Vec<f64>> = idx
            .par_iter()
            .map(|&start| {
                let mut acc = vec![0.0; width];
                let mut a = vec![0.0; nfit];
                let mut y9 = [0.0; LOW];
                for p in start..(start + chunk).min(specular.len()) {
                    let w = specular.weight[p];
                    if w == 0.0 {
                        continue;
                    }
                    basis.eval_into(specular.reflected[p], &mut a);
                    basis9.eval_into(specular.normal[p], &mut y9);
                    let ws2 = w * w * specular.sigma[p] * specular.sigma[p];
                    let (g, rest) = acc.split_at_mut(nfit * nfit);
                    let (s, rest) = rest.split_at_mut(nfit * nfit);
                    for i in 0..nfit {
                        let (wa, sa) = (w * a[i], ws2 * a[i]);
                        let (gi, si) = (&mut g[i * nfit..i * nfit + i + 1], &mut s[i * nfit..i * nfit + i + 1]);
                        for j in 0..=i {
                            gi[j] += wa * a[j];
                            si[j] += sa * a[j];
                        }
                        rest[i * (1 + LOW)] += wa * specular.value[p];
                        for j in 0..LOW {
                            rest[i * (1 + LOW) + 1 + j] += wa * y9[j];
                        }
                    }
                }
                acc
            })
            .collect();
        let mut acc = vec![0.0; width];
        for part in &partial {
            for (a, b) in acc.iter_mut().zip(part) {
                *a += b;
            }
        }
        let (g, rest) = acc.split_at(nfit * nfit);
        let (s, rhs) = rest.split_at(nfit * nfit);
        let mut g = g.to_vec();
        let mut s = s.to_vec();
        for i in 0..nfit {
            for j in 0..i {
                g[j * nfit + i] = g[i * nfit + j];
                s[j * nfit + i] = s[i * nfit + j];
            }
        }
        let chol = Cholesky::new(&g, nfit, 1e-12).map_err(|e| {
            Error::new(format!(
                "specular view: the reflection directions do not determine the lighting up to l = {lmax} (uncovered directions?): {}",
                e.message
            ))
        })?;
        let mut mb: Vec<f64> = (0..nfit).map(|i| rhs[i * (1 + LOW)]).collect();
        chol.solve(&mut mb);
        let mut h = vec![0.0; nfit * LOW];
        for j in 0..LOW {
            let mut col: Vec<f64> = (0..nfit).map(|i| rhs[i * (1 + LOW) + 1 + j]).collect();
            chol.solve(&mut col);
            for i in 0..nfit {
                h[i * LOW + j] = col[i];
            }
        }
        // Cov(M B) = G⁻¹ S G⁻¹.
        let ginv = chol.inverse();
        let gs = matmul(&ginv, &s, nfit);
        let mb_cov = matmul(&gs, &ginv, nfit);
        Ok(Separation { lmax, f: [fl[0], fl[1], fl[2]], b_low, b_low_cov, mb, mb_cov, h, n_specular: specular.len() })
    }

    /// Separates with the split (k_d, k_s): diffuse-side L̂ (l ≤ 2), specular-side lighting to
    /// `lmax`, and the consistency between their low orders.
    pub fn solve(&self, kd: f64, ks: f64) -> Result<Separated> {
        if !(ks > 0.0) || !(kd >= 0.0) || !kd.is_finite() || !ks.is_finite() {
            return Err(Error::new(format!("separation needs k_d ≥ 0 and k_s > 0, got k_d = {kd}, k_s = {ks}")));
        }
        let nfit = num_coefficients(self.lmax);
        // Scale of L̂_j and F L̂ (F = Λ_l ρ̂_l on the 9 low orders).
        let den: Vec<f64> = (0..LOW).map(|j| kd * self.f[lm(j).0] + ks).collect();
        let diffuse: Vec<f64> = (0..LOW).map(|j| self.b_low[j] / den[j]).collect();
        let cov_l: Vec<f64> = (0..LOW * LOW).map(|ij| self.b_low_cov[ij] / (den[ij / LOW] * den[ij % LOW])).collect();
        let fj: Vec<f64> = (0..LOW).map(|j| self.f[lm(j).0]).collect();
        // c = (M B − k_d H F L̂) / k_s.
        let specular: Vec<f64> = (0..nfit)
            .map(|i| (self.mb[i] - kd * (0..LOW).map(|j| self.h[i * LOW + j] * fj[j] * diffuse[j]).sum::<f64>()) / ks)
            .collect();
        // K = ∂c/∂L̂ = −(k_d/k_s) H F (nfit × 9); Var(c_i) = Cov(MB)_ii/k_s² + (K Σ_L Kᵀ)_ii.
        let kmat: Vec<f64> = (0..nfit * LOW).map(|ij| -kd / ks * self.h[ij] * fj[ij % LOW]).collect();
        let specular_se: Vec<f64> = (0..nfit)
            .map(|i| {
                let kr = &kmat[i * LOW..(i + 1) * LOW];
                let q: f64 = (0..LOW).map(|a| (0..LOW).map(|b| kr[a] * cov_l[a * LOW + b] * kr[b]).sum::<f64>()).sum();
                (self.mb_cov[i * nfit + i] / (ks * ks) + q).max(0.0).sqrt()
            })
            .collect();
        // d = L̂ − c_9 = T L̂ − (M B)_9 / k_s, T = I − K_9.
        let consistency: Vec<f64> = (0..LOW).map(|j| diffuse[j] - specular[j]).collect();
        let t: Vec<f64> = (0..LOW * LOW).map(|ij| if ij / LOW == ij % LOW { 1.0 } else { 0.0 } - kmat[ij]).collect();
        let tst = {
            let ts = matmul_rect(&t, &cov_l, LOW, LOW, LOW);
            let mut out = vec![0.0; LOW * LOW];
            for i in 0..LOW {
                for j in 0..LOW {
                    out[i * LOW + j] = (0..LOW).map(|k| ts[i * LOW + k] * t[j * LOW + k]).sum();
                }
            }
            out
        };
        let cov_d: Vec<f64> =
            (0..LOW * LOW).map(|ij| tst[ij] + self.mb_cov[(ij / LOW) * nfit + ij % LOW] / (ks * ks)).collect();
        let consistency_se: Vec<f64> = (0..LOW).map(|j| cov_d[j * LOW + j].max(0.0).sqrt()).collect();
        let diffuse_se = (0..LOW).map(|j| cov_l[j * LOW + j].max(0.0).sqrt()).collect();
        let mut out = Separated {
            kd,
            ks,
            diffuse,
            diffuse_se,
            specular,
            specular_se,
            consistency,
            consistency_se,
            chi2: None,
            consistency_cov: cov_d,
        };
        out.chi2 = out.chi2_of(&out.consistency);
        Ok(out)
    }

    /// Scales the noise of the diffuse view by `diffuse_var` and of the specular views by
    /// `specular_var` (variances): for samples built with σ = 1 whose noise is then estimated from
    /// the residuals ([`ResidualFit::residual_variance`]), every covariance of [`Separation::solve`]
    /// is that of samples with σ̂. The fit itself does not depend on σ (solid-angle weights).
    pub fn scale_noise(&mut self, diffuse_var: f64, specular_var: f64) {
        self.b_low_cov.iter_mut().for_each(|c| *c *= diffuse_var);
        self.mb_cov.iter_mut().for_each(|c| *c *= specular_var);
    }

    /// The consistency χ² as a function of the diffuse fraction x = k_d / (k_d + k_s) at fixed
    /// k_d + k_s = `total`: [(x, χ²)] (fractions giving k_s ≤ 0 or a singular covariance are skipped).
    /// In \[17\] the condition is what fixes the split: χ² is minimal near the true fraction.
    pub fn scan_split(&self, total: f64, fractions: &[f64]) -> Vec<(f64, f64)> {
        fractions
            .iter()
            .filter_map(|&x| self.solve(x * total, (1.0 - x) * total).ok().and_then(|s| s.chi2.map(|c| (x, c))))
            .collect()
    }
}

/// The fraction of a scan with the smallest χ² (None for an empty scan).
pub fn best_split(scan: &[(f64, f64)]) -> Option<(f64, f64)> {
    scan.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1))
}

fn matmul(a: &[f64], b: &[f64], n: usize) -> Vec<f64> {
    matmul_rect(a, b, n, n, n)
}

/// (r × k) · (k × c), row-major.
fn matmul_rect(a: &[f64], b: &[f64], r: usize, k: usize, c: usize) -> Vec<f64> {
    let mut out = vec![0.0; r * c];
    for i in 0..r {
        for t in 0..k {
            let av = a[i * k + t];
            if av != 0.0 {
                for j in 0..c {
                    out[i * c + j] += av * b[t * c + j];
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::gauss_legendre;
    use crate::sh::index;

    /// Gauss–Legendre (in cos θ) × uniform (in φ) directions: exact quadrature of every SH product
    /// of total order < 2·nt (the diffuse view's projection is then exact for band-limited data).
    fn gl_grid(nt: usize, np: usize) -> Vec<([f64; 3], f64, f64, f64)> {
        let (x, w) = gauss_legendre(nt);
        let mut out = vec![];
        for i in 0..nt {
            let theta = x[i].acos();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let n = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
                out.push((n, w[i] * 2.0 * PI / np as f64, theta, phi));
            }
        }
        out
    }

    fn eval(light: &[f64], basis: &ShBasis, d: [f64; 3], filter: Option<&[f64]>) -> f64 {
        let y = basis.eval(d);
        (0..light.len()).map(|k| light[k] * y[k] * filter.map_or(1.0, |f| f[lm(k).0])).sum()
    }

    /// Normal-probe views of k_d·lambert + k_s·mirror under a band-limited lighting: the diffuse view
    /// (normal exitance) and two specular views at θ_o, φ_o ∈ {0°, 180°} (R = n turned by ∓θ_o along
    /// its meridian; together they cover the sphere). Gaussian noise σ with a seeded generator.
    fn views(light: &[f64], kd: f64, ks: f64, theta_o: f64, sigma: f64, seed: u64) -> (Samples, Samples) {
        let lmax = crate::sh::lmax_of(light.len()).unwrap();
        let basis = ShBasis::new(lmax);
        let f = lambert(lmax);
        // The start of the SplitMix64 stream is the seed hashed, so streams of consecutive seeds do
        // not overlap (a plain seed × γ start would make seed k+1 the stream of seed k shifted by one).
        let mut state = {
            let mut z = seed ^ 0x5EED_5EED_5EED_5EED;
            z = (z ^ (z >> 33)).wrapping_mul(0xFF51_AFD7_ED55_8CCD);
            z = (z ^ (z >> 33)).wrapping_mul(0xC4CE_B9FE_1A85_EC53);
            z ^ (z >> 33)
        };
        let mut gauss = move || {
            // SplitMix64 + Box–Muller.
            let mut next = || {
                state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
            };
            let (u1, u2) = (next().max(1e-300), next());
            (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
        };
        let grid = gl_grid(lmax + 4, 2 * lmax + 8);
        let mut dif = Samples::default();
        for &(n, w, _, _) in &grid {
            dif.value.push(kd * eval(light, &basis, n, Some(&f)) + ks * eval(light, &basis, n, None) + sigma * gauss());
            dif.sigma.push(sigma);
            dif.normal.push(n);
            dif.reflected.push(n);
            dif.weight.push(w);
        }
        let mut spec = Samples::default();
        for sign in [1.0, -1.0] {
            for &(n, w, theta, phi) in &grid {
                let t = [theta.cos() * phi.cos(), theta.cos() * phi.sin(), -theta.sin()];
                let wo: Vec<f64> = (0..3).map(|i| theta_o.cos() * n[i] + sign * theta_o.sin() * t[i]).collect();
                let r = reflect(n, [wo[0], wo[1], wo[2]]);
                spec.value
                    .push(kd * eval(light, &basis, n, Some(&f)) + ks * eval(light, &basis, r, None) + sigma * gauss());
                spec.sigma.push(sigma);
                spec.normal.push(n);
                spec.reflected.push(r);
                spec.weight.push(w);
            }
        }
        (dif, spec)
    }

    /// The residual fits estimate the noise: lighting of orders ≤ 3 (no truncation at lmax 4, and
    /// Lambert's Λ_3 ρ̂_3 = 0, so the diffuse part is exactly its 9 terms) with Gaussian noise
    /// σ = 0.002 gives σ̂² / σ² = 1 within 4 standard errors (√(2/ν)), with χ²/ν against the true σ
    /// the same number. On the specular views the normal terms take up the diffuse part whatever the
    /// split; the planted error (the fit without them, the diffuse part as a function of R left
    /// unmodelled) is far above the noise.
    #[test]
    fn residual_fits_estimate_the_noise() {
        let light = light_with(4, &[1, 2, 3]);
        let (kd, ks, sigma) = (0.5, 0.5, 0.002);
        let (dif, spec) = views(&light, kd, ks, 50f64.to_radians(), sigma, 3);
        let d = fit_residuals(&dif, 4, false).unwrap();
        let sp = fit_residuals(&spec, 4, true).unwrap();
        for (what, f) in [("diffuse", d), ("specular", sp)] {
            let ratio = f.residual_variance().unwrap() / (sigma * sigma);
            let se = (2.0 / f.dof as f64).sqrt();
            eprintln!("{what}: σ̂²/σ² = {ratio:.3} (se {se:.3}, ν {})", f.dof);
            assert!((ratio - 1.0).abs() < 4.0 * se, "{what}: σ̂²/σ² = {ratio} (se {se})");
            assert!((f.chi2_per_dof().unwrap() - ratio).abs() < 1e-9, "{what}");
            assert!(f.p_value().unwrap() > 1e-4, "{what}: p {:?}", f.p_value());
        }
        let blind = fit_residuals(&spec, 4, false).unwrap();
        eprintln!("specular without the normal terms: χ²/ν {:?}", blind.chi2_per_dof());
        assert!(blind.chi2_per_dof().unwrap() > 2.0, "χ²/ν {:?}", blind.chi2_per_dof());
        // Scaling the noise scales every covariance: σ = 1 samples with σ̂ give the true-σ bars.
        let sep = Separation::new(&dif, &spec, 4).unwrap();
        let unit = |s: &Samples| Samples { sigma: vec![1.0; s.len()], ..s.clone() };
        let mut scaled = Separation::new(&unit(&dif), &unit(&spec), 4).unwrap();
        scaled.scale_noise(sigma * sigma, sigma * sigma);
        let (a, b) = (sep.solve(kd, ks).unwrap(), scaled.solve(kd, ks).unwrap());
        for (x, y) in a.specular_se.iter().zip(&b.specular_se).chain(a.diffuse_se.iter().zip(&b.diffuse_se)) {
            assert!((x - y).abs() <= 1e-9 * x.abs().max(1e-12), "{x} vs {y}");
        }
    }

    fn light_with(lmax: usize, orders: &[usize]) -> Vec<f64> {
        (0..num_coefficients(lmax))
            .map(|k| {
                let (l, m) = lm(k);
                if k == 0 {
                    2.0
                } else if orders.contains(&l) {
                    0.4 / (1.0 + l as f64) * (((7 * k + 3 * (m + 8) as usize) % 13) as f64 / 13.0 - 0.4)
                } else {
                    0.0
                }
            })
            .collect()
    }

    #[test]
    fn exact_when_the_lighting_has_no_even_order_above_two() {
        // Lambert is 0 at odd l ≥ 3 (eq. 38), so with orders 0,1,2,3,5 the 9-term diffuse part is the
        // whole diffuse part: the recovered lighting is exact and the consistency is exactly 0.
        let light = light_with(5, &[1, 2, 3, 5]);
        let (dif, spec) = views(&light, 0.5, 0.5, 50f64.to_radians(), 0.0, 1);
        let sep = Separation::new(&dif, &spec, 5).unwrap();
        let s = sep.solve(0.5, 0.5).unwrap();
        for k in 0..light.len() {
            assert!((s.specular[k] - light[k]).abs() < 1e-10, "k {k}: {} vs {}", s.specular[k], light[k]);
        }
        for j in 0..LOW {
            assert!((s.diffuse[j] - light[j]).abs() < 1e-10);
            assert!(s.consistency[j].abs() < 1e-10);
        }
        assert!(s.chi2.is_none(), "noise-free data: no covariance");
    }

    #[test]
    fn the_nine_term_residual_is_what_remains() {
        // With l = 4, 6 content (Λ_4 ρ̂_4 = −1/24, Λ_6 ρ̂_6 = 1/64) the specular side is the lighting
        // plus the least-squares fit (at R) of the residual r(n) of eq. 38 — to rounding.
        let lmax = 6;
        let light = light_with(lmax, &[1, 2, 3, 4, 6]);
        let (kd, ks) = (0.6, 0.4);
        let (dif, spec) = views(&light, kd, ks, 50f64.to_radians(), 0.0, 1);
        let sep = Separation::new(&dif, &spec, lmax).unwrap();
        let s = sep.solve(kd, ks).unwrap();
        // The residual field fitted by the same operator (a separation of data = residual at n,
        // no diffuse view content: k_d = 0 so nothing is subtracted).
        let basis = ShBasis::new(lmax);
        let mut y = vec![0.0; light.len()];
        let mut rs = spec.clone();
        for p in 0..rs.len() {
            rs.value[p] = nine_term_residual(&light, kd, ks, &basis, rs.normal[p], &mut y);
        }
        let zero = Samples { value: vec![0.0; dif.len()], ..dif.clone() };
        let r = Separation::new(&zero, &rs, lmax).unwrap().solve(0.0, 1.0).unwrap();
        let mut biggest: f64 = 0.0;
        for k in 0..light.len() {
            assert!((s.specular[k] - light[k] - r.specular[k]).abs() < 1e-10, "k {k}");
            biggest = biggest.max(r.specular[k].abs());
        }
        assert!(biggest > 1e-3, "the residual must not be trivially zero here: {biggest}");
        for j in 0..LOW {
            assert!((s.consistency[j] + r.specular[j]).abs() < 1e-10, "d_j = −(residual fit)_j");
        }
    }

    #[test]
    fn a_wrong_split_breaks_the_consistency_and_the_scan_finds_the_true_one() {
        // Noise σ = 0.01 per sample. At the true split χ² ~ χ²_9 (P(χ² > 33.7) = 1e-4); at a split
        // off by 0.1 in k_d/(k_d+k_s) it is far above. Only l ≤ 3 content (no residual), so the
        // bias is zero and the test is of the statistics alone. The split only shows through the
        // mis-registered diffuse remainder of orders 1–2 (order 0 of D is a constant: any split is
        // consistent there, and a common scale of k_d, k_s scales both sides alike), so those
        // orders are given a lighting-like strength (|L_1m|, |L_2m| up to ≈ 0.5 L_00).
        let mut light = light_with(3, &[1, 2, 3]);
        for v in &mut light[1..LOW] {
            *v *= 10.0;
        }
        let (kd, ks) = (0.5, 0.5);
        let (dif, spec) = views(&light, kd, ks, 50f64.to_radians(), 0.01, 7);
        let sep = Separation::new(&dif, &spec, 3).unwrap();
        let good = sep.solve(kd, ks).unwrap();
        let chi_good = good.chi2.unwrap();
        assert!(chi_good < 33.7, "true split: χ² = {chi_good}");
        for j in 0..LOW {
            assert!(good.consistency[j].abs() < 4.5 * good.consistency_se[j], "j {j}");
        }
        let bad = sep.solve(0.6, 0.4).unwrap();
        let chi_bad = bad.chi2.unwrap();
        // χ²_9 > 100 has probability ≈ 1e-16 for a consistent split.
        assert!(chi_bad > 100.0, "wrong split: χ² = {chi_bad}");
        assert!((0..LOW).any(|j| bad.consistency[j].abs() > 4.0 * bad.consistency_se[j]));
        let fr: Vec<f64> = (0..=40).map(|i| 0.3 + 0.01 * i as f64).collect();
        let (best, _) = best_split(&sep.scan_split(1.0, &fr)).unwrap();
        assert!((best - 0.5).abs() <= 0.011, "scan minimum at {best}");
    }

    #[test]
    fn propagated_errors_match_the_spread() {
        // Lighting to l = 3 (no residual bias, so d is pure noise). Over 40 seeds the mean
        // consistency χ² must be 9 ± 4·√(18/40) (χ²_9 has variance 18), and the spread of a recovered
        // l = 3 coefficient must match its propagated σ (ratio within 30 %: the sample sd of 40
        // draws has a relative sd ≈ 1/√78 ≈ 11 %) with its mean within 4σ/√40 of the truth.
        let light = light_with(3, &[1, 2, 3]);
        let (kd, ks) = (0.5, 0.5);
        let k = index(3, -2);
        let (mut chis, mut vals, mut se) = (vec![], vec![], 0.0);
        for seed in 0..40 {
            let (dif, spec) = views(&light, kd, ks, 55f64.to_radians(), 0.02, seed + 100);
            let s = Separation::new(&dif, &spec, 3).unwrap().solve(kd, ks).unwrap();
            chis.push(s.chi2.unwrap());
            vals.push(s.specular[k]);
            se = s.specular_se[k];
        }
        let mean_chi = chis.iter().sum::<f64>() / chis.len() as f64;
        assert!((mean_chi - 9.0).abs() < 4.0 * (18.0f64 / 40.0).sqrt(), "mean χ² {mean_chi}");
        let mean = vals.iter().sum::<f64>() / vals.len() as f64;
        let sd = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (vals.len() - 1) as f64).sqrt();
        assert!((sd / se - 1.0).abs() < 0.3, "spread {sd} vs propagated {se}");
        assert!((mean - light[k]).abs() < 4.0 * se / 40f64.sqrt(), "mean {mean} vs {}", light[k]);
    }

    #[test]
    fn r_space_weights_cover_the_sphere() {
        // Each specular view's R-space solid angles sum to 2π ∫_{−θ_o}^{π−θ_o} |sin x| dx
        // = 2π ((1 − cos θ_o) + (1 + cos θ_o)) = 4π: the cap folded over the pole is counted twice
        // and the opposite cap of the same size is missed. At θ_o = 0 they are the lat-long
        // pixels' own solid angles, also summing to 4π.
        let (w, h) = (64, 32);
        for (t, flip) in [(0.7, false), (0.7, true), (0.0, false)] {
            let s = probe_samples(&vec![0.0; w * h], &vec![0.0; w * h], w, h, t, flip);
            let total: f64 = s.weight.iter().sum();
            assert!((total - 4.0 * PI).abs() < 1e-12, "{total}");
            // R really is at polar angle θ ∓ θ_o on the pixel's meridian.
            let i = 20 * w + 5;
            let theta = PI * 20.5 / h as f64;
            let want = if flip { theta + t } else { theta - t };
            assert!((s.reflected[i][2] - want.cos()).abs() < 1e-12);
        }
        assert!((abs_sin_integral(-PI) + 2.0).abs() < 1e-12 && (abs_sin_integral(2.0 * PI) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn bad_input_is_an_error() {
        let light = light_with(2, &[1, 2]);
        let (dif, spec) = views(&light, 0.5, 0.5, 50f64.to_radians(), 0.0, 1);
        assert!(Separation::new(&spec, &spec, 2).is_err(), "an oblique view is not a diffuse view");
        let mut short = spec.clone();
        short.sigma.pop();
        assert!(Separation::new(&dif, &short, 2).is_err());
        // Too few directions for l = 12.
        assert!(Separation::new(&dif, &spec, 12).is_err());
        let sep = Separation::new(&dif, &spec, 2).unwrap();
        assert!(sep.solve(0.5, 0.0).is_err());
        assert!(sep.solve(f64::NAN, 0.5).is_err());
    }
}
