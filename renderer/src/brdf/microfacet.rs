//! `microfacet`: the Cook–Torrance / Walter et al. (2007) microfacet BRDF (docs/src/conventions.md §4),
//! BRDF = D(h) G(ω_o, ω_i) F(ω_i·h) / (4 cosθ_i cosθ_o), so ρ̂ = D G F / (4 cosθ_o).
//!
//! Parameters:
//! - `distribution`: `Beckmann`, D = exp(−tan²θ_h/α²) / (π α² cos⁴θ_h), or `Ggx` (Trowbridge–Reitz),
//!   D = α² / (π ((α² − 1) cos²θ_h + 1)²); both normalised so that ∫ D cosθ_h dω_h = 1.
//! - `alpha`: the width α (> 0).
//! - `fresnel`: `None` (F = 1), `Schlick { f0 }`, or `Conductor { eta, k }` (exact, per channel);
//!   its cosine is ω_i·h.
//!
//! Shadowing–masking: Smith's *height-correlated* form G = 1 / (1 + Λ(ω_o) + Λ(ω_i)) (Heitz 2014,
//! eq. 99), with the exact Λ of each distribution (Beckmann's through erfc). It is symmetric, so the
//! BRDF is reciprocal, and with F = 1 the albedo is ≤ 1 (single scattering loses energy at large α).
//! The model is physical: it is zero below the horizon (no `horizon` option).
//!
//! Sampling:
//! - GGX: the distribution of visible normals D_ωo(h) = G1(ω_o) max(0, ω_o·h) D(h) / cosθ_o, drawn
//!   exactly by Heitz (2018); p(ω_i) = G1(ω_o) D(h) / (4 cosθ_o), weight = F G / G1(ω_o).
//! - Beckmann: h from D(h) cosθ_h (tan²θ_h = −α² ln(1 − u), exact inverse CDF); p(ω_i) =
//!   D cosθ_h / (4 ω_o·h), weight = F G (ω_o·h) / (cosθ_o cosθ_h).
//!
//! Both refuse draws with ω_o·h ≤ 0 or ω_i below the horizon; `pdf` integrates to the kept fraction.
use super::fresnel;
use super::{BrdfSamples, Bxdf, Outgoing};
use crate::math::{INV_PI, Rgb, Vec3};
use crate::simd::{Float, Float3, Isa, Mask};

/// The normal distribution D (`distribution`), defined in `vocab`.
pub use vocab::Distribution as MicrofacetDistribution;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// F = 1.
    None,
    /// Schlick's approximation with normal-incidence reflectance F0.
    Schlick { f0: Rgb },
    /// Exact conductor Fresnel with complex index η + i k (per channel).
    Conductor { eta: Rgb, k: Rgb },
}

impl Fresnel {
    /// Reflectance for the cosine between the light and the microfacet normal.
    #[inline]
    pub fn eval(&self, cos_i: f32) -> Rgb {
        self.eval_of(Float::<1>::splat(cos_i)).lane(0)
    }

