//! Projection of any function of direction: c_k = ∫ f(ω) Y_k(ω) dω by a product rule,
//! Gauss–Legendre in cos θ (`n_theta` nodes) × `2 n_theta` uniform φ.
//!
//! The rule is exact for band-limited f of order ≤ 2 n_theta − 1 − l_max, so `n_theta = l_max + 1`
//! recovers the coefficients of an SH-defined function to rounding error; for other functions
//! raise `n_theta` until the coefficients converge.

use crate::quadrature::gauss_legendre;
use crate::sh::{ShBasis, num_coefficients};
use rayon::prelude::*;
use std::f64::consts::PI;

/// RGB coefficients up to `lmax` of `f`, integrated with `n_theta` × 2`n_theta` nodes.
pub fn project_function<F>(lmax: usize, n_theta: usize, f: F) -> Vec<[f64; 3]>
where
    F: Fn([f64; 3]) -> [f64; 3] + Sync,
{
    let n = num_coefficients(lmax);
    let (xs, ws) = gauss_legendre(n_theta.max(1));
    let nphi = 2 * n_theta.max(1);
    let basis = ShBasis::new(lmax);
    // One partial sum per θ node, reduced in a fixed order so the result is thread-count independent.
    let parts: Vec<Vec<[f64; 3]>> = xs
        .par_iter()
        .zip(ws.par_iter())
        .map(|(&z, &wz)| {
            let mut y = vec![0.0; n];
            let mut acc = vec![[0.0; 3]; n];
            let st = (1.0 - z * z).max(0.0).sqrt();
            let w = wz * 2.0 * PI / nphi as f64;
            for j in 0..nphi {
                let phi = 2.0 * PI * (j as f64 + 0.5) / nphi as f64;
                let d = [st * phi.cos(), st * phi.sin(), z];
                let v = f(d);
                basis.eval_into(d, &mut y);
                for k in 0..n {
                    let wy = w * y[k];
                    for ch in 0..3 {
                        acc[k][ch] += wy * v[ch];
                    }
                }
            }
            acc
        })
        .collect();
    super::envmap::sum_parts(parts, n)
}

/// Scalar version of [`project_function`].
pub fn project_function_scalar<F>(lmax: usize, n_theta: usize, f: F) -> Vec<f64>
where
    F: Fn([f64; 3]) -> f64 + Sync,
{
    project_function(lmax, n_theta, |d| [f(d), 0.0, 0.0]).into_iter().map(|c| c[0]).collect()
}
