//! Branch-free polynomial versions of hot libm functions: straight-line f32 arithmetic and
//! selects, so that LLVM can inline them and run them in SIMD lanes (libm's `atan2f` is an
//! out-of-line call with branches on the octant and special cases, and was 20–34 % of the
//! instructions of a lat-long environment render).
//!
//! Each function is written once over the lane type ([`crate::simd::fast`]); these are its one-lane
//! calls. Each function states its maximum error against f64 libm over its domain; the tests below
//! measure it on a dense grid plus random points and assert the stated bound.

use crate::simd::Float;

/// atan2(y, x) ∈ [−π, π], like `f32::atan2` including the signs of zeros (atan2(±0, x < 0) = ±π,
/// atan2(0, 0) = 0).
///
/// **Maximum absolute error 4e-7 rad** over all finite inputs (measured: see the tests), against
/// libm's ≈ 2.4e-7 (½ ulp at π). Octant reduction a = min(|x|,|y|)/max(|x|,|y|) ∈ [0, 1], the
/// polynomial above, then π/2 − r, π − r and the sign of y by selects. NaN in, NaN out. Infinite
/// inputs are not handled like libm (∞/∞ gives NaN); callers pass finite directions.
#[inline(always)]
pub fn atan2(y: f32, x: f32) -> f32 {
    Float::<1>::splat(y).atan2(Float::splat(x)).0[0]
}

/// Two [`atan2`]s at once: `[atan2(y[0], x[0]), atan2(y[1], x[1])]`, the same body at two lanes,
/// so each result has the **same bits** as the one-lane call (see the tests). The lat-long lookup
/// needs θ and φ of one direction: one evaluation instead of two.
#[inline(always)]
pub fn atan2_x2(y: [f32; 2], x: [f32; 2]) -> [f32; 2] {
    Float::<2>::from_array(y).atan2(Float::from_array(x)).0
}

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
    let (s, c) = Float::<1>::splat(u).sincos_2pi();
    (s.0[0], c.0[0])
}

/// 1.5 · 2⁵²: adding and subtracting it rounds an f64 of magnitude < 2⁵¹ to the nearest integer.
const ROUND_MAGIC_F64: f64 = 6_755_399_441_055_744.0;

/// e^x in f64, inlined straight-line arithmetic (libm's `exp` is an out-of-line call of ≈ 51
/// instructions with its wrapper; Beckmann's Λ needs two per evaluation).
///
/// **Maximum relative error 1e-11** for x ∈ [−708, 709] (measured against f64 libm: see the
/// tests): far below f32 resolution, which is what Λ needs (its cancellation at a = 6 magnifies a
/// relative error ≈ 2a² = 72 times, and its result is an f32); x < −708 gives 0 (libm: a subnormal below
/// 3.3e-308), x > 709 is clamped to 709 (libm: ∞). NaN in, NaN out.
/// Reduction x = k ln2 + r with k = round(x / ln2) and |r| ≤ ln2/2 (Cody–Waite: ln2 split in a
/// 32-bit head, exact in k·head for |k| < 2²¹, and a tail), then the Taylor polynomial of e^r to
/// r⁹ (remainder below 0.347¹⁰/10! = 7e-12), scaled by 2^k built in the exponent bits.
/// 1/k! for k = 9 down to 0: the Taylor coefficients of e^r, highest first (Horner order).
const EXP_F64_TAYLOR: [f64; 10] =
    [1.0 / 362_880.0, 1.0 / 40_320.0, 1.0 / 5_040.0, 1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0];

