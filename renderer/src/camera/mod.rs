//! Cameras (docs/src/conventions.md §5, §6). A camera turns a pixel and a film sample into either a ray or,
//! for the `normal-probe` camera, directly into a shading point on a sphere.
//!
//! - [`orthographic`]: parallel rays, half-width `extent`.
//! - [`perspective`]: pinhole, vertical field of view `fov_deg`.
//! - [`normal_probe`]: renders B(n, ω_o) on a lat-long grid of sphere normals at exitance θ_o.

pub mod normal_probe;
pub mod orthographic;
pub mod perspective;

pub use normal_probe::NormalProbe;
pub use orthographic::Orthographic;
pub use perspective::Perspective;

use crate::geometry::Ray;
use crate::math::{Vec2, Vec3};
use crate::simd::{Float, Float3};

/// What a camera produces for one pixel sample.
#[derive(Clone, Copy, Debug)]
pub enum PrimarySample {
    /// Trace this ray into the scene.
    Ray(Ray),
    /// Shade the point `p` with outward normal `n`, seen from direction `wo` (unit, away from the
    /// surface). Produced by the normal-probe camera.
    Surface { p: Vec3, n: Vec3, wo: Vec3 },
}

#[derive(Clone, Debug)]
pub enum Camera {
    Orthographic(Orthographic),
    Perspective(Perspective),
    NormalProbe(NormalProbe),
}

impl Camera {
    /// The sample of pixel (row, col) at film offset `u` ∈ [0,1)² inside the pixel.
    // Always inlined, as the other functions of a sample are, so that the x86-64-v3 version of the
    // render's tile loop (`render::render_tile`) runs it as compiled for that version.
    #[inline(always)]
    pub fn generate(&self, row: u32, col: u32, u: Vec2) -> PrimarySample {
        match self {
            Camera::Orthographic(c) => PrimarySample::Ray(c.generate(row, col, u)),
            Camera::Perspective(c) => PrimarySample::Ray(c.generate(row, col, u)),
            Camera::NormalProbe(c) => c.generate(row, col, u),
        }
    }

    /// The rays of `N` samples of pixel (row, col) at film offsets `u` (lane k: the ray of
    /// [`Camera::generate`] at `(u[0][k], u[1][k])`, the same bits), as origins and directions; None
    /// for the normal-probe camera, which makes shading points instead of rays.
    #[inline(always)]
    pub fn generate_rays<const N: usize>(
        &self,
        row: u32,
        col: u32,
        u: [Float<N>; 2],
    ) -> Option<(Float3<N>, Float3<N>)> {
        match self {
            Camera::Orthographic(c) => Some(c.generate_rays(row, col, u)),
            Camera::Perspective(c) => Some(c.generate_rays(row, col, u)),
            Camera::NormalProbe(_) => None,
        }
    }

    /// Whether the film offset is used (false: every sample looks through the pixel centre).
    pub fn jitters(&self) -> bool {
        match self {
            Camera::NormalProbe(c) => c.jitter,
            _ => true,
        }
    }
}

/// The camera basis of docs/src/conventions.md §5: f = normalize(to − from), right = normalize(f × up),
/// up' = right × f.
pub fn look_at_basis(from: Vec3, to: Vec3, up: Vec3) -> Result<(Vec3, Vec3, Vec3), String> {
    let f = to - from;
    if f.length_squared() < 1e-20 || !f.is_finite() {
        return Err("camera `from` and `to` coincide".into());
    }
    let f = f.normalize();
    let right = f.cross(up);
    if right.length_squared() < 1e-12 {
        return Err("camera `up` is parallel to the viewing direction".into());
    }
    let right = right.normalize();
    Ok((f, right, right.cross(f)))
}
