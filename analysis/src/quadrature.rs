//! Gauss–Legendre quadrature and Legendre polynomials, the numerical workhorses of the crate.
//!
//! - [`gauss_legendre`]`(n)`: nodes and weights on [−1, 1], exact for polynomials of degree ≤ 2n − 1,
//!   found by Newton iteration on P_n from the Tricomi initial guesses (no tables, any n).
//! - [`legendre_all`]`(x, out)`: P_0(x) … P_L(x) by Bonnet's recurrence (stable for |x| ≤ 1, any L).
//! - [`integrate`]: composite Gauss–Legendre over [a, b] in `panels` panels of `n` nodes, for smooth
//!   but oscillatory integrands (e.g. P_100(cos θ)).

use std::f64::consts::PI;

/// Nodes x_i and weights w_i of the n-point Gauss–Legendre rule on [−1, 1], in increasing x.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n > 0, "Gauss–Legendre rule needs at least one node");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        // Tricomi's approximation of the i-th root (counted from x = 1), then Newton on P_n.
        let mut z = ((i as f64 + 0.75) / (nf + 0.5) * PI).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, z);
            dp = d;
            let dz = p / d;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, z);
        if d.is_finite() {
            dp = d;
        }
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    if n % 2 == 1 {
        x[n / 2] = 0.0;
    }
    (x, w)
}

/// P_n(x) and P_n'(x) for |x| < 1.
fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

/// Writes P_l(x) for l < out.len() (Bonnet: (l+1) P_{l+1} = (2l+1) x P_l − l P_{l−1}).
#[inline]
pub fn legendre_all(x: f64, out: &mut [f64]) {
    if out.is_empty() {
        return;
    }
    out[0] = 1.0;
    if out.len() > 1 {
        out[1] = x;
    }
    for l in 1..out.len().saturating_sub(1) {
        let lf = l as f64;
        out[l + 1] = ((2.0 * lf + 1.0) * x * out[l] - lf * out[l - 1]) / (lf + 1.0);
    }
}

/// Composite Gauss–Legendre: ∫_a^b f(x) dx with `panels` equal panels of an `n`-point rule.
/// `f` receives (x, weight) pairs and accumulates itself, so vector-valued integrands cost one pass.
pub fn integrate(a: f64, b: f64, panels: usize, n: usize, mut f: impl FnMut(f64, f64)) {
    let (x, w) = gauss_legendre(n);
    let h = (b - a) / panels as f64;
    for p in 0..panels {
        let lo = a + h * p as f64;
        for i in 0..n {
            f(lo + 0.5 * h * (x[i] + 1.0), 0.5 * h * w[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_degree_2n_minus_1() {
        for n in [1usize, 2, 5, 16, 64, 200] {
            let (x, w) = gauss_legendre(n);
            for deg in [0usize, 1, 2, 2 * n - 2, 2 * n - 1].into_iter().filter(|&d| d < 2 * n) {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = if deg % 2 == 1 { 0.0 } else { 2.0 / (deg as f64 + 1.0) };
                assert!((got - exact).abs() < 1e-13, "n={n} deg={deg}: {got} vs {exact}");
            }
        }
    }

    #[test]
    fn legendre_orthogonality() {
        let (x, w) = gauss_legendre(60);
        let mut p = vec![0.0; 40];
        let mut gram = vec![0.0; 40 * 40];
        for (xi, wi) in x.iter().zip(&w) {
            legendre_all(*xi, &mut p);
            for a in 0..40 {
                for b in 0..40 {
                    gram[a * 40 + b] += wi * p[a] * p[b];
                }
            }
        }
        for a in 0..40 {
            for b in 0..40 {
                let e = if a == b { 2.0 / (2.0 * a as f64 + 1.0) } else { 0.0 };
                assert!((gram[a * 40 + b] - e).abs() < 1e-13);
            }
        }
    }
}
