//! Axially symmetric distant lighting: L(ω) depends only on θ = angle(ω, `axis`), e.g. a sky
//! gradient or a soft "sun" disc about an axis.
//!
//! Parameters: `axis` (normalised) and `profile`, a table of (θ in radians from the axis, RGB
//! radiance) with θ non-decreasing; L is linear in θ between entries and constant beyond the ends
//! (two entries with the same θ make a step). Radiance may be signed; sampling follows |L|.
//!
//! Sampling: θ ∈ [0, π] is cut into `THETA_CELLS` equal cells; cell i gets the weight
//! (g_i + c)·ΔΩ_i, where g_i bounds the luminance of |L| (`super::sampling_weight`) on the cell
//! (a sum of the channels' |L|, each convex between profile knots as L is linear there, so its
//! maximum over a cell is at a cell end or a profile knot: g_i > 0 wherever L ≠ 0), ΔΩ_i =
//! 2π(cosθ_i − cosθ_{i+1}) the cell's exact solid angle, and c a floor that gives 10 % of the mass
//! to the uniform sphere (robustness for MIS). Within a cell z = cosθ and φ are uniform, so the
//! density is exactly p(ω) = (g_i + c) / Σ_j (g_j + c)ΔΩ_j, constant on each cell.

use super::{DistantLight, LightSample};
use crate::math::{Frame, PI, Rgb, Vec2, Vec3};
use crate::sampling::distribution::PiecewiseConstant1D;

/// Resolution in θ of the sampling table (0.18° per cell).
const THETA_CELLS: usize = 1024;
/// Fraction of the sampling mass spread uniformly over the sphere.
const UNIFORM_FRACTION: f64 = 0.1;

#[derive(Clone, Debug)]
pub struct Axial {
    pub axis: Vec3,
    /// Profile: (θ in radians from the axis, radiance), θ increasing from 0 to π; linear in between.
    pub profile: Vec<(f32, Rgb)>,
    /// Frame with `n` = axis, to turn sampled local directions into world ones.
    frame: Frame,
    /// Discrete distribution over the θ cells (weights (g_i + c)ΔΩ_i).
    cells: PiecewiseConstant1D,
    /// cos θ at the THETA_CELLS + 1 cell edges.
    z_edge: Vec<f32>,
    /// Solid-angle density on each cell.
    cell_pdf: Vec<f32>,
}

impl Axial {
    /// Builds the light from an already validated description (see [`Axial::try_new`]). It never
    /// panics: a zero axis becomes +z, non-finite entries are dropped, the profile is sorted by θ,
    /// and an empty profile means no light.
    pub fn new(axis: Vec3, profile: Vec<(f32, Rgb)>) -> Self {
        let axis = axis.try_normalize().unwrap_or(Vec3::Z);
        let mut profile: Vec<(f32, Rgb)> =
            profile.into_iter().filter(|(t, l)| t.is_finite() && l.is_finite()).collect();
        profile.sort_by(|a, b| a.0.total_cmp(&b.0));
        let z64: Vec<f64> =
            (0..=THETA_CELLS).map(|i| (std::f64::consts::PI * i as f64 / THETA_CELLS as f64).cos()).collect();
        let dz: Vec<f64> = z64.windows(2).map(|w| w[0] - w[1]).collect();
        // g_i = max over the cell of the luminance of |L|: at its two ends and at every knot inside.
        let h = |theta: f32| super::sampling_weight(profile_radiance(&profile, theta)) as f64;
        let edge_theta = |i: usize| PI * i as f32 / THETA_CELLS as f32;
        let mut g: Vec<f64> = (0..THETA_CELLS).map(|i| h(edge_theta(i)).max(h(edge_theta(i + 1)))).collect();
        for &(t, l) in &profile {
            let i = theta_cell(t.clamp(0.0, PI));
            g[i] = g[i].max(super::sampling_weight(l) as f64);
        }
        let mass: f64 = g.iter().zip(&dz).map(|(g, d)| g * 2.0 * std::f64::consts::PI * d).sum();
        // Floor c with c·4π = α/(1−α) · Σ gΔΩ, i.e. a fraction α of the total mass.
        let c = if mass > 0.0 {
            UNIFORM_FRACTION / (1.0 - UNIFORM_FRACTION) * mass / (4.0 * std::f64::consts::PI)
        } else {
            1.0
        };
        let norm = mass + c * 4.0 * std::f64::consts::PI;
        let weights: Vec<f32> = g.iter().zip(&dz).map(|(g, d)| ((g + c) * d) as f32).collect();
        Axial {
            axis,
            frame: Frame::from_normal(axis),
            cells: PiecewiseConstant1D::new(&weights),
            z_edge: z64.iter().map(|&z| z as f32).collect(),
            cell_pdf: g.iter().map(|g| ((g + c) / norm) as f32).collect(),
            profile,
        }
    }

