//! [`Frames`]: `N` orthonormal shading frames, one per lane (the lane form of [`crate::math::Frame`],
//! which is its one-lane call).
use super::{Float, Float3, Isa, Sse2};

/// `N` frames (s, t, n), one per lane.
#[derive(Clone, Copy, Debug)]
pub struct Frames<const N: usize, S: Isa = Sse2> {
    pub s: Float3<N, S>,
    pub t: Float3<N, S>,
    pub n: Float3<N, S>,
}

impl<const N: usize, S: Isa> Frames<N, S> {
    /// The frame around each lane's unit `n`, without branches on the pole (Duff et al. 2017).
    #[inline(always)]
    pub fn from_normal(n: Float3<N, S>) -> Self {
        let sign = Float::ONE.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Float3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Float3::new(b, sign + n.y * n.y * a, -n.y);
        Frames { s, t, n }
    }

    /// Each lane's `v` from its frame's coordinates to the world's.
    #[inline(always)]
    pub fn to_world(&self, v: Float3<N, S>) -> Float3<N, S> {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    /// Each lane's `v` in its frame's coordinates.
    #[inline(always)]
    pub fn to_local(&self, v: Float3<N, S>) -> Float3<N, S> {
        Float3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}
