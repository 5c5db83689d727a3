//! Test helpers shared by the BRDF tests (compiled only under `cfg(test)`).
//!
//! Narrow lobes (Phong s = 128, Torrance–Sparrow σ = 0.05, microfacet α = 0.1) fit inside one or two
//! cells of the chi-square harness's equal-area grid, which then has no power. The helpers therefore
//! (1) rotate directions into a frame whose +z is the lobe's axis (R for Phong/TS), which preserves
//! solid angle, and (2) apply a conformal *zoom*: a scaling by `k` of the stereographic projection
//! from −z, tan(β/2) = k·tan(α/2). Directions near the axis spread over the sphere; densities are
//! carried over exactly with the Jacobian dω_α/dω_β = (1 + k²t²)² / (k²(1 + t²)²), t = tan(α/2).

use super::Bxdf;
use crate::math::{Frame, Rgb, Vec2, Vec3};
use crate::sampling::chi2::{Chi2Config, Chi2Result, TestRng, chi2_sphere, integrate_sphere};
use glam::DVec3;

/// Significance of each chi-square test: about 100 such tests run in this crate's BRDF suite, so a
/// Šidák-corrected family-wise level of 1e-3 gives 1e-5 per test.
pub const ALPHA: f64 = 1e-5;

pub fn chi2_cfg() -> Chi2Config {
    Chi2Config { theta_bins: 32, phi_bins: 64, samples: 1_000_000, seed: 17, resolution: 24, ..Default::default() }
}

/// Unit direction at polar angle θ (degrees), azimuth 0.4 rad (off the axes on purpose).
pub fn dir_theta_deg(deg: f32) -> Vec3 {
    crate::math::spherical_direction(deg.to_radians(), 0.4)
}

/// Mirror direction of ω_o about the local normal.
pub fn refl(wo: Vec3) -> Vec3 {
    Vec3::new(-wo.x, -wo.y, wo.z)
}

/// Conformal zoom about +z by factor k (see module doc). `zoom(zoom(d, k), 1/k) = d`.
pub fn zoom(d: Vec3, k: f32) -> Vec3 {
    let den = 1.0 + d.z as f64;
    if den < 1e-12 {
        return -Vec3::Z;
    }
    let x = k as f64 * d.x as f64 / den;
    let y = k as f64 * d.y as f64 / den;
    let r2 = x * x + y * y;
    Vec3::new((2.0 * x / (1.0 + r2)) as f32, (2.0 * y / (1.0 + r2)) as f32, ((1.0 - r2) / (1.0 + r2)) as f32)
}

/// Factor turning a density at d = zoom(d', 1/k) into the density of zoomed directions at d'.
pub fn zoom_density_factor(dz: Vec3, k: f32) -> f64 {
    let den = 1.0 + dz.z as f64;
    let k2 = (k as f64) * (k as f64);
    if den < 1e-12 {
        return k2;
    }
    let tp2 = ((dz.x as f64).powi(2) + (dz.y as f64).powi(2)) / (den * den);
    let t2 = tp2 / k2;
    (1.0 + tp2).powi(2) / (k2 * (1.0 + t2).powi(2))
}

/// Chi-square test of `b.sample` against an arbitrary claimed pdf, in the frame of `axis` zoomed by k.
pub fn chi2_bxdf_with_pdf<B: Bxdf, P: Fn(Vec3) -> f64>(
    b: &B,
    wo: Vec3,
    axis: Vec3,
    k: f32,
    cfg: &Chi2Config,
    pdf: P,
) -> Chi2Result {
    let f = Frame::from_normal(axis.normalize());
    chi2_sphere(
        |ul, u| b.sample(wo, ul, u).map(|s| zoom(f.to_local(s.wi), k)),
        |dz| pdf(f.to_world(zoom(dz, 1.0 / k))) * zoom_density_factor(dz, k),
        cfg,
    )
}

/// Chi-square test of `b.sample` against `b.pdf`.
pub fn chi2_bxdf<B: Bxdf>(b: &B, wo: Vec3, axis: Vec3, k: f32, cfg: &Chi2Config) -> Chi2Result {
    chi2_bxdf_with_pdf(b, wo, axis, k, cfg, |wi| b.pdf(wo, wi) as f64)
}

/// ∫ g(ω) dω by the midpoint rule on an n × 2n grid of the zoomed sphere (exact change of variables).
pub fn integrate_zoomed<G: Fn(Vec3) -> f64>(g: G, axis: Vec3, k: f32, n: usize) -> f64 {
    let f = Frame::from_normal(axis.normalize());
    integrate_sphere(|dz| g(f.to_world(zoom(dz, 1.0 / k))) * zoom_density_factor(dz, k), n)
}

