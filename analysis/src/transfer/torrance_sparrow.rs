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

/// Eq. 50 by quadrature, l = 0 … lmax. Integrated in u = θ/σ,
/// Λ_l ρ̂_l = ∫_0^{min(20, π/2σ)} e^{−u²/4}/2 · (sin σu)/σ · P_l(cos σu) du,
/// so that no 1/σ² is ever formed: finite for every σ > 0 (σ → 0 tends to the mirror's 1, and for
/// σ ≳ 1e154 the coefficients, ~1/(2σ²), underflow to 0 honestly).
pub fn normal_exitance(sigma: f64, lmax: usize) -> Vec<f64> {
    // exp(−θ²/4σ²) < e⁻¹⁰⁰ beyond θ = 20σ.
    let umax = 20.0f64.min(PI / (2.0 * sigma));
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    integrate(0.0, umax, panels_for(sigma * umax, lmax).max(32), 20, |u, w| {
        let t = sigma * u;
        let f = (-u * u / 4.0).exp() / 2.0 * (t.sin() / sigma) * w;
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
///
/// Written for every σ > 0: the polar angle t about R is integrated in u = t/σ (so the lobe's
/// 1/σ² normalisation is never formed, as in [`normal_exitance`]), and the half angle comes from
/// the components of h = ω_i + ω_o in the frame of n, h = 2 cos θ_o n − (1 − cos t) R + sin t v
/// (R + ω_o = 2 cos θ_o n, v ⊥ R the unit azimuth vector), with 1 − cos t = 2 sin²(t/2), and
/// θ'_h = atan2(|h_⊥|, h_n): exact to rounding for any t, where acos(ĥ·n) loses all digits of
/// θ'_h below ~1e-8.
pub fn exitance(sigma: f64, theta_o: f64, lmax: usize, horizon: Horizon) -> Vec<f64> {
    let (so, co) = theta_o.sin_cos();
    // exp(−(θ'_h/σ)²) with θ'_h ≥ t/2 · cos-ish: beyond t = 24σ below e⁻¹⁰⁰ for θ_o < 90°.
    let umax = 24.0f64.min(PI / sigma);
    let nphi = 256;
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    let norm = 1.0 / (4.0 * PI * co);
    integrate(0.0, umax, panels_for(sigma * umax, lmax).max(48), 20, |u, w| {
        let t = sigma * u;
        let (st, ct) = t.sin_cos();
        let omc = 2.0 * (0.5 * t).sin().powi(2);
        let mut ring = 0.0;
        for j in 0..nphi {
            let phi = 2.0 * PI * (j as f64 + 0.5) / nphi as f64;
            let (sp, cp) = phi.sin_cos();
            // ω_i = cos t R + sin t (cos φ t1 + sin φ t2), R = (−sin θ_o, 0, cos θ_o),
            // t1 = (cos θ_o, 0, sin θ_o), t2 = (0, 1, 0); n = z.
            let cos_i = ct * co + st * cp * so;
            if horizon == Horizon::Clamp && cos_i <= 0.0 {
                continue;
            }
            let (hx, hy, hz) = (omc * so + st * cp * co, st * sp, 2.0 * co - omc * co + st * cp * so);
            let h_perp = hx.hypot(hy);
            if h_perp.hypot(hz) <= 1e-12 {
                continue;
            }
            let th = h_perp.atan2(hz);
            ring += (-(th / sigma).powi(2)).exp();
        }
        let f = ring * 2.0 * PI / nphi as f64 * norm * (st / sigma) * w;
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

    /// σ → 0 is the mirror (Λ_l ρ̂_l → 1, eq. 55) at any exitance, and nothing in the quadrature
    /// may overflow on the way: before the u = θ/σ form, σ = 1e-160 gave 1/(2σ²) = inf and NaN,
    /// and the acos half angle lost every digit below σ ≈ 1e-8.
    #[test]
    fn tiny_sigma_tends_to_the_mirror_at_any_exitance() {
        for sigma in [1e-6, 1e-9, 1e-160, 1e-300] {
            let f = normal_exitance(sigma, 8);
            for (l, v) in f.iter().enumerate() {
                // eq. 55: 1 − l(l+1)σ² − 2σ²/3; at σ = 1e-6 that is 1 − 7.3e-11 at l = 8.
                let expect = 1.0 - (l * (l + 1)) as f64 * sigma * sigma - 2.0 * sigma * sigma / 3.0;
                assert!((v - expect).abs() < 1e-13, "σ={sigma} l={l}: {v} vs {expect}");
            }
            for theta_o in [30f64.to_radians(), 80f64.to_radians()] {
                let g = exitance(sigma, theta_o, 8, Horizon::Clamp);
                // The lobe integrates to 1 (the mirror) up to O((σ l)²) and the quadrature's 1e-12.
                for (l, v) in g.iter().enumerate() {
                    assert!((v - 1.0).abs() < 1e-9, "σ={sigma} θ_o={theta_o} l={l}: {v}");
                }
            }
        }
        // Through the model: the mirror-limit switch is continuous (both sides within 1e-15).
        use crate::transfer::{MIRROR_LIMIT_SIGMA_L, TransferModel};
        let lmax = 10;
        let s0 = MIRROR_LIMIT_SIGMA_L / (lmax as f64 + 1.0);
        let below = TransferModel::TorranceSparrow { sigma: 0.99 * s0, theta_o: 0.0 }.lambda_rho(lmax);
        let above = TransferModel::TorranceSparrow { sigma: 1.01 * s0, theta_o: 0.0 }.lambda_rho(lmax);
        for l in 0..=lmax {
            assert!((below[l] - above[l]).abs() < 1e-15, "l={l}: {} vs {}", below[l], above[l]);
        }
    }

    /// Huge σ: the coefficients ~ 1/(2σ²) (exactly ∫_0^{π/2} P_l sin θ dθ / 2σ² as the lobe flattens)
    /// stay finite and underflow to 0 honestly, never NaN.
    #[test]
    fn huge_sigma_is_finite() {
        for sigma in [10.0, 1e100, 1e200, f64::MAX] {
            let f = normal_exitance(sigma, 6);
            assert!(f.iter().all(|v| v.is_finite()), "σ={sigma}: {f:?}");
            // l = 0: ∫_0^{π/2} e^{−θ²/4σ²} sin θ dθ / 2σ² = (1 − (π − 2)/(4σ²) + O(σ⁻⁴)) / (2σ²)
            // (∫_0^{π/2} θ² sin θ dθ = π − 2); the O term is < 1e-5 relative at σ = 10.
            let expect = (1.0 - (std::f64::consts::PI - 2.0) / (4.0 * sigma * sigma)) / (2.0 * sigma * sigma);
            assert!((f[0] - expect).abs() <= 1e-5 * expect, "σ={sigma}: {} vs {expect}", f[0]);
            let g = exitance(sigma.min(1e100), 0.5, 4, Horizon::Clamp);
            assert!(g.iter().all(|v| v.is_finite()), "σ={sigma}: {g:?}");
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