#[inline(always)]
pub fn exp_f64(x: f64) -> f64 {
    const LN2_HI: f64 = 6.931_471_803_691_238e-1; // 0x3fe62e42fee00000
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let xc = x.clamp(-708.0, 709.0);
    let shifted = xc * std::f64::consts::LOG2_E + ROUND_MAGIC_F64;
    let k = shifted - ROUND_MAGIC_F64;
    let r = (xc - k * LN2_HI) - k * LN2_LO;
    let mut p = EXP_F64_TAYLOR[0];
    for c in &EXP_F64_TAYLOR[1..] {
        p = p * r + c;
    }
    // k as an integer from the bits of `shifted` (1.5·2⁵² + k, one exponent for |k| < 2⁵¹): the
    // same integer as `k as i64`, but 64-bit integer lane arithmetic, which AVX2 has (it has no
    // f64 → i64 conversion), so that lane loops of this function stay in SIMD registers.
    let k_int = (shifted.to_bits() as i64).wrapping_sub(ROUND_MAGIC_F64.to_bits() as i64);
    let scale = f64::from_bits(((k_int + 1023) as u64) << 52);
    let y = p * scale;
    // NaN survives the clamp and the polynomial; the exponent bits of `k_int` do not matter then.
    if x < -708.0 { 0.0 } else { y }
}

/// e^x in f32, inlined straight-line arithmetic (libm's `expf` is an out-of-line call).
///
/// **Maximum relative error 2.5e-7** (≈ 4 ulp) for x ∈ [−87.3, 88] (measured against f64 libm: see
/// the tests); x < −87.3 gives 0 (libm: a subnormal below 1.2e-38), x > 88 is clamped to 88
/// (libm: up to 3.4e38, then ∞). NaN in, NaN out. The same reduction as [`exp_f64`] (ln2 split in
/// a head with 9 trailing zero bits and a tail) and the Taylor polynomial of e^r to r⁷ (remainder
/// below 0.347⁸/8! = 5.2e-9), scaled by 2^k built in the exponent bits. Plain multiply-adds.
#[inline(always)]
pub fn exp(x: f32) -> f32 {
    Float::<1>::splat(x).exp().0[0]
}

