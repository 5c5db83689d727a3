//! Normalized Phong transfer coefficients (ρ̂ = (s+1)/(2π) max(R·ω_i, 0)^s, eq. 40).
//!
//! Eq. 43 written as a product of ratios, each of magnitude < 1:
//! Λ_l ρ̂_l = Λ_{l−2} ρ̂_{l−2} · (s − l + 2)/(s + l + 1), with Λ_0 ρ̂_0 = 1 and Λ_1 ρ̂_1 = (s+1)/(s+2).
//! (Odd l: (s+1)(s−1)…(s−l+2) / ((s+2)(s+4)…(s+l+1)); even l: s(s−2)…(s−l+2) / ((s+3)…(s+l+1)).)
//! So nothing overflows for s up to 10⁴ and beyond, there is no subtraction of large terms, and the
//! relative error grows only by one rounding per step. For integer s the factor (s − l + 2) vanishes
//! at l = s + 2, giving the exact zeros at l ≥ s + 2, l ≡ s (mod 2).
//!
//! [`gaussian`] is the approximation exp(−l²/2s) of eq. 46; [`numerical`] integrates eq. 42
//! directly ((s+1) ∫_0^1 u^s P_l(u) du) for checking.

use crate::quadrature::{gauss_legendre, legendre_all};

/// Λ_l ρ̂_l of eq. 43, l = 0 … lmax.
pub fn phong(s: f64, lmax: usize) -> Vec<f64> {
    let mut f = vec![0.0; lmax + 1];
    for l in 0..=lmax {
        f[l] = match l {
            0 => 1.0,
            1 => (s + 1.0) / (s + 2.0),
            _ => f[l - 2] * (s - l as f64 + 2.0) / (s + l as f64 + 1.0),
        };
    }
    f
}

/// Eq. 46: exp(−l² / 2s).
pub fn gaussian(s: f64, lmax: usize) -> Vec<f64> {
    (0..=lmax).map(|l| (-((l * l) as f64) / (2.0 * s)).exp()).collect()
}

/// Eq. 42 by n-point Gauss–Legendre on [0, 1] (exact when s is an integer and s + l < 2n).
pub fn numerical(s: f64, lmax: usize, n: usize) -> Vec<f64> {
    let (x, w) = gauss_legendre(n);
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    for (xi, wi) in x.iter().zip(&w) {
        let u = 0.5 * (xi + 1.0);
        legendre_all(u, &mut p);
        let f = (s + 1.0) * u.powf(s) * 0.5 * wi;
        for l in 0..=lmax {
            out[l] += f * p[l];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_direct_integration() {
        for s in [1.0, 8.0, 32.0, 128.0] {
            let lmax = 40;
            let exact = phong(s, lmax);
            // Integer s: integrand is a polynomial of degree s + l ≤ 168 < 2·120.
            let num = numerical(s, lmax, 120);
            for l in 0..=lmax {
                // 1e-10 relative; at the exact zeros the quadrature's rounding (~1e-16) is all there is.
                let tol = (1e-10 * exact[l].abs()).max(1e-14);
                assert!((exact[l] - num[l]).abs() <= tol, "s={s} l={l}: {} vs {}", exact[l], num[l]);
            }
        }
    }

    #[test]
    fn exact_zeros_for_integer_s() {
        for s in [1usize, 2, 5, 8, 32] {
            let f = phong(s as f64, 100);
            for l in 0..=100 {
                if l >= s + 2 && l % 2 == s % 2 {
                    assert_eq!(f[l], 0.0, "s={s} l={l}");
                } else {
                    assert_ne!(f[l], 0.0, "s={s} l={l}");
                }
            }
        }
    }

    #[test]
    fn lambert_is_phong_with_s_1() {
        let a = phong(1.0, 12);
        let b = crate::transfer::lambert::lambert(12);
        for l in 0..=12 {
            assert!((a[l] - b[l]).abs() < 1e-15);
        }
    }

    /// s → ∞ is the mirror (Λ_l ρ̂_l → 1) and s → 0 the uniform lobe: both ends of the range give
    /// finite values (the ratio recurrence never forms s! or Γ(s)).
    #[test]
    fn ends_of_the_exponent_range_are_finite() {
        for s in [1e18, 1e300, f64::MAX] {
            let f = phong(s, 64);
            assert!(f.iter().all(|v| (v - 1.0).abs() < 1e-14), "s={s}: {f:?}");
        }
        let f = phong(1e-300, 64);
        assert!(f.iter().all(|v| v.is_finite() && v.abs() <= 1.0), "{f:?}");
        // s → 0: ρ̂ = 1/2π on the hemisphere, Λ_1 ρ̂_1 = ∫_0^1 u du = 1/2.
        assert!((f[1] - 0.5).abs() < 1e-15, "{}", f[1]);
    }

    #[test]
    fn large_s_neither_overflows_nor_loses_precision() {
        let s = 1.0e4;
        let f = phong(s, 100);
        assert!(f.iter().all(|v| v.is_finite() && *v > 0.0 && *v <= 1.0));
        // Eq. 45: log Λρ̂ = −l²(1/2s − 1/2s²) + O(l⁴/s²); at l = 100, s = 10⁴ the O term is ~1e-2·…
        // check against the Gamma-function form (eq. 44) evaluated with lgamma-free products in
        // long double-free f64: compare with a product computed in the opposite order.
        let mut g = 1.0f64;
        for j in (1..=50).rev() {
            let l = 2 * j;
            g *= (s - l as f64 + 2.0) / (s + l as f64 + 1.0);
        }
        assert!((f[100] - g).abs() < 1e-13 * g, "{} vs {g}", f[100]);
        // Independent check: eq. 41 integrated in θ (composite Gauss resolving the 1/√s-wide lobe).
        let num =
            crate::transfer::radial::radial(|t| (s + 1.0) / (2.0 * std::f64::consts::PI) * t.cos().powf(s), 0.2, 100);
        for l in 0..=100 {
            assert!((num[l] - f[l]).abs() < 1e-10 * f[l], "l={l}: {} vs {}", num[l], f[l]);
        }
        // and the Gaussian limit of eq. 46 to within its stated O(l²/s²) correction
        let approx = (-(100.0f64 * 100.0) / (2.0 * s)).exp();
        assert!((f[100] / approx - 1.0).abs() < 0.02, "{} vs eq.46 {approx}", f[100]);
    }
}
