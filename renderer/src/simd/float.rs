//! [`Float`] and [`Mask`]: `N` lanes of f32 and of bool, the kernel's value types.
//!
//! Every operation is the IEEE single-precision operation of `f32` applied lane by lane (the same
//! `min`, `max`, `clamp`, `sqrt`, `/` …, in the same order), so lane k of any computation has the
//! bits the same computation has at `N = 1`, whatever `N` is: the one-sample case is the same
//! code, not a twin. The arithmetic (with `sqrt`, `abs`, `min`, `max`, `clamp`, `copysign`), the
//! comparisons and tests, and the masks' operations and selects run through intrinsics where `N`
//! is 4 or 8 (`quads!`): four lanes at a time in 128-bit SSE registers (x86-64's baseline, which
//! every instruction-set copy of the tile loop may inline), or all eight in a 256-bit AVX register
//! when the [`Isa`] is `Avx2` (only in the copies compiled with AVX2); `powf`, `sin_cos` and
//! `exp2_int` are loops over the arrays.
//! Left to loops over arrays, LLVM broke the lanes into scalars and rebuilt vectors with shuffles
//! (guide, "Performance notes and their history", 2026-12-04). Nothing here fuses a multiply and
//! an add (`mul_add` rounds twice), so the baseline, x86-64-v3 and x86-64-v4 copies agree bit for bit.
// Lane loops index every operand by the lane: the form LLVM vectorizes.
#![allow(clippy::needless_range_loop)]

use super::isa::{Isa, Sse2};
use std::marker::PhantomData;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// `N` f32 lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Float<const N: usize, S: Isa = Sse2>(pub [f32; N], pub PhantomData<S>);

/// `N` boolean lanes: which lanes a condition holds in. Each lane is all ones (holds) or all
/// zeros, as an SSE comparison leaves it in a register, so that a select is three bitwise
/// operations and a mask never converts between bytes and lanes. Read with [`Mask::lane`],
/// written with [`Mask::set`] or [`Mask::from_bools`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mask<const N: usize, S: Isa = Sse2>([u32; N], PhantomData<S>);

/// A lane of a [`Mask`] that holds.
const HOLDS: u32 = u32::MAX;

/// Every bit of an f32 but its sign.
const MAGNITUDE: f32 = f32::from_bits(0x7fff_ffff);

/// Lane-by-lane application of a unary f32 expression (a loop LLVM vectorizes).
macro_rules! lanes1 {
    ($a:expr, |$v:ident| $e:expr) => {{
        let a = $a;
        let mut out = [0.0f32; N];
        for k in 0..N {
            let $v = a.0[k];
            out[k] = $e;
        }
        Float::from_array(out)
    }};
}

