//! Special functions the analysis and the verifier share, in f64.
//!
//! - [`erfc`]: the complementary error function for x ≥ 0 (Beckmann's Smith Λ, Gaussian tail
//!   probabilities). Not on any hot path: the renderer keeps its own f32-path approximation.
//! - [`sidak_k`], [`pixel_family_k`]: k of a k·σ rule over many comparisons (Šidák, Student t).
//! - [`chi2_survival`], [`gamma_q`], [`ln_gamma`]: χ² tail probabilities (the renderer's sampling
//!   χ² tests, the separation's consistency p-value, two-sided χ² bounds in tests).
//! - [`student_t_central`], [`binomial_cdf`]: the coverage P(|t_ν| < k) of a k·σ̂ error bar whose σ̂
//!   has ν degrees of freedom, and the binomial limits of a count of covered pixels (error-bar
//!   coverage tests).
//! - [`beta_i`], [`student_t_two_sided_tail`], [`normal_score`]: Student-t tail probabilities and
//!   their Gaussian equivalents (the z of `compare` when a variance is estimated from few samples).

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

/// Two-sided Gaussian tail P(|Z| > k) = erfc(k/√2).
pub fn normal_two_sided_tail(k: f64) -> f64 {
    erfc(k / std::f64::consts::SQRT_2)
}

/// The k of a two-sided k·σ rule applied to `n` independent comparisons such that all pass with
/// probability 1 − `alpha` when every null hypothesis holds (Šidák: per-comparison tail
/// 1 − (1 − α)^{1/n}), for Gaussian errors with known σ. Bisection on [0, 40], to f64 precision.
pub fn sidak_k(n: usize, alpha: f64) -> f64 {
    let per_row = 1.0 - (1.0 - alpha).powf(1.0 / n.max(1) as f64);
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if normal_two_sided_tail(mid) > per_row { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// Student-t quantile with ν degrees of freedom at the same tail probability as the Gaussian
/// quantile z, by the Cornish–Fisher expansion (Abramowitz & Stegun 26.7.5, terms to ν⁻³):
/// the k to use when σ is itself estimated from ν + 1 samples (a pixel's standard error from its
/// spp samples). Accurate to < 1e-3 for ν ≥ 30 and z ≤ 6.
pub fn student_t_from_normal(z: f64, nu: f64) -> f64 {
    let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
    z + (z3 + z) / (4.0 * nu)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * nu * nu)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * nu.powi(3))
}

/// k for `n` per-pixel comparisons of a pixel mean with a known value, each pixel's σ estimated from
/// `spp` independent samples: Šidák's k for family-wise false-alarm rate `alpha`, widened to the
/// Student-t quantile with spp − 1 degrees of freedom.
pub fn pixel_family_k(n: usize, spp: u32, alpha: f64) -> f64 {
    student_t_from_normal(sidak_k(n, alpha), spp.saturating_sub(1).max(1) as f64)
}

/// P(χ²_k > x): the regularized upper incomplete gamma Q(k/2, x/2).
pub fn chi2_survival(x: f64, k: f64) -> f64 {
    if !x.is_finite() {
        return 0.0;
    }
    gamma_q(0.5 * k, 0.5 * x)
}

/// ln Γ(x) for x > 0.
pub fn ln_gamma(x: f64) -> f64 {
    // Lanczos approximation (g = 7, n = 9), accurate to ~1e-15 for x > 0.
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularized upper incomplete gamma function Q(a, x) (series / continued fraction).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let lg = ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - lg).exp()
    } else {
        // Lentz's continued fraction.
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - lg).exp() * h
    }
}

/// P(|T| < t) for Student's t with `nu` ≥ 1 degrees of freedom, t ≥ 0: the coverage of a k·σ̂
/// interval about a normal mean when σ̂² has ν degrees of freedom (ν → ∞: 1 − erfc(k/√2)); the
/// complement of [`student_t_two_sided_tail`].
pub fn student_t_central(t: f64, nu: u32) -> f64 {
    assert!(nu >= 1, "Student t needs ν ≥ 1");
    1.0 - student_t_two_sided_tail(t, f64::from(nu))
}

