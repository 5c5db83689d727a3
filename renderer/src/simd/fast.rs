//! The kernel's transcendental functions, written once over [`Float`]: branch-free polynomials
//! and selects (libm's are out-of-line calls with branches). `math::fast` calls them at one lane;
//! its tests measure each function's error against f64 libm and state the bounds.
use super::{Float, Isa};
use std::f32::consts::{FRAC_PI_2, PI};

/// Coefficients c_k of atan(a) ≈ a · Σ c_k (a²)^k on a ∈ [0, 1] (degree 15 in a, odd), fitted by
/// iteratively reweighted least squares toward the minimax absolute error (≈ 1.3e-7 for the
/// polynomial alone in f32 Horner form).
pub(crate) const ATAN_COEFFS: [f32; 8] = [
    0.999_999_34,
    -0.333_298_62,
    0.199_465_77,
    -0.139_086_47,
    0.096_421_99,
    -0.055_912_063,
    0.021_862_669,
    -0.004_054_471,
];

/// 1.5 · 2²³: adding and subtracting it rounds an f32 of magnitude < 2²² to the nearest integer
/// (ties to even) with plain IEEE adds (`f32::round` is a call to `roundf` without SSE4.1).
const ROUND_MAGIC: f32 = 12_582_912.0;

impl<const N: usize, S: Isa> Float<N, S> {
    /// atan2(self, x) lane by lane (`self` is y); see `math::fast::atan2` for its error and its
    /// special cases. Octant reduction a = min(|x|,|y|)/max(|x|,|y|), the polynomial, then
    /// π/2 − r, π − r and the sign of y by selects.
    #[inline(always)]
    pub fn atan2(self, x: Self) -> Self {
        let y = self;
        let (ax, ay) = (x.abs(), y.abs());
        let (mn, mx) = (ax.min(ay), ax.max(ay));
        let a = mx.gt(Float::ZERO).select(mn / mx, Float::ZERO);
        let s = a * a;
        let c = &ATAN_COEFFS;
        let mut p = Float::splat(c[7]);
        for &ck in c[..7].iter().rev() {
            p = p * s + ck;
        }
        let mut r = a * p;
        r = ay.gt(ax).select(FRAC_PI_2 - r, r);
        r = x.is_sign_negative().select(PI - r, r);
        // min/max drop a NaN operand: (x + y)·0 brings it back (r ≥ 0 here, so adding ±0 keeps it).
        r = r + (x + y) * 0.0;
        r.copysign(y)
    }

    /// e^x lane by lane; see `math::fast::exp`. Reduction x = k ln2 + r (ln2 in a head with 9
    /// trailing zero bits and a tail), the Taylor polynomial of e^r to r⁷, scaled by 2^k.
    #[inline(always)]
    pub fn exp(self) -> Self {
        const LN2_HI: f32 = 0.693_145_75; // 0x3f317200
        const LN2_LO: f32 = 1.428_606_8e-6;
        let xc = self.clamp(-87.3, 88.0);
        let k = (xc * std::f32::consts::LOG2_E + ROUND_MAGIC) - ROUND_MAGIC;
        let r = (xc - k * LN2_HI) - k * LN2_LO;
        let mut p = Float::splat(1.0 / 5040.0);
        for c in [1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
            p = p * r + c;
        }
        let y = p * k.exp2_int();
        self.lt(Float::splat(-87.3)).select(Float::ZERO, y)
    }

    /// ln(1 + x) lane by lane for x ∈ (−1, 10⁶]; see `math::fast::ln_1p`. ln w = e ln2 + 2 atanh s
    /// for w = 1 + x = 2^e m, then Goldberg's correction ln w · x / (w − 1).
    #[inline(always)]
    pub fn ln_1p(self) -> Self {
        const LN2_HI: f32 = 0.693_145_75;
        const LN2_LO: f32 = 1.428_606_8e-6;
        const SQRT_HALF_BITS: i32 = 0x3f35_04f3;
        let w = 1.0 + self;
        // The exponent e (as f32) and the mantissa m ∈ [√½, √2) from the bits of w.
        let (mut ef, mut m) = ([0.0f32; N], [0.0f32; N]);
        for k in 0..N {
            let bits = w.0[k].to_bits() as i32;
            let e = (bits - SQRT_HALF_BITS) >> 23;
            m[k] = f32::from_bits((bits - (e << 23)) as u32);
            ef[k] = e as f32;
        }
        let (ef, m) = (Float::from_array(ef), Float::from_array(m));
        let s = (m - 1.0) / (m + 1.0);
        let s2 = s * s;
        let mut q = Float::splat(1.0 / 9.0);
        for c in [1.0 / 7.0, 0.2, 1.0 / 3.0, 1.0] {
            q = q * s2 + c;
        }
        let ln_w = ef * LN2_HI + (ef * LN2_LO + 2.0 * s * q);
        let d = w - 1.0;
        d.eq(Float::ZERO).select(self, ln_w * (self / d))
    }

    /// (sin 2πu, cos 2πu) lane by lane for |u| ≤ 2²⁰; see `math::fast::sincos_2pi`. Exact reduction
    /// to a quarter turn, Taylor polynomials on [−π/4, π/4], rotated by the quarter turns.
    #[inline(always)]
    pub fn sincos_2pi(self) -> (Self, Self) {
        let t = 4.0 * self;
        let q = (t + ROUND_MAGIC) - ROUND_MAGIC;
        let x = (t - q) * FRAC_PI_2;
        let x2 = x * x;
        let s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
        let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0))));
        // Quarter turns: (s, c) → (c, −s) → (−s, −c) → (−c, s).
        let (mut so, mut co) = ([0.0f32; N], [0.0f32; N]);
        for k in 0..N {
            let q = q.0[k] as i32;
            let (s, c) = if q & 1 != 0 { (c.0[k], s.0[k]) } else { (s.0[k], c.0[k]) };
            so[k] = if q & 2 != 0 { -s } else { s };
            co[k] = if (q + 1) & 2 != 0 { -c } else { c };
        }
        (Float::from_array(so), Float::from_array(co))
    }
}
