//! Importance sampling of directions on a lat-long grid of cells (docs/src/conventions.md §2: row r spans
//! θ ∈ [πr/H, π(r+1)/H], column c spans φ ∈ [2πc/W, 2π(c+1)/W], row 0 at the top, θ = 0).
//!
//! Parameters: `height` H, `width` W and a non-negative value g per cell (the radiance to follow,
//! e.g. the luminance of a pixel). A cell is chosen with probability ∝ g·ΔΩ, ΔΩ = (2π/W)·Δz its
//! exact solid angle (Δz = cos θ_top − cos θ_bottom), by a [`PiecewiseConstant2D`] over the unit square
//! (u = φ/2π, v = row coordinate). Within the cell the direction is drawn uniformly in solid
//! angle: φ linear in u and z = cosθ linear in v. That warp has the constant Jacobian
//! dω = dz dφ = 2π·H·Δz_r du dv on row r, so the solid-angle density is exactly
//! p(ω) = p_uv / (2π H Δz_r) = g / Σ g ΔΩ: piecewise constant on the sphere, proportional to g,
//! bounded at the poles (unlike a θ-linear warp, whose density grows as 1/sinθ there).

use crate::math::{PI, Vec2, Vec3};
use crate::sampling::distribution::{PiecewiseConstant2D, len_f32};
use crate::simd::{Float, Float3, Isa, Mask};

/// Margins of [`LatLongGrid::sample_directions`], each a few times the error it covers. In z:
/// the row edges' f32 rounding (6e-8) plus sinθ × the error of `cell`'s θ, which is below 2e-6 rad
/// (its atan2, 4e-7; the rounding of θ·H/π, 3π·2⁻²⁴ ≈ 6e-7; a rotation and its inverse in f32 and a
/// normalize, < 1e-6 on the components).
const Z_MARGIN: f32 = 8e-6;
/// In φ, radians times sinθ: the components' error (rotation, normalize, the warp's `sincos_2pi`,
/// < 1.2e-6) moves φ by that over sinθ; `cell`'s atan2 (4e-7) and its + 2π (2.4e-7) are inside it
/// too, as sinθ ≤ 1.
const PHI_MARGIN: f32 = 4e-6;
/// In φ, the rounding of `cell`'s φ·W/2π and of u·W here, relative to W (a few ulps of W).
const PHI_ROUNDING: f32 = 16.0 / 16_777_216.0;