    /// Reflectance for each lane's cosine.
    #[inline(always)]
    pub fn eval_of<const N: usize, S: Isa>(&self, cos_i: Float<N, S>) -> Float3<N, S> {
        match *self {
            Fresnel::None => Float3::splat(Rgb::ONE),
            Fresnel::Schlick { f0 } => fresnel::schlick_of(cos_i, f0),
            Fresnel::Conductor { eta, k } => fresnel::conductor_of(cos_i, eta, k),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Microfacet {
    pub distribution: MicrofacetDistribution,
    pub alpha: f32,
    pub fresnel: Fresnel,
    alpha2: f32,
    inv_alpha2: f32,
}

/// erfc(x) for x ≥ 0 in f64 (Chebyshev fit of Numerical Recipes' `erfcc`, relative error < 1.2e-7,
/// which keeps Beckmann's Λ accurate despite the cancellation at large a).
#[inline(always)]
fn erfc_pos(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.5 * x);
    let p = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    t * crate::math::fast::exp_f64(-x * x + p)
}

/// Beckmann's Smith Λ as a function of a = cotθ / α: (e^{−a²}/(a√π) − erfc(a)) / 2, without the
/// cut at a ≥ 6 (the caller selects 0 there): straight-line f64 arithmetic, so that a loop of it
/// over the lanes runs in SIMD registers.
#[inline(always)]
fn beckmann_lambda_formula(a: f64) -> f64 {
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    (0.5 * (crate::math::fast::exp_f64(-a * a) * INV_SQRT_PI / a - erfc_pos(a))).max(0.0)
}

impl Microfacet {
    pub fn new(distribution: MicrofacetDistribution, alpha: f32, fresnel: Fresnel) -> Self {
        let alpha2 = alpha * alpha;
        Microfacet { distribution, alpha, fresnel, alpha2, inv_alpha2: 1.0 / alpha2 }
    }

    /// Normal distribution D(h) (per steradian of h, projected-area normalised).
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        self.d_of(Float::<1>::splat(h.z)).lane(0)
    }

    /// D(h) of each lane from cosθ_h = `hz` (zero below the horizon).
    #[inline(always)]
    fn d_of<const N: usize, S: Isa>(&self, hz: Float<N, S>) -> Float<N, S> {
        let c2 = hz * hz;
        let d = match self.distribution {
            MicrofacetDistribution::Beckmann => {
                let tan2 = (1.0 - c2).max(Float::ZERO) / c2;
                (-tan2 * self.inv_alpha2).exp() * (INV_PI * self.inv_alpha2) / (c2 * c2)
            }
            MicrofacetDistribution::Ggx => {
                let t = (self.alpha2 - 1.0) * c2 + 1.0;
                self.alpha2 * INV_PI / (t * t)
            }
        };
        hz.le(Float::ZERO).select(Float::ZERO, d)
    }

    /// Smith's Λ(ω) (ω in the upper hemisphere).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        self.lambda_of(Float::<1>::splat(w.z)).lane(0)
    }

    /// Smith's Λ(ω) of each lane from cosθ = `z`.
    #[inline(always)]
    fn lambda_of<const N: usize, S: Isa>(&self, z: Float<N, S>) -> Float<N, S> {
        let c2 = z * z;
        let s2 = (1.0 - c2).max(Float::ZERO);
        let v = match self.distribution {
            MicrofacetDistribution::Ggx => 0.5 * ((1.0 + self.alpha2 * s2 / c2).sqrt() - 1.0),
            MicrofacetDistribution::Beckmann => {
                let a = z.abs() / (self.alpha * s2.sqrt());
                // Λ < 1e-17 beyond a = 6.
                let mut l = a.to_f64();
                for v in &mut l {
                    *v = beckmann_lambda_formula(*v);
                }
                a.ge(Float::splat(6.0)).select(Float::ZERO, Float::from_f64(l))
            }
        };
        s2.le(Float::ZERO).select(Float::ZERO, v)
    }

