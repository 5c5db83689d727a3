//! `orthographic` camera: parameters `from`, `to`, `up`, `extent` (half-width of the view).
//! The ray through film point (x, y) has direction f and origin from + x·right + y·up'
//! (docs/src/conventions.md §5), with x = extent·(2(c+½)/W − 1), y = extent·(H/W)·(1 − 2(r+½)/H) at pixel
//! centres; `u` moves the point inside the pixel (box filter).

use super::look_at_basis;
use crate::geometry::Ray;
use crate::math::{Vec2, Vec3};
use crate::simd::{Float, Float3, Isa};

#[derive(Clone, Debug)]
pub struct Orthographic {
    pub from: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub extent: f32,
    pub width: u32,
    pub height: u32,
}

impl Orthographic {
    pub fn new(from: Vec3, to: Vec3, up: Vec3, extent: f32, width: u32, height: u32) -> Result<Self, String> {
        if !(extent > 0.0 && extent.is_finite()) {
            return Err(format!("orthographic extent must be positive, got {extent}"));
        }
        let (forward, right, up) = look_at_basis(from, to, up)?;
        Ok(Orthographic { from, forward, right, up, extent, width, height })
    }

    /// Film coordinates (x, y) of the points `u` inside pixel (row, col), lane by lane.
    #[inline(always)]
    pub fn film_xy<const N: usize, S: Isa>(
        &self,
        row: u32,
        col: u32,
        u: [Float<N, S>; 2],
    ) -> (Float<N, S>, Float<N, S>) {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = Float::splat(self.extent) * ((Float::splat(2.0) * (Float::splat(col as f32) + u[0])) / w - 1.0);
        let y =
            Float::splat(self.extent * (h / w)) * (1.0 - (Float::splat(2.0) * (Float::splat(row as f32) + u[1])) / h);
        (x, y)
    }

    /// The ray of film offset `u` inside pixel (row, col): the one-lane [`Orthographic::generate_rays`].
    #[inline]
    pub fn generate(&self, row: u32, col: u32, u: Vec2) -> Ray {
        let (o, d) = self.generate_rays(row, col, [Float::<1>::splat(u.x), Float::splat(u.y)]);
        Ray::new(o.lane(0), d.lane(0))
    }

    /// Origins and directions of the rays at film offsets `u` of `N` samples of pixel (row, col):
    /// `film_xy`'s point, then from + x·right + y·up' (the same operations in the same order as on
    /// glam vectors, lane by lane).
    #[inline(always)]
    pub fn generate_rays<const N: usize, S: Isa>(
        &self,
        row: u32,
        col: u32,
        u: [Float<N, S>; 2],
    ) -> (Float3<N, S>, Float3<N, S>) {
        let (x, y) = self.film_xy(row, col, u);
        let origin = Float3::splat(self.from) + Float3::splat(self.right) * x + Float3::splat(self.up) * y;
        (origin, Float3::splat(self.forward))
    }
}
