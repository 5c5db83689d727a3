//! Environment-map lighting: measured radiance from an HDR image (docs/src/conventions.md §2, §6).
//!
//! Parameters: `image` (linear RGB radiance, no negative values), `mapping` (`LatLong` or
//! `Angular`, exactly as docs/src/conventions.md §2), `scale` (multiplies the radiance) and `rotation`
//! (world = rotation · map direction, from `rotate_deg`; `eval(wi)` looks up rotationᵀ·wi).
//!
//! The radiance is piecewise constant: the pixel whose area on the continuous image plane contains
//! the direction (nearest pixel). Sampling follows the same pixels, by their luminance Y
//! (`super::sampling_weight`) less the map's mean luminance Ȳ over the sphere, max(Y − Ȳ, 0)
//! (MIS compensation, `super::compensated`: the darker pixels are left to the BRDF's samples):
//! - lat-long: a pixel is chosen with probability ∝ max(Y − Ȳ, 0) × its exact solid angle
//!   (2π/W)(cosθ_top − cosθ_bottom) and the direction is uniform in solid angle within it
//!   (`LatLongGrid` in `light/latlong_grid.rs`), so p(ω) ∝ the pixel's max(Y − Ȳ, 0) exactly;
//! - angular map: a continuous point (a, b) ∈ [−1, 1]² of the image plane is drawn from a
//!   [`PiecewiseConstant2D`] with pixel weights ∝ max(Y − Ȳ, 0) × sinθ/θ at the pixel centre (∝ its
//!   solid angle, 0 for pixels whose centre lies outside the disc ρ ≤ 1), mapped by θ = πρ,
//!   φ = atan2(b, a). In polar coordinates da db = ρ dρ dφ and dω = sinθ dθ dφ = π sin(πρ) dρ dφ,
//!   so dω = π² (sinθ/θ) da db = 4π² (sinθ/θ) du dv for the unit square (u, v) the distribution
//!   lives on, and p(ω) = p_uv / (4π² sinθ/θ) with the exact Jacobian at the sampled point. Points
//!   of a rim pixel that fall outside the disc are refused (`sample` returns None): the density of
//!   the accepted directions is still p(ω), which integrates to slightly less than 1.

use super::latlong_grid::{LatLongGrid, row_edges};
use super::{DistantLight, LightSample, LightSamples, Located, compensated, sampling_weight};
use crate::math::{PI, Rgb, Vec2, Vec3, fast, prefetch_read};
use crate::sampling::distribution::PiecewiseConstant2D;
use crate::simd::{Float, Float3, Isa, Mask};
use rayon::prelude::*;
use std::path::Path;
use vocab::image::RgbImage;

/// Environment-map parameterization (docs/src/conventions.md §2), defined in `vocab`.
pub use vocab::Mapping;

/// The density an environment map's light samples follow (docs/src/conventions.md §2, "Light
/// sampling"), per pixel × its solid angle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Table {
    /// max(Y − Ȳ, 0), Y the pixel's luminance and Ȳ the map's mean (MIS compensation, `light::compensated`):
    /// zero on the pixels no brighter than the mean, so the samples are only for combining by
    /// MIS with samples that cover every direction, as the path tracer's BRDF samples do. What
    /// [`Envmap::new`] builds and the renderer uses.
    #[default]
    Compensated,
    /// Y: every pixel with light, so the light's samples alone estimate ∫L dω (the Python
    /// objects' default, `reflect.light.Envmap(compensated=False)`).
    Luminance,
}

impl Table {
    /// The table's weights from the pixels' luminance `g` and their solid angles.
    fn weights(self, g: &[f32], solid_angle: impl Fn(usize) -> f64) -> Vec<f32> {
        match self {
            Table::Compensated => compensated(g, solid_angle),
            Table::Luminance => g.to_vec(),
        }
    }
}

/// The importance-sampling structure of each mapping.
#[derive(Clone, Debug)]
/// Each keeps the map's [`Texel`]s in its sampling entries, one per pixel (row-major).
enum EnvSampler {
    LatLong(LatLongGrid<Texel>),
    Angular(PiecewiseConstant2D<Texel>),
}

/// Treat the public fields as read-only after construction: the sampling tables are built from them.
#[derive(Clone, Debug)]
pub struct Envmap {
    pub image: RgbImage,
    pub mapping: Mapping,
    pub scale: f32,
    /// Applied to the map's directions (docs/src/conventions.md §6 `rotate_deg`): world = rotation · map.
    pub rotation: glam::Mat3,
    /// rotationᵀ: world → map.
    inv_rotation: glam::Mat3,
    /// The density the light samples follow ([`Table`]).
    table: Table,
    /// The sampling tables, which also hold the hot-path texels (see [`Texel`]).
    sampler: EnvSampler,
}

/// One pixel of the hot-path table: radiance × scale (0 outside the angular disc) and the sampling
/// density. It is the payload of the pixel's entry in the sampling table (32 bytes with the CDF,
/// aligned), so `eval_pdf` of a BRDF-sampled direction is a single cache line (the table is
/// megabytes, and such directions land anywhere), and a light sample's own texel is in the line
/// its CDF search read.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
struct Texel {
    radiance: [f32; 3],
    /// Lat-long: the solid-angle density of the pixel, exactly `LatLongGrid::pdf_cell` (the
    /// density is constant over a pixel). Angular: the density with respect to the unit square,
    /// which `angular_pdf` divides by the Jacobian at the direction's θ.
    pdf: f32,
}

/// m · v with the operations of glam's `Mat3 * Vec3` (x_axis·vx + y_axis·vy + z_axis·vz, added in
/// that order: the same bits), as plain f32 arithmetic for the lane loops.
#[inline(always)]
fn mat3_mul<const N: usize, S: Isa>(m: &glam::Mat3, v: Float3<N, S>) -> Float3<N, S> {
    Float3::new(
        m.x_axis.x * v.x + m.y_axis.x * v.y + m.z_axis.x * v.z,
        m.x_axis.y * v.x + m.y_axis.y * v.y + m.z_axis.y * v.z,
        m.x_axis.z * v.x + m.y_axis.z * v.y + m.z_axis.z * v.z,
    )
}

/// sinθ/θ, → 1 at θ = 0 (the angular map's solid-angle factor).
#[inline]
fn sinc(theta: f32) -> f32 {
    if theta < 1e-3 { 1.0 - theta * theta * (1.0 / 6.0) } else { theta.sin() / theta }
}