/// A 128-bit operation `$sse` on four lanes at a time of one or two arrays of 32-bit lanes (an
/// intrinsic of x86-64's baseline, which every copy of the kernel may inline) where `N` is 4 or 8,
/// or the 256-bit operation `$avx` on all eight where `N` is 8 and the [`Isa`] `S` is
/// [`super::Avx2`]; `$e` lane by lane for any other `N`: the same bits lane by lane. LLVM then
/// keeps vectors instead of rebuilding them from scalars. Straight-line code, no loop: with a loop
/// per operation over `N` lanes (unrolled only late) the kernel's compile time was 2.7× longer.
/// `$zero` gives the output's lane type.
#[cfg(target_arch = "x86_64")]
macro_rules! quads {
    ($a:expr, $zero:expr, $sse:ident, $avx:ident, |$x:ident| $e:expr) => {{
        let a = $a;
        let mut out = [$zero; N];
        // SAFETY (every branch): N is 8 or 4 and the lanes are 32 bits wide, so each array is
        // exactly one `__m256`, two `__m128` or one `__m128` (the copies read and write 32 or 16
        // bytes of 32- or 16-byte arrays). SSE and SSE2 are in x86-64's baseline; `S::AVX2` holds
        // only in code compiled with AVX2 for CPUs that have it (`Isa`).
        if N == 8 && S::AVX2 {
            use std::arch::x86_64::*;
            use std::mem::transmute_copy as cast;
            unsafe {
                out = cast(&$avx(cast::<_, __m256>(&a)));
            }
        } else if N == 8 {
            use std::arch::x86_64::*;
            use std::mem::transmute_copy as cast;
            unsafe {
                let a: [__m128; 2] = cast(&a);
                out = cast(&[$sse(a[0]), $sse(a[1])]);
            }
        } else if N == 4 {
            use std::arch::x86_64::*;
            use std::mem::transmute_copy as cast;
            unsafe {
                out = cast(&$sse(cast::<_, __m128>(&a)));
            }
        } else {
            for k in 0..N {
                let $x = a[k];
                out[k] = $e;
            }
        }
        out
    }};
    ($a:expr, $b:expr, $zero:expr, $sse:ident, $avx:ident, |$x:ident, $y:ident| $e:expr) => {{
        let (a, b) = ($a, $b);
        let mut out = [$zero; N];
        // SAFETY: as in the one-operand form.
        if N == 8 && S::AVX2 {
            use std::arch::x86_64::*;
            use std::mem::transmute_copy as cast;
            unsafe {
                out = cast(&$avx(cast::<_, __m256>(&a), cast::<_, __m256>(&b)));
            }
        } else if N == 8 {
            use std::arch::x86_64::*;
            use std::mem::transmute_copy as cast;
            unsafe {
                let (a, b): ([__m128; 2], [__m128; 2]) = (cast(&a), cast(&b));
                out = cast(&[$sse(a[0], b[0]), $sse(a[1], b[1])]);
            }
        } else if N == 4 {
            use std::arch::x86_64::*;
            use std::mem::transmute_copy as cast;
            unsafe {
                out = cast(&$sse(cast::<_, __m128>(&a), cast::<_, __m128>(&b)));
            }
        } else {
            for k in 0..N {
                let ($x, $y) = (a[k], b[k]);
                out[k] = $e;
            }
        }
        out
    }};
}

/// Elsewhere than on x86-64: `$e` lane by lane.
#[cfg(not(target_arch = "x86_64"))]
macro_rules! quads {
    ($a:expr, $zero:expr, $sse:ident, $avx:ident, |$x:ident| $e:expr) => {{
        let a = $a;
        let mut out = [$zero; N];
        for k in 0..N {
            let $x = a[k];
            out[k] = $e;
        }
        out
    }};
    ($a:expr, $b:expr, $zero:expr, $sse:ident, $avx:ident, |$x:ident, $y:ident| $e:expr) => {{
        let (a, b) = ($a, $b);
        let mut out = [$zero; N];
        for k in 0..N {
            let ($x, $y) = (a[k], b[k]);
            out[k] = $e;
        }
        out
    }};
}

/// The 256-bit comparisons with the predicates of SSE's `cmpltps`, `cmpleps`, `cmpgtps`,
/// `cmpgeps`, `cmpeqps` and `cmpunordps` (the same result in every lane; `vcmpps` takes the
/// predicate as an immediate).
#[cfg(target_arch = "x86_64")]
mod cmp256 {
    use std::arch::x86_64::*;
    macro_rules! cmp {
        ($name:ident, $pred:ident) => {
            /// # Safety
            /// The CPU must have AVX; inline only into code compiled with it.
            #[inline(always)]
            pub(super) unsafe fn $name(a: __m256, b: __m256) -> __m256 {
                // SAFETY: the caller's.
                unsafe { _mm256_cmp_ps::<$pred>(a, b) }
            }
        };
    }
    cmp!(cmplt256, _CMP_LT_OS);
    cmp!(cmple256, _CMP_LE_OS);
    cmp!(cmpgt256, _CMP_GT_OS);
    cmp!(cmpge256, _CMP_GE_OS);
    cmp!(cmpeq256, _CMP_EQ_OQ);
    cmp!(cmpunord256, _CMP_UNORD_Q);