/// [`integrate_zoomed`] with its stated error: |I_n − I_{n/2}| (the n-point rule's own error is
/// |I_n − I_{n/2}| / (2^p − 1) for a rule converging at order p ≥ 1, so this bounds it) plus
/// `f32_rel`·|I_n| for the f32 evaluation of g, which does not converge away: 1e-6 for smooth
/// lobes, s·ε_f32 for a power cosˢ of a dot product of unit vectors (their lengths are 1 only to
/// ε_f32, and the power multiplies that relative error by s). Replaces a fixed "quadrature
/// allowance" by the rule's measured error.
pub fn integrate_zoomed_err<G: Fn(Vec3) -> f64>(g: G, axis: Vec3, k: f32, n: usize, f32_rel: f64) -> (f64, f64) {
    let fine = integrate_zoomed(&g, axis, k, n);
    let coarse = integrate_zoomed(&g, axis, k, n / 2);
    (fine, (fine - coarse).abs() + f32_rel * fine.abs())
}

/// [`albedo_quadrature_zoomed`] with its stated error per channel, as [`integrate_zoomed_err`].
pub fn albedo_quadrature_zoomed_err<B: Bxdf>(
    b: &B,
    wo: Vec3,
    axis: Vec3,
    k: f32,
    n: usize,
    f32_rel: f64,
) -> (DVec3, DVec3) {
    let c = |i: usize| integrate_zoomed_err(|wi| b.eval(wo, wi)[i] as f64, axis, k, n, f32_rel);
    let (r, g, bl) = (c(0), c(1), c(2));
    (DVec3::new(r.0, g.0, bl.0), DVec3::new(r.1, g.1, bl.1))
}

/// Fraction of draws `sample` does not refuse, with its binomial standard error.
pub fn sampled_fraction<B: Bxdf>(b: &B, wo: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = TestRng::new(seed);
    let mut ok = 0usize;
    for _ in 0..n {
        let ul = rng.next_f32();
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        if b.sample(wo, ul, u).is_some() {
            ok += 1;
        }
    }
    let p = ok as f64 / n as f64;
    (p, (p * (1.0 - p) / n as f64).sqrt())
}

/// For non-delta samples: `sample.pdf` equals `pdf(wo, wi)` (relative 1e-3, float recomputation)
/// and `weight` equals `eval / pdf` (relative 1e-4), all finite and non-negative.
pub fn check_sample_consistency<B: Bxdf>(b: &B, wo: Vec3, n: usize, seed: u64) {
    let mut rng = TestRng::new(seed);
    for _ in 0..n {
        let ul = rng.next_f32();
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let Some(s) = b.sample(wo, ul, u) else { continue };
        assert!((s.wi.length() - 1.0).abs() < 1e-4, "wi not unit: {}", s.wi);
        assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0, "weight {}", s.weight);
        assert!(s.pdf.is_finite() && s.pdf > 0.0, "pdf {}", s.pdf);
        if s.delta {
            continue;
        }
        let p = b.pdf(wo, s.wi);
        assert!((p - s.pdf).abs() <= 1e-3 * p.max(s.pdf), "pdf {} vs sample.pdf {} at wi {}", p, s.pdf, s.wi);
        let ratio = b.eval(wo, s.wi) / p;
        let tol = 1e-4 * ratio.max_element().max(s.weight.max_element()) + 1e-12;
        assert!((ratio - s.weight).abs().max_element() <= tol, "weight {} vs eval/pdf {}", s.weight, ratio);
    }
}

/// Directional albedo ∫ ρ̂(ω_o, ω_i) dω_i per channel by zoomed midpoint quadrature.
pub fn albedo_quadrature_zoomed<B: Bxdf>(b: &B, wo: Vec3, axis: Vec3, k: f32, n: usize) -> DVec3 {
    let c = |i: usize| integrate_zoomed(|wi| b.eval(wo, wi)[i] as f64, axis, k, n);
    DVec3::new(c(0), c(1), c(2))
}

pub fn albedo_quadrature<B: Bxdf>(b: &B, wo: Vec3, n: usize) -> DVec3 {
    albedo_quadrature_zoomed(b, wo, Vec3::Z, 1.0, n)
}