/// P(X ≤ k) for X ~ Binomial(n, p), 0 ≤ p ≤ 1: the sum of the probability masses (in logs, by
/// [`ln_gamma`]) on the shorter side of the mean. Accurate to ~1e-12 relative for n up to 10⁷.
pub fn binomial_cdf(k: u64, n: u64, p: f64) -> f64 {
    if k >= n || p <= 0.0 {
        return 1.0;
    }
    if p >= 1.0 {
        return 0.0;
    }
    let ln_choose = |i: u64| ln_gamma(n as f64 + 1.0) - ln_gamma(i as f64 + 1.0) - ln_gamma((n - i) as f64 + 1.0);
    let pmf = |i: u64| (ln_choose(i) + i as f64 * p.ln() + (n - i) as f64 * (1.0 - p).ln()).exp();
    if (k as f64) < n as f64 * p {
        (0..=k).map(pmf).sum::<f64>().min(1.0)
    } else {
        (1.0 - (k + 1..=n).map(pmf).sum::<f64>()).max(0.0)
    }
}

/// The regularized incomplete beta function I_x(a, b), 0 ≤ x ≤ 1, a, b > 0: the continued
/// fraction of Abramowitz & Stegun 26.5.8 evaluated by Lentz's method, on the side of the symmetry
/// I_x(a, b) = 1 − I_{1−x}(b, a) where it converges fast (x < (a + 1)/(a + b + 2)).
pub fn beta_i(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front = |x: f64, a: f64, b: f64| {
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp() / a
    };
    if x > (a + 1.0) / (a + b + 2.0) {
        return 1.0 - front(1.0 - x, b, a) * beta_fraction(1.0 - x, b, a);
    }
    front(x, a, b) * beta_fraction(x, a, b)
}

