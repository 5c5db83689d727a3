//! [`Float3`]: `N` three-vectors in structure-of-arrays form (directions, normals, RGB).
//!
//! The products and sums follow glam's `Vec3` operation for operation (its `dot` is
//! (x·x' + y·y') + z·z', its `normalize` multiplies by 1/length), so lane k has the bits glam gives
//! that lane's vector.
use super::{Float, Isa, Mask, Sse2};
use crate::math::Vec3;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// `N` three-vectors, one per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Float3<const N: usize, S: Isa = Sse2> {
    pub x: Float<N, S>,
    pub y: Float<N, S>,
    pub z: Float<N, S>,
}

impl<const N: usize, S: Isa> Float3<N, S> {
    pub const ZERO: Self = Float3 { x: Float::ZERO, y: Float::ZERO, z: Float::ZERO };

    /// The same lanes, operated on in the instruction set `T` (no instruction).
    #[inline(always)]
    pub fn with_isa<T: Isa>(self) -> Float3<N, T> {
        Float3 { x: self.x.with_isa(), y: self.y.with_isa(), z: self.z.with_isa() }
    }

    #[inline(always)]
    pub fn new(x: Float<N, S>, y: Float<N, S>, z: Float<N, S>) -> Self {
        Float3 { x, y, z }
    }

    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Self {
        Float3 { x: Float::splat(v.x), y: Float::splat(v.y), z: Float::splat(v.z) }
    }

    /// Lane k holds `v[k]`.
    #[inline(always)]
    pub fn from_vecs(v: &[Vec3; N]) -> Self {
        let mut out = Self::ZERO;
        for (k, v) in v.iter().enumerate() {
            out.set_lane(k, *v);
        }
        out
    }

    /// Lane `k`.
    #[inline(always)]
    pub fn lane(&self, k: usize) -> Vec3 {
        Vec3::new(self.x.0[k], self.y.0[k], self.z.0[k])
    }

    /// Writes lane `k`.
    #[inline(always)]
    pub fn set_lane(&mut self, k: usize, v: Vec3) {
        self.x.0[k] = v.x;
        self.y.0[k] = v.y;
        self.z.0[k] = v.z;
    }

    #[inline(always)]
    pub fn dot(self, o: Self) -> Float<N, S> {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// The vector times 1/length (glam's `normalize`).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (1.0 / self.dot(self).sqrt())
    }

    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Float3 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    /// `a` where the mask holds, `b` elsewhere.
    #[inline(always)]
    pub fn select(m: Mask<N, S>, a: Self, b: Self) -> Self {
        Float3 { x: m.select(a.x, b.x), y: m.select(a.y, b.y), z: m.select(a.z, b.z) }
    }

    /// Lanes whose vector is exactly zero (−0.0 included), as `v == Vec3::ZERO`.
    #[inline(always)]
    pub fn is_zero(self) -> Mask<N, S> {
        self.x.eq(Float::ZERO) & self.y.eq(Float::ZERO) & self.z.eq(Float::ZERO)
    }
}

impl<const N: usize, S: Isa> Add for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Float3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl<const N: usize, S: Isa> Sub for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Float3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl<const N: usize, S: Isa> Neg for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Float3 { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// Each lane's vector times that lane's scalar.
impl<const N: usize, S: Isa> Mul<Float<N, S>> for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: Float<N, S>) -> Self {
        Float3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

/// Component by component (an RGB weight times an RGB colour).
impl<const N: usize, S: Isa> Mul for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Float3 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

/// Every lane's vector times the same scalar.
impl<const N: usize, S: Isa> Mul<f32> for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: f32) -> Self {
        Float3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

/// The same colour or vector in every lane times each lane's scalar (`Rgb * f32` of glam).
impl<const N: usize, S: Isa> Mul<Float<N, S>> for Vec3 {
    type Output = Float3<N, S>;
    #[inline(always)]
    fn mul(self, s: Float<N, S>) -> Float3<N, S> {
        Float3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

/// Each lane's vector divided by that lane's scalar (component by component, as glam's `Vec3 / f32`).
impl<const N: usize, S: Isa> Div<Float<N, S>> for Float3<N, S> {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: Float<N, S>) -> Self {
        Float3 { x: self.x / s, y: self.y / s, z: self.z / s }
    }
}
