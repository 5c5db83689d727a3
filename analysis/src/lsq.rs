//! Dense symmetric positive-definite linear algebra for weighted least squares: Cholesky
//! factorization G = L Lᵀ, solves, and the inverse (for coefficient covariances).
//!
//! Matrices are row-major `p × p` `Vec<f64>`. A pivot below `rel_tol` × the largest diagonal entry
//! means the normal equations do not determine the unknowns (e.g. SH orders the covered part of
//! the sphere cannot separate); that is reported as an error rather than a garbage solution.

use crate::error::{Error, Result};

/// Lower-triangular Cholesky factor of a symmetric positive-definite matrix.
#[derive(Clone, Debug)]
pub struct Cholesky {
    p: usize,
    l: Vec<f64>,
}

impl Cholesky {
    /// Factors `g` (only its lower triangle is read).
    pub fn new(g: &[f64], p: usize, rel_tol: f64) -> Result<Cholesky> {
        assert_eq!(g.len(), p * p);
        let dmax = (0..p).map(|i| g[i * p + i]).fold(0.0f64, f64::max);
        let mut l = vec![0.0; p * p];
        for j in 0..p {
            let mut d = g[j * p + j];
            for k in 0..j {
                d -= l[j * p + k] * l[j * p + k];
            }
            if !(d > rel_tol * dmax) {
                return Err(Error::new(format!(
                    "least-squares system is singular or ill-conditioned at unknown {j} of {p} (pivot {d:.3e})"
                )));
            }
            let d = d.sqrt();
            l[j * p + j] = d;
            for i in (j + 1)..p {
                let mut s = g[i * p + j];
                let (ri, rj) = (&l[i * p..i * p + j], &l[j * p..j * p + j]);
                for k in 0..j {
                    s -= ri[k] * rj[k];
                }
                l[i * p + j] = s / d;
            }
        }
        Ok(Cholesky { p, l })
    }

    /// Solves G x = b in place.
    pub fn solve(&self, b: &mut [f64]) {
        let (p, l) = (self.p, &self.l);
        for i in 0..p {
            let mut s = b[i];
            for k in 0..i {
                s -= l[i * p + k] * b[k];
            }
            b[i] = s / l[i * p + i];
        }
        for i in (0..p).rev() {
            let mut s = b[i];
            for k in (i + 1)..p {
                s -= l[k * p + i] * b[k];
            }
            b[i] = s / l[i * p + i];
        }
    }

    /// G⁻¹, row-major.
    pub fn inverse(&self) -> Vec<f64> {
        let p = self.p;
        let mut inv = vec![0.0; p * p];
        let mut e = vec![0.0; p];
        for j in 0..p {
            e.iter_mut().for_each(|v| *v = 0.0);
            e[j] = 1.0;
            self.solve(&mut e);
            for i in 0..p {
                inv[i * p + j] = e[i];
            }
        }
        inv
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
