//! `phong`: the normalised Phong lobe about the reflection vector (docs/src/conventions.md §4, paper eq. 40),
//! ρ̂ = k_s (s+1)/(2π) · max(R·ω_i, 0)^s. The cosine of the transfer function is *inside* this
//! definition (the lobe is written for ρ̂, as in the paper), so no extra cosθ_i factor appears.
//!
//! Parameters: `ks` (RGB), `s` (exponent > 0), `horizon`:
//! - `Clamp`: ρ̂ = 0 where ω_i·n ≤ 0 (physical); draws that land there are refused (`None`) and `pdf`
//!   is zero there, so `pdf` integrates to the fraction of the lobe above the horizon.
//! - `Ignore`: the whole lobe (paper sec. 3.6, eq. 43 exactly); the albedo is exactly k_s.
//!
//! Sampling is exact: cos α = u^{1/(s+1)} about R, pdf = (s+1)/(2π) cos^s α, weight = k_s.
use super::{BrdfSamples, Bxdf, Horizon, Outgoing};
use crate::math::{INV_2PI, Rgb};
use crate::sampling::warp;
use crate::simd::{Float, Float3, Frames, Isa, Mask};

#[derive(Clone, Debug)]
pub struct Phong {
    pub ks: Rgb,
    pub s: f32,
    pub horizon: Horizon,
    /// (s+1)/(2π): the lobe's normalisation.
    norm: f32,
    /// 1/(s+1): exponent of the inverse CDF.
    inv_s_plus_1: f32,
}
impl Phong {
    pub fn new(ks: Rgb, s: f32, horizon: Horizon) -> Self {
        Phong { ks, s, horizon, norm: (s + 1.0) * INV_2PI, inv_s_plus_1: 1.0 / (s + 1.0) }
    }

    /// Lanes where `wi` is cut by the horizon (clamp) or ω_o is below it.
    #[inline(always)]
    fn below<const N: usize, S: Isa>(&self, wo: Float3<N, S>, wi: Float3<N, S>) -> Mask<N, S> {
        let clamp = Mask::splat(self.horizon == Horizon::Clamp);
        wo.z.le(Float::ZERO) | (clamp & wi.z.le(Float::ZERO))
    }