    /// Heitz 2018: visible normal for each lane's ω_o (upper hemisphere) from u ∈ [0,1)².
    #[inline(always)]
    fn sample_ggx_vndf<const N: usize, S: Isa>(&self, wo: Float3<N, S>, u: [Float<N, S>; 2]) -> Float3<N, S> {
        // Stretch to the hemisphere configuration (α = 1).
        let vh = Float3::new(self.alpha * wo.x, self.alpha * wo.y, wo.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let len = lensq.sqrt();
        let tilted = lensq.gt(Float::ZERO);
        let t1 = Float3::new(
            tilted.select(-vh.y / len, Float::ONE),
            tilted.select(vh.x / len, Float::ZERO),
            tilted.select(Float::ZERO / len, Float::ZERO),
        );
        let t2 = vh.cross(t1);
        // Uniform disk point, squeezed onto the visible half of the projected hemisphere.
        let r = u[0].sqrt();
        let (sp, cp) = u[1].sincos_2pi();
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(Float::ZERO).sqrt() + s * (r * sp);
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(Float::ZERO).sqrt();
        // Unstretch.
        Float3::new(self.alpha * nh.x, self.alpha * nh.y, nh.z.max(Float::ZERO)).normalize()
    }

    /// Density of ω_i given h = normalize(ω_o + ω_i) (its z `hz`, ω_o·h `woh`), D(h) and Λ(ω_o).
    #[inline(always)]
    fn pdf_h<const N: usize, S: Isa>(
        &self,
        wo_z: Float<N, S>,
        hz: Float<N, S>,
        woh: Float<N, S>,
        d: Float<N, S>,
        lambda_o: Float<N, S>,
    ) -> Float<N, S> {
        match self.distribution {
            MicrofacetDistribution::Ggx => d / ((1.0 + lambda_o) * 4.0 * wo_z),
            MicrofacetDistribution::Beckmann => d * hz / (4.0 * woh),
        }
    }
}

impl Bxdf for Microfacet {
    /// Λ(ω_o), which G needs in every sample and eval (and GGX's pdf): once per vertex.
    #[inline(always)]
    fn outgoing<const N: usize, S: Isa>(&self, wo: Float3<N, S>) -> Outgoing<N, S> {
        Outgoing { wo, lambda_o: wo.z.gt(Float::ZERO).select(self.lambda_of(wo.z), Float::ZERO) }
    }

    #[inline(always)]
    fn eval_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float3<N, S> {
        let wo = o.wo;
        let below = wo.z.le(Float::ZERO) | wi.z.le(Float::ZERO);
        let h = (wo + wi).normalize();
        let g = 1.0 / (1.0 + o.lambda_o + self.lambda_of(wi.z));
        let v = self.fresnel.eval_of(wi.dot(h)) * (self.d_of(h.z) * g / (4.0 * wo.z));
        Float3::select(below, Float3::ZERO, v)
    }

    #[inline(always)]
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        _u_lobe: Float<N, S>,
        u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S> {
        let wo = o.wo;
        let m = match self.distribution {
            MicrofacetDistribution::Ggx => self.sample_ggx_vndf(wo, u),
            MicrofacetDistribution::Beckmann => {
                // m from D(h) cosθ_h: tan²θ_m = −α² ln(1 − u).
                let tan2 = -self.alpha2 * (-u[0]).ln_1p();
                let c = 1.0 / (1.0 + tan2).sqrt();
                let s = (1.0 - c * c).max(Float::ZERO).sqrt();
                let (sp, cp) = u[1].sincos_2pi();
                Float3::new(s * cp, s * sp, c)
            }
        };
        let wom = wo.dot(m);
        let wi = (m * (2.0 * wom) - wo).normalize();
        // Recompute h from (ω_o, ω_i) as eval/pdf do, so weight == eval/pdf to the rounding.
        let h = (wo + wi).normalize();
        let woh = wo.dot(h);
        let d = self.d_of(h.z);
        let lo = o.lambda_o;
        let pdf = self.pdf_h(wo.z, h.z, woh, d, lo);
        let valid = !(wo.z.le(Float::ZERO) | wom.le(Float::ZERO) | wi.z.le(Float::ZERO))
            & pdf.is_finite()
            & pdf.gt(Float::ZERO);
        let g = 1.0 / (1.0 + lo + self.lambda_of(wi.z));
        let f = self.fresnel.eval_of(wi.dot(h));
        let weight = match self.distribution {
            MicrofacetDistribution::Ggx => f * (g * (1.0 + lo)),
            MicrofacetDistribution::Beckmann => f * (g * woh / (wo.z * h.z)),
        };
        BrdfSamples { wi, weight, pdf, delta: Mask::NONE, valid }
    }