/// The continued fraction 1/(1 + d₁/(1 + d₂/(1 + …))) of I_x(a, b) (A&S 26.5.8), by Lentz's method.
fn beta_fraction(x: f64, a: f64, b: f64) -> f64 {
    let tiny = 1e-300;
    let clamp = |v: f64| if v.abs() < tiny { tiny } else { v };
    let (mut c, mut d) = (1.0, 1.0 / clamp(1.0 - (a + b) * x / (a + 1.0)));
    let mut h = d;
    for m in 1..10_000 {
        let m = m as f64;
        // Even step d_{2m}, then odd step d_{2m+1}.
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        d = 1.0 / clamp(1.0 + even * d);
        c = clamp(1.0 + even / c);
        h *= d * c;
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        d = 1.0 / clamp(1.0 + odd * d);
        c = clamp(1.0 + odd / c);
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// P(|T| > t) for Student's t with ν > 0 degrees of freedom: I_{ν/(ν + t²)}(ν/2, 1/2)
/// (A&S 26.7.1); ν = ∞ (or above 10⁷) is the Gaussian [`normal_two_sided_tail`].
pub fn student_t_two_sided_tail(t: f64, nu: f64) -> f64 {
    let t = t.abs();
    if nu > 1e7 {
        return normal_two_sided_tail(t);
    }
    beta_i(nu / (nu + t * t), 0.5 * nu, 0.5)
}

/// The Gaussian score of a Student-t value: the u with P(|Z| > |u|) = P(|T_ν| > |t|) and the sign
/// of t, so that a t with ν degrees of freedom becomes an N(0, 1) variate (a χ² of such scores has
/// its nominal distribution however few samples estimated each variance). ν = ∞ returns t. |u| is
/// capped at 38 (a tail probability below f64's smallest normal number).
pub fn normal_score(t: f64, nu: f64) -> f64 {
    if nu > 1e7 || t == 0.0 {
        return t;
    }
    let p = student_t_two_sided_tail(t, nu);
    let (mut lo, mut hi) = (0.0, 38.0);
    if p > 0.0 {
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if normal_two_sided_tail(mid) > p { lo = mid } else { hi = mid }
        }
    } else {
        lo = 38.0;
    }
    (0.5 * (lo + hi)).copysign(t).clamp(-38.0, 38.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn student_t_tail_and_normal_score_reference_values() {
        // By midpoint quadrature of the t density (2·10⁵ steps): (2.0, 5) → 0.10193948, (3.0, 10) → 0.01334366; (1.0, 1) → 0.5 exactly.
        assert!((student_t_two_sided_tail(2.0, 5.0) - 0.101_939_48).abs() < 1e-7);
        assert!((student_t_two_sided_tail(3.0, 10.0) - 0.013_343_66).abs() < 1e-7);
        assert!((student_t_two_sided_tail(1.0, 1.0) - 0.5).abs() < 1e-12);
        // Large ν approaches the Gaussian; the score of a t inverts the tail.
        // (the difference is ≈ 2φ(t)(t³ + t)/(4ν) = 1.6e-6 at ν = 1e5)
        assert!((student_t_two_sided_tail(2.5, 1e5) - normal_two_sided_tail(2.5)).abs() < 3e-6);
        let u = normal_score(-3.0, 10.0);
        assert!(u < 0.0 && (normal_two_sided_tail(-u) - 0.013_343_66).abs() < 1e-8, "{u}");
        assert_eq!(normal_score(1.5, f64::INFINITY), 1.5);
        // I_x(a, b) symmetry and a closed form: I_x(1, b) = 1 − (1 − x)^b.
        assert!((beta_i(0.3, 1.0, 4.0) - (1.0 - 0.7f64.powi(4))).abs() < 1e-13);
        assert!((beta_i(0.8, 2.5, 1.5) + beta_i(0.2, 1.5, 2.5) - 1.0).abs() < 1e-13);
    }

    #[test]
    fn sidak_and_student_t_reference_values() {
        // One comparison at α = 6.334e-5 is the 4σ rule; Šidák for n = 81 keeps the family rate.
        assert!((sidak_k(1, 6.334_248_366_623_996e-5) - 4.0).abs() < 1e-9);
        let k = sidak_k(81, 1e-3);
        assert!(((1.0 - normal_two_sided_tail(k)).powi(81) - (1.0 - 1e-3)).abs() < 1e-12);
        // Student t quantiles: by quadrature of the t density: ν = 63, two-sided 1e-3 → 3.45177; ν = 30, 1e-4 → 4.48242.
        let z = sidak_k(1, 1e-3);
        assert!((student_t_from_normal(z, 63.0) - 3.45177).abs() < 1e-3, "{}", student_t_from_normal(z, 63.0));
        let z = sidak_k(1, 1e-4);
        assert!((student_t_from_normal(z, 30.0) - 4.48242).abs() < 1e-3, "{}", student_t_from_normal(z, 30.0));
    }

    #[test]
    fn erfc_reference_values() {
        // Python math.erfc, on both sides of the switch at 2.5 and in the tail.
        assert!((erfc(0.0) - 1.0).abs() < 1e-15);
        assert!((erfc(0.5) - 0.479_500_122_186_953_5).abs() < 1e-14);
        assert!((erfc(2.4) - 6.885_138_966_450_789e-4).abs() < 1e-15);
        assert!((erfc(2.6) - 2.360_344_165_293_490_8e-4).abs() < 1e-15);
        assert!((erfc(4.0 / std::f64::consts::SQRT_2) / 6.334_248_366_623_996e-5 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn student_t_and_binomial_reference_values() {
        // Closed forms: ν = 1 (Cauchy) (2/π) atan t, ν = 2 t/√(2 + t²); ν = 15 and 63 by Simpson
        // quadrature of the t density (2·10⁵ intervals); large ν tends to the normal.
        for t in [0.5, 1.0, 3.0] {
            assert!((student_t_central(t, 1) - 2.0 / PI * f64::atan(t)).abs() < 1e-14);
            assert!((student_t_central(t, 2) - t / (2.0 + t * t).sqrt()).abs() < 1e-14);
        }
        for (nu, want) in [
            (15, [0.666_829_864_084_520_8, 0.936_054_992_715_286_5, 0.991_027_262_522_779_1]),
            (63, [0.678_863_968_417_371_7, 0.950_184_236_300_957_6, 0.996_136_161_523_887_4]),
        ] {
            for (k, w) in want.iter().enumerate() {
                let got = student_t_central(k as f64 + 1.0, nu);
                assert!((got - w).abs() < 1e-10, "ν {nu}, t {}: {got} vs {w}", k + 1);
            }
        }
        assert!((student_t_central(2.0, 100_000) - (1.0 - normal_two_sided_tail(2.0))).abs() < 1e-5);
        // Exact sums (Python's math.comb): P(X ≤ 5) for Bin(100, 0.03), P(X ≤ 40) for Bin(4096, 0.009).
        assert!((binomial_cdf(5, 100, 0.03) - 0.919_162_871_098_624).abs() < 1e-11);
        assert!((binomial_cdf(40, 4096, 0.009) - 0.732_000_335_538_828_6).abs() < 1e-11);
        assert_eq!(binomial_cdf(100, 100, 0.5), 1.0);
    }
}
