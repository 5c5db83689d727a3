//! Independent references for the verify unit tests: Bonnet's recurrence and composite Simpson
//! quadrature written out here, sharing no code with `verify::transfer` or `analysis::transfer`
//! (the code the tests check), so a sign, index or normalization slip there cannot cancel.

use std::f64::consts::PI;

/// P_0(x) … P_lmax(x) by Bonnet's recurrence (l+1) P_{l+1} = (2l+1) x P_l − l P_{l−1}.
pub fn legendre(x: f64, lmax: usize) -> Vec<f64> {
    let mut p = vec![1.0, x];
    for l in 1..lmax {
        let next = ((2 * l + 1) as f64 * x * p[l] - l as f64 * p[l - 1]) / (l + 1) as f64;
        p.push(next);
    }
    p.truncate(lmax + 1);
    p
}

/// Λ_l ρ̂_l = 2π ∫_0^{θ_max} ρ̂(θ) P_l(cos θ) sin θ dθ for a kernel ρ̂ radially symmetric about R (the
/// Funk–Hecke form of eq. 15), by composite Simpson with `n` (even) panels: error O((h/w)⁴) for a
/// lobe of angular width w, < 1e-9 for the lobes and n the tests use.
pub fn radial_simpson(rho: impl Fn(f64) -> f64, theta_max: f64, lmax: usize, n: usize) -> Vec<f64> {
    assert!(n.is_multiple_of(2));
    let h = theta_max / n as f64;
    let mut out = vec![0.0; lmax + 1];
    for i in 0..=n {
        let t = i as f64 * h;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let f = rho(t) * t.sin() * w * h / 3.0 * 2.0 * PI;
        for (o, p) in out.iter_mut().zip(legendre(t.cos(), lmax)) {
            *o += f * p;
        }
    }
    out
}

/// The normalized Phong lobe (s+1)/(2π) cosˢ θ about R, with no horizon (eq. 40, eq. 43's setting).
pub fn phong_by_quadrature(s: f64, lmax: usize) -> Vec<f64> {
    radial_simpson(|t| (s + 1.0) / (2.0 * PI) * t.cos().max(0.0).powf(s), 0.5 * PI, lmax, 20_000)
}

/// Torrance–Sparrow at normal exitance (θ_h = θ_i/2, k_s = 1): ρ̂ = exp(−θ²/4σ²)/(4πσ²) above the
/// horizon (eq. 48 × cos θ_i at θ_o = 0, eq. 50's integrand).
pub fn torrance_sparrow_by_quadrature(sigma: f64, lmax: usize) -> Vec<f64> {
    radial_simpson(|t| (-(t * t) / (4.0 * sigma * sigma)).exp() / (4.0 * PI * sigma * sigma), 0.5 * PI, lmax, 20_000)
}

/// A deterministic ±σ pattern (−1, +1, +½, −½, …) added to exact values, so the "passes" half of a
/// test sees scatter of the size it must tolerate, not exact agreement.
pub fn scatter(v: &[f64], sigma: f64) -> Vec<f64> {
    v.iter().enumerate().map(|(i, x)| x + sigma * [-1.0, 1.0, 0.5, -0.5][i % 4]).collect()
}

#[test]
fn references_reproduce_known_closed_forms() {
    // Lambert (docs/src/conventions.md §4): 1, 2/3, 1/4, 0, −1/24, 0, 1/64.
    let lam = radial_simpson(|t| t.cos() / PI, 0.5 * PI, 6, 2000);
    for (a, b) in lam.iter().zip([1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0, 0.0, 1.0 / 64.0]) {
        assert!((a - b).abs() < 1e-10, "{a} vs {b}");
    }
    // Phong s = 1: (s+1)∫_0^1 μ P_l dμ = 1, 2/3, 1/4 (the Lambert lobe).
    let p = phong_by_quadrature(1.0, 2);
    assert!((p[0] - 1.0).abs() < 1e-10 && (p[1] - 2.0 / 3.0).abs() < 1e-10 && (p[2] - 0.25).abs() < 1e-10);
}
