//! Reconstruction of a function of direction from its SH coefficients: f(ω) = Σ_k c_k Y_k(ω).
//!
//! Coefficients are RGB triples in index order k (docs/src/conventions.md §3); their count fixes l_max.
//! [`Reconstructor`] owns its scratch buffer so repeated evaluation does not allocate.

use super::basis::{ShBasis, num_coefficients};

/// l_max of a coefficient vector of length (l_max + 1)², or `None` if the length is not a square.
pub fn lmax_of(len: usize) -> Option<usize> {
    let l = (len as f64).sqrt().round() as usize;
    (l >= 1 && l * l == len).then(|| l - 1)
}

/// Evaluates Σ_k c_k Y_k(ω) for RGB coefficients.
#[derive(Clone, Debug)]
pub struct Reconstructor {
    basis: ShBasis,
    y: Vec<f64>,
}

impl Reconstructor {
    pub fn new(lmax: usize) -> Self {
        Reconstructor { basis: ShBasis::new(lmax), y: vec![0.0; num_coefficients(lmax)] }
    }

    /// RGB value at unit direction `dir`; coefficients beyond this reconstructor's l_max are ignored,
    /// missing ones count as zero.
    pub fn eval(&mut self, coeffs: &[[f64; 3]], dir: [f64; 3]) -> [f64; 3] {
        self.basis.eval_into(dir, &mut self.y);
        let mut s = [0.0; 3];
        for (c, y) in coeffs.iter().zip(&self.y) {
            for ch in 0..3 {
                s[ch] += c[ch] * y;
            }
        }
        s
    }

    /// Scalar value at `dir`.
    pub fn eval_scalar(&mut self, coeffs: &[f64], dir: [f64; 3]) -> f64 {
        self.basis.eval_into(dir, &mut self.y);
        coeffs.iter().zip(&self.y).map(|(c, y)| c * y).sum()
    }
}

/// Direction of the lat-long pixel (row, col) of a W × H map (docs/src/conventions.md §2).
#[inline]
pub fn latlong_direction(row: usize, col: usize, width: usize, height: usize) -> [f64; 3] {
    let theta = std::f64::consts::PI * (row as f64 + 0.5) / height as f64;
    let phi = 2.0 * std::f64::consts::PI * (col as f64 + 0.5) / width as f64;
    [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()]
}

/// Renders RGB coefficients onto a W × H lat-long image (row-major, row 0 at θ ≈ 0).
pub fn reconstruct_latlong(coeffs: &[[f64; 3]], width: usize, height: usize) -> Vec<[f64; 3]> {
    use rayon::prelude::*;
    let lmax = lmax_of(coeffs.len()).unwrap_or(0);
    (0..height)
        .into_par_iter()
        .flat_map_iter(|r| {
            let mut rec = Reconstructor::new(lmax);
            (0..width).map(move |c| rec.eval(coeffs, latlong_direction(r, c, width, height))).collect::<Vec<_>>()
        })
        .collect()
}
