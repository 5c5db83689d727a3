//! Uniform (constant) distant lighting: L(ω) = `radiance` from every direction — the "white
//! furnace" when the radiance is 1.
//!
//! Parameters: `radiance` (RGB). Sampling draws the uniform sphere, pdf 1/4π: a light cannot
//! prefer the upper hemisphere of a shading point it does not know, and the integrator's BRDF
//! sampling (combined by MIS) covers the lobe.

use super::{DistantLight, LightSample};
use crate::math::{INV_4PI, PI, Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Uniform {
    pub radiance: Rgb,
}

impl Uniform {
    pub fn new(radiance: Rgb) -> Self {
        Uniform { radiance }
    }
}

/// Maps [0, 1)² to the unit sphere preserving area: z = 1 − 2u₁, φ = 2πu₂ (Archimedes), so the
/// density is 1/4π everywhere.
#[inline]
pub(crate) fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = crate::math::fast::sincos_2pi(u.y);
    Vec3::new(r * c, r * s, z)
}

impl DistantLight for Uniform {
    #[inline]
    fn eval(&self, _wi: Vec3) -> Rgb {
        self.radiance
    }

    #[inline]
    fn sample(&self, u: Vec2) -> Option<LightSample> {
        Some(LightSample { wi: uniform_sphere(u), value: self.radiance * (4.0 * PI), pdf: INV_4PI, delta: false })
    }

    #[inline]
    fn pdf(&self, _wi: Vec3) -> f32 {
        INV_4PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::testutil::check_light;

    #[test]
    fn uniform_sampling_matches_pdf_and_values() {
        let l = Uniform::new(Rgb::new(0.5, 1.0, 2.0));
        check_light(&l, "uniform", 1.0);
        assert_eq!(l.eval(Vec3::new(0.0, 0.6, -0.8)), Rgb::new(0.5, 1.0, 2.0));
        assert!(!l.is_delta());
    }

    #[test]
    fn uniform_irradiance_is_pi_radiance() {
        // White furnace: E = ∫_{H²} L cosθ dω = πL. MC with the light's own samples, per-sample
        // estimate f = (L/pdf)·max(z, 0); 4σ with σ = sqrt(sample variance / n).
        let l = Uniform::new(Rgb::ONE);
        let mut rng = crate::sampling::chi2::TestRng::new(3);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let ls = l.sample(Vec2::new(rng.next_f32(), rng.next_f32())).unwrap();
            let f = (ls.value.x * ls.wi.z.max(0.0)) as f64;
            s += f;
            s2 += f * f;
        }
        let mean = s / n as f64;
        let sigma = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - std::f64::consts::PI).abs() < 4.0 * sigma, "{mean} ± {sigma}");
    }
}