    #[inline(always)]
    fn pdf_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float<N, S> {
        let wo = o.wo;
        let below = wo.z.le(Float::ZERO) | wi.z.le(Float::ZERO);
        let h = (wo + wi).normalize();
        let pdf = self.pdf_h(wo.z, h.z, wo.dot(h), self.d_of(h.z), o.lambda_o);
        below.select(Float::ZERO, pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::testutil::*;
    use MicrofacetDistribution::{Beckmann, Ggx};

    const ALPHAS: [f32; 2] = [0.1, 0.5];
    const THETAS: [f32; 3] = [0.0, 30.0, 70.0];

    fn frame_for(alpha: f32, wo: Vec3) -> (Vec3, f32) {
        if alpha >= 0.3 { (Vec3::Z, 1.0) } else { (refl(wo), (0.25 / alpha / wo.z.sqrt()).max(1.0)) }
    }

    /// D is normalised (∫ D cosθ_h dω_h = 1) and Λ is consistent with it: the projected area of the
    /// visible microfacets is ∫ D(h) max(0, ω·h) dω_h = (1 + Λ(ω)) cosθ (Heitz 2014, eq. 17).
    #[test]
    fn d_normalised_and_lambda_consistent() {
        for dist in [Beckmann, Ggx] {
            for a in [0.2f32, 0.5] {
                let b = Microfacet::new(dist, a, Fresnel::None);
                // Midpoint rule, 2048 × 4096 on the sphere zoomed ×(0.5/α) about n (resolves the
                // peak): quadrature error < 1e-4.
                let m = integrate_zoomed(|h| (b.d(h) * h.z.max(0.0)) as f64, Vec3::Z, (0.5 / a).max(1.0), 2048);
                assert!((m - 1.0).abs() < 1e-4, "{dist:?} α={a}: ∫D cos = {m}");
                for t in [30.0f32, 60.0, 80.0] {
                    let w = dir_theta_deg(t);
                    let proj =
                        integrate_zoomed(|h| (b.d(h) * w.dot(h).max(0.0)) as f64, Vec3::Z, (0.5 / a).max(1.0), 2048);
                    let want = (1.0 + b.lambda(w) as f64) * w.z as f64;
                    assert!((proj - want).abs() < 2e-4 * want, "{dist:?} α={a} θ={t}: {proj} vs {want}");
                }
            }
        }
    }

    #[test]
    fn chi2_all() {
        for dist in [Beckmann, Ggx] {
            for a in ALPHAS {
                let b = Microfacet::new(dist, a, Fresnel::None);
                for t in THETAS {
                    let wo = dir_theta_deg(t);
                    let (axis, k) = frame_for(a, wo);
                    let r = chi2_bxdf(&b, wo, axis, k, &chi2_cfg());
                    eprintln!("{dist:?} α={a} θo={t}: p = {:.3e}, pdf mass {:.5}", r.p_value, r.pdf_integral);
                    assert!(r.passes(ALPHA), "{dist:?} α={a} θo={t}: {r:?}");
                }
            }
        }
    }

    /// Claiming D cosθ_h sampling for the GGX VNDF sampler must fail (wrong shape at 70°).
    #[test]
    fn chi2_rejects_wrong_pdf() {
        let b = Microfacet::new(Ggx, 0.5, Fresnel::None);
        let wo = dir_theta_deg(70.0);
        let r = chi2_bxdf_with_pdf(&b, wo, Vec3::Z, 1.0, &chi2_cfg(), |wi| {
            if wi.z <= 0.0 {
                return 0.0;
            }
            let h = (wo + wi).normalize();
            (b.d(h) * h.z / (4.0 * wo.dot(h))) as f64
        });
        assert!(!r.passes(ALPHA), "{r:?}");
    }

    #[test]
    fn pdf_mass_matches_sampled_fraction() {
        for dist in [Beckmann, Ggx] {
            for a in ALPHAS {
                let b = Microfacet::new(dist, a, Fresnel::None);
                for t in THETAS {
                    let wo = dir_theta_deg(t);
                    let (axis, k) = frame_for(a, wo);
                    let (m, qe) = integrate_zoomed_err(|wi| b.pdf(wo, wi) as f64, axis, k, 1024, 1e-6);
                    let (f, sf) = sampled_fraction(&b, wo, 1_000_000, 3);
                    // 5σ binomial + the quadrature's stated error.
                    assert!((m - f).abs() < 5.0 * sf + qe, "{dist:?} α={a} θo={t}: mass {m} ± {qe:.1e} vs {f}");
                }
            }
        }
    }

    #[test]
    fn weights_match_eval_over_pdf() {
        let fresnels = [
            Fresnel::None,
            Fresnel::Schlick { f0: Rgb::new(0.04, 0.5, 0.9) },
            Fresnel::Conductor { eta: Rgb::new(0.2, 0.9, 1.1), k: Rgb::new(3.9, 2.4, 2.2) },
        ];
        for dist in [Beckmann, Ggx] {
            for a in ALPHAS {
                for fr in fresnels {
                    let b = Microfacet::new(dist, a, fr);
                    for t in THETAS {
                        check_sample_consistency(&b, dir_theta_deg(t), 10_000, 9);
                    }
                }
            }
        }
    }

    /// Albedo with F = 1: ≤ 1 everywhere, close to its geometric bound for α = 0.1 at normal
    /// exitance (single scattering loses little for a smooth surface). MC with the BRDF's sampling, 5σ bounds; the quadrature
    /// estimate must agree with it.
    #[test]
    fn albedo_energy() {
        for dist in [Beckmann, Ggx] {
            for a in ALPHAS {
                let b = Microfacet::new(dist, a, Fresnel::None);
                for t in THETAS {
                    let wo = dir_theta_deg(t);
                    let (m, e) = albedo_mc(&b, wo, 1_000_000, 8);
                    let (axis, k) = frame_for(a, wo);
                    let (q, qe) = albedo_quadrature_zoomed_err(&b, wo, axis, k, 1024, 1e-6);
                    eprintln!("{dist:?} α={a} θo={t}: albedo MC {:.5} ± {:.1e}, quadrature {:.5}", m.x, e.x, q.x);
                    assert!(m.x - 5.0 * e.x <= 1.0, "{dist:?} α={a} θo={t}: {m}");
                    assert!((q.x - m.x).abs() < 5.0 * e.x + qe.x, "{dist:?} α={a} θo={t}: {q} ± {qe} vs {m}");
                    if t == 0.0 {
                        // At normal exitance ω_i = reflect(n, h) is above the horizon iff θ_h < 45°,
                        // and the weight there is G/G1(n) = G ≤ 1, so the albedo is at most
                        // P(θ_h < 45°) under D cosθ_h: 1/(1 + α²) for GGX, 1 − e^{−1/α²} for Beckmann.
                        let bound = match dist {
                            Ggx => 1.0 / (1.0 + (a * a) as f64),
                            Beckmann => 1.0 - (-1.0 / (a * a) as f64).exp(),
                        };
                        assert!(m.x - 5.0 * e.x <= bound, "{dist:?} α={a}: {m} > {bound}");
                        if a == 0.1 {
                            // …and the shadowing loss is small: within 0.5 % of that bound.
                            assert!(m.x + 5.0 * e.x >= bound - 5e-3, "{dist:?}: {m} vs {bound}");
                        }
                    }
                }
            }
        }
    }

    /// Fresnel enters as F(ω_i·h): the ratio to the F = 1 model is exactly the Fresnel term.
    #[test]
    fn fresnel_factor() {
        let eta = Rgb::new(0.2, 0.9, 1.1);
        let k = Rgb::new(3.9, 2.4, 2.2);
        let plain = Microfacet::new(Ggx, 0.3, Fresnel::None);
        let cond = Microfacet::new(Ggx, 0.3, Fresnel::Conductor { eta, k });
        let wo = dir_theta_deg(40.0);
        let wi = dir_theta_deg(-20.0);
        let h = (wo + wi).normalize();
        let want = fresnel::conductor(wi.dot(h), eta, k) * plain.eval(wo, wi).x;
        assert!((cond.eval(wo, wi) - want).abs().max_element() < 1e-6 * want.max_element());
    }

    #[test]
    fn reciprocity() {
        for dist in [Beckmann, Ggx] {
            for a in ALPHAS {
                let fr = Fresnel::Schlick { f0: Rgb::new(0.04, 0.5, 0.9) };
                check_reciprocity(&Microfacet::new(dist, a, fr), 7);
            }
        }
    }
}
