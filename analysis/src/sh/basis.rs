//! Evaluation of all real spherical harmonics Y_lm, l ≤ l_max, at one direction.
//!
//! Uses the standard stable three-term recurrences for the normalized associated Legendre functions
//! (never factorials), so it stays accurate far beyond l = 100. Real basis per CONVENTIONS §3:
//! Y_l0 = K_l0 P_l, Y_lm = √2 K_lm P_l^m cos(mφ) (m > 0), √2 K_l|m| P_l^|m| sin(|m|φ) (m < 0),
//! with no Condon–Shortley phase.

/// Flat index k = l(l+1) + m.
#[inline]
pub fn index(l: usize, m: i64) -> usize {
    ((l * (l + 1)) as i64 + m) as usize
}

/// (l, m) of flat index k.
#[inline]
pub fn lm(k: usize) -> (usize, i64) {
    let l = ((k as f64).sqrt()) as usize;
    let l = if (l + 1) * (l + 1) <= k { l + 1 } else if l * l > k { l - 1 } else { l };
    (l, k as i64 - (l * (l + 1)) as i64)
}

/// Number of coefficients up to and including order `lmax`: (lmax + 1)².
#[inline]
pub fn num_coefficients(lmax: usize) -> usize {
    (lmax + 1) * (lmax + 1)
}

/// Precomputed recurrence constants for fast repeated evaluation up to `lmax`.
#[derive(Clone, Debug)]
pub struct ShBasis {
    lmax: usize,
    /// a_lm, b_lm of the recurrence P̄_l^m = a_lm (z P̄_{l-1}^m − b_lm P̄_{l-2}^m), indexed like k for m ≥ 0.
    a: Vec<f64>,
    b: Vec<f64>,
}

impl ShBasis {
    pub fn new(lmax: usize) -> Self {
        let n = num_coefficients(lmax);
        let mut a = vec![0.0; n];
        let mut b = vec![0.0; n];
        for l in 2..=lmax {
            for m in 0..=(l - 2) {
                let (lf, mf) = (l as f64, m as f64);
                let k = index(l, m as i64);
                a[k] = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                b[k] = (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0)).sqrt();
            }
        }
        ShBasis { lmax, a, b }
    }

    pub fn lmax(&self) -> usize {
        self.lmax
    }

    /// Writes Y_k(dir) for k < (lmax+1)² into `out` (which must have at least that length).
    /// `dir` must be a unit vector (x, y, z) in the world frame of CONVENTIONS §1.
    pub fn eval_into(&self, dir: [f64; 3], out: &mut [f64]) {
        let lmax = self.lmax;
        let [x, y, z] = dir;
        let n = num_coefficients(lmax);
        assert!(out.len() >= n, "output buffer too small for lmax {lmax}");
        // Normalized P̄_l^m(z) such that Y_lm = P̄_l^m · {1, √2 cos mφ, √2 sin mφ} · (sinθ)^m-free part:
        // we fold sin^m θ cos(mφ) = Re (x + iy)^m, which needs no trigonometry and is exact at the poles.
        const INV_4PI: f64 = 1.0 / (4.0 * std::f64::consts::PI);
        // P̄_m^m = (−1)^0 · sqrt((2m+1)/(4π) · (2m−1)!!² / (2m)!) without the sin^m θ factor.
        let mut pmm = INV_4PI.sqrt(); // m = 0
        let (mut c, mut s) = (1.0f64, 0.0f64); // Re/Im of (x + i y)^m
        for m in 0..=lmax {
            if m > 0 {
                let mf = m as f64;
                pmm *= ((2.0 * mf + 1.0) / (2.0 * mf)).sqrt();
                let (c2, s2) = (c * x - s * y, c * y + s * x);
                c = c2;
                s = s2;
            }
            let (cm, sm) = if m == 0 { (1.0, 0.0) } else { (std::f64::consts::SQRT_2 * c, std::f64::consts::SQRT_2 * s) };
            // l = m
            let mut p_prev2 = 0.0;
            let mut p_prev = pmm;
            store(out, m, m, p_prev, cm, sm);
            if m < lmax {
                // l = m + 1: P̄_{m+1}^m = sqrt(2m+3) z P̄_m^m
                let p = (2.0 * m as f64 + 3.0).sqrt() * z * pmm;
                store(out, m + 1, m, p, cm, sm);
                p_prev2 = p_prev;
                p_prev = p;
            }
            for l in (m + 2)..=lmax {
                let k = index(l, m as i64);
                let p = self.a[k] * (z * p_prev - self.b[k] * p_prev2);
                store(out, l, m, p, cm, sm);
                p_prev2 = p_prev;
                p_prev = p;
            }
        }

        #[inline(always)]
        fn store(out: &mut [f64], l: usize, m: usize, p: f64, cm: f64, sm: f64) {
            if m == 0 {
                out[index(l, 0)] = p;
            } else {
                out[index(l, m as i64)] = p * cm;
                out[index(l, -(m as i64))] = p * sm;
            }
        }
    }

    /// Convenience: allocate and return all Y_k(dir).
    pub fn eval(&self, dir: [f64; 3]) -> Vec<f64> {
        let mut out = vec![0.0; num_coefficients(self.lmax)];
        self.eval_into(dir, &mut out);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_values_of_conventions_section_3() {
        let d = {
            let v = [0.3f64, -0.5, 0.7];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let [x, y, z] = d;
        let y_ = ShBasis::new(2).eval(d);
        let expect = [
            0.282095,
            0.488603 * y,
            0.488603 * z,
            0.488603 * x,
            1.092548 * x * y,
            1.092548 * y * z,
            0.315392 * (3.0 * z * z - 1.0),
            1.092548 * x * z,
            0.546274 * (x * x - y * y),
        ];
        for k in 0..9 {
            assert!((y_[k] - expect[k]).abs() < 2e-6, "k={k}: {} vs {}", y_[k], expect[k]);
        }
    }

    #[test]
    fn index_round_trip() {
        for k in 0..2000 {
            let (l, m) = lm(k);
            assert!(m.unsigned_abs() as usize <= l);
            assert_eq!(index(l, m), k);
        }
    }
}
