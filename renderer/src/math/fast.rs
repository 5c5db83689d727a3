//! Branch-free polynomial versions of hot libm functions: straight-line f32 arithmetic and
//! selects, so that LLVM can inline them and run them in SIMD lanes (libm's `atan2f` is an
//! out-of-line call with branches on the octant and special cases, and was 20–34 % of the
//! instructions of a lat-long environment render).
//!
//! Each function states its maximum error against f64 libm over its domain; the tests below
//! measure it on a dense grid plus random points and assert the stated bound.

use super::PI;
use std::f32::consts::FRAC_PI_2;

/// Coefficients c_k of atan(a) ≈ a · Σ c_k (a²)^k on a ∈ [0, 1] (degree 15 in a, odd), fitted by
/// iteratively reweighted least squares toward the minimax absolute error (≈ 1.3e-7 for the
/// polynomial alone in f32 Horner form). Plain multiply-adds: `mul_add` would be a call to
/// `fmaf` on targets built without FMA.
const ATAN_COEFFS: [f32; 8] = [
    0.999_999_34,
    -0.333_298_62,
    0.199_465_77,
    -0.139_086_47,
    0.096_421_99,
    -0.055_912_063,
    0.021_862_669,
    -0.004_054_471,
];

/// atan2(y, x) ∈ [−π, π], like `f32::atan2` including the signs of zeros (atan2(±0, x < 0) = ±π,
/// atan2(0, 0) = 0).
///
/// **Maximum absolute error 4e-7 rad** over all finite inputs (measured: see the tests), against
/// libm's ≈ 2.4e-7 (½ ulp at π). Octant reduction a = min(|x|,|y|)/max(|x|,|y|) ∈ [0, 1], the
/// polynomial above, then π/2 − r, π − r and the sign of y by selects. NaN in, NaN out. Infinite
/// inputs are not handled like libm (∞/∞ gives NaN); callers pass finite directions.
#[inline(always)]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (mn, mx) = (ax.min(ay), ax.max(ay));
    let a = if mx > 0.0 { mn / mx } else { 0.0 };
    let s = a * a;
    let c = &ATAN_COEFFS;
    let p = c[7];
    let p = p * s + c[6];
    let p = p * s + c[5];
    let p = p * s + c[4];
    let p = p * s + c[3];
    let p = p * s + c[2];
    let p = p * s + c[1];
    let p = p * s + c[0];
    let mut r = a * p;
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x.is_sign_negative() {
        r = PI - r;
    }
    // min/max drop a NaN operand: (x + y)·0 brings it back (r ≥ 0 here, so adding ±0 keeps it).
    r += (x + y) * 0.0;
    r.copysign(y)
}

/// Two [`atan2`]s at once: `[atan2(y[0], x[0]), atan2(y[1], x[1])]`, computed in two lanes of one
/// SSE register (glam's `Vec4`) by exactly the operations of [`atan2`] (IEEE single-precision
/// multiplies, adds and a divide, no fused multiply-add), so each result has the **same bits** as
/// the scalar call for finite inputs (and is NaN where the scalar one is; see the tests). The lat-long
/// lookup needs θ and φ of one direction: one evaluation instead of two.
#[inline(always)]
pub fn atan2_x2(y: [f32; 2], x: [f32; 2]) -> [f32; 2] {
    use glam::Vec4;
    // Lanes z, w compute atan2(0, 1) and are dropped.
    let y = Vec4::new(y[0], y[1], 0.0, 0.0);
    let x = Vec4::new(x[0], x[1], 1.0, 1.0);
    let (ax, ay) = (x.abs(), y.abs());
    let (mn, mx) = (ax.min(ay), ax.max(ay));
    let a = Vec4::select(mx.cmpgt(Vec4::ZERO), mn / mx, Vec4::ZERO);
    let s = a * a;
    let c = ATAN_COEFFS.map(Vec4::splat);
    let p = c[7];
    let p = p * s + c[6];
    let p = p * s + c[5];
    let p = p * s + c[4];
    let p = p * s + c[3];
    let p = p * s + c[2];
    let p = p * s + c[1];
    let p = p * s + c[0];
    let mut r = a * p;
    r = Vec4::select(ay.cmpgt(ax), Vec4::splat(FRAC_PI_2) - r, r);
    // x.is_sign_negative() lane by lane (−0.0 included).
    r = Vec4::select(Vec4::ONE.copysign(x).cmplt(Vec4::ZERO), Vec4::splat(PI) - r, r);
    r += (x + y) * 0.0;
    let r = r.copysign(y);
    [r.x, r.y]
}

