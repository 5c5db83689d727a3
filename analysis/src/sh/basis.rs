//! Evaluation of all real spherical harmonics Y_lm, l ≤ l_max, at one direction.
//!
//! Uses the standard stable three-term recurrences for the normalized associated Legendre functions
//! (never factorials), so it stays accurate far beyond l = 100. Real basis per docs/src/conventions.md §3:
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
    let l = if (l + 1) * (l + 1) <= k {
        l + 1
    } else if l * l > k {
        l - 1
    } else {
        l
    };
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
    /// √(2l+1) (for P̄_l^{l−1} = √(2l+1) z P̄_{l−1}^{l−1}) and √((2l+1)/(2l)) (for P̄_l^l), by l.
    sub_diag: Vec<f64>,
    diag: Vec<f64>,
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
        let sub_diag = (0..=lmax).map(|l| (2.0 * l as f64 + 1.0).sqrt()).collect();
        let diag =
            (0..=lmax).map(|l| if l == 0 { 0.0 } else { ((2.0 * l as f64 + 1.0) / (2.0 * l as f64)).sqrt() }).collect();
        ShBasis { lmax, a, b, sub_diag, diag }
    }

    pub fn lmax(&self) -> usize {
        self.lmax
    }

    /// Writes Y_k(dir) for k < (lmax+1)² into `out` (which must have at least that length).
    /// `dir` must be a unit vector (x, y, z) in the world frame of docs/src/conventions.md §1.
    ///
    /// Two passes, no allocation: (1) the normalized associated Legendre values P̄_l^m(z) (without
    /// the sin^m θ factor) go into the m ≥ 0 slots, l outer and m inner, so the recurrences of the
    /// different m are independent and pipeline/vectorize instead of forming one long dependency
    /// chain; (2) each m is multiplied by √2 Re/Im (x + iy)^m = √2 sin^m θ (cos mφ, sin mφ), which
    /// needs no trigonometry and is exact at the poles.
    pub fn eval_into(&self, dir: [f64; 3], out: &mut [f64]) {
        let lmax = self.lmax;
        let [x, y, z] = dir;
        let n = num_coefficients(lmax);
        assert!(out.len() >= n, "output buffer too small for lmax {lmax}");
        let out = &mut out[..n];
        const INV_4PI: f64 = 1.0 / (4.0 * std::f64::consts::PI);
        // Pass 1. P̄_0^0 = 1/√(4π); P̄_m^m = P̄_{m−1}^{m−1} √((2m+1)/(2m)); P̄_{m+1}^m = √(2m+3) z P̄_m^m;
        // P̄_l^m = a_lm (z P̄_{l−1}^m − b_lm P̄_{l−2}^m).
        out[0] = INV_4PI.sqrt();
        let mut pmm = out[0];
        for l in 1..=lmax {
            let k = l * (l + 1);
            let k1 = (l - 1) * l;
            if l >= 2 {
                let k2 = (l - 2) * (l - 1);
                let (a, b) = (&self.a[k..k + l - 1], &self.b[k..k + l - 1]);
                for m in 0..=(l - 2) {
                    out[k + m] = a[m] * (z * out[k1 + m] - b[m] * out[k2 + m]);
                }
            }
            // m = l − 1 and m = l.
            out[k + l - 1] = self.sub_diag[l] * z * pmm;
            pmm *= self.diag[l];
            out[k + l] = pmm;
        }
        // Pass 2: azimuthal factors.
        let (mut c, mut s) = (1.0f64, 0.0f64);
        for m in 1..=lmax {
            let (c2, s2) = (c * x - s * y, c * y + s * x);
            c = c2;
            s = s2;
            let (cm, sm) = (std::f64::consts::SQRT_2 * c, std::f64::consts::SQRT_2 * s);
            for l in m..=lmax {
                let k = l * (l + 1);
                let p = out[k + m];
                out[k - m] = p * sm;
                out[k + m] = p * cm;
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