/// Directional albedo by Monte Carlo with the BRDF's own sampling (refused draws count as 0):
/// returns (mean, standard error of the mean) per channel.
pub fn albedo_mc<B: Bxdf>(b: &B, wo: Vec3, n: usize, seed: u64) -> (DVec3, DVec3) {
    let mut rng = TestRng::new(seed);
    let (mut s1, mut s2) = (DVec3::ZERO, DVec3::ZERO);
    for _ in 0..n {
        let ul = rng.next_f32();
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let w = b.sample(wo, ul, u).map_or(DVec3::ZERO, |s| s.weight.as_dvec3());
        s1 += w;
        s2 += w * w;
    }
    let m = s1 / n as f64;
    let var = (s2 / n as f64 - m * m).max(DVec3::ZERO);
    (m, (var / n as f64).sqrt())
}

/// Helmholtz reciprocity of the BRDF: ρ̂(ω_o, ω_i)/cosθ_i = ρ̂(ω_i, ω_o)/cosθ_o for random pairs in
/// the upper hemisphere (relative 1e-4).
pub fn check_reciprocity<B: Bxdf>(b: &B, seed: u64) {
    let mut rng = TestRng::new(seed);
    for _ in 0..2000 {
        let a = crate::sampling::warp::square_to_uniform_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let c = crate::sampling::warp::square_to_uniform_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        if a.z < 1e-3 || c.z < 1e-3 {
            continue;
        }
        let f1: Rgb = b.eval(a, c) / c.z;
        let f2: Rgb = b.eval(c, a) / a.z;
        let tol = 1e-4 * f1.max_element().max(f2.max_element()) + 1e-20;
        assert!((f1 - f2).abs().max_element() <= tol, "{f1} vs {f2} at {a} {c}");
    }
}

#[test]
fn zoom_round_trip_and_jacobian() {
    let d = Vec3::new(0.1, -0.2, 0.9).normalize();
    assert!((zoom(zoom(d, 7.0), 1.0 / 7.0) - d).length() < 1e-5);
    // A normalised cos^100 lobe about an oblique axis still integrates to one after zooming (the
    // lobe has no mass near the antipode, where the zoom concentrates the grid's error).
    let axis = Vec3::new(0.3, 0.1, 0.5).normalize();
    let m = integrate_zoomed(
        |d| crate::sampling::warp::cos_power_lobe_pdf(Frame::from_normal(axis).to_local(d), 100.0) as f64,
        axis,
        5.0,
        512,
    );
    assert!((m - 1.0).abs() < 1e-4, "{m}");
}

/// Rough cost per call of sample + eval + pdf for each model (run with `--ignored --nocapture`;
/// prints only, timing is machine dependent).
#[test]
#[ignore]
fn timing() {
    use super::*;
    let models: Vec<(&str, Brdf)> = vec![
        ("lambert", Brdf::Lambert(Lambert::new(Rgb::ONE))),
        ("mirror", Brdf::Mirror(Mirror::new(Rgb::ONE))),
        ("phong s=32", Brdf::Phong(Phong::new(Rgb::ONE, 32.0, Horizon::Clamp))),
        ("ts σ=0.2", Brdf::TorranceSparrow(TorranceSparrow::new(Rgb::ONE, 0.2, Horizon::Clamp))),
        ("ggx α=0.3", Brdf::Microfacet(Microfacet::new(MicrofacetDistribution::Ggx, 0.3, Fresnel::None))),
        ("beckmann α=0.3", Brdf::Microfacet(Microfacet::new(MicrofacetDistribution::Beckmann, 0.3, Fresnel::None))),
        (
            "mix lambert+ggx",
            Brdf::Mix(Mix::new(vec![
                (0.5, Brdf::Lambert(Lambert::new(Rgb::ONE))),
                (0.5, Brdf::Microfacet(Microfacet::new(MicrofacetDistribution::Ggx, 0.3, Fresnel::None))),
            ])),
        ),
    ];
    let wo = dir_theta_deg(35.0);
    for (name, b) in &models {
        let mut rng = TestRng::new(1);
        let n = 2_000_000;
        let t0 = std::time::Instant::now();
        let mut acc = 0.0f32;
        for _ in 0..n {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            if let Some(s) = b.sample(wo, rng.next_f32(), u) {
                acc += s.weight.x;
            }
        }
        let ts = t0.elapsed().as_secs_f64() / n as f64 * 1e9;
        let t0 = std::time::Instant::now();
        for _ in 0..n {
            let wi = crate::sampling::warp::square_to_cosine_hemisphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            acc += b.eval(wo, wi).x + b.pdf(wo, wi);
        }
        let te = t0.elapsed().as_secs_f64() / n as f64 * 1e9;
        eprintln!("{name:>16}: sample {ts:.1} ns, eval+pdf (+warp) {te:.1} ns  [{acc:.1}]");
    }
}
