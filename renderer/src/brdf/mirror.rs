//! `mirror`: the perfect specular reflector, ρ̂ = k_r δ(ω_i = R) (docs/src/conventions.md §4, paper eq. 33:
//! Λ_l ρ̂_l = 1 for k_r = 1).
//!
//! Parameters: `kr` (RGB reflectance). In the local frame R = (−ω_o.x, −ω_o.y, ω_o.z). The lobe is
//! a Dirac: `eval` and `pdf` are zero, `sample` returns ω_i = R with weight k_r, pdf 1 and
//! `delta = true`.
use super::{BrdfSample, Bxdf};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Mirror {
    pub kr: Rgb,
}
impl Mirror {
    pub fn new(kr: Rgb) -> Self {
        Mirror { kr }
    }
}
impl Bxdf for Mirror {
    #[inline]
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Rgb {
        // A Dirac has no finite value: it is reached only through `sample`.
        Rgb::ZERO
    }
    #[inline]
    fn sample(&self, wo: Vec3, _u_lobe: f32, _u: Vec2) -> Option<BrdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        Some(BrdfSample { wi: Vec3::new(-wo.x, -wo.y, wo.z), weight: self.kr, pdf: 1.0, delta: true })
    }
    #[inline]
    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }
    #[inline]
    fn is_delta(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::reflect;

    #[test]
    fn sample_is_exact_reflection() {
        let m = Mirror::new(Rgb::new(0.9, 0.5, 0.1));
        for wo in [Vec3::Z, Vec3::new(0.3, -0.2, 0.9).normalize(), Vec3::new(-0.9, 0.1, 0.05).normalize()] {
            let s = m.sample(wo, 0.3, Vec2::new(0.1, 0.7)).unwrap();
            // Same as the world-frame formula R = 2(n·ω_o)n − ω_o with n = +z.
            assert!((s.wi - reflect(wo, Vec3::Z)).length() < 1e-6);
            assert_eq!(s.weight, m.kr);
            assert_eq!(s.pdf, 1.0);
            assert!(s.delta);
            assert_eq!(m.eval(wo, s.wi), Rgb::ZERO);
            assert_eq!(m.pdf(wo, s.wi), 0.0);
        }
        assert!(m.is_delta() && !m.ignores_horizon());
        assert!(m.sample(Vec3::new(0.0, 0.6, -0.8), 0.5, Vec2::splat(0.5)).is_none(), "viewed from below");
    }
}
