//! Simplified Torrance–Sparrow (eq. 48, k_s = 1) transfer coefficients, reparameterized by the
//! reflection vector.
//!
//! - [`normal_exitance`]: eq. 50, Λ_l ρ̂_l = ∫_0^{π/2} exp(−θ²/4σ²)/(2σ²) P_l(cos θ) sin θ dθ
//!   (θ'_h = θ'_i/2 at normal exitance; the 1/cos θ'_i of the BRDF cancels the cosine of ρ̂), by
//!   composite Gauss–Legendre. [`gaussian`] is its approximation exp(−(σl)²), eq. 57.
//! - [`exitance`]: at exitance angle θ_o, the q = 0 coefficient of eq. 49,
//!   Λ_l ρ̂_l0(θ_o) = ∫_{S²} ρ̂(ω_i; ω_o) P_l(R·ω_i) dω_i with
//!   ρ̂ = exp(−(θ'_h/σ)²)/(4πσ² cos θ_o), the exact half angle θ'_h (not the Taylor form eq. 58),
//!   integrated in polar coordinates about R (Gauss in θ, trapezoid in φ, which is spectrally
//!   accurate for the periodic φ integrand). `Horizon::Clamp` drops n·ω_i ≤ 0.
//! - [`eq59`]: the paper's first-order form (eq. 59), using eq. 58's
//!   θ'_h² = (θ'_i/2)²(1 + sin²φ tan²θ_o) averaged over φ.

use super::Horizon;
use crate::quadrature::{integrate, legendre_all};
use std::f64::consts::PI;

fn panels_for(range: f64, lmax: usize) -> usize {
    8 + 2 * ((range * (lmax as f64 + 1.0)) / PI).ceil() as usize
}

/// Eq. 50 by quadrature, l = 0 … lmax.
pub fn normal_exitance(sigma: f64, lmax: usize) -> Vec<f64> {
    // exp(−θ²/4σ²) < e⁻¹⁰⁰ beyond θ = 20σ.
    let tmax = (20.0 * sigma).min(PI / 2.0);
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    integrate(0.0, tmax, panels_for(tmax, lmax).max(32), 20, |t, w| {
        let f = (-t * t / (4.0 * sigma * sigma)).exp() / (2.0 * sigma * sigma) * t.sin() * w;
        legendre_all(t.cos(), &mut p);
        for l in 0..=lmax {
            out[l] += f * p[l];
        }
    });
    out
}

/// Eq. 57: exp(−(σl)²).
pub fn gaussian(sigma: f64, lmax: usize) -> Vec<f64> {
    (0..=lmax).map(|l| (-(sigma * l as f64).powi(2)).exp()).collect()
}

/// The q = 0 coefficient Λ_l ρ̂_l0(θ_o) by 2D quadrature over the reparameterized lobe.
pub fn exitance(sigma: f64, theta_o: f64, lmax: usize, horizon: Horizon) -> Vec<f64> {
    let n = [0.0, 0.0, 1.0];
    let (so, co) = theta_o.sin_cos();
    let wo = [so, 0.0, co];
    let r = [-so, 0.0, co];
    // Orthonormal frame (t1, t2, R).
    let t1 = [co, 0.0, so];
    let t2 = [0.0, 1.0, 0.0];
    let tmax = (24.0 * sigma).min(PI);
    let nphi = 256;
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    let norm = 1.0 / (4.0 * PI * sigma * sigma * co);
    integrate(0.0, tmax, panels_for(tmax, lmax).max(48), 20, |t, w| {
        let (st, ct) = t.sin_cos();
        let mut ring = 0.0;
        for j in 0..nphi {
            let phi = 2.0 * PI * (j as f64 + 0.5) / nphi as f64;
            let (sp, cp) = phi.sin_cos();
            let wi = [
                ct * r[0] + st * (cp * t1[0] + sp * t2[0]),
                ct * r[1] + st * (cp * t1[1] + sp * t2[1]),
                ct * r[2] + st * (cp * t1[2] + sp * t2[2]),
            ];
            let cos_i = wi[0] * n[0] + wi[1] * n[1] + wi[2] * n[2];
            if horizon == Horizon::Clamp && cos_i <= 0.0 {
                continue;
            }
            let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
            let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            if hl <= 1e-12 {
                continue;
            }
            let th = (h[2] / hl).clamp(-1.0, 1.0).acos();
            ring += (-(th / sigma).powi(2)).exp();
        }
        let f = ring * 2.0 * PI / nphi as f64 * norm * st * w;
        legendre_all(ct, &mut p);
        for l in 0..=lmax {
            out[l] += f * p[l];
        }
    });
    out
}

/// Eq. 59: (1/cos θ_o) ∫_0^∞ 2u e^{−u²} P_l(cos 2σu) (1 − u² tan²θ_o / 2) du.
pub fn eq59(sigma: f64, theta_o: f64, lmax: usize) -> Vec<f64> {
    let umax = 10.0f64.min(PI / (2.0 * sigma));
    let tan2 = theta_o.tan().powi(2);
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    integrate(0.0, umax, panels_for(2.0 * sigma * umax, lmax).max(32), 20, |u, w| {
        let f = 2.0 * u * (-u * u).exp() * (1.0 - u * u * tan2 / 2.0) / theta_o.cos() * w;
        legendre_all((2.0 * sigma * u).cos(), &mut p);
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
    fn normal_exitance_tends_to_eq57_and_eq55() {
        let sigma = 0.05;
        let f = normal_exitance(sigma, 40);
        let g = gaussian(sigma, 40);
        // Eq. 53 replaces sin θ by θ; the exact integral keeps −θ³/6, which lowers Λ_0 ρ̂_0 by
        // (8σ²/6) ∫ u³ e^{−u²} du = 2σ²/3, with the next term O(σ⁴).
        let s2 = sigma * sigma;
        assert!((f[0] - (1.0 - 2.0 * s2 / 3.0)).abs() < 2.0 * s2 * s2, "{}", f[0]);
        // eq. 51 → 55: 1 − l(l+1)σ² (the paper rounds l(l+1) to l²) − 2σ²/3 + O((σ(l+1))⁴).
        for l in 1..=6 {
            let x = sigma * (l + 1) as f64;
            let expect = 1.0 - (l * (l + 1)) as f64 * s2 - 2.0 * s2 / 3.0;
            assert!((f[l] - expect).abs() < x.powi(4), "l={l}: {} vs {expect}", f[l]);
        }
        // eq. 57 is an approximation: within a few percent of the peak where it matters.
        for l in 0..=40 {
            assert!((f[l] - g[l]).abs() < 0.05, "l={l}: {} vs {}", f[l], g[l]);
        }
    }

    #[test]
    fn exitance_zero_reduces_to_eq50() {
        let sigma = 0.1;
        let a = exitance(sigma, 0.0, 30, Horizon::Clamp);
        let b = normal_exitance(sigma, 30);
        for l in 0..=30 {
            assert!((a[l] - b[l]).abs() < 1e-9, "l={l}: {} vs {}", a[l], b[l]);
        }
    }

    #[test]
    fn small_exitance_close_to_eq59() {
        let sigma = 0.05;
        let theta_o = 20f64.to_radians();
        let a = exitance(sigma, theta_o, 20, Horizon::Ignore);
        let b = eq59(sigma, theta_o, 20);
        // Both agree with eq. 55 to first order; differences are O(θ_o² (σl)² · small).
        for l in 0..=20 {
            assert!((a[l] - b[l]).abs() < 0.03, "l={l}: {} vs {}", a[l], b[l]);
        }
    }
}
