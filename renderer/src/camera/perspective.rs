//! `perspective` (pinhole) camera: parameters `from`, `to`, `up`, `fov_deg` (full vertical field
//! of view). Same image axes as the orthographic camera (docs/src/conventions.md §5).

use super::look_at_basis;
use crate::geometry::Ray;
use crate::math::{Vec2, Vec3};
use crate::simd::{Float, Float3, Isa};

#[derive(Clone, Debug)]
pub struct Perspective {
    pub from: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    /// tan(fov/2): half-height of the image plane at unit distance.
    pub tan_half: f32,
    pub width: u32,
    pub height: u32,
}

impl Perspective {
    pub fn new(from: Vec3, to: Vec3, up: Vec3, fov_deg: f32, width: u32, height: u32) -> Result<Self, String> {
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(format!("perspective fov_deg must be in (0, 180), got {fov_deg}"));
        }
        let (forward, right, up) = look_at_basis(from, to, up)?;
        Ok(Perspective { from, forward, right, up, tan_half: (0.5 * fov_deg.to_radians()).tan(), width, height })
    }

    /// The ray of film offset `u` inside pixel (row, col): the one-lane [`Perspective::generate_rays`].
    #[inline]
    pub fn generate(&self, row: u32, col: u32, u: Vec2) -> Ray {
        let (o, d) = self.generate_rays(row, col, [Float::<1>::splat(u.x), Float::splat(u.y)]);
        Ray::new(o.lane(0), d.lane(0))
    }

    /// Origins and directions of the rays at film offsets `u` of `N` samples of pixel (row, col):
    /// normalize(forward + x·right + y·up') through the image-plane point (x, y) at unit distance.
    #[inline(always)]
    pub fn generate_rays<const N: usize, S: Isa>(
        &self,
        row: u32,
        col: u32,
        u: [Float<N, S>; 2],
    ) -> (Float3<N, S>, Float3<N, S>) {
        let (w, h) = (self.width as f32, self.height as f32);
        let aspect = w / h;
        let x =
            Float::splat(self.tan_half * aspect) * ((Float::splat(2.0) * (Float::splat(col as f32) + u[0])) / w - 1.0);
        let y = Float::splat(self.tan_half) * (1.0 - (Float::splat(2.0) * (Float::splat(row as f32) + u[1])) / h);
        let dir =
            (Float3::splat(self.forward) + Float3::splat(self.right) * x + Float3::splat(self.up) * y).normalize();
        (Float3::splat(self.from), dir)
    }
}