impl Envmap {
    /// Validates the image (non-empty, square for the angular map, finite non-negative pixels), the
    /// scale (finite, ≥ 0) and the rotation, and builds the sampling tables.
    pub fn new(image: RgbImage, mapping: Mapping, scale: f32, rotation: glam::Mat3) -> crate::Result<Self> {
        let (w, h) = (image.width, image.height);
        if w == 0 || h == 0 || image.pixels.len() != w * h {
            return Err(crate::Error::new(format!(
                "environment map: image of {w}×{h} pixels has {} values",
                image.pixels.len()
            )));
        }
        if mapping == Mapping::Angular && w != h {
            return Err(crate::Error::new(format!(
                "environment map: an angular map must be square, this one is {w}×{h}"
            )));
        }
        if !scale.is_finite() || scale < 0.0 {
            return Err(crate::Error::new(format!("environment map: scale {scale} must be finite and ≥ 0")));
        }
        if !rotation.is_finite() {
            return Err(crate::Error::new("environment map: rotation is not finite"));
        }
        if let Some(i) = image.pixels.iter().position(|p| p.iter().any(|v| !v.is_finite() || *v < 0.0)) {
            return Err(crate::Error::new(format!(
                "environment map: pixel at row {}, column {} is {:?}; radiance must be finite and non-negative",
                i / w,
                i % w,
                image.pixels[i]
            )));
        }
        let sampler = build_sampler(&image, mapping, scale, Table::Compensated);
        Ok(Envmap {
            image,
            mapping,
            scale,
            rotation,
            inv_rotation: rotation.transpose(),
            table: Table::Compensated,
            sampler,
        })
    }

    /// The same light with its light samples drawn from `table`; the radiance is unchanged.
    pub fn with_table(self, table: Table) -> Self {
        if table == self.table {
            return self;
        }
        let sampler = build_sampler(&self.image, self.mapping, self.scale, table);
        Envmap { table, sampler, ..self }
    }

    /// The density the light samples follow.
    pub fn table(&self) -> Table {
        self.table
    }

    /// Reads an `.exr` / `.hdr` file and builds the light; every error names the file.
    /// `rotate_deg` = rotations about x, then y, then z applied to the map (docs/src/conventions.md §6).
    pub fn load(path: &Path, mapping: Mapping, scale: f32, rotate_deg: [f32; 3]) -> crate::Result<Self> {
        let image = vocab::image::read_rgb(path)?;
        Envmap::new(image, mapping, scale, crate::math::rotation_xyz_deg(rotate_deg)).map_err(|e| e.in_file(path))
    }

    /// (row-major texel index, θ) of world direction `wi`: the one pixel lookup that `eval`, `pdf`,
    /// `eval_pdf` and `locate` share (θ is used by the angular map's Jacobian only).
    #[inline(always)]
    fn texel_index(&self, wi: Vec3) -> (usize, f32) {
        let d = self.inv_rotation * wi;
        match &self.sampler {
            EnvSampler::LatLong(grid) => {
                let (r, c) = grid.cell(d);
                (r * self.image.width + c, 0.0)
            }
            EnvSampler::Angular(_) => {
                let (r, c, theta) = self.angular_lookup(d);
                (r * self.image.width + c, theta)
            }
        }
    }

    /// The texel of pixel `index` (row-major).
    #[inline(always)]
    fn texel(&self, index: usize) -> &Texel {
        match &self.sampler {
            EnvSampler::LatLong(grid) => grid.payload(index),
            EnvSampler::Angular(dist) => dist.payload(index),
        }
    }

    /// Angular map: (row, column, θ) of map direction `d`, clamped to the image.
    #[inline]
    fn angular_lookup(&self, d: Vec3) -> (usize, usize, f32) {
        let s = (d.x * d.x + d.y * d.y).sqrt();
        let theta = fast::atan2(s, d.z);
        let rho = theta * (1.0 / PI);
        // (a, b) = ρ (cosφ, sinφ); at the poles φ = atan2(0, 0) = 0.
        let (a, b) = if s > 0.0 { (rho * d.x / s, rho * d.y / s) } else { (rho, 0.0) };
        let w = self.image.width;
        let half = 0.5 * w as f32;
        let c = (((a + 1.0) * half).max(0.0) as usize).min(w - 1);
        let r = (((1.0 - b) * half).max(0.0) as usize).min(w - 1);
        (r, c, theta)
    }