/// cos(πr/H) for r = 0..=H, in f64: the z of each row's top and bottom edge (row r spans
/// z ∈ [edge r + 1, edge r], its cells' solid angle (2π/W) × the difference).
pub(super) fn row_edges(height: usize) -> Vec<f64> {
    (0..=height).map(|r| (std::f64::consts::PI * r as f64 / height as f64).cos()).collect()
}

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
        let z64 = row_edges(height);
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

    /// (row, column) of the cell containing unit direction `d`: the one-lane [`LatLongGrid::cells`].
    #[inline]
    pub fn cell(&self, d: Vec3) -> (usize, usize) {
        let (r, c) = self.cells(Float3::<1>::splat(d));
        (r[0], c[0])
    }

    /// The rows and columns of the cells containing each lane's unit direction.
    #[inline(always)]
    pub fn cells<const N: usize, S: Isa>(&self, d: Float3<N, S>) -> ([usize; N], [usize; N]) {
        // atan2 keeps θ accurate near the poles, where acos(z) loses precision in f32. The
        // polynomial atan2 (error ≤ 4e-7 rad, `math::fast`) can put a direction within that of a
        // pixel edge in the neighbouring pixel; eval and pdf both use this function, so they agree.
        let theta = (d.x * d.x + d.y * d.y).sqrt().atan2(d.z);
        let phi = d.y.atan2(d.x);
        let phi = phi.lt(Float::ZERO).select(phi + 2.0 * PI, phi);
        let fr = theta * (1.0 / PI) * len_f32(self.height);
        let fc = phi * (0.5 / PI) * len_f32(self.width);
        let (ir, ic) = (fr.index_below(self.height), fc.index_below(self.width));
        let (mut r, mut c) = ([0usize; N], [0usize; N]);
        for k in 0..N {
            (r[k], c[k]) = (ir[k] as usize, ic[k] as usize);
        }
        (r, c)
    }

    /// Draws a direction; returns it with its solid-angle density, or None if nothing can be sampled.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        if !self.can_sample() {
            return None;
        }
        let ([pu, pv], iu, iv) = self.dist.sample_points([Float::<1>::splat(u.x), Float::splat(u.y)], Mask::ALL);
        let (d, r, ..) = self.warp(pu, pv);
        Some((d.lane(0), self.dist.pdf_index(iu[0], iv[0]) * self.inv_jacobian[r[0]]))
    }

    /// The direction of `sample(u)` in each lane `k` with `want[k]`, without its density (which is
    /// not read: a caller that looks the density up from the direction saves a cache miss), or None
    /// in every lane if nothing can be sampled (the other lanes' values are unspecified).
    ///
    /// With it, the cell index (row · W + column) when the direction is provably in the cell it was
    /// drawn from *as [`LatLongGrid::cell`] sees it*, also after a rotation ρ applied to it and undone
    /// (`cell(ρᵀ·normalize(ρ·d))`, f32 matrices): it lies at least `Z_MARGIN` in z from the
    /// row's edges and at least `PHI_MARGIN / sinθ` rad plus `PHI_ROUNDING` cell widths in φ from
    /// the column's edges. None near an edge, where rounding (of the warp, the rotation and
    /// `cell`'s arctangents) may move it across; a caller then looks the direction up. A caller
    /// given the index can read the cell's data without the lookup (two arctangents) and gets the
    /// bits `cell` would give.
    ///
    /// The cutpoint walk of each lane runs on its own (its loop length depends on the table;
    /// [`PiecewiseConstant2D::sample_points`] runs the rest over the lanes); the warp to the sphere
    /// and the in-cell tests run over all lanes, in SIMD registers inside the x86-64-v3 copy of the
    /// render's tile loop.
    #[inline(always)]
    pub fn sample_directions<const N: usize, S: Isa>(
        &self,
        u: [Float<N, S>; 2],
        want: Mask<N, S>,
    ) -> Option<(Float3<N, S>, [Option<usize>; N])> {
        self.sample_directions_with(u, want, Z_MARGIN, PHI_MARGIN, PHI_ROUNDING)
    }

    /// [`LatLongGrid::sample_directions`] with its margins as arguments (the tests show that zero
    /// margins give wrong cells).
    #[inline(always)]
    fn sample_directions_with<const N: usize, S: Isa>(
        &self,
        u: [Float<N, S>; 2],
        want: Mask<N, S>,
        z_margin: f32,
        phi_margin: f32,
        phi_rounding: f32,
    ) -> Option<(Float3<N, S>, [Option<usize>; N])> {
        if !self.can_sample() {
            return None;
        }
        let ([pu, pv], iu, _) = self.dist.sample_points(u, want);
        let (d, r, sin_theta, z0, z1) = self.warp(pu, pv);
        // Row: z against the row's stored edges (which are within 6e-8 of cos(πr/H)).
        let margin = Float::splat(z_margin);
        let row_inside = (z0 - d.z).gt(margin) & (d.z - z1).gt(margin);
        // Column: the distance of u·W from the column's edges, in cells (f32 rounding of the
        // product is below one ulp of W, inside `phi_rounding`); an angular error ε of the
        // direction's components moves φ by ε / sinθ.
        let w = len_f32(self.width);
        let mut fiu = Float::<N, S>::ZERO;
        for (f, &i) in fiu.0.iter_mut().zip(&iu) {
            *f = len_f32(i);
        }
        let tu = pu * w - fiu;
        let col_inside =
            ((tu.min(1.0 - tu) - phi_rounding * w) * sin_theta).gt(Float::splat(phi_margin * w * (0.5 / PI)));
        let inside = row_inside & col_inside;
        let mut cell = [None; N];
        for k in 0..N {
            if inside.lane(k) {
                cell[k] = Some(r[k] * self.width + iu[k]);
            }
        }
        Some((d, cell))
    }

    /// The direction of each lane's unit-square point (u, v) (uniform in solid angle within its
    /// cell), its row, its sinθ and its row's z edges.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn warp<const N: usize, S: Isa>(
        &self,
        pu: Float<N, S>,
        pv: Float<N, S>,
    ) -> (Float3<N, S>, [usize; N], Float<N, S>, Float<N, S>, Float<N, S>) {
        let fv = pv * len_f32(self.height);
        let ir = fv.index_below(self.height);
        let (mut r, mut fr, mut ir1) = ([0usize; N], Float::<N, S>::ZERO, [0u32; N]);
        for k in 0..N {
            r[k] = ir[k] as usize;
            fr.0[k] = ir[k] as f32;
            ir1[k] = ir[k] + 1;
        }
        let t = (fv - fr).clamp(0.0, 1.0);
        let (z0, z1) = (Float::gather(&self.z_edge, ir), Float::gather(&self.z_edge, ir1));
        let z = z0 + t * (z1 - z0);
        let sin_theta = ((1.0 - z) * (1.0 + z)).max(Float::ZERO).sqrt();
        let (sp, cp) = pu.sincos_2pi();
        (Float3::new(sin_theta * cp, sin_theta * sp, z), r, sin_theta, z0, z1)
    }

    /// A hint that `sample(u)` follows soon (starts loading its table entries; no effect on results).
    #[inline(always)]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotation_xyz_deg;
    use crate::sampling::chi2::TestRng;

    /// A 2048 × 1024 grid with cells of very different weights, and the rotations the tests apply.
    /// `cells` at eight lanes is its one-lane call `cell` lane by lane: random unit directions, the poles, the seam φ = 0
    /// from both sides, and ±0 components.
    #[test]
    fn eight_wide_cells_are_one_wide_cells() {
        let g = grid();
        let mut dirs: Vec<Vec3> = (0..4096)
            .map(|i| {
                let u = Vec2::new((i as f32 * 0.618_034).fract(), (i as f32 * 0.414_213_57 + 0.1).fract());
                crate::sampling::warp::square_to_uniform_sphere(u)
            })
            .collect();
        dirs.extend([
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            -Vec3::X,
            Vec3::new(1.0, -0.0, 0.0),
            Vec3::new(1.0, -1e-8, 1e-3).normalize(),
        ]);
        dirs.extend([Vec3::new(-0.0, 0.0, 1.0), Vec3::new(0.0, -0.0, -1.0)]);
        while !dirs.len().is_multiple_of(8) {
            dirs.push(Vec3::Y);
        }
        for chunk in dirs.chunks_exact(8) {
            let (rows, cols) = g.cells(Float3::<8>::from_vecs(chunk.try_into().unwrap()));
            for k in 0..8 {
                assert_eq!((rows[k], cols[k]), g.cell(chunk[k]), "{:?}", chunk[k]);
            }
        }
    }

    fn grid() -> LatLongGrid {
        let (w, h) = (2048, 1024);
        let g: Vec<f32> = (0..w * h).map(|i| 1.0 + ((i * 7919) % 97) as f32).collect();
        LatLongGrid::new(&g, w, h)
    }

    /// (draws whose cell was given, of them the ones whose direction `cell` puts elsewhere), over
    /// `n` draws under rotation `rot_deg` (undone in f32 as `Envmap` does).
    fn count(grid: &LatLongGrid, n: usize, rot_deg: [f32; 3], margins: (f32, f32, f32)) -> (usize, usize) {
        let rot = rotation_xyz_deg(rot_deg);
        let inv = rot.transpose();
        let mut rng = TestRng::new(7);
        let (mut given, mut wrong) = (0, 0);
        for _ in 0..n {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let (d, cell) = grid
                .sample_directions_with(
                    [Float::<1>::splat(u.x), Float::splat(u.y)],
                    Mask::ALL,
                    margins.0,
                    margins.1,
                    margins.2,
                )
                .map(|(d, c)| (d.lane(0), c[0]))
                .unwrap();
            if let Some(i) = cell {
                given += 1;
                let (r, c) = grid.cell(inv * (rot * d).normalize());
                wrong += usize::from(r * grid.width + c != i);
            }
        }
        (given, wrong)
    }

    /// The cell given with a sample is the cell `cell` finds for its direction, with and without a
    /// rotation (the bits of a lookup), for all but a small fraction of the draws (those near an
    /// edge); with zero margins, rounding puts some directions in a neighbouring cell, so the test
    /// can see a wrong margin.
    #[test]
    fn given_cell_is_the_looked_up_cell() {
        let g = grid();
        for rot in [[0.0, 0.0, 0.0], [31.0, -47.0, 113.0]] {
            let (given, wrong) = count(&g, 400_000, rot, (Z_MARGIN, PHI_MARGIN, PHI_ROUNDING));
            assert_eq!(wrong, 0, "rotation {rot:?}: {wrong} of {given} given cells are not the looked-up cell");
            assert!(given > 390_000, "rotation {rot:?}: only {given} of 400000 draws had their cell given");
            let (given0, wrong0) = count(&g, 400_000, rot, (0.0, 0.0, 0.0));
            assert!(wrong0 > 0, "rotation {rot:?}: zero margins gave no wrong cell in {given0} draws");
        }
    }
}