    /// Lobe density (s+1)/(2π) max(R·ω_i, 0)^s, after the horizon test; shared by eval and pdf.
    #[inline(always)]
    fn lobe<const N: usize, S: Isa>(&self, wo: Float3<N, S>, wi: Float3<N, S>) -> Float<N, S> {
        let c = wi.dot(Float3::new(-wo.x, -wo.y, wo.z));
        let zero = self.below(wo, wi) | c.le(Float::ZERO);
        zero.select(Float::ZERO, self.norm * c.powf(self.s))
    }
}
impl Bxdf for Phong {
    #[inline(always)]
    fn eval_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float3<N, S> {
        self.ks * self.lobe(o.wo, wi)
    }
    #[inline(always)]
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        _u_lobe: Float<N, S>,
        u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S> {
        let wo = o.wo;
        let r = Float3::new(-wo.x, -wo.y, wo.z);
        let local = warp::cos_power_lobe(u, self.inv_s_plus_1);
        // Rotate the +z lobe onto R (keeping cos α = local.z).
        let wi = Frames::from_normal(r).to_world(local);
        let pdf = self.norm * local.z.powf(self.s);
        let valid = !(self.below(wo, wi) | pdf.le(Float::ZERO));
        BrdfSamples { wi, weight: Float3::splat(self.ks), pdf, delta: Mask::NONE, valid }
    }
    #[inline(always)]
    fn pdf_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float<N, S> {
        self.lobe(o.wo, wi)
    }
    #[inline]
    fn ignores_horizon(&self) -> bool {
        self.horizon == Horizon::Ignore
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::testutil::*;
    use crate::math::{Vec2, Vec3};

    const SS: [f32; 3] = [1.0, 8.0, 128.0];
    const THETAS: [f32; 3] = [0.0, 30.0, 70.0];

    /// Zoom so that the lobe (angular width ~ 1/sqrt(s)) covers the chi-square grid.
    fn zoom_for(s: f32) -> f32 {
        (0.5 * s.sqrt()).max(1.0)
    }

    /// Binning frame: about R, zoomed, unless the horizon cuts the lobe visibly; then about n
    /// unzoomed, so that the cut z = 0 is a bin edge (a cut across cells is not resolved by the
    /// harness's midpoint rule).
    fn frame_for(b: &Phong, wo: Vec3) -> (Vec3, f32) {
        if b.horizon == Horizon::Clamp && b.s <= 8.0 && wo.z < 0.9 { (Vec3::Z, 1.0) } else { (refl(wo), zoom_for(b.s)) }
    }

    #[test]
    fn closed_form_peak() {
        for s in SS {
            let b = Phong::new(Rgb::new(1.0, 0.5, 0.25), s, Horizon::Clamp);
            let wo = dir_theta_deg(30.0);
            let e = b.eval(wo, refl(wo));
            let want = b.ks * ((s + 1.0) / (2.0 * std::f32::consts::PI));
            assert!((e - want).abs().max_element() < 1e-5 * want.max_element(), "{e} vs {want}");
        }
    }

    #[test]
    fn chi2_both_horizons() {
        for horizon in [Horizon::Clamp, Horizon::Ignore] {
            for s in SS {
                let b = Phong::new(Rgb::ONE, s, horizon);
                for t in THETAS {
                    let wo = dir_theta_deg(t);
                    let (axis, k) = frame_for(&b, wo);
                    let r = chi2_bxdf(&b, wo, axis, k, &chi2_cfg());
                    assert!(r.passes(ALPHA), "{horizon:?} s={s} θo={t}: {r:?}");
                }
            }
        }
    }

    /// Deliberately wrong pdf (exponent off by 10 %) must fail the same test: it has power.
    #[test]
    fn chi2_rejects_wrong_pdf() {
        let b = Phong::new(Rgb::ONE, 128.0, Horizon::Ignore);
        let wrong = Phong::new(Rgb::ONE, 140.0, Horizon::Ignore);
        let wo = dir_theta_deg(30.0);
        let r = chi2_bxdf_with_pdf(&b, wo, refl(wo), zoom_for(128.0), &chi2_cfg(), |wi| wrong.pdf(wo, wi) as f64);
        assert!(!r.passes(ALPHA), "{r:?}");
    }

    #[test]
    fn pdf_mass_matches_sampled_fraction() {
        for horizon in [Horizon::Clamp, Horizon::Ignore] {
            for s in SS {
                let b = Phong::new(Rgb::ONE, s, horizon);
                for t in THETAS {
                    let wo = dir_theta_deg(t);
                    let (m, qe) = integrate_zoomed_err(
                        |wi| b.pdf(wo, wi) as f64,
                        refl(wo),
                        zoom_for(s),
                        1024,
                        (s as f64).max(1.0) * f32::EPSILON as f64,
                    );
                    let (f, sf) = sampled_fraction(&b, wo, 1_000_000, 3);
                    // 5σ binomial error + the quadrature's stated error.
                    assert!(
                        (m - f).abs() < 5.0 * sf + qe,
                        "{horizon:?} s={s} θo={t}: mass {m} ± {qe:.1e}, sampled {f}"
                    );
                    if horizon == Horizon::Ignore {
                        assert!((m - 1.0).abs() < qe, "mass {m} ± {qe:.1e}");
                        assert_eq!(f, 1.0);
                    }
                }
            }
        }
    }

    #[test]
    fn weights_are_exact() {
        for horizon in [Horizon::Clamp, Horizon::Ignore] {
            for s in SS {
                let b = Phong::new(Rgb::new(0.9, 0.6, 0.3), s, horizon);
                for t in THETAS {
                    let wo = dir_theta_deg(t);
                    check_sample_consistency(&b, wo, 20_000, 9);
                    let mut rng = crate::sampling::chi2::TestRng::new(2);
                    for _ in 0..1000 {
                        let u = Vec2::new(rng.next_f32(), rng.next_f32());
                        if let Some(smp) = b.sample(wo, 0.0, u) {
                            assert_eq!(smp.weight, b.ks);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn albedo() {
        for s in SS {
            for t in THETAS {
                let wo = dir_theta_deg(t);
                // Ignore: the whole normalised lobe, albedo = k_s exactly (within the stated quadrature error).
                let b = Phong::new(Rgb::ONE, s, Horizon::Ignore);
                let (a, e) = albedo_quadrature_zoomed_err(
                    &b,
                    wo,
                    refl(wo),
                    zoom_for(s),
                    1024,
                    (s as f64).max(1.0) * f32::EPSILON as f64,
                );
                assert!(((a - glam::DVec3::ONE).abs() - e).max_element() < 0.0, "s={s} θo={t}: {a} ± {e}");
                // Clamp: ≤ 1 and equal to the sampled fraction (the weight is k_s on accepted draws).
                let c = Phong::new(Rgb::ONE, s, Horizon::Clamp);
                let (a, e) = albedo_quadrature_zoomed_err(
                    &c,
                    wo,
                    refl(wo),
                    zoom_for(s),
                    1024,
                    (s as f64).max(1.0) * f32::EPSILON as f64,
                );
                let (f, sf) = sampled_fraction(&c, wo, 1_000_000, 4);
                assert!(a.x <= 1.0 + e.x, "{a} ± {e}");
                assert!((a.x - f).abs() < 5.0 * sf + e.x, "s={s} θo={t}: {a} ± {e} vs {f}");
            }
        }
    }

    #[test]
    fn ignore_flag_and_below_horizon() {
        let wo = dir_theta_deg(80.0);
        let below = Vec3::new(-wo.x, -wo.y, -0.05).normalize();
        let c = Phong::new(Rgb::ONE, 8.0, Horizon::Clamp);
        let i = Phong::new(Rgb::ONE, 8.0, Horizon::Ignore);
        assert_eq!(c.eval(wo, below), Rgb::ZERO);
        assert!(i.eval(wo, below).x > 0.0);
        assert!(i.ignores_horizon() && !c.ignores_horizon());
    }
}