    /// [`super::sign_fill`] of eight lanes.
    ///
    /// # Safety
    /// The CPU must have AVX2; inline only into code compiled with it.
    #[inline(always)]
    pub(super) unsafe fn sign_fill256(x: __m256) -> __m256 {
        // SAFETY: the caller's.
        unsafe { _mm256_castsi256_ps(_mm256_srai_epi32::<31>(_mm256_castps_si256(x))) }
    }
}
#[cfg(target_arch = "x86_64")]
use cmp256::*;

/// Each 32-bit lane filled with copies of its sign bit (an arithmetic shift by 31).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn sign_fill(x: std::arch::x86_64::__m128) -> std::arch::x86_64::__m128 {
    use std::arch::x86_64::*;
    // SAFETY: SSE2, which these intrinsics need, is in x86-64's baseline.
    unsafe { _mm_castsi128_ps(_mm_srai_epi32::<31>(_mm_castps_si128(x))) }
}

impl<const N: usize, S: Isa> Float<N, S> {
    pub const ZERO: Self = Float::from_array([0.0; N]);

    /// The lanes `v`.
    #[inline(always)]
    pub const fn from_array(v: [f32; N]) -> Self {
        Float(v, PhantomData)
    }

    pub const ONE: Self = Float::from_array([1.0; N]);

