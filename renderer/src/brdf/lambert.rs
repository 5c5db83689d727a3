//! `lambert`: the ideal diffuse reflector, BRDF = albedo/π, so ρ̂ = albedo/π · max(cosθ_i, 0)
//! (docs/src/conventions.md §4; its transfer coefficients are eq. 38 × 1/π).
//!
//! Parameters: `albedo` (RGB, the directional albedo at every θ_o). Sampling: cosine-weighted
//! hemisphere, pdf = cosθ_i/π, so every sample carries weight = albedo exactly.
use super::{BrdfSamples, Bxdf, Outgoing};
use crate::math::{INV_PI, Rgb};
use crate::sampling::warp;
use crate::simd::{Float, Float3, Isa, Mask};

#[derive(Clone, Debug)]
pub struct Lambert {
    pub albedo: Rgb,
}
impl Lambert {
    pub fn new(albedo: Rgb) -> Self {
        Lambert { albedo }
    }
}
impl Bxdf for Lambert {
    #[inline(always)]
    fn eval_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float3<N, S> {
        let zero = o.wo.z.le(Float::ZERO) | wi.z.le(Float::ZERO);
        Float3::select(zero, Float3::ZERO, self.albedo * (wi.z * INV_PI))
    }
    #[inline(always)]
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        _u_lobe: Float<N, S>,
        u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S> {
        let wi = warp::cosine_hemisphere(u);
        // On the rim the density is zero: refuse rather than return an infinite weight.
        let valid = !(o.wo.z.le(Float::ZERO) | wi.z.le(Float::ZERO));
        BrdfSamples { wi, weight: Float3::splat(self.albedo), pdf: wi.z * INV_PI, delta: Mask::NONE, valid }
    }
    #[inline(always)]
    fn pdf_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float<N, S> {
        let zero = o.wo.z.le(Float::ZERO) | wi.z.le(Float::ZERO);
        zero.select(Float::ZERO, wi.z * INV_PI)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::testutil::*;
    use crate::math::{Vec2, Vec3};

    fn wos() -> [Vec3; 3] {
        [dir_theta_deg(0.0), dir_theta_deg(30.0), dir_theta_deg(70.0)]
    }

    #[test]
    fn closed_form() {
        let b = Lambert::new(Rgb::new(0.8, 0.5, 0.2));
        let wo = dir_theta_deg(30.0);
        let wi = Vec3::new(0.3, 0.4, 0.5f32.sqrt()).normalize();
        let e = b.eval(wo, wi);
        assert!((e - b.albedo * wi.z / std::f32::consts::PI).abs().max_element() < 1e-7);
        assert_eq!(b.eval(wo, Vec3::new(0.6, 0.0, -0.8)), Rgb::ZERO);
        assert_eq!(b.eval(Vec3::new(0.6, 0.0, -0.8), wi), Rgb::ZERO);
    }

    #[test]
    fn chi2_pdf_mass_and_weights() {
        let b = Lambert::new(Rgb::ONE);
        for wo in wos() {
            let r = chi2_bxdf(&b, wo, Vec3::Z, 1.0, &chi2_cfg());
            assert!(r.passes(ALPHA), "{wo}: {r:?}");
            // Midpoint rule 512 × 1024 on the smooth cosine: error < 1e-4.
            let m = integrate_zoomed(|wi| b.pdf(wo, wi) as f64, Vec3::Z, 1.0, 512);
            assert!((m - 1.0).abs() < 1e-4, "{m}");
            check_sample_consistency(&b, wo, 20_000, 1);
        }
    }

    #[test]
    fn albedo_is_exact() {
        let b = Lambert::new(Rgb::new(0.8, 0.5, 0.2));
        for wo in wos() {
            // Quadrature of ρ̂ (midpoint rule, 1024 × 2048 cells; error ≪ 1e-4).
            let a = albedo_quadrature(&b, wo, 1024);
            assert!((a - b.albedo.as_dvec3()).abs().max_element() < 1e-4, "{a}");
            // And every sample's weight is the albedo itself.
            let s = b.sample(wo, 0.0, Vec2::new(0.3, 0.8)).unwrap();
            assert_eq!(s.weight, b.albedo);
        }
    }

    #[test]
    fn reciprocity() {
        check_reciprocity(&Lambert::new(Rgb::new(0.8, 0.5, 0.2)), 5);
    }
}
