//! The Beckmann microfacet BRDF (docs/src/conventions.md §4: `microfacet`, distribution `beckmann`, Smith
//! masking–shadowing, Fresnel off) at normal exitance, where it is radially symmetric about n:
//! its lobe ρ̂(θ_i) and transfer coefficients Λ_l ρ̂_l (eq. 13–15 by quadrature of the lobe).

use crate::special::erfc;
use std::f64::consts::PI;

/// Beckmann's Smith Λ at polar angle θ (radians) for roughness α:
/// (e^{−a²}/(a√π) − erfc(a)) / 2 with a = cot θ / α; 0 at θ = 0.
pub fn beckmann_lambda(theta: f64, alpha: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    if s <= 0.0 {
        return 0.0;
    }
    let a = c / (alpha * s);
    0.5 * ((-a * a).exp() / (a * PI.sqrt()) - erfc(a))
}

/// ρ̂(θ_i) = BRDF · cos θ_i of the Beckmann microfacet BRDF (F = 1) at normal exitance: the half
/// vector is at θ_i/2, cos θ_o = 1 and Λ(ω_o) = 0, so ρ̂ = D(θ_i/2) / (4 (1 + Λ(θ_i))) with
/// D(θ_h) = exp(−tan²θ_h/α²) / (π α² cos⁴θ_h).
pub fn beckmann_normal_lobe(theta_i: f64, alpha: f64) -> f64 {
    let c = (0.5 * theta_i).cos();
    let d = (-(0.5 * theta_i).tan().powi(2) / (alpha * alpha)).exp() / (PI * alpha * alpha * c.powi(4));
    d / (4.0 * (1.0 + beckmann_lambda(theta_i, alpha)))
}

/// Λ_l ρ̂_l, l ≤ `lmax`, of the Beckmann sphere seen at normal exitance (k_s = 1, F = 1), by
/// [`super::radial::radial`] quadrature of [`beckmann_normal_lobe`] over θ_i ∈ [0, π/2].
pub fn beckmann_normal_exitance(alpha: f64, lmax: usize) -> Vec<f64> {
    super::radial::radial(|t| beckmann_normal_lobe(t, alpha), PI / 2.0, lmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_and_smith_limits() {
        // Λ_0 ρ̂_0 is the albedo at normal exitance: 1 for small α (D is normalised, G ≈ 1 where
        // D lives), below 1 for a rough surface (single-scattering energy lost to G).
        let (a, b) = (beckmann_normal_exitance(0.05, 2)[0], beckmann_normal_exitance(0.4, 2)[0]);
        assert!((a - 1.0).abs() < 1e-6, "{a}");
        assert!(b < 0.99 && b > 0.8, "{b}");
        // Smith Λ vanishes towards the normal and grows towards grazing.
        assert!(beckmann_lambda(0.1, 0.3) < 1e-12);
        assert!(beckmann_lambda(1.5, 0.3) > beckmann_lambda(1.2, 0.3));
        // A narrow lobe's filter tends to the mirror's (1 at every low order).
        let f = beckmann_normal_exitance(0.01, 4);
        assert!(f.iter().all(|v| (v - 1.0).abs() < 2e-3), "{f:?}");
    }
}
