//! Lambertian transfer coefficients, eq. 38 in closed form.
//!
//! For BRDF = 1 (transfer function max(cos θ'_i, 0)) the irradiance kernel is A_l = Λ_l ρ̂_l:
//! A_0 = π, A_1 = 2π/3, A_l = 0 for odd l > 1, and for even l
//! A_l = 2π (−1)^{l/2−1} / ((l+2)(l−1)) · l! / (2^l (l/2)!²)   (eq. 38 × Λ_l; eq. 39 numbers).
//! The central binomial ratio l!/(2^l (l/2)!²) is built by its recurrence ×(l+1)/(l+2) per step of
//! 2, never from factorials, so any l is exact to rounding. For BRDF = albedo/π divide by π:
//! 1, 2/3, 1/4, 0, −1/24, 0, 1/64, … (docs/src/conventions.md §4).

use std::f64::consts::PI;

/// A_l for BRDF = 1 (eq. 39: π, 2π/3, π/4, 0, −π/24, 0, π/64, …).
pub fn irradiance_kernel(lmax: usize) -> Vec<f64> {
    let mut a = vec![0.0; lmax + 1];
    let mut central = 1.0; // l!/(2^l (l/2)!²) at l = 0
    for l in 0..=lmax {
        if l % 2 == 0 {
            if l > 0 {
                central *= (l as f64 - 1.0) / l as f64; // C(l) = C(l−2) (l−1)/l
            }
            let sign = if (l / 2) % 2 == 1 { 1.0 } else { -1.0 }; // (−1)^{l/2 − 1}
            a[l] = 2.0 * PI * sign / ((l as f64 + 2.0) * (l as f64 - 1.0)) * central;
        } else if l == 1 {
            a[l] = 2.0 * PI / 3.0;
        }
    }
    a
}

/// Λ_l ρ̂_l for a Lambertian BRDF of unit albedo (BRDF = 1/π).
pub fn lambert(lmax: usize) -> Vec<f64> {
    irradiance_kernel(lmax).into_iter().map(|a| a / PI).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq38_values_for_unit_albedo() {
        let expect = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0, 0.0, 1.0 / 64.0, 0.0, -1.0 / 128.0];
        let got = lambert(8);
        for l in 0..=8 {
            assert!((got[l] - expect[l]).abs() < 1e-15, "l={l}: {} vs {}", got[l], expect[l]);
        }
    }

    #[test]
    #[allow(clippy::approx_constant)] // the paper's printed 3-digit numbers
    fn eq39_numbers() {
        let expect = [3.142, 2.094, 0.785, 0.0, -0.131, 0.0, 0.049];
        let got = irradiance_kernel(6);
        for l in 0..=6 {
            assert!((got[l] - expect[l]).abs() < 5e-4, "l={l}: {} vs {}", got[l], expect[l]);
        }
    }

    #[test]
    fn energy_127_128_in_first_three_orders() {
        // Energy of the clamped cosine max(cos θ, 0)/π: Σ_l (2l+1)/(4π) A_l²/π²·… — with
        // ρ̂_l = A_l/Λ_l the L² norm is Σ ρ̂_l², and ∫ cos²θ over the hemisphere = 2π/3.
        let a = irradiance_kernel(2000);
        let lam2 = |l: usize| 4.0 * PI / (2.0 * l as f64 + 1.0);
        let energy = |ls: std::ops::RangeInclusive<usize>| ls.map(|l| a[l] * a[l] / lam2(l)).sum::<f64>();
        let total = 2.0 * PI / 3.0;
        assert!((energy(0..=2000) - total).abs() < 1e-7 * total, "Parseval: {} vs {total}", energy(0..=2000));
        let frac = energy(0..=2) / total;
        assert!((frac - 127.0 / 128.0).abs() < 1e-14, "fraction in l ≤ 2: {frac}");
    }
}