    /// The angular map's sample: a point of the unit square drawn from its table, lifted to the
    /// probe's disc and the sphere; value and density from the lookup of the direction, so that they
    /// agree exactly with `pdf(wi)` and `eval(wi)`.
    #[inline]
    fn sample_angular(&self, u: Vec2) -> Option<LightSample> {
        let EnvSampler::Angular(dist) = &self.sampler else { return None };
        if dist.integral() <= 0.0 {
            return None;
        }
        let (uv, _) = dist.sample_point_cell(u);
        let (a, b) = (2.0 * uv.x - 1.0, 1.0 - 2.0 * uv.y);
        let rho2 = a * a + b * b;
        if rho2 > 1.0 {
            // The part of a rim pixel outside the probe's disc: no direction maps there.
            return None;
        }
        let rho = rho2.sqrt();
        let (st, ct) = (PI * rho).sin_cos();
        let d = if rho > 0.0 { Vec3::new(st * a / rho, st * b / rho, ct) } else { Vec3::Z };
        let wi = (self.rotation * d).normalize();
        let (value, pdf) = self.eval_pdf(wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(LightSample { wi, value: value / pdf, pdf, delta: false })
    }

    /// ∫ L dω over the sphere (the scalar irradiance, 4π × the mean radiance), per channel, as the
    /// pixel sum with the per-pixel solid angles of docs/src/conventions.md §2 (exact for lat-long; the
    /// midpoint value (2π/W)² sinθ/θ for the angular map, whose pixels outside the disc count 0).
    pub fn radiance_integral(&self) -> [f64; 3] {
        let (w, h) = (self.image.width, self.image.height);
        let mut sum = [0.0f64; 3];
        for r in 0..h {
            let row_omega = match self.mapping {
                Mapping::LatLong => {
                    let t = std::f64::consts::PI / h as f64;
                    Some(2.0 * std::f64::consts::PI / w as f64 * ((t * r as f64).cos() - (t * (r + 1) as f64).cos()))
                }
                Mapping::Angular => None,
            };
            for c in 0..w {
                let omega = match row_omega {
                    Some(o) => o,
                    None => match angular_pixel_theta(r, c, w) {
                        Some(theta) => {
                            let k = 2.0 * std::f64::consts::PI / w as f64;
                            let theta = theta as f64;
                            k * k * if theta > 0.0 { theta.sin() / theta } else { 1.0 }
                        }
                        None => 0.0,
                    },
                };
                let p = self.image.get(r, c);
                for ch in 0..3 {
                    sum[ch] += p[ch] as f64 * omega;
                }
            }
        }
        sum.map(|s| s * self.scale as f64)
    }
}

/// The sampling tables of a validated image, with its texels (radiance × `scale`) as their payload.
fn build_sampler(image: &RgbImage, mapping: Mapping, scale: f32, table: Table) -> EnvSampler {
    let (w, h) = (image.width, image.height);
    let mut sampler = match mapping {
        Mapping::LatLong => {
            let g: Vec<f32> = image.pixels.iter().map(|&p| sampling_weight(Rgb::from(p))).collect();
            // A row's pixels share their solid angle, ∝ cosθ_top − cosθ_bottom.
            let z = row_edges(h);
            EnvSampler::LatLong(LatLongGrid::build(&table.weights(&g, |i| z[i / w] - z[i / w + 1]), w, h))
        }
        Mapping::Angular => {
            // A pixel's solid angle ∝ sinθ/θ at its centre, 0 outside the disc.
            let solid_angle: Vec<f32> =
                (0..w * h).into_par_iter().map(|i| angular_pixel_theta(i / w, i % w, w).map_or(0.0, sinc)).collect();
            let g: Vec<f32> = image
                .pixels
                .iter()
                .zip(&solid_angle)
                .map(|(&p, &a)| if a > 0.0 { sampling_weight(Rgb::from(p)) } else { 0.0 })
                .collect();
            let weights: Vec<f32> =
                table.weights(&g, |i| solid_angle[i] as f64).iter().zip(&solid_angle).map(|(&g, &a)| g * a).collect();
            EnvSampler::Angular(PiecewiseConstant2D::build(&weights, w, h))
        }
    };
    let texels: Vec<Texel> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let radiance = match mapping {
                Mapping::Angular if angular_pixel_theta(i / w, i % w, w).is_none() => Rgb::ZERO,
                _ => Rgb::from(image.pixels[i]) * scale,
            };
            let pdf = match &sampler {
                EnvSampler::Angular(dist) => dist.pdf_index(i % w, i / w),
                EnvSampler::LatLong(grid) => grid.pdf_cell(i / w, i % w),
            };
            Texel { radiance: radiance.to_array(), pdf }
        })
        .collect();
    match &mut sampler {
        EnvSampler::LatLong(grid) => grid.set_payloads(&texels),
        EnvSampler::Angular(dist) => dist.set_payloads(&texels),
    }
    sampler
}

/// θ = πρ at the centre of angular-map pixel (r, c) of a W × W image, or None if ρ > 1.
#[inline]
fn angular_pixel_theta(r: usize, c: usize, w: usize) -> Option<f32> {
    let half = 0.5 * w as f32;
    let u = (c as f32 + 0.5 - half) / half;
    let v = (half - r as f32 - 0.5) / half;
    let rho2 = u * u + v * v;
    (rho2 <= 1.0).then(|| PI * rho2.sqrt())
}

impl DistantLight for Envmap {
    #[inline]
    fn eval(&self, wi: Vec3) -> Rgb {
        self.eval_each(Float3::<1>::splat(wi), Mask::ALL)[0]
    }

    #[inline]
    fn locate(&self, wi: Vec3) -> Located {
        self.locate_each(Float3::<1>::splat(wi), Mask::ALL)[0]
    }

    /// Lat-long: the grid's warp and in-cell tests, the rotation to the world and the normalize
    /// over the lanes, then each lane's texel or, near a pixel edge, its lookup, and the division
    /// by the density over the lanes. Angular: lane by lane.
    #[inline(always)]
    fn sample_each<const N: usize, S: Isa>(&self, u: [Float<N, S>; 2], want: Mask<N, S>) -> LightSamples<N, S> {
        let mut out = LightSamples::NONE;
        let EnvSampler::LatLong(grid) = &self.sampler else {
            for k in 0..N {
                if want.lane(k)
                    && let Some(s) = self.sample_angular(Vec2::new(u[0].0[k], u[1].0[k]))
                {
                    out.set_lane(k, &s);
                }
            }
            return out;
        };
        let Some((d, cell)) = grid.sample_directions(u, want) else { return out };
        let wi = mat3_mul(&self.rotation, d).normalize();
        let (mut value, mut pdf) = (Float3::<N, S>::ZERO, Float::<N, S>::ZERO);
        for (k, &cell) in cell.iter().enumerate() {
            if !want.lane(k) {
                continue;
            }
            // Where the direction is provably in the pixel it was drawn from as `eval_pdf(wi)`
            // would find it (`sample_directions`), that pixel's texel is the one the lookup would
            // read (same bits, without its two arctangents; the texel is in the line the search
            // just read). Near a pixel edge the lookup from wi, so that (pdf, value) agree exactly
            // with pdf(wi) and eval(wi), also where rounding puts wi across the edge.
            let (v, p) = match cell {
                Some(index) => {
                    let t = self.texel(index);
                    (Rgb::from(t.radiance), t.pdf)
                }
                None => self.eval_pdf(wi.lane(k)),
            };
            value.set_lane(k, v);
            pdf.0[k] = p;
        }
        let valid = want & pdf.gt(Float::ZERO) & pdf.is_finite();
        out.wi = Float3::select(valid, wi, out.wi);
        out.value = Float3::select(valid, value / pdf, Float3::ZERO);
        out.pdf = valid.select(pdf, Float::ZERO);
        out.valid = valid;
        out
    }

    /// Lat-long: the rotation to the map's frame and the grid's `cells` over the lanes, then each
    /// texel's load starts. Angular: lane by lane.
    #[inline(always)]
    fn locate_each<const N: usize, S: Isa>(&self, wi: Float3<N, S>, want: Mask<N, S>) -> [Located; N] {
        let mut out = [Located::NONE; N];
        let EnvSampler::LatLong(grid) = &self.sampler else {
            for (k, o) in out.iter_mut().enumerate() {
                if want.lane(k) {
                    let (index, theta) = self.texel_index(wi.lane(k));
                    prefetch_read(self.texel(index));
                    *o = Located { wi: wi.lane(k), index, theta };
                }
            }
            return out;
        };
        let (r, c) = grid.cells(mat3_mul(&self.inv_rotation, wi));
        for k in 0..N {
            if want.lane(k) {
                let index = r[k] * self.image.width + c[k];
                prefetch_read(self.texel(index));
                out[k] = Located { wi: wi.lane(k), index, theta: 0.0 };
            }
        }
        out
    }

