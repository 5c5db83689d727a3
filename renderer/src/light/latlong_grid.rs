//! Importance sampling of directions on a lat-long grid of cells (CONVENTIONS §2: row r spans
//! θ ∈ [πr/H, π(r+1)/H], column c spans φ ∈ [2πc/W, 2π(c+1)/W], row 0 at the top, θ = 0).
//!
//! Parameters: `height` H, `width` W and a non-negative value g per cell (the radiance to follow,
//! e.g. the max channel of a pixel). A cell is chosen with probability ∝ g·ΔΩ, ΔΩ = (2π/W)·Δz its
//! exact solid angle (Δz = cos θ_top − cos θ_bottom), by a [`PiecewiseConstant2D`] over the unit square
//! (u = φ/2π, v = row coordinate). Within the cell the direction is drawn uniformly in solid
//! angle: φ linear in u and z = cosθ linear in v. That warp has the constant Jacobian
//! dω = dz dφ = 2π·H·Δz_r du dv on row r, so the solid-angle density is exactly
//! p(ω) = p_uv / (2π H Δz_r) = g / Σ g ΔΩ: piecewise constant on the sphere, proportional to g,
//! bounded at the poles (unlike a θ-linear warp, whose density grows as 1/sinθ there).

use crate::math::{PI, Vec2, Vec3, fast};
use crate::sampling::distribution::{PiecewiseConstant2D, index_below, len_f32};

/// The grid's sampling table can carry a payload `P` per cell (see [`PiecewiseConstant2D`]): the
/// environment map keeps its texels there, so the sampled cell's texel is in the cache line the
/// search just read.
#[derive(Clone, Debug)]
pub struct LatLongGrid<P = ()> {
    width: usize,
    height: usize,
    dist: PiecewiseConstant2D<P>,
    /// cos(πr/H) for r = 0..=H: the z range of each row.
    z_edge: Vec<f32>,
    /// 1 / (2π H Δz_r): converts the unit-square density to solid angle on row r.
    inv_jacobian: Vec<f32>,
}

impl LatLongGrid {
    /// `g` is row-major, `height` rows of `width` cells, all ≥ 0 (negative or NaN count as 0).
    pub fn new(g: &[f32], width: usize, height: usize) -> Self {
        Self::build(g, width, height)
    }
}

impl<P: Copy + Default + Send + Sync> LatLongGrid<P> {
    /// As [`LatLongGrid::new`], with a payload per cell (`P::default()` until `set_payloads`).
    pub fn build(g: &[f32], width: usize, height: usize) -> Self {
        assert!(width > 0 && height > 0 && g.len() == width * height, "LatLongGrid: bad size");
        let z64: Vec<f64> = (0..=height).map(|r| (std::f64::consts::PI * r as f64 / height as f64).cos()).collect();
        let dz: Vec<f64> = z64.windows(2).map(|w| w[0] - w[1]).collect();
        let weights: Vec<f32> = g
            .chunks_exact(width)
            .zip(&dz)
            .flat_map(|(row, &d)| row.iter().map(move |&v| if v > 0.0 { (v as f64 * d) as f32 } else { 0.0 }))
            .collect();
        let inv_jacobian =
            dz.iter().map(|&d| (1.0 / (2.0 * std::f64::consts::PI * height as f64 * d)) as f32).collect();
        LatLongGrid {
            width,
            height,
            dist: PiecewiseConstant2D::build(&weights, width, height),
            z_edge: z64.iter().map(|&z| z as f32).collect(),
            inv_jacobian,
        }
    }

    /// Stores `payloads[row * width + column]` beside each cell. No effect on sampling.
    pub fn set_payloads(&mut self, payloads: &[P]) {
        self.dist.set_payloads(payloads);
    }

    /// The payload of cell `index = row * width + column`.
    #[inline(always)]
    pub fn payload(&self, index: usize) -> &P {
        self.dist.payload(index)
    }

    /// False when every cell has g = 0 (nothing to sample).
    #[inline]
    pub fn can_sample(&self) -> bool {
        self.dist.integral() > 0.0
    }

    /// (row, column) of the cell containing unit direction `d`.
    #[inline]
    pub fn cell(&self, d: Vec3) -> (usize, usize) {
        // atan2 keeps θ accurate near the poles, where acos(z) loses precision in f32. The
        // polynomial atan2 (error ≤ 4e-7 rad, `math::fast`) can put a direction within that of a
        // pixel edge in the neighbouring pixel; eval and pdf both use this function, so they agree.
        // Both angles in one two-lane evaluation (the bits of two `fast::atan2` calls).
        let [theta, mut phi] = fast::atan2_x2([(d.x * d.x + d.y * d.y).sqrt(), d.y], [d.z, d.x]);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let r = index_below(theta * (1.0 / PI) * len_f32(self.height), self.height);
        let c = index_below(phi * (0.5 / PI) * len_f32(self.width), self.width);
        (r, c)
    }

    /// Draws a direction; returns it with its solid-angle density, or None if nothing can be sampled.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        if !self.can_sample() {
            return None;
        }
        let (uv, (iu, iv)) = self.dist.sample_point_cell(u);
        let (d, r) = self.warp(uv);
        Some((d, self.dist.pdf_index(iu, iv) * self.inv_jacobian[r]))
    }

    /// The direction of `sample(u)` without its density (which is not read: a caller that looks the
    /// density up from the direction saves a cache miss), or None if nothing can be sampled.
    #[inline]
    pub fn sample_direction(&self, u: Vec2) -> Option<Vec3> {
        if !self.can_sample() {
            return None;
        }
        Some(self.warp(self.dist.sample_point_cell(u).0).0)
    }

    /// The direction of unit-square point `uv` (uniform in solid angle within its cell) and its row.
    #[inline(always)]
    fn warp(&self, uv: Vec2) -> (Vec3, usize) {
        let fv = uv.y * len_f32(self.height);
        let r = index_below(fv, self.height);
        let t = (fv - len_f32(r)).clamp(0.0, 1.0);
        let z = self.z_edge[r] + t * (self.z_edge[r + 1] - self.z_edge[r]);
        let sin_theta = ((1.0 - z) * (1.0 + z)).max(0.0).sqrt();
        let (sp, cp) = fast::sincos_2pi(uv.x);
        (Vec3::new(sin_theta * cp, sin_theta * sp, z), r)
    }

    /// A hint that `sample(u)` follows soon (starts loading its table entries; no effect on results).
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2) {
        self.dist.prefetch(u);
    }

    /// Solid-angle density of `sample` at unit direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        let (r, c) = self.cell(d);
        self.pdf_cell(r, c)
    }

    /// Solid-angle density on cell (row, column).
    #[inline]
    pub fn pdf_cell(&self, r: usize, c: usize) -> f32 {
        self.dist.pdf_index(c, r) * self.inv_jacobian[r]
    }
}
