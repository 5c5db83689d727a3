//! The measured filter: per-order estimates of Λ_l ρ̂_l from measured B_lm and lighting L_lm.
//!
//! Eq. 15 says B_lm = f_l L_lm for every m of order l, so f_l is the least-squares slope over m:
//! f̂_l = Σ_m B_lm L_lm / Σ_m L_lm², i.e. each m weighted by the lighting's energy in it. Its
//! standard error propagates the B_lm standard errors, √(Σ_m L_lm² σ_lm²) / Σ_m L_lm², or, without
//! them, the scatter of the residuals over m (2l degrees of freedom; none at l = 0). An order is
//! unobservable when Σ_m L_lm² ≤ `rel_tol` × the largest order energy: L has no energy there, so
//! any f_l fits (the paper's factorization ambiguity, sec. 3.4).
//! Each RGB channel is estimated separately.

use crate::sh::index;

/// Estimate for one order l.
#[derive(Clone, Debug, PartialEq)]
pub struct OrderEstimate {
    pub l: usize,
    /// Σ_m L_lm² per channel.
    pub energy: [f64; 3],
    /// f̂_l per channel, `None` where the order is unobservable.
    pub estimate: [Option<f64>; 3],
    /// Standard error of f̂_l (`None` if unobservable or not estimable).
    pub stderr: [Option<f64>; 3],
}

impl OrderEstimate {
    pub fn observable(&self) -> bool {
        self.estimate.iter().any(|e| e.is_some())
    }
}

/// Per-order filter estimates for l = 0 … lmax (both inputs must have at least (lmax+1)² entries).
pub fn measured_filter(
    b: &[[f64; 3]],
    b_stderr: Option<&[[f64; 3]]>,
    lighting: &[[f64; 3]],
    lmax: usize,
    rel_tol: f64,
) -> Vec<OrderEstimate> {
    let energy: Vec<[f64; 3]> = (0..=lmax)
        .map(|l| {
            let mut e = [0.0; 3];
            for m in -(l as i64)..=(l as i64) {
                let c = lighting[index(l, m)];
                for ch in 0..3 {
                    e[ch] += c[ch] * c[ch];
                }
            }
            e
        })
        .collect();
    let emax: Vec<f64> = (0..3).map(|ch| energy.iter().map(|e| e[ch]).fold(0.0, f64::max)).collect();
    (0..=lmax)
        .map(|l| {
            let mut est = [None; 3];
            let mut se = [None; 3];
            for ch in 0..3 {
                let e = energy[l][ch];
                if !(e > rel_tol * emax[ch]) || e == 0.0 {
                    continue;
                }
                let mut num = 0.0;
                for m in -(l as i64)..=(l as i64) {
                    let k = index(l, m);
                    num += b[k][ch] * lighting[k][ch];
                }
                let f = num / e;
                est[ch] = Some(f);
                se[ch] = match b_stderr {
                    Some(s) => {
                        let v: f64 = (-(l as i64)..=(l as i64))
                            .map(|m| {
                                let k = index(l, m);
                                (lighting[k][ch] * s[k][ch]).powi(2)
                            })
                            .sum();
                        Some(v.sqrt() / e)
                    }
                    None if l > 0 => {
                        let rss: f64 = (-(l as i64)..=(l as i64))
                            .map(|m| {
                                let k = index(l, m);
                                (b[k][ch] - f * lighting[k][ch]).powi(2)
                            })
                            .sum();
                        Some((rss / (2 * l) as f64 / e).sqrt())
                    }
                    None => None,
                };
            }
            OrderEstimate { l, energy: energy[l], estimate: est, stderr: se }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_filter_and_flags_empty_orders() {
        let lmax = 4;
        let n = (lmax + 1) * (lmax + 1);
        // Lighting with no energy at l = 3.
        let lighting: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let (l, m) = crate::sh::lm(k);
                if l == 3 { [0.0; 3] } else { [1.0 + 0.1 * m as f64, 0.5, -0.3 * (k as f64).cos()] }
            })
            .collect();
        let f = crate::transfer::phong::phong(8.0, lmax);
        let b = crate::predict::predict(&lighting, &f, [1.0, 1.0, 1.0]);
        let est = measured_filter(&b, None, &lighting, lmax, 1e-12);
        for e in &est {
            if e.l == 3 {
                assert!(!e.observable());
                continue;
            }
            for ch in 0..3 {
                let v = e.estimate[ch].expect("observable");
                assert!((v - f[e.l]).abs() < 1e-14, "l={} ch={ch}", e.l);
            }
        }
    }
}
