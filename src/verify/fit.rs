//! Linear analysis of rendered images: lat-long quadrature (CONVENTIONS §2) of a `normal-probe`
//! render into SH with the propagated standard error, and weighted least squares in pixel space
//! with its covariance. Both are linear in the pixel values, so independent per-pixel standard
//! errors σ_p propagate exactly: Var(Σ_p w_p B_p) = Σ_p w_p² σ_p².
//!
//! The filter fits of the checks are done in *pixel space*: B(n_p) ≈ Σ_l a_l S_l(n_p) with
//! S_l(n) = Σ_m L_lm Y_lm(n) the order-l part of the (known) lighting. When the model is exact
//! (band-limited lighting, radial BRDF) this has no quadrature error at all, unlike projecting the
//! image by a pixel sum first.

use analysis::sh::{ShBasis, index, num_coefficients};
use renderer::film::Film;
use std::f64::consts::PI;

/// Direction of the centre of lat-long pixel (r, c) of a W × H grid (CONVENTIONS §2).
pub fn latlong_dir(r: usize, c: usize, w: usize, h: usize) -> [f64; 3] {
    let t = PI * (r as f64 + 0.5) / h as f64;
    let p = 2.0 * PI * (c as f64 + 0.5) / w as f64;
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// Exact solid angle of a lat-long pixel of row r.
pub fn latlong_omega(r: usize, w: usize, h: usize) -> f64 {
    let t0 = PI * r as f64 / h as f64;
    let t1 = PI * (r as f64 + 1.0) / h as f64;
    2.0 * PI / w as f64 * (t0.cos() - t1.cos())
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    if n > 0.0 { [a[0] / n, a[1] / n, a[2] / n] } else { a }
}

/// One channel of a film: value, standard error and (for the normal probe) the pixel's normal and
/// solid angle.
#[derive(Clone, Debug, Default)]
pub struct Channel {
    pub width: usize,
    pub height: usize,
    pub value: Vec<f64>,
    pub sigma: Vec<f64>,
    pub normal: Vec<[f64; 3]>,
    pub mask: Vec<f64>,
}

impl Channel {
    pub fn from_film(f: &Film, c: usize) -> Channel {
        Channel {
            width: f.width as usize,
            height: f.height as usize,
            value: f.pixels.iter().map(|p| p.rgb[c] as f64).collect(),
            sigma: f.pixels.iter().map(|p| p.stderr[c] as f64).collect(),
            normal: f.pixels.iter().map(|p| p.normal.map(|v| v as f64)).collect(),
            mask: f.pixels.iter().map(|p| p.mask as f64).collect(),
        }
    }

    #[cfg(test)]
    /// A synthetic normal-probe image (tests): value f(n) + noise, stderr σ.
    pub fn synthetic_probe(w: usize, h: usize, f: impl Fn([f64; 3]) -> f64, sigma: f64, seed: u64) -> Channel {
        let mut rng = renderer::sampling::chi2::TestRng::new(seed);
        let mut ch = Channel { width: w, height: h, ..Default::default() };
        for r in 0..h {
            for c in 0..w {
                let n = latlong_dir(r, c, w, h);
                // Box–Muller normal noise.
                let mut u = || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
                let (u1, u2) = (u().max(1e-300), u());
                let g = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                ch.value.push(f(n) + sigma * g);
                ch.sigma.push(sigma);
                ch.normal.push(n);
                ch.mask.push(1.0);
            }
        }
        ch
    }
}

/// SH projection of a normal-probe image by lat-long quadrature: (B_k, σ(B_k)) for k < (lmax+1)².
pub fn project_probe(ch: &Channel, lmax: usize) -> (Vec<f64>, Vec<f64>) {
    let (w, h) = (ch.width, ch.height);
    let n = num_coefficients(lmax);
    let basis = ShBasis::new(lmax);
    let mut y = vec![0.0; n];
    let mut b = vec![0.0; n];
    let mut var = vec![0.0; n];
    for r in 0..h {
        let om = latlong_omega(r, w, h);
        for c in 0..w {
            let i = r * w + c;
            basis.eval_into(latlong_dir(r, c, w, h), &mut y);
            for k in 0..n {
                let wk = om * y[k];
                b[k] += wk * ch.value[i];
                var[k] += wk * wk * ch.sigma[i] * ch.sigma[i];
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
            rows.push(basis.eval(latlong_dir(r, c, w, h)));
            weight.push(om);
        }
    }
    (rows, weight)
}

/// RMS over m of g(index(l, m)) at order l.
pub fn order_rms(l: usize, g: impl Fn(usize) -> f64) -> f64 {
    ((-(l as i64)..=(l as i64)).map(|m| g(index(l, m)).powi(2)).sum::<f64>() / (2 * l + 1) as f64).sqrt()
}

/// Order-l parts of a (scalar) SH lighting at `dir`: S_l = Σ_m L_lm Y_lm(dir), l ≤ lmax.
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

/// Result of a weighted linear least-squares fit.
#[derive(Clone, Debug)]
pub struct Fit {
    pub coef: Vec<f64>,
    /// Standard errors from the propagated per-pixel σ (sandwich covariance).
    pub sigma: Vec<f64>,
    /// The full sandwich covariance (p × p, row-major): non-uniform pixel noise correlates the
    /// coefficients even when the regressors are orthogonal.
    pub cov: Vec<f64>,
    /// Σ_p w_p (residual_p / σ_p)² / Σ_p w_p over pixels with σ_p > 0 (≈ 1 for a correct model
    /// with honest σ and unit weights); None when no pixel has σ > 0.
    pub reduced_chi2: Option<f64>,
}

/// Weighted least squares: minimise Σ_p w_p (v_p − Σ_j A_pj x_j)². Rows with w_p = 0 are skipped.
/// Covariance (AᵀWA)⁻¹ Aᵀ W Σ W A (AᵀWA)⁻¹, Σ = diag(σ_p²).
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
    let (mut chi, mut wsum) = (0.0, 0.0);
    for (i, a) in rows.iter().enumerate() {
        if weight[i] == 0.0 {
            continue;
        }
        let r = value[i] - (0..p).map(|j| a[j] * coef[j]).sum::<f64>();
        if sigma[i] > 0.0 {
            chi += weight[i] * (r / sigma[i]).powi(2);
            wsum += weight[i];
        }
    }
    Some(Fit { coef, sigma: sig, cov, reduced_chi2: (wsum > 0.0).then(|| chi / wsum) })
}

/// Gauss–Jordan inverse with partial pivoting of a small p × p matrix; None if singular.
pub fn invert(a: &[f64], p: usize) -> Option<Vec<f64>> {
    let mut m = a.to_vec();
    let mut inv = vec![0.0; p * p];
    for i in 0..p {
        inv[i * p + i] = 1.0;
    }
    let scale = (0..p).map(|i| a[i * p + i].abs()).fold(0.0, f64::max);
    for col in 0..p {
        let piv = (col..p).max_by(|&x, &y| m[x * p + col].abs().total_cmp(&m[y * p + col].abs()))?;
        if m[piv * p + col].abs() <= 1e-13 * scale.max(1e-300) {
            return None;
        }
        for k in 0..p {
            m.swap(col * p + k, piv * p + k);
            inv.swap(col * p + k, piv * p + k);
        }
        let d = m[col * p + col];
        for k in 0..p {
            m[col * p + k] /= d;
            inv[col * p + k] /= d;
        }
        for r in 0..p {
            if r != col {
                let f = m[r * p + col];
                if f != 0.0 {
                    for k in 0..p {
                        m[r * p + k] -= f * m[col * p + k];
                        inv[r * p + k] -= f * inv[col * p + k];
                    }
                }
            }
        }
    }
    Some(inv)
}

/// Per-order filter a_l of a normal-probe render under a known SH lighting `light` (scalar, index k):
/// weighted (solid angle) least squares of B(n_p) on S_l(n_p), l ≤ lmax_fit. Exact when the lighting
/// is band-limited to lmax_fit and the BRDF radial (no quadrature error).
pub fn fit_filter_probe(ch: &Channel, light: &[f64], lmax_fit: usize) -> Option<Fit> {
    let (w, h) = (ch.width, ch.height);
    fit_filter_at(ch, light, lmax_fit, |r, c| latlong_dir(r, c, w, h))
}

/// Like [`fit_filter_probe`], but the order parts are evaluated at `dir(r, c)` instead of the
/// pixel's normal (e.g. the reflection vector R at non-normal exitance).
pub fn fit_filter_at(
    ch: &Channel,
    light: &[f64],
    lmax_fit: usize,
    dir: impl Fn(usize, usize) -> [f64; 3],
) -> Option<Fit> {
    let (w, h) = (ch.width, ch.height);
    let basis = ShBasis::new(lmax_fit);
    let mut y = vec![0.0; num_coefficients(lmax_fit)];
    let mut rows = Vec::with_capacity(w * h);
    let mut weight = Vec::with_capacity(w * h);
    for r in 0..h {
        let om = latlong_omega(r, w, h);
        for c in 0..w {
            let mut s = vec![0.0; lmax_fit + 1];
            order_parts(&basis, light, dir(r, c), &mut y, &mut s);
            rows.push(s);
            weight.push(om);
        }
    }
    lsq(&rows, &ch.value, &ch.sigma, &weight)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_jordan_inverts() {
        let a = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
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
        // B = Σ a_l S_l exactly plus noise σ: the fit returns a_l within 4σ(a_l), and σ(a_l)
        // matches the spread over seeds (checked loosely: ratio within 30 % over 40 seeds).
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
        let mut est = vec![];
        let mut sig = 0.0;
        for seed in 0..40 {
            let ch = Channel::synthetic_probe(32, 16, f, 0.05, seed);
            let fit = fit_filter_probe(&ch, &light, lmax).unwrap();
            // 200 comparisons: 4.5σ keeps the chance of a spurious failure at ≈ 0.1 %.
            for (l, &a) in a_true.iter().enumerate() {
                assert!((fit.coef[l] - a).abs() < 4.5 * fit.sigma[l], "seed {seed} l {l}");
            }
            est.push(fit.coef[2]);
            sig = fit.sigma[2];
            // Weighted reduced χ²: sd = √(2 Σw²)/Σw with w ∝ pixel solid angle (≈ 0.07 here).
            let chi = fit.reduced_chi2.unwrap();
            let om: Vec<f64> = (0..16).map(|r| latlong_omega(r, 32, 16)).collect();
            let (s1, s2) = (om.iter().sum::<f64>() * 32.0, om.iter().map(|w| w * w).sum::<f64>() * 32.0);
            assert!((chi - 1.0).abs() < 4.0 * (2.0 * s2).sqrt() / s1, "reduced chi2 {chi}");
        }
        let mean = est.iter().sum::<f64>() / est.len() as f64;
        let sd = (est.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (est.len() - 1) as f64).sqrt();
        assert!((sd / sig - 1.0).abs() < 0.3, "spread {sd} vs propagated {sig}");
    }

    #[test]
    fn projection_of_a_constant() {
        // Exact solid angles make B_00 exact; the higher m = 0 terms carry the midpoint rule's
        // O((π/H)² l²) error in θ (≈ 4e-4 for l = 2, H = 128).
        let ch = Channel::synthetic_probe(256, 128, |_| 2.0, 0.0, 1);
        let (b, s) = project_probe(&ch, 2);
        assert!((b[0] - 2.0 * (4.0 * PI).sqrt()).abs() < 1e-9);
        assert!(b[1..].iter().all(|v| v.abs() < 1e-3), "{b:?}");
        assert!(s.iter().all(|&v| v == 0.0));
    }
}