    /// The same lanes, operated on in the instruction set `T` (no instruction).
    #[inline(always)]
    pub fn with_isa<T: Isa>(self) -> Float<N, T> {
        Float::from_array(self.0)
    }

    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: f32) -> Self {
        Float::from_array([v; N])
    }

    /// Lane `k`.
    #[inline(always)]
    pub fn lane(self, k: usize) -> f32 {
        self.0[k]
    }

    /// `table[index[k]]` in lane k (a gather); panics where an index is out of the table.
    #[inline(always)]
    pub fn gather(table: &[f32], index: [u32; N]) -> Self {
        let mut out = [0.0f32; N];
        for k in 0..N {
            out[k] = table[index[k] as usize];
        }
        Float::from_array(out)
    }

    #[inline(always)]
    pub fn sqrt(self) -> Self {
        Float::from_array(quads!(self.0, 0.0f32, _mm_sqrt_ps, _mm256_sqrt_ps, |v| v.sqrt()))
    }

    /// The sign bit cleared (as `f32::abs`).
    #[inline(always)]
    pub fn abs(self) -> Self {
        Float::from_array(quads!(self.0, [MAGNITUDE; N], 0.0f32, _mm_and_ps, _mm256_and_ps, |x, m| f32::from_bits(
            x.to_bits() & m.to_bits()
        )))
    }

    /// `f32::min` lane by lane (a NaN operand gives the other one; of two equal lanes, `self`'s).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        // minps(o, self) is `o < self ? o : self`, which gives `self` where either is NaN; the
        // second step puts `o` where `self` is NaN. (LLVM lowers the scalar `minnum` the same way.)
        let m =
            Float::from_array(quads!(o.0, self.0, 0.0f32, _mm_min_ps, _mm256_min_ps, |y, x| if y < x { y } else { x }));
        self.is_nan().select(o, m)
    }

    /// `f32::max` lane by lane (a NaN operand gives the other one; of two equal lanes, `self`'s).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        let m =
            Float::from_array(quads!(o.0, self.0, 0.0f32, _mm_max_ps, _mm256_max_ps, |y, x| if y > x { y } else { x }));
        self.is_nan().select(o, m)
    }

    /// `f32::clamp` lane by lane (NaN stays NaN; `lo ≤ hi`).
    #[inline(always)]
    pub fn clamp(self, lo: f32, hi: f32) -> Self {
        // maxps(lo, v) is `lo > v ? lo : v` and minps(hi, v) is `hi < v ? hi : v`: a NaN lane
        // passes both, as in `f32::clamp`'s two comparisons.
        let v = quads!([lo; N], self.0, 0.0f32, _mm_max_ps, _mm256_max_ps, |l, v| if l > v { l } else { v });
        Float::from_array(quads!([hi; N], v, 0.0f32, _mm_min_ps, _mm256_min_ps, |h, v| if h < v { h } else { v }))
    }

    /// Each lane's `⌊x⌋` as an index below `n` (0 < n < 2³²): the lanes of
    /// `sampling::distribution::index_below`, `(x as u32).min(n − 1)` (0 for NaN and x < 0).
    #[inline(always)]
    pub fn index_below(self, n: usize) -> [u32; N] {
        debug_assert!(n > 0 && n <= u32::MAX as usize);
        let last = (n - 1) as u32;
        if last < 1 << 24 {
            // `x > 0 ? x : 0` (NaN and −0 give 0), then `v < last ? v : last` (`last` is exact in
            // f32 below 2²⁴), then truncation: ⌊·⌋ is monotone and `last` an integer, so this is
            // min(⌊x⌋, last) without the saturating conversion's tests.
            let v = quads!(self.0, [0.0; N], 0.0f32, _mm_max_ps, _mm256_max_ps, |x, z| if x > z { x } else { z });
            let v = quads!(v, [last as f32; N], 0.0f32, _mm_min_ps, _mm256_min_ps, |v, l| if v < l { v } else { l });
            quads!(v, 0u32, _mm_cvttps_epi32, _mm256_cvttps_epi32, |v| v as u32)
        } else {
            let mut out = [0u32; N];
            for k in 0..N {
                out[k] = (self.0[k] as u32).min(last);
            }
            out
        }
    }

    /// Each lane with the sign of `sign`'s lane.
    #[inline(always)]
    pub fn copysign(self, sign: Self) -> Self {
        let magnitude =
            quads!(self.0, [MAGNITUDE; N], 0u32, _mm_and_ps, _mm256_and_ps, |x, m| x.to_bits() & m.to_bits());
        let signs =
            quads!([MAGNITUDE; N], sign.0, 0u32, _mm_andnot_ps, _mm256_andnot_ps, |m, s| !m.to_bits() & s.to_bits());
        Float::from_array(quads!(magnitude, signs, 0.0f32, _mm_or_ps, _mm256_or_ps, |x, s| f32::from_bits(x | s)))
    }

    /// a·b + c, rounded after the multiply and after the add (not fused: the same bits in every
    /// instruction-set copy, and no `fmaf` call where the build has no FMA).
    #[inline(always)]
    pub fn mul_add(self, b: Self, c: Self) -> Self {
        self * b + c
    }

    /// `f32::powf` lane by lane (libm: a call per lane).
    #[inline(always)]
    pub fn powf(self, e: f32) -> Self {
        lanes1!(self, |v| v.powf(e))
    }

    /// `f32::sin_cos` lane by lane (libm: a call per lane).
    #[inline(always)]
    pub fn sin_cos(self) -> (Self, Self) {
        (lanes1!(self, |v| v.sin()), lanes1!(self, |v| v.cos()))
    }

    /// 2^k for lanes holding integers k ∈ [−126, 127] (built in the exponent bits).
    #[inline(always)]
    pub fn exp2_int(self) -> Self {
        lanes1!(self, |v| f32::from_bits(((v as i32 + 127) as u32) << 23))
    }

    #[inline(always)]
    pub fn lt(self, o: Self) -> Mask<N, S> {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_cmplt_ps, cmplt256, |x, y| if x < y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn le(self, o: Self) -> Mask<N, S> {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_cmple_ps, cmple256, |x, y| if x <= y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn gt(self, o: Self) -> Mask<N, S> {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_cmpgt_ps, cmpgt256, |x, y| if x > y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn ge(self, o: Self) -> Mask<N, S> {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_cmpge_ps, cmpge256, |x, y| if x >= y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn eq(self, o: Self) -> Mask<N, S> {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_cmpeq_ps, cmpeq256, |x, y| if x == y { HOLDS } else { 0 }))
    }

    /// Lanes that are neither infinite nor NaN.
    #[inline(always)]
    pub fn is_finite(self) -> Mask<N, S> {
        // |x| < ∞ fails for ±∞ and for NaN (an unordered comparison).
        self.abs().lt(Float::splat(f32::INFINITY))
    }

    /// NaN lanes.
    #[inline(always)]
    pub fn is_nan(self) -> Mask<N, S> {
        Mask::from_array(quads!(
            self.0,
            self.0,
            0u32,
            _mm_cmpunord_ps,
            cmpunord256,
            |x, y| if x.is_nan() || y.is_nan() { HOLDS } else { 0 }
        ))
    }

    /// Lanes with the sign bit set (−0.0 included).
    #[inline(always)]
    pub fn is_sign_negative(self) -> Mask<N, S> {
        Mask::from_array(quads!(self.0, 0u32, sign_fill, sign_fill256, |x| if x.is_sign_negative() {
            HOLDS
        } else {
            0
        }))
    }

    /// Each lane widened to f64.
    #[inline(always)]
    pub fn to_f64(self) -> [f64; N] {
        let mut out = [0.0f64; N];
        for k in 0..N {
            out[k] = self.0[k] as f64;
        }
        out
    }

    /// Lanes of f64 rounded to f32.
    #[inline(always)]
    pub fn from_f64(v: [f64; N]) -> Self {
        let mut out = [0.0f32; N];
        for k in 0..N {
            out[k] = v[k] as f32;
        }
        Float::from_array(out)
    }
}

impl<const N: usize, S: Isa> Mask<N, S> {
    /// Lanes each all ones (holds) or all zeros.
    #[inline(always)]
    const fn from_array(v: [u32; N]) -> Self {
        Mask(v, PhantomData)
    }

    pub const NONE: Self = Mask::from_array([0; N]);
    pub const ALL: Self = Mask::from_array([HOLDS; N]);

    /// The same lanes, operated on in the instruction set `T` (no instruction).
    #[inline(always)]
    pub fn with_isa<T: Isa>(self) -> Mask<N, T> {
        Mask::from_array(self.0)
    }

    #[inline(always)]
    pub fn splat(v: bool) -> Self {
        Mask::from_array([if v { HOLDS } else { 0 }; N])
    }

    /// The mask holding in the lanes where `b` is true.
    #[inline(always)]
    pub fn from_bools(b: [bool; N]) -> Self {
        let mut out = [0u32; N];
        for k in 0..N {
            out[k] = if b[k] { HOLDS } else { 0 };
        }
        Mask::from_array(out)
    }

    /// `a` where the mask holds, `b` elsewhere (bitwise: (m ∧ a) ∨ (¬m ∧ b)).
    #[inline(always)]
    pub fn select(self, a: Float<N, S>, b: Float<N, S>) -> Float<N, S> {
        let ma = quads!(self.0, a.0, 0u32, _mm_and_ps, _mm256_and_ps, |m, x| m & x.to_bits());
        let mb = quads!(self.0, b.0, 0u32, _mm_andnot_ps, _mm256_andnot_ps, |m, x| !m & x.to_bits());
        Float::from_array(quads!(ma, mb, 0.0f32, _mm_or_ps, _mm256_or_ps, |x, y| f32::from_bits(x | y)))
    }

    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        let mut any = 0;
        for k in 0..N {
            any |= self.0[k];
        }
        any != 0
    }

    /// Lane `k`.
    #[inline(always)]
    pub fn lane(self, k: usize) -> bool {
        self.0[k] != 0
    }

    /// Sets lane `k` to hold or not.
    #[inline(always)]
    pub fn set(&mut self, k: usize, v: bool) {
        self.0[k] = if v { HOLDS } else { 0 };
    }
}

