//! `perspective` (pinhole) camera: parameters `from`, `to`, `up`, `fov_deg` (full vertical field
//! of view). Same image axes as the orthographic camera (docs/src/conventions.md §5).

use super::look_at_basis;
use crate::geometry::Ray;
use crate::math::{Vec2, Vec3};

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

    #[inline]
    pub fn generate(&self, row: u32, col: u32, u: Vec2) -> Ray {
        let (w, h) = (self.width as f32, self.height as f32);
        let aspect = w / h;
        let x = self.tan_half * aspect * (2.0 * (col as f32 + u.x) / w - 1.0);
        let y = self.tan_half * (1.0 - 2.0 * (row as f32 + u.y) / h);
        Ray::new(self.from, (self.forward + x * self.right + y * self.up).normalize())
    }
}
