//! [`Float`] and [`Mask`]: `N` lanes of f32 and of bool, the kernel's value types.
//!
//! Every operation is the IEEE single-precision operation of `f32` applied lane by lane (the same
//! `min`, `max`, `clamp`, `sqrt`, `/` …, in the same order), so lane k of any computation has the
//! bits the same computation has at `N = 1`, whatever `N` is: the one-sample case is the same
//! code, not a twin. The arithmetic, the comparisons and the masks' operations and selects run
//! four lanes at a time through 128-bit SSE intrinsics (`quads!`; SSE is in x86-64's baseline, so
//! every instruction-set copy of the tile loop inlines them), the rest as loops over the arrays.
//! Left to loops over arrays, LLVM broke the lanes into scalars and rebuilt vectors with shuffles
//! (guide, "Performance notes and their history", 2026-12-04). Nothing here fuses a multiply and
//! an add (`mul_add` rounds twice), so the baseline and the x86-64-v3 copies agree bit for bit.
// Lane loops index every operand by the lane: the form LLVM vectorizes.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// `N` f32 lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Float<const N: usize>(pub [f32; N]);

/// `N` boolean lanes: which lanes a condition holds in. Each lane is all ones (holds) or all
/// zeros, as an SSE comparison leaves it in a register, so that a select is three bitwise
/// operations and a mask never converts between bytes and lanes. Read with [`Mask::lane`],
/// written with [`Mask::set`] or [`Mask::from_bools`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mask<const N: usize>([u32; N]);

/// A lane of a [`Mask`] that holds.
const HOLDS: u32 = u32::MAX;

/// Lane-by-lane application of a unary f32 expression (a loop LLVM vectorizes).
macro_rules! lanes1 {
    ($a:expr, |$v:ident| $e:expr) => {{
        let a = $a;
        let mut out = [0.0f32; N];
        for k in 0..N {
            let $v = a.0[k];
            out[k] = $e;
        }
        Float(out)
    }};
}

/// Lane-by-lane application of a binary f32 expression.
macro_rules! lanes2 {
    ($a:expr, $b:expr, |$x:ident, $y:ident| $e:expr) => {{
        let (a, b) = ($a, $b);
        let mut out = [0.0f32; N];
        for k in 0..N {
            let ($x, $y) = (a.0[k], b.0[k]);
            out[k] = $e;
        }
        Float(out)
    }};
}

/// Lane-by-lane test of a condition `$e` (a lane that holds is all ones).
macro_rules! test {
    ($a:expr, |$x:ident| $e:expr) => {{
        let a = $a;
        let mut out = [0u32; N];
        for k in 0..N {
            let $x = a.0[k];
            out[k] = if $e { HOLDS } else { 0 };
        }
        Mask(out)
    }};
}

/// A 128-bit operation `$sse` on four lanes at a time of two arrays of 32-bit lanes (an intrinsic
/// of x86-64's baseline, which every copy of the kernel may inline), and `$e` on the other `N` mod
/// 4 lanes: the same bits lane by lane. LLVM then keeps vectors of four lanes instead of rebuilding
/// them from scalars. `$zero` gives the output's lane type.
macro_rules! quads {
    ($a:expr, $b:expr, $zero:expr, $sse:ident, |$x:ident, $y:ident| $e:expr) => {{
        let (a, b) = ($a, $b);
        let mut out = [$zero; N];
        #[allow(unused_mut)]
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            while done + 4 <= N {
                // SAFETY: lanes done..done + 4 are inside the three arrays (done + 4 ≤ N), whose
                // lanes are 32 bits wide; the loads and the store are unaligned.
                unsafe {
                    let v = $sse(_mm_loadu_ps(a.as_ptr().add(done).cast()), _mm_loadu_ps(b.as_ptr().add(done).cast()));
                    _mm_storeu_ps(out.as_mut_ptr().add(done).cast(), v);
                }
                done += 4;
            }
        }
        for k in done..N {
            let ($x, $y) = (a[k], b[k]);
            out[k] = $e;
        }
        out
    }};
}