macro_rules! binary {
    ($tr:ident, $f:ident, $op:tt, $sse:ident, $avx:ident) => {
        impl<const N: usize, S: Isa> $tr for Float<N, S> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Float::from_array(quads!(self.0, o.0, 0.0f32, $sse, $avx, |x, y| x $op y))
            }
        }
        impl<const N: usize, S: Isa> $tr<f32> for Float<N, S> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: f32) -> Self {
                Float::from_array(quads!(self.0, [o; N], 0.0f32, $sse, $avx, |x, y| x $op y))
            }
        }
        impl<const N: usize, S: Isa> $tr<Float<N, S>> for f32 {
            type Output = Float<N, S>;
            #[inline(always)]
            fn $f(self, o: Float<N, S>) -> Float<N, S> {
                Float::from_array(quads!([self; N], o.0, 0.0f32, $sse, $avx, |x, y| x $op y))
            }
        }
    };
}
binary!(Add, add, +, _mm_add_ps, _mm256_add_ps);
binary!(Sub, sub, -, _mm_sub_ps, _mm256_sub_ps);
binary!(Mul, mul, *, _mm_mul_ps, _mm256_mul_ps);
binary!(Div, div, /, _mm_div_ps, _mm256_div_ps);

impl<const N: usize, S: Isa> Neg for Float<N, S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Float::from_array(quads!(self.0, [-0.0f32; N], 0.0f32, _mm_xor_ps, _mm256_xor_ps, |x, s| f32::from_bits(
            x.to_bits() ^ s.to_bits()
        )))
    }
}

