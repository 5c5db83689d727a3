//! `mirror`: the perfect specular reflector, ρ̂ = k_r δ(ω_i = R) (docs/src/conventions.md §4, paper eq. 33:
//! Λ_l ρ̂_l = 1 for k_r = 1).
//!
//! Parameters: `kr` (RGB reflectance). In the local frame R = (−ω_o.x, −ω_o.y, ω_o.z). The lobe is
//! a Dirac: `eval` and `pdf` are zero, `sample` returns ω_i = R with weight k_r, pdf 1 and
//! `delta = true`.
use super::{BrdfSamples, Bxdf, Outgoing};
use crate::math::Rgb;
use crate::simd::{Float, Float3, Isa, Mask};

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
    #[inline(always)]
    fn eval_at<const N: usize, S: Isa>(&self, _o: &Outgoing<N, S>, _wi: Float3<N, S>) -> Float3<N, S> {
        // A Dirac has no finite value: it is reached only through `sample`.
        Float3::ZERO
    }
    #[inline(always)]
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        _u_lobe: Float<N, S>,
        _u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S> {
        let wo = o.wo;
        BrdfSamples {
            wi: Float3::new(-wo.x, -wo.y, wo.z),
            weight: Float3::splat(self.kr),
            pdf: Float::ONE,
            delta: Mask::ALL,
            valid: !wo.z.le(Float::ZERO),
        }
    }
    #[inline(always)]
    fn pdf_at<const N: usize, S: Isa>(&self, _o: &Outgoing<N, S>, _wi: Float3<N, S>) -> Float<N, S> {
        Float::ZERO
    }
    #[inline]
    fn is_delta(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Vec2, Vec3, reflect};

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