/// ln(1 + x) in f32 for x ∈ (−1, 10⁶], accurate near x = 0 like libm's `log1pf` (the inverse CDFs
/// of the Beckmann and Torrance–Sparrow samplers take ln(1 − u) for u ∈ [0, 1)).
///
/// **Maximum relative error 3e-7** (≈ 5 ulp) over (−1, 10⁶] (measured against f64 libm: see the
/// tests). w = 1 + x is rounded; ln w = e ln2 + ln m with m ∈ [√½, √2) from the exponent bits
/// and ln m = 2 atanh s, s = (m − 1)/(m + 1), |s| ≤ 0.172, by its series to s⁹ (remainder below
/// 2 · 0.172¹¹/11 = 7e-10); then Goldberg's correction ln(1 + x) = ln w · x / (w − 1) cancels the
/// rounding of w (exact where w = 1: the result is x). x ≤ −1 is outside the domain (no NaN or −∞
/// is produced there, just an unspecified number).
#[inline(always)]
pub fn ln_1p(x: f32) -> f32 {
    Float::<1>::splat(x).ln_1p().0[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::PI;
    use crate::sampling::chi2::TestRng;
    use std::f32::consts::FRAC_PI_2;

    /// The stated bound; the reference is f64 libm.
    const ATAN2_MAX_ERR: f64 = 4e-7;

    /// `Float::<8>::atan2` is the one-lane `atan2` lane by lane, bit for bit (NaN where it is NaN).
    #[test]
    fn atan2_eight_wide_is_one_wide() {
        let mut rng = TestRng::new(9);
        for _ in 0..100_000 {
            let m = |rng: &mut TestRng| (rng.next_f32() * 2.0 - 1.0) * 10f32.powf(rng.next_f32() * 8.0 - 4.0);
            let y: [f32; 8] = std::array::from_fn(|_| m(&mut rng));
            let x: [f32; 8] = std::array::from_fn(|k| if k == 3 { 0.0 } else { m(&mut rng) });
            let r = Float::<8>::from_array(y).atan2(Float::from_array(x)).0;
            for k in 0..8 {
                let want = atan2(y[k], x[k]);
                assert!(r[k].to_bits() == want.to_bits() || (r[k].is_nan() && want.is_nan()));
            }
        }
    }

    /// Not a check: a workload for counting instructions under callgrind (guide "Performance notes and their history",
    /// round seven): 2^19 arctangents one call at a time, and in lanes of 8 in functions compiled
    /// for the baseline and for x86-64-v3.
    #[test]
    #[ignore]
    fn atan2_instruction_count_workload() {
        const N: u32 = 1 << 16;
        let arg = |i: u32| ((i as f32 * 0.618).sin(), (i as f32 * 0.377).cos());
        #[inline(never)]
        fn scalar(xy: &[(f32, f32)]) -> f32 {
            xy.iter().map(|&(y, x)| atan2(y, x)).sum()
        }
        #[inline(always)]
        fn lanes_body(ys: &[[f32; 8]], xs: &[[f32; 8]]) -> f32 {
            ys.iter()
                .zip(xs)
                .map(|(y, x)| Float::<8>::from_array(*y).atan2(Float::from_array(*x)).0.iter().sum::<f32>())
                .sum()
        }
        #[inline(never)]
        fn lanes_base(ys: &[[f32; 8]], xs: &[[f32; 8]]) -> f32 {
            lanes_body(ys, xs)
        }
        #[inline(never)]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,movbe,f16c,popcnt")]
        fn lanes_v3(ys: &[[f32; 8]], xs: &[[f32; 8]]) -> f32 {
            lanes_body(ys, xs)
        }
        let xy: Vec<(f32, f32)> = (0..8 * N).map(arg).collect();
        let ys: Vec<[f32; 8]> = (0..N).map(|b| std::array::from_fn(|k| arg(b * 8 + k as u32).0)).collect();
        let xs: Vec<[f32; 8]> = (0..N).map(|b| std::array::from_fn(|k| arg(b * 8 + k as u32).1)).collect();
        let a = scalar(&xy);
        let b = lanes_base(&ys, &xs);
        #[cfg(target_arch = "x86_64")]
        if crate::render::has_x86_64_v3() {
            // SAFETY: every feature of lanes_v3 was detected.
            assert_eq!(b, unsafe { lanes_v3(&ys, &xs) });
        }
        assert!(a.is_finite() && b.is_finite());
    }

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
            atan2(y, x)
                + (crate::simd::fast::ATAN_COEFFS[7] as f64 * a.powi(15)) as f32 * (if y < 0.0 { 1.0 } else { -1.0 })
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
    /// Largest relative error of `f` against `reference` (f64) at `points`, skipping reference zeros.
    fn max_rel_error<T: Copy>(
        points: impl Iterator<Item = T>,
        f: impl Fn(T) -> f64,
        reference: impl Fn(T) -> f64,
    ) -> f64 {
        let mut worst = 0.0f64;
        for x in points {
            let r = reference(x);
            if r != 0.0 {
                worst = worst.max(((f(x) - r) / r).abs());
            }
        }
        worst
    }

    const EXP_F64_MAX_REL_ERR: f64 = 1e-11;

    /// Dense grid of [−708, 709] plus random points of the domain and of Beckmann's Λ range [−40, 2].
    fn exp_f64_points() -> impl Iterator<Item = f64> {
        let n = 4_000_000;
        let grid = (0..=n).map(move |k| -708.0 + 1417.0 * k as f64 / n as f64);
        let mut rng = TestRng::new(21);
        let random = (0..1_000_000).map(move |_| -40.0 + 42.0 * rng.next_f32() as f64 + rng.next_f32() as f64 * 1e-7);
        grid.chain(random).chain([0.0, -0.0, 1.0, -1.0, 709.0, -708.0, 1e-300, -1e-300])
    }

    #[test]
    fn exp_f64_error_bound() {
        let worst = max_rel_error(exp_f64_points(), exp_f64, f64::exp);
        eprintln!("fast exp_f64: max rel error {worst:.3e}");
        assert!(worst <= EXP_F64_MAX_REL_ERR, "{worst:e}");
        assert_eq!(exp_f64(0.0), 1.0);
        assert_eq!(exp_f64(-1000.0), 0.0);
        assert!(exp_f64(f64::NAN).is_nan());
        // Planted error: the polynomial without its r⁹ term breaks the bound.
        let short = |x: f64| {
            let k = (x * std::f64::consts::LOG2_E).round();
            let r = x - k * std::f64::consts::LN_2;
            exp_f64(x) - r.powi(9) / 362_880.0 * 2f64.powi(k as i32)
        };
        assert!(max_rel_error(exp_f64_points(), short, f64::exp) > EXP_F64_MAX_REL_ERR);
    }

    const EXP_MAX_REL_ERR: f64 = 2.5e-7;

    fn exp_points() -> impl Iterator<Item = f32> {
        let n = 4_000_000;
        let grid = (0..=n).map(move |k| -87.3 + 175.3 * k as f32 / n as f32);
        let mut rng = TestRng::new(22);
        let random = (0..1_000_000)
            .map(move |_| -(rng.next_f32() * 10f32.powf(rng.next_f32() * 6.0 - 4.0)))
            .filter(|&x| x >= -87.3);
        grid.chain(random).chain([0.0, -0.0, 1.0, -1.0, 88.0, -87.3, 1e-30, -1e-30])
    }

    #[test]
    fn exp_error_bound() {
        let worst = max_rel_error(exp_points(), |x| exp(x) as f64, |x| (x as f64).exp());
        eprintln!("fast exp: max rel error {worst:.3e}");
        assert!(worst <= EXP_MAX_REL_ERR, "{worst:e}");
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-100.0), 0.0);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert!(exp(f32::NAN).is_nan());
        // Planted error: the polynomial without its r⁶ term.
        let short = |x: f32| {
            let k = (x as f64 * std::f64::consts::LOG2_E).round();
            let r = x as f64 - k * std::f64::consts::LN_2;
            exp(x) as f64 - r.powi(6) / 720.0 * 2f64.powi(k as i32)
        };
        assert!(max_rel_error(exp_points(), short, |x| (x as f64).exp()) > EXP_MAX_REL_ERR);
    }

    const LN_1P_MAX_REL_ERR: f64 = 3e-7;

    /// Every f32 of (−1, −2⁻³⁰] ∪ [2⁻³⁰, 1] at a stride, random magnitudes up to 10⁶, and the
    /// sampler's arguments −u for u = k/2²⁴.
    fn ln_1p_points() -> impl Iterator<Item = f32> {
        let lo = (2f32.powi(-30)).to_bits();
        let hi = 1f32.to_bits();
        let pos = (lo..hi).step_by(97).map(f32::from_bits);
        let neg = (lo..hi).step_by(97).map(|b| -f32::from_bits(b)).filter(|&x| x > -1.0);
        let us = (1..(1u32 << 24)).step_by(7).map(|k| -(k as f32) / (1u32 << 24) as f32);
        let mut rng = TestRng::new(23);
        let big = (0..1_000_000).map(move |_| 10f32.powf(rng.next_f32() * 6.0));
        pos.chain(neg).chain(us).chain(big).chain([0.0, -0.0, 1e-40, -1e-40, 1e6])
    }

    #[test]
    fn ln_1p_error_bound() {
        let worst = max_rel_error(ln_1p_points(), |x| ln_1p(x) as f64, |x| (x as f64).ln_1p());
        eprintln!("fast ln_1p: max rel error {worst:.3e}");
        assert!(worst <= LN_1P_MAX_REL_ERR, "{worst:e}");
        assert_eq!(ln_1p(0.0).to_bits(), 0f32.to_bits());
        assert_eq!(ln_1p(-0.0).to_bits(), (-0f32).to_bits());
        // Planted error: ln(1 + x) without Goldberg's correction (ln of the rounded w) fails near 0.
        let plain = |x: f32| {
            let w = 1.0 + x;
            if w == 1.0 { 0.0 } else { ln_1p(w - 1.0) as f64 }
        };
        assert!(max_rel_error(ln_1p_points(), plain, |x| (x as f64).ln_1p()) > LN_1P_MAX_REL_ERR);
    }
}