    /// The lookups of `locate_each`, then each texel's radiance.
    #[inline(always)]
    fn eval_each<const N: usize, S: Isa>(&self, wi: Float3<N, S>, want: Mask<N, S>) -> [Rgb; N] {
        let mut out = [Rgb::ZERO; N];
        let located = self.locate_each(wi, want);
        for k in 0..N {
            if want.lane(k) {
                out[k] = Rgb::from(self.texel(located[k].index).radiance);
            }
        }
        out
    }

    #[inline(always)]
    fn eval_pdf_located(&self, at: Located) -> (Rgb, f32) {
        let t = self.texel(at.index);
        let pdf = match &self.sampler {
            EnvSampler::LatLong(_) => t.pdf,
            EnvSampler::Angular(_) => angular_pdf(t.pdf, at.theta),
        };
        (Rgb::from(t.radiance), pdf)
    }

    #[inline(always)]
    fn prefetch_sample(&self, u: Vec2) {
        match &self.sampler {
            EnvSampler::LatLong(grid) => grid.prefetch_sample(u),
            EnvSampler::Angular(dist) => dist.prefetch(u),
        }
    }

    #[inline]
    fn eval_pdf(&self, wi: Vec3) -> (Rgb, f32) {
        let (index, theta) = self.texel_index(wi);
        self.eval_pdf_located(Located { wi, index, theta })
    }

    #[inline(always)]
    fn sample(&self, u: Vec2) -> Option<LightSample> {
        self.sample_each([Float::<1>::splat(u.x), Float::splat(u.y)], Mask::ALL).lane(0)
    }

    #[inline]
    fn pdf(&self, wi: Vec3) -> f32 {
        self.eval_pdf(wi).1
    }
}

