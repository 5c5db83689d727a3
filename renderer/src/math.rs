//! Small geometric helpers in the world frame of docs/src/conventions.md §1 (+z up, right-handed).

pub mod fast;

pub use glam::{Vec2, Vec3};

/// Linear RGB radiance or reflectance. A plain `Vec3` so all glam arithmetic applies.
pub type Rgb = Vec3;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Asks the CPU to start loading `x` into cache (no-op where there is no such instruction).
#[inline(always)]
pub fn prefetch_read<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that never faults and has no architectural effect; the pointer
    // comes from a live reference.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(x as *const T as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// ω(θ, φ) = (sinθ cosφ, sinθ sinφ, cosθ).
#[inline]
pub fn spherical_direction(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

/// (θ ∈ [0, π], φ ∈ [0, 2π)) of a unit vector.
#[inline]
pub fn spherical_angles(d: Vec3) -> (f32, f32) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    (theta, phi)
}

/// Reflection of `wo` about `n`: R = 2(n·ω_o)n − ω_o (docs/src/conventions.md §1).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * n.dot(wo) * n - wo
}

/// An orthonormal frame (s, t, n). Local coordinates have the normal along +z, so BRDFs work with
/// cosθ = w.z.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around unit `n` without branches on the pole (Duff et al. 2017): the one-lane
    /// [`crate::simd::Frames::from_normal`].
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let f = crate::simd::Frames::<1>::from_normal(crate::simd::Float3::splat(n));
        Frame { s: f.s.lane(0), t: f.t.lane(0), n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Rotation matrix of docs/src/conventions.md §6 `rotate_deg = [x, y, z]`: about x, then y, then z.
pub fn rotation_xyz_deg(deg: [f32; 3]) -> glam::Mat3 {
    let [x, y, z] = deg.map(f32::to_radians);
    glam::Mat3::from_rotation_z(z) * glam::Mat3::from_rotation_y(y) * glam::Mat3::from_rotation_x(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in
            [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.4, 0.5).normalize(), Vec3::new(1e-8, 0.0, -1.0).normalize()]
        {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            assert!((f.s.cross(f.t) - n).length() < 1e-5, "right-handed");
            let v = Vec3::new(0.2, 0.7, -0.1);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn spherical_round_trip() {
        let d = spherical_direction(1.1, 4.0);
        let (t, p) = spherical_angles(d);
        assert!((t - 1.1).abs() < 1e-5 && (p - 4.0).abs() < 1e-5);
    }
}