impl<const N: usize, S: Isa> BitAnd for Mask<N, S> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_and_ps, _mm256_and_ps, |x, y| x & y))
    }
}

impl<const N: usize, S: Isa> BitOr for Mask<N, S> {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        Mask::from_array(quads!(self.0, o.0, 0u32, _mm_or_ps, _mm256_or_ps, |x, y| x | y))
    }
}

impl<const N: usize, S: Isa> Not for Mask<N, S> {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        Mask::from_array(quads!(self.0, [HOLDS; N], 0u32, _mm_xor_ps, _mm256_xor_ps, |x, y| x ^ y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values where lane operations and scalar ones could part: signed zeros, infinities, NaN,
    /// subnormals and the largest finite magnitudes.
    const SPECIAL: [f32; 13] = [
        0.0,
        -0.0,
        1.0,
        -2.5,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MIN_POSITIVE / 4.0,
        -f32::MIN_POSITIVE / 4.0,
        f32::MAX,
        -f32::MAX,
        0.3,
        1e-30,
    ];

    /// Equal bits, or both NaN (a NaN's payload is not specified by Rust's scalar operations).
    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// Every pair of special values, in lanes of width `N`, chunk by chunk: each lane of each
    /// operation is the one-lane operation on that lane's values, which is the f32 operation
    /// (min and max of two zeros of either sign give `self`'s, a choice f32's leave open).
    fn check<const N: usize, S: Isa>() {
        let pairs: Vec<(f32, f32)> = SPECIAL.iter().flat_map(|&x| SPECIAL.iter().map(move |&y| (x, y))).collect();
        for chunk in pairs.chunks(N) {
            let mut xs = [0.5f32; N];
            let mut ys = [0.25f32; N];
            for (k, &(x, y)) in chunk.iter().enumerate() {
                (xs[k], ys[k]) = (x, y);
            }
            let (a, b) = (Float::from_array(xs), Float::from_array(ys));
            for k in 0..N {
                let (x, y) = (xs[k], ys[k]);
                let (one_x, one_y) = (Float::<1>::from_array([x]), Float::from_array([y]));
                let lanes: [(&str, f32, f32, f32); 12] = [
                    ("+", (a + b).0[k], (one_x + one_y).0[0], x + y),
                    ("-", (a - b).0[k], (one_x - one_y).0[0], x - y),
                    ("*", (a * b).0[k], (one_x * one_y).0[0], x * y),
                    ("/", (a / b).0[k], (one_x / one_y).0[0], x / y),
                    ("neg", (-a).0[k], (-one_x).0[0], -x),
                    ("sqrt", a.sqrt().0[k], one_x.sqrt().0[0], x.sqrt()),
                    ("abs", a.abs().0[k], one_x.abs().0[0], x.abs()),
                    ("copysign", a.copysign(b).0[k], one_x.copysign(one_y).0[0], x.copysign(y)),
                    ("min", a.min(b).0[k], one_x.min(one_y).0[0], if x == y { x } else { x.min(y) }),
                    ("max", a.max(b).0[k], one_x.max(one_y).0[0], if x == y { x } else { x.max(y) }),
                    ("clamp", a.clamp(-1.0, 2.0).0[k], one_x.clamp(-1.0, 2.0).0[0], x.clamp(-1.0, 2.0)),
                    (
                        "select",
                        a.lt(b).select(a, b).0[k],
                        one_x.lt(one_y).select(one_x, one_y).0[0],
                        if x < y { x } else { y },
                    ),
                ];
                for (name, lane, one, scalar) in lanes {
                    assert!(
                        same(lane, one) && same(lane, scalar),
                        "{name}({x:e}, {y:e}) in N = {N}: lane {lane:e}, one-lane {one:e}, f32 {scalar:e}"
                    );
                }
                let tests: [(&str, Mask<N, S>, bool); 8] = [
                    ("<", a.lt(b), x < y),
                    ("<=", a.le(b), x <= y),
                    (">", a.gt(b), x > y),
                    (">=", a.ge(b), x >= y),
                    ("==", a.eq(b), x == y),
                    ("is_finite", a.is_finite(), x.is_finite()),
                    ("is_nan", a.is_nan(), x.is_nan()),
                    ("is_sign_negative", a.is_sign_negative(), x.is_sign_negative()),
                ];
                for (name, mask, want) in tests {
                    assert_eq!(mask.lane(k), want, "{name}({x:e}, {y:e}) in N = {N}");
                    assert!(mask.0[k] == 0 || mask.0[k] == HOLDS, "{name}: lane {k} is neither all ones nor zeros");
                }
                for n in [1usize, 2, 7, 1 << 24, (1 << 24) + 1, u32::MAX as usize] {
                    let want = ((x as u32) as usize).min(n - 1) as u32;
                    assert_eq!(
                        (a.index_below(n)[k], one_x.index_below(n)[0]),
                        (want, want),
                        "index_below({x:e}, {n}) in N = {N}"
                    );
                }
                let (m, n) = (a.lt(b), a.is_sign_negative());
                assert_eq!((m & n).lane(k), (x < y) && x.is_sign_negative());
                assert_eq!((m | n).lane(k), (x < y) || x.is_sign_negative());
                assert_eq!((!m).lane(k), !m.lane(k));
            }
        }
    }

    #[test]
    fn lanes_are_the_scalar_operations() {
        // 8 and 4: SSE registers; 7 and 1: the scalar expressions lane by lane.
        check::<8, Sse2>();
        check::<7, Sse2>();
        check::<4, Sse2>();
        check::<1, Sse2>();
        // 8 in one 256-bit register (the tile loop's AVX2 copies), on a CPU that has AVX2; the
        // operations are then calls to the intrinsics rather than inlined, the same instructions.
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            check::<8, super::super::Avx2>();
        } else {
            eprintln!("lanes_are_the_scalar_operations: this CPU has no AVX2; the 256-bit lanes are not checked");
        }
    }
}