/// Angular map: solid-angle density from the unit-square density, dω = 4π² (sinθ/θ) du dv. At
/// θ = π (a single direction) the Jacobian vanishes: density 0 there by convention.
#[inline]
fn angular_pdf(p_uv: f32, theta: f32) -> f32 {
    let jac = 4.0 * PI * PI * sinc(theta);
    if p_uv > 0.0 && jac > 0.0 { p_uv / jac } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::testutil::{check_light, check_light_with};
    use crate::math::{rotation_xyz_deg, spherical_direction};
    use crate::sampling::chi2::{Chi2Config, TestRng};

    const GRACE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data/grace_probe.hdr");

    /// A W × H image: a coloured gradient, a black band, and a small very bright spot.
    fn synthetic(w: usize, h: usize) -> RgbImage {
        let mut pixels = Vec::with_capacity(w * h);
        for r in 0..h {
            for c in 0..w {
                let (x, y) = (c as f32 / w as f32, r as f32 / h as f32);
                let mut p = [0.2 + x, 0.1 + 0.5 * y, 0.3 + 0.2 * (6.0 * x).sin().abs()];
                if (r * 7 / h) == 5 {
                    p = [0.0; 3];
                }
                // Bright, but not so bright that the mean luminance exceeds the gradient's
                // (about a third of the pixels lie above it: light samples see both).
                if (r as i64 - (h / 4) as i64).abs() <= 1 && (c as i64 - (5 * w / 8) as i64).abs() <= 1 {
                    p = [40.0, 30.0, 20.0];
                }
                pixels.push(p);
            }
        }
        RgbImage { width: w, height: h, pixels }
    }

    /// Probability that an angular map's `sample` refuses: the mass of rim pixels that lies outside
    /// the disc (fraction by a 32 × 32 sub-grid per pixel).
    fn refused_mass(e: &Envmap) -> f64 {
        let EnvSampler::Angular(dist) = &e.sampler else { return 0.0 };
        let w = e.image.width;
        let k = 32;
        let mut refused = 0.0;
        for r in 0..w {
            for c in 0..w {
                let p = dist.pdf_index(c, r) as f64 / (w * w) as f64;
                if p == 0.0 {
                    continue;
                }
                let mut outside = 0;
                for i in 0..k {
                    for j in 0..k {
                        let a = 2.0 * (c as f64 + (j as f64 + 0.5) / k as f64) / w as f64 - 1.0;
                        let b = 1.0 - 2.0 * (r as f64 + (i as f64 + 0.5) / k as f64) / w as f64;
                        outside += (a * a + b * b > 1.0) as usize;
                    }
                }
                refused += p * outside as f64 / (k * k) as f64;
            }
        }
        refused
    }

    /// Map direction of the centre of pixel (r, c), straight from docs/src/conventions.md §2.
    fn centre_direction(mapping: Mapping, r: usize, c: usize, w: usize, h: usize) -> Option<Vec3> {
        match mapping {
            Mapping::LatLong => {
                Some(spherical_direction(PI * (r as f32 + 0.5) / h as f32, 2.0 * PI * (c as f32 + 0.5) / w as f32))
            }
            Mapping::Angular => {
                let half = w as f32 / 2.0;
                let u = (c as f32 + 0.5 - half) / half;
                let v = (half - r as f32 - 0.5) / half;
                let rho = (u * u + v * v).sqrt();
                (rho <= 1.0).then(|| spherical_direction(PI * rho, v.atan2(u)))
            }
        }
    }

    #[test]
    fn eval_reproduces_pixels_at_their_centres() {
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Angular, 64, 64)] {
            let img = synthetic(w, h);
            let e = Envmap::new(img.clone(), mapping, 2.5, glam::Mat3::IDENTITY).unwrap();
            let mut outside = 0;
            for r in 0..h {
                for c in 0..w {
                    match centre_direction(mapping, r, c, w, h) {
                        Some(d) => {
                            assert_eq!(e.eval(d), Rgb::from(img.get(r, c)) * 2.5, "{mapping:?} pixel ({r}, {c})")
                        }
                        None => outside += 1,
                    }
                }
            }
            if mapping == Mapping::Angular {
                // Corners are outside the probe: a W×W square minus the disc ≈ (1 − π/4) W².
                assert!((outside as f32 / (w * h) as f32 - (1.0 - PI / 4.0)).abs() < 0.02, "{outside}");
            }
        }
    }

    #[test]
    fn angular_corner_pixels_are_dark() {
        // A constant image: the corner pixels (centre ρ > 1) must not leak into eval or sampling.
        let img = RgbImage { width: 8, height: 8, pixels: vec![[1.0; 3]; 64] };
        let e = Envmap::new(img, Mapping::Angular, 1.0, glam::Mat3::IDENTITY).unwrap();
        assert_eq!(angular_pixel_theta(0, 0, 8), None);
        let EnvSampler::Angular(dist) = &e.sampler else { unreachable!() };
        assert_eq!(dist.pdf_index(0, 0), 0.0);
        // The south pole maps to ρ = 1, φ = 0: row 4, column 7 (centre ρ ≈ 0.88 < 1, inside).
        assert_eq!(e.angular_lookup(-Vec3::Z).0..=e.angular_lookup(-Vec3::Z).1, 4..=7);
        // (a, b) = (0.8, 0.55) is inside the disc (ρ ≈ 0.971) but in pixel (1, 7), whose centre
        // (0.875, 0.625) is outside: radiance and density 0 there.
        let d = spherical_direction(PI * (0.8f32 * 0.8 + 0.55 * 0.55).sqrt(), 0.55f32.atan2(0.8));
        let (r, c, _) = e.angular_lookup(d);
        assert_eq!((r, c), (1, 7));
        assert_eq!(e.eval(Vec3::Z), Rgb::ONE);
        assert_eq!(e.eval(d), Rgb::ZERO);
        assert_eq!(e.pdf(d), 0.0);
    }

    /// `locate` + `eval_pdf_located` (the path tracer's lookup of a BRDF-sampled direction) returns
    /// each pixel's radiance and density at its rotated centre, with the bits of `eval` and `pdf`.
    /// Eight lanes of `sample_each` and `locate_each` are their one-lane calls (`sample`,
    /// `locate`) lane by lane, bit for bit, with and without a rotation, for both mappings.
    #[test]
    fn eight_wide_samples_and_lookups_are_one_wide() {
        let rotation = rotation_xyz_deg([20.0, -35.0, 110.0]);
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Angular, 64, 64)] {
            for rot in [glam::Mat3::IDENTITY, rotation] {
                let e = Envmap::new(synthetic(w, h), mapping, 2.5, rot).unwrap();
                let mut rng = crate::sampling::chi2::TestRng::new(11);
                let (mut near_edge, mut given) = (0, 0);
                for batch in 0..4096 {
                    let u: [Vec2; 8] = std::array::from_fn(|_| Vec2::new(rng.next_f32(), rng.next_f32()));
                    let want: [bool; 8] = std::array::from_fn(|k| (batch + k) % 5 != 0);
                    let lanes = e.sample_each(
                        [Float::<8>::from_array(u.map(|u| u.x)), Float::from_array(u.map(|u| u.y))],
                        Mask::from_bools(want),
                    );
                    let dirs: [Vec3; 8] = std::array::from_fn(|k| lanes.lane(k).map_or(Vec3::Z, |s| s.wi));
                    let located = e.locate_each(Float3::<8>::from_vecs(&dirs), Mask::from_bools(want));
                    for k in 0..8 {
                        if !want[k] {
                            assert!(lanes.lane(k).is_none());
                            continue;
                        }
                        let one = e.sample(u[k]);
                        let bits = |s: Option<LightSample>| {
                            s.map(|s| {
                                (
                                    s.wi.to_array().map(f32::to_bits),
                                    s.value.to_array().map(f32::to_bits),
                                    s.pdf.to_bits(),
                                )
                            })
                        };
                        assert_eq!(bits(lanes.lane(k)), bits(one), "{mapping:?} u = {:?}", u[k]);
                        let at = e.locate(dirs[k]);
                        assert_eq!((located[k].index, located[k].theta.to_bits()), (at.index, at.theta.to_bits()));
                        if let EnvSampler::LatLong(grid) = &e.sampler {
                            let cell = grid
                                .sample_directions([Float::<1>::splat(u[k].x), Float::splat(u[k].y)], Mask::ALL)
                                .and_then(|(_, c)| c[0]);
                            if cell.is_some() { given += 1 } else { near_edge += 1 }
                        }
                    }
                }
                if mapping == Mapping::LatLong {
                    // Both branches of the sample (the drawn texel, and the lookup near a pixel edge) ran.
                    assert!(given > 1000 && near_edge > 0, "given {given}, near an edge {near_edge}");
                }
            }
        }
    }

    #[test]
    fn located_lookup_is_the_pixel_and_matches_eval_pdf() {
        let rotation = rotation_xyz_deg([20.0, -35.0, 110.0]);
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Angular, 64, 64)] {
            let img = synthetic(w, h);
            let e = Envmap::new(img.clone(), mapping, 2.5, rotation).unwrap();
            for r in 0..h {
                for c in 0..w {
                    let Some(d) = centre_direction(mapping, r, c, w, h) else { continue };
                    let wi = rotation * d;
                    let at = e.locate(wi);
                    assert_eq!(at.wi, wi);
                    let (value, pdf) = e.eval_pdf_located(at);
                    assert_eq!(value, Rgb::from(img.get(r, c)) * 2.5, "{mapping:?} pixel ({r}, {c})");
                    // θ of the direction looked up (f64 reference; the rotation's rounding moves it
                    // off the pixel centre's θ).
                    let m = (e.inv_rotation * wi).as_dvec3();
                    let theta = m.x.hypot(m.y).atan2(m.z);
                    let (expect, tol) = match &e.sampler {
                        // The cell's density, exactly.
                        EnvSampler::LatLong(grid) => (grid.pdf_cell(r, c), 0.0),
                        // sinθ/θ moves by |cot θ − 1/θ| · |Δθ| relative under the fast atan2's error
                        // |Δθ| ≤ 4e-7 rad (large near θ = π: a rim pixel of a 64² map has π − θ ≈ 0.003),
                        // plus 1e-5 for the f32 Jacobian's own rounding.
                        EnvSampler::Angular(dist) => {
                            let slope = (theta.cos() / theta.sin() - 1.0 / theta).abs();
                            (angular_pdf(dist.pdf_index(c, r), theta as f32), 1e-5 + 4e-7 * slope)
                        }
                    };
                    assert!(
                        (pdf as f64 - expect as f64).abs() <= tol * expect as f64,
                        "{mapping:?} ({r}, {c}): {pdf} vs {expect}"
                    );
                    assert_eq!((value, pdf.to_bits()), (e.eval(wi), e.pdf(wi).to_bits()));
                }
            }
        }
    }

    #[test]
    fn rotation_moves_features() {
        // One bright pixel at map +x (lat-long row H/2, column 0); rotating 90° about z moves it to
        // world +y: world = R·map.
        let (w, h) = (64, 32);
        let mut img = RgbImage { width: w, height: h, pixels: vec![[0.1; 3]; w * h] };
        img.pixels[(h / 2) * w] = [9.0, 8.0, 7.0];
        let d_map = centre_direction(Mapping::LatLong, h / 2, 0, w, h).unwrap();
        let plain = Envmap::new(img.clone(), Mapping::LatLong, 1.0, glam::Mat3::IDENTITY).unwrap();
        let rot = Envmap::new(img, Mapping::LatLong, 1.0, rotation_xyz_deg([0.0, 0.0, 90.0])).unwrap();
        let d_world = Vec3::new(-d_map.y, d_map.x, d_map.z); // 90° about +z
        assert_eq!(plain.eval(d_map), Rgb::new(9.0, 8.0, 7.0));
        assert_eq!(rot.eval(d_world), Rgb::new(9.0, 8.0, 7.0));
        assert_eq!(rot.eval(d_map), Rgb::splat(0.1));
        assert!((rot.pdf(d_world) - plain.pdf(d_map)).abs() < 1e-4 * plain.pdf(d_map));
        // The sampled directions follow. Only the bright pixel lies above the map's mean luminance,
        // so every light sample lands in it (θ ∈ [90°, 95.6°], φ ∈ [90°, 95.6°] after the rotation:
        // every point within 7.95° < acos 0.99 = 8.1° of +y).
        let mut rng = TestRng::new(2);
        let samples: Vec<LightSample> =
            (0..2000).filter_map(|_| rot.sample(Vec2::new(rng.next_f32(), rng.next_f32()))).collect();
        assert_eq!(samples.len(), 2000);
        assert!(samples.iter().all(|s| s.wi.dot(Vec3::Y) > 0.99), "a sample outside the bright pixel");
    }

    /// The solid-angle mean of the luminance of `e`'s pixels (f64, from the pixels' solid angles of
    /// `radiance_integral`, which the tests of the integral check).
    fn mean_luminance(e: &Envmap) -> f64 {
        let y = |p: [f32; 3]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
        let grey = |img: &RgbImage, f: &dyn Fn([f32; 3]) -> f64| {
            let pixels = img.pixels.iter().map(|&p| [f(p) as f32; 3]).collect();
            Envmap::new(RgbImage { pixels, ..*img }, e.mapping, 1.0, glam::Mat3::IDENTITY).unwrap().radiance_integral()
                [0]
        };
        grey(&e.image, &y) / grey(&e.image, &|_| 1.0)
    }

    /// The sampling tables follow luminance less its mean (`light::compensated`): pixels of equal
    /// solid angle, lit in one channel each, have densities in the ratio of their luminances less
    /// the map's mean, pixels below the mean have none, and a constant map keeps its plain
    /// luminance table, in both mappings.
    #[test]
    fn sampling_follows_luminance_above_the_mean() {
        // Lat-long: three pixels of one row. Angular: three pixels at the same radius (mirror images).
        // Each has one channel lit, to luminance 2, 3 and 5, on a grey background of luminance 0.5.
        let cases = [
            (Mapping::LatLong, 16, 8, [(3, 2), (3, 9), (3, 13)]),
            (Mapping::Angular, 16, 16, [(3, 5), (5, 3), (3, 10)]),
        ];
        let coefficient = [0.2126, 0.7152, 0.0722];
        let luminance = [2.0, 3.0, 5.0];
        for (mapping, w, h, pixels) in cases {
            let mut img = RgbImage { width: w, height: h, pixels: vec![[0.5; 3]; w * h] };
            for (k, &(r, c)) in pixels.iter().enumerate() {
                let mut p = [0.0; 3];
                p[k] = (luminance[k] / coefficient[k]) as f32;
                img.pixels[r * w + c] = p;
            }
            let e = Envmap::new(img, mapping, 1.0, glam::Mat3::IDENTITY).unwrap();
            let mean = mean_luminance(&e);
            assert!(mean > 0.5 && mean < 2.0, "{mapping:?}: mean luminance {mean}");
            let pdf = pixels.map(|(r, c)| e.pdf(centre_direction(mapping, r, c, w, h).unwrap()) as f64);
            for k in 0..3 {
                let (ratio, want) = (pdf[k] / pdf[0], (luminance[k] - mean) / (luminance[0] - mean));
                assert!(
                    (ratio - want).abs() <= 1e-5 * want,
                    "{mapping:?} channel {k}: density ratio {ratio}, want {want}"
                );
            }
            // The background, below the mean, is left to the BRDF's samples.
            assert_eq!(e.pdf(centre_direction(mapping, 6, 7, w, h).unwrap()), 0.0, "{mapping:?}");
            // A map with no pixel above its mean (constant) is sampled by its luminance as it is.
            let flat = RgbImage { width: w, height: h, pixels: vec![[0.3, 0.6, 0.9]; w * h] };
            let e = Envmap::new(flat, mapping, 1.0, glam::Mat3::IDENTITY).unwrap();
            let p = e.pdf(centre_direction(mapping, 6, 7, w, h).unwrap()) as f64;
            assert!(p > 0.0 && (p - e.pdf(centre_direction(mapping, 3, 5, w, h).unwrap()) as f64).abs() < 1e-4 * p);
        }
    }

    #[test]
    fn latlong_sampling_matches_pdf() {
        let e = Envmap::new(synthetic(64, 32), Mapping::LatLong, 1.0, glam::Mat3::IDENTITY).unwrap();
        check_light(&e, "envmap lat-long 64×32", 1.0);
        // Zero-radiance pixels are never sampled.
        assert_eq!(e.pdf(centre_direction(Mapping::LatLong, 23, 3, 64, 32).unwrap()), 0.0);
    }

    #[test]
    fn latlong_rotated_sampling_matches_pdf() {
        let e = Envmap::new(synthetic(64, 32), Mapping::LatLong, 1.0, rotation_xyz_deg([30.0, -50.0, 100.0])).unwrap();
        check_light(&e, "envmap lat-long rotated", 1.0);
    }

    #[test]
    fn angular_sampling_matches_pdf() {
        let e = Envmap::new(synthetic(64, 64), Mapping::Angular, 1.0, glam::Mat3::IDENTITY).unwrap();
        let mass = 1.0 - refused_mass(&e);
        let r = check_light_with(&e, "envmap angular 64×64", mass, 200);
        assert!((r.sampled_fraction - mass).abs() < 4.0 * (mass * (1.0 - mass) / 1e6).sqrt() + 1e-4, "{r:?} vs {mass}");
    }

    #[test]
    fn angular_rotated_sampling_matches_pdf() {
        // The rotation keeps the bright spot away from the z axis of the χ² grid, whose cells are
        // uniform in cosθ: near its poles the harness's quadrature of the expected counts resolves θ
        // coarsely, and a sharp spot there biases the expected mass (seen with [−70, 20, 45]: the
        // spot at z = −0.98 made the quadrature total 0.998 while a 3× finer one gives 1.0001).
        let e = Envmap::new(synthetic(64, 64), Mapping::Angular, 1.0, rotation_xyz_deg([30.0, -50.0, 100.0])).unwrap();
        check_light(&e, "envmap angular rotated", 1.0 - refused_mass(&e));
    }

    #[test]
    fn wrong_pdfs_are_rejected() {
        // Negative tests: the χ² must see two plausible mistakes.
        let cfg = Chi2Config { samples: 1_000_000, resolution: 96, ..Default::default() };
        let run = |e: &Envmap, pdf: &dyn Fn(Vec3) -> f64| {
            crate::sampling::chi2::chi2_sphere(|_, u| e.sample(u).map(|s| s.wi), pdf, &cfg)
        };
        // (1) Angular map without the Jacobian sinθ/θ of the image plane (p_uv / 4π² only).
        let e = Envmap::new(synthetic(64, 64), Mapping::Angular, 1.0, glam::Mat3::IDENTITY).unwrap();
        let r = run(&e, &|d| {
            let theta = (d.x * d.x + d.y * d.y).sqrt().atan2(d.z);
            (e.pdf(d) * sinc(theta)) as f64
        });
        assert!(!r.passes(1e-3), "missing Jacobian not detected: {r:?}");
        // (2) Lat-long with the density of a θ-linear warp inside each pixel, p ∝ 1/(Δθ sinθ),
        // instead of the z-linear one, p ∝ 1/Δz: same mass per pixel, wrong shape within pixels.
        let (w, h) = (64, 32);
        let e = Envmap::new(synthetic(w, h), Mapping::LatLong, 1.0, glam::Mat3::IDENTITY).unwrap();
        let r = run(&e, &|d| {
            let theta = (d.x * d.x + d.y * d.y).sqrt().atan2(d.z) as f64;
            let dt = std::f64::consts::PI / h as f64;
            let row = ((theta / dt) as usize).min(h - 1) as f64;
            let dz = (row * dt).cos() - ((row + 1.0) * dt).cos();
            e.pdf(d) as f64 * dz / (dt * theta.sin().max(1e-6))
        });
        assert!(!r.passes(1e-3), "θ-linear density not detected: {r:?}");
    }

    #[test]
    fn grace_loads_and_samples_by_its_pdf() {
        let e = Envmap::load(Path::new(GRACE), Mapping::Angular, 1.0, [0.0; 3]).unwrap();
        assert_eq!((e.image.width, e.image.height), (1000, 1000));
        // The probe's sharp window edges need an even finer quadrature of the expected counts: at
        // 96² points per cell the quadrature total is 0.99989 and p ≈ 1e-3 (seed 7); at 200² it is
        // 1.00001 and p = 0.09, 0.48, 0.12 for seeds 7, 8, 9.
        check_light_with(&e, "envmap grace", 1.0 - refused_mass(&e), 200);
    }

    /// MC estimate of ∫ L dω as the integrator forms it: each of `n` steps takes one light sample
    /// and one direction uniform on the sphere (the other technique, standing in for the BRDF's
    /// samples, whose density covers every direction) and weights them by the balance heuristic,
    /// L(ω)/(p_light(ω) + 1/4π) for each. The light's samples alone would miss the pixels below
    /// the mean luminance. (mean, σ) per channel, σ = sqrt(var/n).
    fn mc_integral(e: &Envmap, n: usize, seed: u64) -> [(f64, f64); 3] {
        let mut rng = TestRng::new(seed);
        let uniform = 1.0 / (4.0 * PI);
        let (mut s, mut s2) = ([0.0f64; 3], [0.0f64; 3]);
        for _ in 0..n {
            let mut v = e
                .sample(Vec2::new(rng.next_f32(), rng.next_f32()))
                .map_or(Rgb::ZERO, |s| e.eval(s.wi) / (s.pdf + uniform));
            let d = crate::math::spherical_direction((1.0 - 2.0 * rng.next_f32()).acos(), 2.0 * PI * rng.next_f32());
            let (l, p) = e.eval_pdf(d);
            v += l / (p + uniform);
            for ch in 0..3 {
                s[ch] += v[ch] as f64;
                s2[ch] += (v[ch] as f64).powi(2);
            }
        }
        std::array::from_fn(|ch| {
            let mean = s[ch] / n as f64;
            (mean, ((s2[ch] / n as f64 - mean * mean) / n as f64).sqrt())
        })
    }

    /// `Table::Luminance` (the Python objects' default): every lit pixel is sampled, by its
    /// luminance, in both mappings (χ²), and the light's samples alone integrate the whole map,
    /// where the compensated table's miss the pixels below the mean.
    #[test]
    fn luminance_table_samples_every_lit_pixel_and_integrates_alone() {
        for (mapping, w, h) in [(Mapping::LatLong, 64, 32), (Mapping::Angular, 64, 64)] {
            let e = Envmap::new(synthetic(w, h), mapping, 1.5, rotation_xyz_deg([0.0, 40.0, 0.0])).unwrap();
            let plain = e.clone().with_table(Table::Luminance);
            assert_eq!((e.table(), plain.table()), (Table::Compensated, Table::Luminance));
            // A dim lit pixel (the gradient's darkest corner): sampled by luminance only.
            let d = rotation_xyz_deg([0.0, 40.0, 0.0]) * centre_direction(mapping, 3, w / 2 - 3, w, h).unwrap();
            assert!(plain.pdf(d) > 0.0 && e.pdf(d) == 0.0, "{mapping:?}: {} / {}", plain.pdf(d), e.pdf(d));
            assert_eq!(plain.eval(d), e.eval(d));
            let mass = if mapping == Mapping::Angular { 1.0 - refused_mass(&plain) } else { 1.0 };
            check_light_with(&plain, &format!("envmap {mapping:?}, luminance table"), mass, 200);
            let exact = plain.radiance_integral();
            let mut rng = TestRng::new(31);
            let n = 400_000;
            let (mut s, mut s2) = ([0.0f64; 3], [0.0f64; 3]);
            for _ in 0..n {
                let v = plain.sample(Vec2::new(rng.next_f32(), rng.next_f32())).map_or(Rgb::ZERO, |s| s.value);
                for ch in 0..3 {
                    s[ch] += v[ch] as f64;
                    s2[ch] += (v[ch] as f64).powi(2);
                }
            }
            for ch in 0..3 {
                let mean = s[ch] / n as f64;
                let sigma = ((s2[ch] / n as f64 - mean * mean) / n as f64).sqrt();
                // The angular map's pixel sum is a midpoint rule (≈ 1e-5 relative): inside 4σ.
                assert!(
                    (mean - exact[ch]).abs() < 4.0 * sigma,
                    "{mapping:?} ch {ch}: {mean} ± {sigma} vs {}",
                    exact[ch]
                );
            }
        }
    }

    #[test]
    fn latlong_integral_by_sampling_matches_pixel_sum() {
        // Lat-long pixel solid angles are exact, so the pixel sum is the exact ∫ L dω: 4σ.
        let e = Envmap::new(synthetic(64, 32), Mapping::LatLong, 1.5, rotation_xyz_deg([0.0, 40.0, 0.0])).unwrap();
        let exact = e.radiance_integral();
        for (ch, (mean, sigma)) in mc_integral(&e, 400_000, 23).into_iter().enumerate() {
            assert!((mean - exact[ch]).abs() < 4.0 * sigma, "channel {ch}: {mean} ± {sigma} vs {}", exact[ch]);
        }
    }

    #[test]
    fn grace_integral_by_sampling_matches_pixel_sum() {
        // ∫ L dω by MC with the light's samples and uniform ones vs the pixel sum with the per-pixel solid angles
        // of docs/src/conventions.md §2. 4σ per channel with σ = sqrt(sample variance / n) (≈ 3e-4 relative).
        // The §2 angular formula is the midpoint value of the exact Jacobian (2/W)²·π² sinθ/θ: its
        // error, O((2/W)²) ≈ 1e-5 relative plus the few dark rim pixels, is far below σ.
        let e = Envmap::load(Path::new(GRACE), Mapping::Angular, 0.5, [10.0, 20.0, 30.0]).unwrap();
        let exact = e.radiance_integral();
        for (ch, (mean, sigma)) in mc_integral(&e, 1_000_000, 17).into_iter().enumerate() {
            eprintln!("grace ∫L dω channel {ch}: MC {mean} ± {sigma}, pixel sum {}", exact[ch]);
            assert!((mean - exact[ch]).abs() < 4.0 * sigma, "channel {ch}: {mean} ± {sigma} vs {}", exact[ch]);
            // Importance sampling by luminance: each channel's estimate is already precise.
            assert!(sigma / mean < 5e-3, "relative σ {}", sigma / mean);
        }
    }

    #[test]
    fn grace_builds_quickly() {
        let img = vocab::image::read_rgb(GRACE).unwrap();
        let t = std::time::Instant::now();
        let e = Envmap::new(img, Mapping::Angular, 1.0, glam::Mat3::IDENTITY).unwrap();
        eprintln!("Envmap::new(grace 1000×1000) took {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
        assert!(e.sample(Vec2::splat(0.5)).is_some_and(|s| s.pdf > 0.0));
    }

    fn temp_dir() -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("reflect-light-test-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn bad_files_are_errors_naming_the_file() {
        let dir = temp_dir();
        let load = |p: &Path| Envmap::load(p, Mapping::LatLong, 1.0, [0.0; 3]).unwrap_err().to_string();
        // Missing.
        let e = load(&dir.join("missing_probe.hdr"));
        assert!(e.contains("missing_probe.hdr"), "{e}");
        // Corrupt.
        let corrupt = dir.join("corrupt_probe.hdr");
        std::fs::write(&corrupt, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 8\n\x02\x02").unwrap();
        let e = load(&corrupt);
        assert!(e.contains("corrupt_probe.hdr"), "{e}");
        // A NaN pixel in a float EXR.
        let nan = dir.join("nan_probe.exr");
        exr::prelude::write_rgb_file(
            &nan,
            4,
            2,
            |x, y| if (x, y) == (1, 1) { (f32::NAN, 0.0, 0.0) } else { (1.0, 1.0, 1.0) },
        )
        .unwrap();
        let e = load(&nan);
        assert!(e.contains("nan_probe.exr") && e.contains("non-finite"), "{e}");
        // A negative pixel.
        let neg = dir.join("negative_probe.exr");
        exr::prelude::write_rgb_file(
            &neg,
            4,
            2,
            |x, y| if (x, y) == (2, 1) { (1.0, -0.5, 0.0) } else { (1.0, 1.0, 1.0) },
        )
        .unwrap();
        let e = load(&neg);
        assert!(e.contains("negative_probe.exr") && e.contains("row 1, column 2") && e.contains("non-negative"), "{e}");
        // A non-square angular map, and a good file read back exactly.
        let e = Envmap::load(&dir.join("nan_probe.exr"), Mapping::Angular, 1.0, [0.0; 3]).unwrap_err().to_string();
        assert!(e.contains("nan_probe.exr"), "{e}");
        let ok = dir.join("ok_probe.exr");
        exr::prelude::write_rgb_file(&ok, 4, 2, |x, y| (x as f32, y as f32, 0.5)).unwrap();
        let e = Envmap::load(&ok, Mapping::Angular, 1.0, [0.0; 3]).unwrap_err().to_string();
        assert!(e.contains("ok_probe.exr") && e.contains("square"), "{e}");
        let l = Envmap::load(&ok, Mapping::LatLong, 2.0, [0.0; 3]).unwrap();
        assert_eq!(l.eval(centre_direction(Mapping::LatLong, 1, 3, 4, 2).unwrap()), Rgb::new(6.0, 2.0, 1.0));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let img = synthetic(8, 4);
        assert!(Envmap::new(img.clone(), Mapping::LatLong, -1.0, glam::Mat3::IDENTITY).is_err());
        assert!(Envmap::new(img.clone(), Mapping::LatLong, f32::NAN, glam::Mat3::IDENTITY).is_err());
        let empty = RgbImage { width: 0, height: 0, pixels: vec![] };
        assert!(Envmap::new(empty, Mapping::LatLong, 1.0, glam::Mat3::IDENTITY).is_err());
        let short = RgbImage { width: 8, height: 4, pixels: vec![[1.0; 3]; 5] };
        assert!(Envmap::new(short, Mapping::LatLong, 1.0, glam::Mat3::IDENTITY).is_err());
        // A black map cannot be sampled, and says so without panicking.
        let black = RgbImage { width: 8, height: 8, pixels: vec![[0.0; 3]; 64] };
        for m in [Mapping::LatLong, Mapping::Angular] {
            let e = Envmap::new(black.clone(), m, 1.0, glam::Mat3::IDENTITY).unwrap();
            assert!(e.sample(Vec2::new(0.5, 0.5)).is_none());
            assert_eq!(e.pdf(Vec3::Z), 0.0);
        }
    }
}
