//! Transfer coefficients of any radially symmetric transfer function ρ̂(θ'_i) by numerical
//! integration of eq. 13: ρ̂_l = 2π ∫ ρ̂(θ) Y_l0(θ) sin θ dθ, so (with Λ_l Y_l0 = P_l(cos θ))
//! Λ_l ρ̂_l = 2π ∫_0^{θ_max} ρ̂(θ) P_l(cos θ) sin θ dθ.
//!
//! Parameters: `rho_hat(θ)`, the upper limit `theta_max` (ρ̂ taken as 0 beyond, e.g. π/2 for a
//! clamped lobe, so that the integrand is smooth on the interval), `lmax`. Composite Gauss–Legendre
//! with enough panels to resolve P_lmax's oscillation (wavelength ≈ 2π/l).

use crate::quadrature::{integrate, legendre_all};
use std::f64::consts::PI;

/// Λ_l ρ̂_l, l = 0 … lmax, of the radially symmetric `rho_hat` supported on [0, theta_max].
pub fn radial(rho_hat: impl Fn(f64) -> f64, theta_max: f64, lmax: usize) -> Vec<f64> {
    let panels = 8 + ((theta_max * (lmax as f64 + 1.0)) / PI).ceil() as usize * 2;
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    integrate(0.0, theta_max, panels, 20, |t, w| {
        let f = 2.0 * PI * rho_hat(t) * t.sin() * w;
        legendre_all(t.cos(), &mut p);
        for l in 0..=lmax {
            out[l] += f * p[l];
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamped_cosine_gives_eq38() {
        let num = radial(|t| t.cos() / PI, PI / 2.0, 30);
        let exact = crate::transfer::lambert::lambert(30);
        for l in 0..=30 {
            assert!((num[l] - exact[l]).abs() < 1e-13, "l={l}: {} vs {}", num[l], exact[l]);
        }
    }

    #[test]
    fn phong_lobe_gives_eq43() {
        let s = 32.0;
        let num = radial(|t| (s + 1.0) / (2.0 * PI) * t.cos().powf(s), PI / 2.0, 60);
        let exact = crate::transfer::phong::phong(s, 60);
        for l in 0..=60 {
            assert!((num[l] - exact[l]).abs() < 1e-12, "l={l}: {} vs {}", num[l], exact[l]);
        }
    }
}
