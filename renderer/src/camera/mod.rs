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
use crate::simd::{Float, Float3, Isa};

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
    pub fn generate_rays<const N: usize, S: Isa>(
        &self,
        row: u32,
        col: u32,
        u: [Float<N, S>; 2],
    ) -> Option<(Float3<N, S>, Float3<N, S>)> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::TestRng;

    /// The rays of 8 lanes are, bit for bit, the rays of the conventions' formulas (§5) evaluated on
    /// glam vectors one sample at a time: the orthographic origin from + x·right + y·up' at the
    /// film point (x, y), and the perspective direction normalize(forward + x·right + y·up'), over
    /// random pixels and film offsets including the pixel's corners.
    #[test]
    fn rays_in_lanes_are_the_formulas() {
        let (from, to, up) = (Vec3::new(4.8, -0.3, 1.4), Vec3::new(0.1, 0.2, -0.1), Vec3::Z);
        let ortho = Orthographic::new(from, to, up, 1.05, 97, 61).unwrap();
        let persp = Perspective::new(from, to, up, 38.0, 97, 61).unwrap();
        let mut rng = TestRng::new(3);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for batch in 0..400 {
            let (row, col) = ((rng.next_u64() % 61) as u32, (rng.next_u64() % 97) as u32);
            let u: [Vec2; 8] = std::array::from_fn(|k| match (batch + k) % 9 {
                0 => Vec2::ZERO,
                1 => Vec2::splat(0.999_999_94),
                _ => Vec2::new(rng.next_f32(), rng.next_f32()),
            });
            let lanes = [Float::<8>::from_array(u.map(|u| u.x)), Float::from_array(u.map(|u| u.y))];
            let (o, d) = ortho.generate_rays(row, col, lanes);
            let (po, pd) = persp.generate_rays(row, col, lanes);
            for (k, uk) in u.iter().enumerate() {
                let (w, h) = (ortho.width as f32, ortho.height as f32);
                let x = ortho.extent * (2.0 * (col as f32 + uk.x) / w - 1.0);
                let y = ortho.extent * (h / w) * (1.0 - 2.0 * (row as f32 + uk.y) / h);
                assert_eq!(bits(o.lane(k)), bits(ortho.from + x * ortho.right + y * ortho.up), "orthographic origin");
                assert_eq!(bits(d.lane(k)), bits(ortho.forward));
                let (w, h) = (persp.width as f32, persp.height as f32);
                let x = persp.tan_half * (w / h) * (2.0 * (col as f32 + uk.x) / w - 1.0);
                let y = persp.tan_half * (1.0 - 2.0 * (row as f32 + uk.y) / h);
                let dir = (persp.forward + x * persp.right + y * persp.up).normalize();
                assert_eq!(bits(pd.lane(k)), bits(dir), "perspective direction");
                assert_eq!(bits(po.lane(k)), bits(persp.from));
            }
        }
    }
}
