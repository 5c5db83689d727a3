//! Special functions the analysis and the verifier share, in f64.
//!
//! - [`erfc`]: the complementary error function for x ≥ 0 (Beckmann's Smith Λ, Gaussian tail
//!   probabilities). Not on any hot path: the renderer keeps its own f32-path approximation.

use std::f64::consts::PI;

/// erfc(x), x ≥ 0, in f64: the erf series below 2.5 (cancellation costs < 4 digits there), the
/// Laplace continued fraction above (bottom-up, 80 terms).
pub fn erfc(x: f64) -> f64 {
    if x < 2.5 {
        let (mut term, mut sum) = (x, x);
        for n in 1..200 {
            term *= -x * x / n as f64;
            let t = term / (2 * n + 1) as f64;
            sum += t;
            if t.abs() < 1e-17 {
                break;
            }
        }
        1.0 - 2.0 / PI.sqrt() * sum
    } else {
        let mut f = x;
        for k in (1..80).rev() {
            f = x + (k as f64 / 2.0) / f;
        }
        (-x * x).exp() / PI.sqrt() / f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_reference_values() {
        // Python math.erfc, on both sides of the switch at 2.5 and in the tail.
        assert!((erfc(0.0) - 1.0).abs() < 1e-15);
        assert!((erfc(0.5) - 0.479_500_122_186_953_5).abs() < 1e-14);
        assert!((erfc(2.4) - 6.885_138_966_450_789e-4).abs() < 1e-15);
        assert!((erfc(2.6) - 2.360_344_165_293_490_8e-4).abs() < 1e-15);
        assert!((erfc(4.0 / std::f64::consts::SQRT_2) / 6.334_248_366_623_996e-5 - 1.0).abs() < 1e-9);
    }
}