/// 1.5 · 2²³: adding and subtracting it rounds an f32 of magnitude < 2²² to the nearest integer
/// (ties to even) with plain IEEE adds (`f32::round` is a call to `roundf` without SSE4.1).
const ROUND_MAGIC: f32 = 12_582_912.0;

/// (sin 2πu, cos 2πu), the azimuth of a warp from a uniform number u.
///
/// **Maximum absolute error 1.2e-7** for |u| ≤ 2²⁰ (measured against f64 libm: see the tests;
/// libm's `(2.0 * PI * u).sin_cos()` errs by up to 3.7e-7 near u = 1, from rounding 2πu to f32).
/// Exact reduction to a quarter turn: t = 4u, q = round(t), f = t − q ∈ [−½, ½] (both exact), then
/// x = (π/2) f ∈ [−π/4, π/4] and the Taylor polynomials of sin to x⁹ and cos to x⁸ (remainders
/// below 1.7e-9 and 2.5e-8 on that interval), rotated by q quarter turns with swaps and negations.
/// Straight-line f32 arithmetic and selects, no table and no call. Beyond |u| = 2²⁰ the reduction
/// is still exact but q no longer fits the rounding trick: callers pass u ∈ [0, 1].
#[inline(always)]
pub fn sincos_2pi(u: f32) -> (f32, f32) {
    let t = 4.0 * u;
    let q = (t + ROUND_MAGIC) - ROUND_MAGIC;
    let x = (t - q) * FRAC_PI_2;
    let x2 = x * x;
    let s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0))));
    let q = q as i32;
    // Quarter turns: (s, c) → (c, −s) → (−s, −c) → (−c, s).
    let (s, c) = if q & 1 != 0 { (c, s) } else { (s, c) };
    let s = if q & 2 != 0 { -s } else { s };
    let c = if (q + 1) & 2 != 0 { -c } else { c };
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::TestRng;

    /// The stated bound; the reference is f64 libm.
    const ATAN2_MAX_ERR: f64 = 4e-7;

    /// Largest |f(y, x) − atan2(y, x)| over every angle of a fine circle at three radii (so the
    /// reduced ratio covers [0, 1] densely in every octant), random components of random
    /// magnitudes, and the axes.
    fn atan2_max_error(f: impl Fn(f32, f32) -> f32) -> f64 {
        let mut worst = 0.0f64;
        let mut check = |y: f32, x: f32| worst = worst.max((f(y, x) as f64 - (y as f64).atan2(x as f64)).abs());
        let n = 1_000_000;
        for k in 0..n {
            let t = (k as f64 + 0.5) / n as f64 * 2.0 * std::f64::consts::PI - std::f64::consts::PI;
            for r in [1.0f64, 1e-20, 3e15] {
                check((r * t.sin()) as f32, (r * t.cos()) as f32);
            }
        }
        let mut rng = TestRng::new(5);
        for _ in 0..1_000_000 {
            let m = |rng: &mut TestRng| (rng.next_f32() * 2.0 - 1.0) * 10f32.powf(rng.next_f32() * 8.0 - 4.0);
            check(m(&mut rng), m(&mut rng));
        }
        for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (1e-30, -1.0), (-1e-30, -1.0), (1.0, 1.0)] {
            check(y, x);
        }
        worst
    }

    #[test]
    fn atan2_error_bound() {
        let worst = atan2_max_error(atan2);
        eprintln!("fast atan2: max abs error {worst:.3e} rad");
        assert!(worst <= ATAN2_MAX_ERR, "{worst:e}");
        // The harness sees a planted error: the polynomial without its last term.
        let truncated = |y: f32, x: f32| {
            let a = (x.abs().min(y.abs()) / x.abs().max(y.abs())) as f64;
            atan2(y, x) + (ATAN_COEFFS[7] as f64 * a.powi(15)) as f32 * (if y < 0.0 { 1.0 } else { -1.0 })
        };
        assert!(atan2_max_error(truncated) > ATAN2_MAX_ERR);
    }

    /// `atan2_x2` gives the bits of two scalar `atan2` calls: on the error harness's points (fine
    /// circles at three radii in every octant, random magnitudes), signed zeros, the axes, and NaN.
    #[test]
    fn atan2_x2_is_bit_identical_to_atan2() {
        let mut points: Vec<(f32, f32)> = Vec::new();
        let n = 200_000;
        for k in 0..n {
            let t = (k as f64 + 0.5) / n as f64 * 2.0 * std::f64::consts::PI - std::f64::consts::PI;
            for r in [1.0f64, 1e-20, 3e15] {
                points.push(((r * t.sin()) as f32, (r * t.cos()) as f32));
            }
        }
        let mut rng = TestRng::new(11);
        for _ in 0..200_000 {
            let m = |rng: &mut TestRng| (rng.next_f32() * 2.0 - 1.0) * 10f32.powf(rng.next_f32() * 8.0 - 4.0);
            points.push((m(&mut rng), m(&mut rng)));
        }
        let z = [0.0f32, -0.0, 1.0, -1.0, 1e-30, -1e-30, 2.5];
        for y in z {
            for x in z {
                points.push((y, x));
            }
        }
        for pair in points.chunks_exact(2) {
            let [(y0, x0), (y1, x1)] = [pair[0], pair[1]];
            let got = atan2_x2([y0, y1], [x0, x1]);
            assert_eq!(got[0].to_bits(), atan2(y0, x0).to_bits(), "atan2({y0:e}, {x0:e})");
            assert_eq!(got[1].to_bits(), atan2(y1, x1).to_bits(), "atan2({y1:e}, {x1:e})");
            // The lanes are independent: swapped, each still gives its own value.
            let swapped = atan2_x2([y1, y0], [x1, x0]);
            assert_eq!((swapped[0].to_bits(), swapped[1].to_bits()), (got[1].to_bits(), got[0].to_bits()));
        }
        let nan = atan2_x2([f32::NAN, 1.0], [1.0, f32::NAN]);
        assert!(nan[0].is_nan() && nan[1].is_nan());
    }

    #[test]
    fn atan2_special_values_match_libm() {
        for (y, x) in [(0.0f32, 0.0f32), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0), (0.0, -2.0), (-0.0, -2.0), (0.0, 3.0)]
        {
            assert_eq!(atan2(y, x).to_bits(), y.atan2(x).to_bits(), "atan2({y:?}, {x:?})");
        }
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
        // Exact at the octant boundaries that are pixel edges of every lat-long map: ±π/2 and π.
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-1.0, 0.0), -FRAC_PI_2);
        assert_eq!(atan2(0.0, -1.0), PI);
    }

    /// The stated bound of `sincos_2pi`; the reference is f64 libm of 2πu (u exact in f64).
    const SINCOS_2PI_MAX_ERR: f64 = 1.2e-7;

    /// Largest error of `f` against (sin 2πu, cos 2πu): every u = k/2²² of [0, 1] (each quarter
    /// turn densely, the octant edges exactly), random u of [−2²⁰, 2²⁰] at random scales, and the
    /// quarter turns themselves.
    fn sincos_2pi_max_error(f: impl Fn(f32) -> (f32, f32)) -> f64 {
        let mut worst = 0.0f64;
        let mut check = |u: f32| {
            let (s, c) = f(u);
            let (rs, rc) = (2.0 * std::f64::consts::PI * u as f64).sin_cos();
            worst = worst.max((s as f64 - rs).abs()).max((c as f64 - rc).abs());
        };
        let n = 1u32 << 22;
        for k in 0..=n {
            check(k as f32 / n as f32);
        }
        let mut rng = TestRng::new(8);
        for _ in 0..1_000_000 {
            check((rng.next_f32() * 2.0 - 1.0) * 2f32.powf(rng.next_f32() * 20.0));
        }
        for k in -8..=8 {
            check(k as f32 * 0.125);
        }
        worst
    }

    #[test]
    fn sincos_2pi_error_bound() {
        let worst = sincos_2pi_max_error(sincos_2pi);
        eprintln!("fast sincos_2pi: max abs error {worst:.3e}");
        assert!(worst <= SINCOS_2PI_MAX_ERR, "{worst:e}");
        // Exact values at the quarter turns (−0.0 == 0.0 here).
        for (u, sc) in
            [(0.0f32, (0.0f32, 1.0f32)), (0.25, (1.0, 0.0)), (0.5, (0.0, -1.0)), (0.75, (-1.0, 0.0)), (1.0, (0.0, 1.0))]
        {
            assert_eq!(sincos_2pi(u), sc, "u = {u}");
        }
        // The harness sees planted errors: libm after rounding 2πu to f32 (what the warps did, up
        // to 3.7e-7 off), and the quarter-turn rotation off by one.
        assert!(sincos_2pi_max_error(|u| (2.0 * PI * u).sin_cos()) > SINCOS_2PI_MAX_ERR);
        assert!(sincos_2pi_max_error(|u| sincos_2pi(u + 0.25)) > 0.5);
    }
}