    /// Validates a user description: a finite non-zero axis, a non-empty profile with finite θ in
    /// [0, π] in non-decreasing order and finite radiance.
    pub fn try_new(axis: Vec3, profile: Vec<(f32, Rgb)>) -> crate::Result<Self> {
        if !axis.is_finite() || axis.length_squared() == 0.0 {
            return Err(crate::Error::new(format!("axial lighting: axis {axis} must be a finite non-zero vector")));
        }
        if profile.is_empty() {
            return Err(crate::Error::new("axial lighting: the profile is empty"));
        }
        let mut last = 0.0f32;
        for (i, &(t, l)) in profile.iter().enumerate() {
            if !(0.0..=PI + 1e-5).contains(&t) || t < last {
                return Err(crate::Error::new(format!(
                    "axial lighting: profile entry {i} has θ = {t} rad; θ must lie in [0, π] and not decrease"
                )));
            }
            if !l.is_finite() {
                return Err(crate::Error::new(format!(
                    "axial lighting: profile entry {i} has non-finite radiance {l}"
                )));
            }
            last = t;
        }
        Ok(Axial::new(axis, profile))
    }

    /// Angle θ ∈ [0, π] between `wi` and the axis (atan2 form: accurate near the axis).
    #[inline]
    fn theta(&self, wi: Vec3) -> f32 {
        self.axis.cross(wi).length().atan2(self.axis.dot(wi))
    }
}

/// Index of the θ cell containing `theta` ∈ [0, π].
#[inline]
fn theta_cell(theta: f32) -> usize {
    ((theta * (THETA_CELLS as f32 / PI)) as usize).min(THETA_CELLS - 1)
}

/// The profile at θ: linear between knots, constant beyond the ends, 0 if empty.
#[inline]
fn profile_radiance(profile: &[(f32, Rgb)], theta: f32) -> Rgb {
    let Some(first) = profile.first() else { return Rgb::ZERO };
    // First knot strictly beyond θ; the one before it is at or below θ.
    let i = profile.partition_point(|p| p.0 <= theta);
    if i == 0 {
        return first.1;
    }
    if i == profile.len() {
        return profile[i - 1].1;
    }
    let ((t0, l0), (t1, l1)) = (profile[i - 1], profile[i]);
    // t0 ≤ θ < t1, so t1 > t0.
    l0 + (l1 - l0) * ((theta - t0) / (t1 - t0))
}

impl DistantLight for Axial {
    #[inline]
    fn eval(&self, wi: Vec3) -> Rgb {
        profile_radiance(&self.profile, self.theta(wi))
    }

    #[inline]
    fn sample(&self, u: Vec2) -> Option<LightSample> {
        let (i, _, t) = self.cells.sample_discrete(u.x);
        let z = self.z_edge[i] + t * (self.z_edge[i + 1] - self.z_edge[i]);
        let sin_theta = ((1.0 - z) * (1.0 + z)).max(0.0).sqrt();
        let (sp, cp) = crate::math::fast::sincos_2pi(u.y);
        let wi = self.frame.to_world(Vec3::new(sin_theta * cp, sin_theta * sp, z)).normalize();
        // Recomputed from wi so that (pdf, value) agree exactly with pdf(wi) and eval(wi).
        let pdf = self.pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(LightSample { wi, value: self.eval(wi) / pdf, pdf, delta: false })
    }

