//! The z of a difference of two estimates with estimated variances, and its Gaussian score.

use crate::special::normal_score;

/// A difference Δ = a − b with variances `va`, `vb` of ν_a, ν_b degrees of freedom (∞ for known
/// variances): z = Δ / √(va + vb) and Welch–Satterthwaite's ν = (va + vb)² / (va²/ν_a + vb²/ν_b),
/// the degrees of freedom of the Student t that z follows when the noise is Gaussian (Welch 1947).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Difference {
    pub z: f64,
    pub dof: f64,
}

impl Difference {
    /// `None` when va + vb = 0 (two exact values: no z).
    pub fn new(delta: f64, va: f64, vb: f64, dof_a: f64, dof_b: f64) -> Option<Difference> {
        let v = va + vb;
        if !(v > 0.0) {
            return None;
        }
        let denom = va * va / dof_a + vb * vb / dof_b;
        let dof = if denom > 0.0 { (v * v / denom).min(1e9) } else { f64::INFINITY };
        Some(Difference { z: delta / v.sqrt(), dof })
    }

    /// The Gaussian score of z: N(0, 1) when the two estimates agree, whatever ν
    /// ([`normal_score`]).
    pub fn score(&self) -> f64 {
        normal_score(self.z, self.dof)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welch_dof_of_equal_and_lopsided_variances() {
        // Equal variances and ν: ν doubles; one side exact: the other side's ν.
        let d = Difference::new(1.0, 1.0, 1.0, 9.0, 9.0).unwrap();
        assert!((d.dof - 18.0).abs() < 1e-12 && (d.z - 1.0 / 2f64.sqrt()).abs() < 1e-15);
        let d = Difference::new(1.0, 0.0, 4.0, f64::INFINITY, 7.0).unwrap();
        assert!((d.dof - 7.0).abs() < 1e-12 && (d.z - 0.5).abs() < 1e-15);
        assert!(Difference::new(1.0, 0.0, 0.0, 1.0, 1.0).is_none());
        // Known variances: the score is z itself.
        let d = Difference::new(2.0, 1.0, 3.0, f64::INFINITY, f64::INFINITY).unwrap();
        assert_eq!(d.score(), 1.0);
    }
}
