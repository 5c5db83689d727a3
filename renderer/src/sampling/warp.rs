//! Warps from the unit square to directions, each with its solid-angle density.
//!
//! Every `square_to_*` maps u ∈ [0,1)² to a unit vector and has a matching `*_pdf` giving the
//! density (per steradian) of the directions it produces, so `eval / pdf` is an unbiased weight.
//! All directions are in a local frame whose axis of symmetry is +z (use [`crate::math::Frame`]
//! to rotate them onto a normal or a reflection vector R).
//!
//! - `uniform_sphere`: pdf = 1/(4π).
//! - `uniform_hemisphere` (z ≥ 0): pdf = 1/(2π).
//! - `concentric_disk`: Shirley–Chiu's area-preserving square → disk map (no pdf: uniform on the disk).
//! - `cosine_hemisphere`: Malley's method (disk lifted to the hemisphere), pdf = cosθ/π.
//! - `uniform_cone(cos_max)`: uniform in the cone θ ≤ θ_max, pdf = 1/(2π(1 − cosθ_max)).
//! - `cos_power_lobe(s)`: density (s+1)/(2π) cos^s α on the hemisphere α < π/2 about +z — the
//!   normalised Phong lobe of eq. 40, sampled exactly by cos α = u^{1/(s+1)}.
//! - `cos_power_lobe_about(axis, s)`: the same lobe about an arbitrary unit axis (e.g. R).

use crate::math::{Frame, INV_2PI, INV_4PI, INV_PI, Vec2, Vec3};
use crate::simd::{Float, Float3, Isa};

/// Unit vector with z = `cos_t` and azimuth φ = 2π `u_phi` (sinθ ≥ 0 from cosθ).
#[inline]
fn from_cos_and_phi(cos_t: f32, u_phi: f32) -> Vec3 {
    cos_and_phi(Float::<1>::splat(cos_t), Float::splat(u_phi)).lane(0)
}

/// The unit vector of each lane with z = `cos_t` and azimuth φ = 2π `u_phi`.
#[inline(always)]
pub fn cos_and_phi<const N: usize, S: Isa>(cos_t: Float<N, S>, u_phi: Float<N, S>) -> Float3<N, S> {
    let sin_t = (1.0 - cos_t * cos_t).max(Float::ZERO).sqrt();
    let (sp, cp) = u_phi.sincos_2pi();
    Float3::new(sin_t * cp, sin_t * sp, cos_t)
}

/// Uniform direction on the whole sphere (z = 1 − 2u₀, φ = 2πu₁).
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    from_cos_and_phi(1.0 - 2.0 * u.x, u.y)
}

#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

/// Uniform direction on the upper hemisphere z ≥ 0.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    from_cos_and_phi(1.0 - u.x, u.y)
}

#[inline]
pub fn uniform_hemisphere_pdf(d: Vec3) -> f32 {
    if d.z >= 0.0 { INV_2PI } else { 0.0 }
}

/// Shirley–Chiu concentric map of the square onto the unit disk (area preserving, low distortion).
#[inline]
pub fn square_to_concentric_disk(u: Vec2) -> Vec2 {
    let [x, y] = concentric_disk([Float::<1>::splat(u.x), Float::splat(u.y)]);
    Vec2::new(x.lane(0), y.lane(0))
}

/// [`square_to_concentric_disk`] in each lane: the point (x, y) of the disk. The angle is taken in
/// turns, π/4 · b/a = 2π · (b/a)/8, so that its sine and cosine are `sincos_2pi`'s.
#[inline(always)]
pub fn concentric_disk<const N: usize, S: Isa>(u: [Float<N, S>; 2]) -> [Float<N, S>; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    let wide = a.abs().gt(b.abs());
    let r = wide.select(a, b);
    let turns = wide.select(0.125 * (b / a), 0.25 - 0.125 * (a / b));
    let (s, c) = turns.sincos_2pi();
    let centre = a.eq(Float::ZERO) & b.eq(Float::ZERO);
    [centre.select(Float::ZERO, r * c), centre.select(Float::ZERO, r * s)]
}