    #[inline]
    fn pdf(&self, wi: Vec3) -> f32 {
        self.cell_pdf[theta_cell(self.theta(wi))]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::testutil::check_light;
    use crate::sampling::chi2::integrate_sphere;

    /// A bright soft disc of 5° about the axis on a dim sky that fades to 0 below the horizon.
    fn sunny() -> Axial {
        let d = PI / 180.0;
        Axial::try_new(
            Vec3::new(1.0, -0.5, 2.0),
            vec![
                (0.0, Rgb::new(200.0, 180.0, 150.0)),
                (4.0 * d, Rgb::new(200.0, 180.0, 150.0)),
                (5.0 * d, Rgb::new(0.5, 0.6, 1.0)),
                (90.0 * d, Rgb::new(0.2, 0.2, 0.3)),
                (100.0 * d, Rgb::ZERO),
            ],
        )
        .unwrap()
    }

    #[test]
    fn axial_eval_interpolates_linearly_and_extrapolates_constantly() {
        let a = Axial::new(Vec3::Z, vec![(0.5, Rgb::splat(1.0)), (1.0, Rgb::new(3.0, 5.0, -1.0))]);
        let at = |theta: f32| a.eval(crate::math::spherical_direction(theta, 0.7));
        assert!((at(0.75) - Rgb::new(2.0, 3.0, 0.0)).abs().max_element() < 1e-5);
        assert!((at(0.1) - Rgb::ONE).abs().max_element() < 1e-6);
        assert!((at(2.5) - Rgb::new(3.0, 5.0, -1.0)).abs().max_element() < 1e-6);
        // A step: two knots at the same θ.
        let s = Axial::new(Vec3::X, vec![(0.3, Rgb::ONE), (0.3, Rgb::ZERO)]);
        assert_eq!(s.eval(Vec3::X), Rgb::ONE);
        assert_eq!(s.eval(Vec3::Y), Rgb::ZERO);
    }

    #[test]
    fn axial_sampling_matches_pdf() {
        let a = sunny();
        check_light(&a, "axial", 1.0);
        // Every direction with L ≠ 0 has pdf > 0 (and so does every other, thanks to the floor).
        assert!(a.pdf(-a.axis) > 0.0);
    }

    /// The table follows luminance (`super::sampling_weight`): a pure red hemisphere and a pure
    /// green one of the same value have densities in the ratio (0.7152 + c) / (0.2126 + c), c the
    /// uniform floor (c·4π a ninth of Σ g ΔΩ = 2π (0.2126 + 0.7152)); the largest channel makes it 1.
    /// The cell at the step takes the larger of the two (0.3 % of the mass: 2e-4 of the ratio).
    #[test]
    fn axial_samples_by_luminance() {
        let (red, green) = (Rgb::new(1.0, 0.0, 0.0), Rgb::new(0.0, 1.0, 0.0));
        let a = Axial::new(Vec3::Z, vec![(0.0, red), (PI / 2.0, red), (PI / 2.0, green), (PI, green)]);
        let (yr, yg) = (0.2126, 0.7152);
        let c = (yr + yg) / 2.0 / 9.0;
        let want = (yg + c) / (yr + c);
        let at = |theta: f32| a.pdf(crate::math::spherical_direction(theta, 0.3)) as f64;
        let ratio = at(2.5) / at(0.6);
        assert!((ratio - want).abs() < 1e-3 * want, "density ratio {ratio}, luminance's {want}");
    }

    #[test]
    fn axial_integral_by_sampling_matches_quadrature() {
        // ∫ L dω = 2π ∫ L(θ) sinθ dθ by a fine midpoint rule (converged to < 1e-4 relative),
        // against MC with the light's samples: 4σ with σ = sqrt(sample variance / n).
        let a = sunny();
        let m = 200_000;
        let quad: f64 = (0..m)
            .map(|i| {
                let t = std::f64::consts::PI * (i as f64 + 0.5) / m as f64;
                profile_radiance(&a.profile, t as f32).x as f64 * t.sin()
            })
            .sum::<f64>()
            * 2.0
            * std::f64::consts::PI
            * std::f64::consts::PI
            / m as f64;
        let mut rng = crate::sampling::chi2::TestRng::new(5);
        let n = 400_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let v = a.sample(Vec2::new(rng.next_f32(), rng.next_f32())).map_or(0.0, |s| s.value.x as f64);
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        let sigma = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - quad).abs() < 4.0 * sigma, "MC {mean} ± {sigma} vs quadrature {quad}");
        // The pdf is close to proportional to L: the relative error is small.
        assert!(sigma / mean < 0.01, "relative σ {}", sigma / mean);
        let pdf_int = integrate_sphere(|d| a.pdf(d) as f64, 512);
        assert!((pdf_int - 1.0).abs() < 2e-3);
    }

    #[test]
    fn axial_rejects_bad_profiles() {
        assert!(Axial::try_new(Vec3::ZERO, vec![(0.0, Rgb::ONE)]).is_err());
        assert!(Axial::try_new(Vec3::Z, vec![]).is_err());
        assert!(Axial::try_new(Vec3::Z, vec![(1.0, Rgb::ONE), (0.5, Rgb::ONE)]).is_err());
        assert!(Axial::try_new(Vec3::Z, vec![(4.0, Rgb::ONE)]).is_err());
        assert!(Axial::try_new(Vec3::Z, vec![(0.0, Rgb::new(f32::NAN, 0.0, 0.0))]).is_err());
        // The infallible constructor survives bad input without panicking.
        let a = Axial::new(Vec3::ZERO, vec![]);
        assert_eq!(a.eval(Vec3::Z), Rgb::ZERO);
        assert!(a.sample(Vec2::new(0.3, 0.3)).is_some_and(|s| s.value == Rgb::ZERO));
    }
}