impl<const N: usize> Float<N> {
    pub const ZERO: Self = Float([0.0; N]);
    pub const ONE: Self = Float([1.0; N]);

    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: f32) -> Self {
        Float([v; N])
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
        Float(out)
    }

    #[inline(always)]
    pub fn sqrt(self) -> Self {
        lanes1!(self, |v| v.sqrt())
    }

    #[inline(always)]
    pub fn abs(self) -> Self {
        lanes1!(self, |v| v.abs())
    }

    /// `f32::min` lane by lane (a NaN operand gives the other one).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        lanes2!(self, o, |x, y| x.min(y))
    }

    /// `f32::max` lane by lane (a NaN operand gives the other one).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        lanes2!(self, o, |x, y| x.max(y))
    }

    /// `f32::clamp` lane by lane (NaN stays NaN).
    #[inline(always)]
    pub fn clamp(self, lo: f32, hi: f32) -> Self {
        lanes1!(self, |v| v.clamp(lo, hi))
    }

    /// Each lane with the sign of `sign`'s lane.
    #[inline(always)]
    pub fn copysign(self, sign: Self) -> Self {
        lanes2!(self, sign, |x, s| x.copysign(s))
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
    pub fn lt(self, o: Self) -> Mask<N> {
        Mask(quads!(self.0, o.0, 0u32, _mm_cmplt_ps, |x, y| if x < y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn le(self, o: Self) -> Mask<N> {
        Mask(quads!(self.0, o.0, 0u32, _mm_cmple_ps, |x, y| if x <= y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn gt(self, o: Self) -> Mask<N> {
        Mask(quads!(self.0, o.0, 0u32, _mm_cmpgt_ps, |x, y| if x > y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn ge(self, o: Self) -> Mask<N> {
        Mask(quads!(self.0, o.0, 0u32, _mm_cmpge_ps, |x, y| if x >= y { HOLDS } else { 0 }))
    }

    #[inline(always)]
    pub fn eq(self, o: Self) -> Mask<N> {
        Mask(quads!(self.0, o.0, 0u32, _mm_cmpeq_ps, |x, y| if x == y { HOLDS } else { 0 }))
    }

    /// Lanes that are neither infinite nor NaN.
    #[inline(always)]
    pub fn is_finite(self) -> Mask<N> {
        test!(self, |x| x.is_finite())
    }

    /// Lanes with the sign bit set (−0.0 included).
    #[inline(always)]
    pub fn is_sign_negative(self) -> Mask<N> {
        test!(self, |x| x.is_sign_negative())
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
        Float(out)
    }
}

impl<const N: usize> Mask<N> {
    pub const NONE: Self = Mask([0; N]);
    pub const ALL: Self = Mask([HOLDS; N]);

    #[inline(always)]
    pub fn splat(v: bool) -> Self {
        Mask([if v { HOLDS } else { 0 }; N])
    }

    /// The mask holding in the lanes where `b` is true.
    #[inline(always)]
    pub fn from_bools(b: [bool; N]) -> Self {
        let mut out = [0u32; N];
        for k in 0..N {
            out[k] = if b[k] { HOLDS } else { 0 };
        }
        Mask(out)
    }

    /// `a` where the mask holds, `b` elsewhere (bitwise: (m ∧ a) ∨ (¬m ∧ b)).
    #[inline(always)]
    pub fn select(self, a: Float<N>, b: Float<N>) -> Float<N> {
        let ma = quads!(self.0, a.0, 0u32, _mm_and_ps, |m, x| m & x.to_bits());
        let mb = quads!(self.0, b.0, 0u32, _mm_andnot_ps, |m, x| !m & x.to_bits());
        Float(quads!(ma, mb, 0.0f32, _mm_or_ps, |x, y| f32::from_bits(x | y)))
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
    ($tr:ident, $f:ident, $op:tt, $sse:ident) => {
        impl<const N: usize> $tr for Float<N> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Float(quads!(self.0, o.0, 0.0f32, $sse, |x, y| x $op y))
            }
        }
        impl<const N: usize> $tr<f32> for Float<N> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: f32) -> Self {
                Float(quads!(self.0, [o; N], 0.0f32, $sse, |x, y| x $op y))
            }
        }
        impl<const N: usize> $tr<Float<N>> for f32 {
            type Output = Float<N>;
            #[inline(always)]
            fn $f(self, o: Float<N>) -> Float<N> {
                Float(quads!([self; N], o.0, 0.0f32, $sse, |x, y| x $op y))
            }
        }
    };
}
binary!(Add, add, +, _mm_add_ps);
binary!(Sub, sub, -, _mm_sub_ps);
binary!(Mul, mul, *, _mm_mul_ps);
binary!(Div, div, /, _mm_div_ps);

impl<const N: usize> Neg for Float<N> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        lanes1!(self, |v| -v)
    }
}

impl<const N: usize> BitAnd for Mask<N> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        Mask(quads!(self.0, o.0, 0u32, _mm_and_ps, |x, y| x & y))
    }
}

impl<const N: usize> BitOr for Mask<N> {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        Mask(quads!(self.0, o.0, 0u32, _mm_or_ps, |x, y| x | y))
    }
}

impl<const N: usize> Not for Mask<N> {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        Mask(quads!(self.0, [HOLDS; N], 0u32, _mm_xor_ps, |x, y| x ^ y))
    }
}