/// Cosine-weighted upper hemisphere (Malley: a uniform disk point lifted to the hemisphere).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    cosine_hemisphere([Float::<1>::splat(u.x), Float::splat(u.y)]).lane(0)
}

/// [`square_to_cosine_hemisphere`] in each lane.
#[inline(always)]
pub fn cosine_hemisphere<const N: usize, S: Isa>(u: [Float<N, S>; 2]) -> Float3<N, S> {
    let [x, y] = concentric_disk(u);
    let z = (1.0 - (x * x + y * y)).max(Float::ZERO).sqrt();
    Float3::new(x, y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(d: Vec3) -> f32 {
    d.z.max(0.0) * INV_PI
}

/// Uniform direction in the cone θ ≤ θ_max about +z.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    from_cos_and_phi(1.0 - u.x * (1.0 - cos_max), u.y)
}

#[inline]
pub fn uniform_cone_pdf(d: Vec3, cos_max: f32) -> f32 {
    if d.z >= cos_max { INV_2PI / (1.0 - cos_max) } else { 0.0 }
}

/// Phong lobe (s+1)/(2π) cos^s α about +z: the CDF in cos α is (cos α)^{s+1}, so
/// cos α = u₀^{1/(s+1)}. `inv_s_plus_1` = 1/(s+1) is passed precomputed (hot path).
#[inline]
pub fn square_to_cos_power_lobe(u: Vec2, inv_s_plus_1: f32) -> Vec3 {
    cos_power_lobe([Float::<1>::splat(u.x), Float::splat(u.y)], inv_s_plus_1).lane(0)
}

/// [`square_to_cos_power_lobe`] in each lane.
#[inline(always)]
pub fn cos_power_lobe<const N: usize, S: Isa>(u: [Float<N, S>; 2], inv_s_plus_1: f32) -> Float3<N, S> {
    // 1 − u₀ ∈ (0, 1]: avoids cos α = 0 exactly (a direction with zero density).
    cos_and_phi((1.0 - u[0]).powf(inv_s_plus_1), u[1])
}

/// Density of [`square_to_cos_power_lobe`] for exponent `s`: (s+1)/(2π) cos^s α on z > 0.
#[inline]
pub fn cos_power_lobe_pdf(d: Vec3, s: f32) -> f32 {
    if d.z > 0.0 { (s + 1.0) * INV_2PI * d.z.powf(s) } else { 0.0 }
}

/// The cos^s lobe about a unit `axis`: density (s+1)/(2π) max(axis·ω, 0)^s.
#[inline]
pub fn square_to_cos_power_lobe_about(u: Vec2, axis: Vec3, inv_s_plus_1: f32) -> Vec3 {
    Frame::from_normal(axis).to_world(square_to_cos_power_lobe(u, inv_s_plus_1))
}

#[inline]
pub fn cos_power_lobe_about_pdf(d: Vec3, axis: Vec3, s: f32) -> f32 {
    let c = d.dot(axis);
    if c > 0.0 { (s + 1.0) * INV_2PI * c.powf(s) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{Chi2Config, chi2_sphere, integrate_sphere};

    // Ten chi-square tests in this module: Šidák-style alpha 1e-3 / 10.
    const ALPHA: f64 = 1e-3 / 10.0;

    fn cfg() -> Chi2Config {
        // Fine midpoint resolution: the s = 20 lobe varies a lot inside one cosθ bin.
        Chi2Config { samples: 400_000, seed: 11, resolution: 16, ..Default::default() }
    }

    #[test]
    fn uniform_sphere_chi2() {
        let r = chi2_sphere(|_, u| Some(square_to_uniform_sphere(u)), |_| uniform_sphere_pdf() as f64, &cfg());
        assert!(r.passes(ALPHA), "{r:?}");
    }

    #[test]
    fn uniform_hemisphere_chi2() {
        let r = chi2_sphere(|_, u| Some(square_to_uniform_hemisphere(u)), |d| uniform_hemisphere_pdf(d) as f64, &cfg());
        assert!(r.passes(ALPHA), "{r:?}");
        assert!((r.pdf_integral - 1.0).abs() < 1e-3, "{r:?}");
    }

    #[test]
    fn cosine_hemisphere_chi2() {
        let r = chi2_sphere(|_, u| Some(square_to_cosine_hemisphere(u)), |d| cosine_hemisphere_pdf(d) as f64, &cfg());
        assert!(r.passes(ALPHA), "{r:?}");
        assert!((r.pdf_integral - 1.0).abs() < 1e-3, "{r:?}");
    }

    #[test]
    fn uniform_cone_chi2() {
        // cos θ_max on a bin edge (bins are 2/32 wide in z): the pdf's jump is then resolved exactly.
        let cm = 0.375f32;
        let r = chi2_sphere(|_, u| Some(square_to_uniform_cone(u, cm)), |d| uniform_cone_pdf(d, cm) as f64, &cfg());
        assert!(r.passes(ALPHA), "{r:?}");
    }

    #[test]
    fn cos_power_lobe_chi2_and_mass() {
        // Narrow lobes need the zoomed test of brdf::phong: in this unzoomed grid the midpoint rule
        // cannot resolve cos^s inside the top cosθ bin for large s.
        for s in [1.0f32, 3.0, 8.0] {
            let inv = 1.0 / (s + 1.0);
            let r =
                chi2_sphere(|_, u| Some(square_to_cos_power_lobe(u, inv)), |d| cos_power_lobe_pdf(d, s) as f64, &cfg());
            assert!(r.passes(ALPHA), "s = {s}: {r:?}");
            // Midpoint rule on a 512 × 1024 grid: error O(h²) ≪ 1e-3 for these smooth lobes.
            let m = integrate_sphere(|d| cos_power_lobe_pdf(d, s) as f64, 512);
            assert!((m - 1.0).abs() < 1e-3, "s = {s}: mass {m}");
        }
    }

    /// About an oblique axis (the Phong use, axis = R): the lobe must land where the pdf says.
    #[test]
    fn cos_power_lobe_about_axis_chi2() {
        let axis = Vec3::new(0.5, -0.3, 0.4).normalize();
        let r = chi2_sphere(
            |_, u| Some(square_to_cos_power_lobe_about(u, axis, 1.0 / 4.0)),
            |d| cos_power_lobe_about_pdf(d, axis, 3.0) as f64,
            &cfg(),
        );
        assert!(r.passes(ALPHA), "{r:?}");
    }

    /// Wrong normalisation (pdf of s = 8 claimed for s = 10 draws) must be caught.
    #[test]
    fn cos_power_lobe_wrong_pdf_fails() {
        let r = chi2_sphere(
            |_, u| Some(square_to_cos_power_lobe(u, 1.0 / 11.0)),
            |d| cos_power_lobe_pdf(d, 8.0) as f64,
            &cfg(),
        );
        assert!(!r.passes(ALPHA), "{r:?}");
    }

    #[test]
    fn concentric_disk_is_inside_and_corners_exact() {
        // The square's corners land on the circle; its centre at the origin.
        assert_eq!(square_to_concentric_disk(Vec2::splat(0.5)), Vec2::ZERO);
        for c in [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0)] {
            assert!((square_to_concentric_disk(c).length() - 1.0).abs() < 1e-6);
        }
        let mut rng = crate::sampling::chi2::TestRng::new(3);
        for _ in 0..10_000 {
            let p = square_to_concentric_disk(Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!(p.length() <= 1.0 + 1e-6);
        }
    }

    #[test]
    fn directions_are_unit() {
        let mut rng = crate::sampling::chi2::TestRng::new(5);
        for _ in 0..10_000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            for d in [
                square_to_uniform_sphere(u),
                square_to_uniform_hemisphere(u),
                square_to_cosine_hemisphere(u),
                square_to_uniform_cone(u, -0.5),
                square_to_cos_power_lobe(u, 1.0 / 9.0),
            ] {
                assert!((d.length() - 1.0).abs() < 1e-5, "{d}");
            }
        }
    }
}
