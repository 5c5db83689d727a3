//! Dense symmetric positive-definite linear algebra for weighted least squares: Cholesky
//! factorization G = L Lᵀ, solves, and the inverse (for coefficient covariances), over nalgebra.
//!
//! Matrices are row-major `p × p` `Vec<f64>`. A pivot below `rel_tol` × the largest diagonal entry
//! means the normal equations do not determine the unknowns (e.g. SH orders the covered part of
//! the sphere cannot separate); that is reported as an error rather than a garbage solution.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};

/// Lower-triangular Cholesky factor of a symmetric positive-definite matrix.
#[derive(Clone, Debug)]
pub struct Cholesky {
    factor: nalgebra::Cholesky<f64, nalgebra::Dyn>,
}

impl Cholesky {
    /// Factors `g` (`p × p`, row-major; only its lower triangle is read). Errors when a pivot
    /// L_jj² is not above `rel_tol` × the largest diagonal entry of `g`.
    pub fn new(g: &[f64], p: usize, rel_tol: f64) -> Result<Cholesky> {
        assert_eq!(g.len(), p * p);
        let dmax = (0..p).map(|i| g[i * p + i]).fold(0.0f64, f64::max);
        let singular = |j: usize, pivot: f64| {
            Error::new(format!(
                "least-squares system is singular or ill-conditioned at unknown {j} of {p} (pivot {pivot:.3e})"
            ))
        };
        let Some(factor) = nalgebra::Cholesky::new(DMatrix::from_row_slice(p, p, g)) else {
            return Err(Error::new(format!(
                "least-squares system of {p} unknowns is singular (not positive definite)"
            )));
        };
        let l = factor.l_dirty();
        if let Some(j) = (0..p).find(|&j| !(l[(j, j)] * l[(j, j)] > rel_tol * dmax)) {
            return Err(singular(j, l[(j, j)] * l[(j, j)]));
        }
        Ok(Cholesky { factor })
    }

    /// Solves G x = b in place (`b` has p entries).
    pub fn solve(&self, b: &mut [f64]) {
        let mut x = DVector::from_column_slice(b);
        self.factor.solve_mut(&mut x);
        b.copy_from_slice(x.as_slice());
    }

    /// G⁻¹, row-major.
    pub fn inverse(&self) -> Vec<f64> {
        // Column-major storage of the transpose is the row-major storage of G⁻¹.
        self.factor.inverse().transpose().as_slice().to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_and_inverts_a_spd_system() {
        // G = Aᵀ A + I for a fixed A.
        let p = 7;
        let a: Vec<f64> = (0..p * p).map(|i| ((i * 37 % 11) as f64 - 5.0) / 3.0).collect();
        let mut g = vec![0.0; p * p];
        for i in 0..p {
            for j in 0..p {
                g[i * p + j] =
                    (0..p).map(|k| a[k * p + i] * a[k * p + j]).sum::<f64>() + if i == j { 1.0 } else { 0.0 };
            }
        }
        let ch = Cholesky::new(&g, p, 1e-14).unwrap();
        let x: Vec<f64> = (0..p).map(|i| i as f64 - 2.5).collect();
        let mut b: Vec<f64> = (0..p).map(|i| (0..p).map(|j| g[i * p + j] * x[j]).sum()).collect();
        ch.solve(&mut b);
        for i in 0..p {
            assert!((b[i] - x[i]).abs() < 1e-10);
        }
        let inv = ch.inverse();
        for i in 0..p {
            for j in 0..p {
                let v: f64 = (0..p).map(|k| g[i * p + k] * inv[k * p + j]).sum();
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn singular_system_is_an_error() {
        let g = vec![1.0, 1.0, 1.0, 1.0];
        assert!(Cholesky::new(&g, 2, 1e-12).is_err());
    }
}
