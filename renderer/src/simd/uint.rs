//! [`U32`]: `N` lanes of u32, the sampler's integer value type beside [`super::Float`].
//!
//! Every operation is the u32 operation applied lane by lane (wrapping multiplication and
//! addition, shifts, exclusive or, bit reversal), written as a loop over a fixed-size array, so
//! lane k of a computation has the bits of the same computation at `N = 1`. Inside the render's
//! tile loop compiled for x86-64-v3 the loops at `N = 8` become AVX2 instructions (`vpmulld`,
//! `vpxor`, shifts; the bit reversal as byte shuffles).
// Lane loops index every operand by the lane: the form LLVM vectorizes.
#![allow(clippy::needless_range_loop)]

use super::Float;
use super::isa::{Isa, Sse2};
use std::marker::PhantomData;
use std::ops::{BitAnd, BitXor};

/// `N` u32 lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct U32<const N: usize, S: Isa = Sse2>(pub [u32; N], pub PhantomData<S>);

/// Lane-by-lane application of a u32 expression of one lane `k`.
macro_rules! lanes {
    (|$k:ident| $e:expr) => {{
        let mut out = [0u32; N];
        for $k in 0..N {
            out[$k] = $e;
        }
        U32::from_array(out)
    }};
}

impl<const N: usize, S: Isa> U32<N, S> {
    /// The lanes `v`.
    #[inline(always)]
    pub const fn from_array(v: [u32; N]) -> Self {
        U32(v, PhantomData)
    }

    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: u32) -> Self {
        U32::from_array([v; N])
    }

    /// Lane k: `first + k` (wrapping).
    #[inline(always)]
    pub fn ramp(first: u32) -> Self {
        lanes!(|k| first.wrapping_add(k as u32))
    }

    /// Lane `k`.
    #[inline(always)]
    pub fn lane(self, k: usize) -> u32 {
        self.0[k]
    }

    /// `self + o`, wrapping.
    #[inline(always)]
    pub fn wrapping_add(self, o: Self) -> Self {
        lanes!(|k| self.0[k].wrapping_add(o.0[k]))
    }

    /// `self · m`, wrapping (the low 32 bits of the product).
    #[inline(always)]
    pub fn wrapping_mul(self, m: u32) -> Self {
        lanes!(|k| self.0[k].wrapping_mul(m))
    }

    /// `self >> s` (logical).
    #[inline(always)]
    pub fn shift_right(self, s: u32) -> Self {
        lanes!(|k| self.0[k] >> s)
    }

    /// `self & m` in every lane.
    #[inline(always)]
    pub fn and(self, m: u32) -> Self {
        lanes!(|k| self.0[k] & m)
    }

    /// The bits of every lane in reverse order.
    #[inline(always)]
    pub fn reverse_bits(self) -> Self {
        lanes!(|k| self.0[k].reverse_bits())
    }

    /// `(x >> 8) · 2⁻²⁴` of every lane: its 24 high bits as a float in [0, 1), exactly (a 24-bit
    /// integer is an f32, and the scale is a power of two), strictly below 1.
    #[inline(always)]
    pub fn to_unit_f32(self) -> Float<N, S> {
        let mut out = [0.0f32; N];
        for k in 0..N {
            // As i32: the value is below 2^24, and a signed conversion is one instruction in lanes.
            out[k] = (self.0[k] >> 8) as i32 as f32 * (1.0 / 16_777_216.0);
        }
        Float::from_array(out)
    }
}

impl<const N: usize, S: Isa> BitXor for U32<N, S> {
    type Output = Self;
    #[inline(always)]
    fn bitxor(self, o: Self) -> Self {
        lanes!(|k| self.0[k] ^ o.0[k])
    }
}

impl<const N: usize, S: Isa> BitAnd for U32<N, S> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        lanes!(|k| self.0[k] & o.0[k])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each lane is the one-lane operation on that lane's value.
    #[test]
    fn lanes_are_the_scalar_operations() {
        let x = U32::<8>::from_array([0, 1, 0x8000_0001, 0xdead_beef, u32::MAX, 12345, 1 << 31, 0x00ff_ff00]);
        for k in 0..8 {
            let one = U32::<1>::from_array([x.0[k]]);
            assert_eq!(x.reverse_bits().0[k], x.0[k].reverse_bits());
            assert_eq!(x.wrapping_mul(0x6c50_b47c).0[k], x.0[k].wrapping_mul(0x6c50_b47c));
            assert_eq!(x.shift_right(7).0[k], one.shift_right(7).0[0]);
            assert_eq!((x ^ U32::splat(5)).0[k], x.0[k] ^ 5);
            assert_eq!(x.to_unit_f32().0[k], (x.0[k] >> 8) as f32 / 16_777_216.0);
            assert!(x.to_unit_f32().0[k] < 1.0);
        }
        assert_eq!(U32::<4>::ramp(u32::MAX - 1).0, [u32::MAX - 1, u32::MAX, 0, 1]);
    }
}
