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
use super::{BrdfSample, Bxdf, Outgoing};
use crate::math::{INV_PI, Rgb, Vec2, Vec3};
use crate::sampling::LANES;

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
        match *self {
            Fresnel::None => Rgb::ONE,
            Fresnel::Schlick { f0 } => fresnel::schlick(cos_i, f0),
            Fresnel::Conductor { eta, k } => fresnel::conductor(cos_i, eta, k),
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

/// Beckmann's Smith Λ as a function of a = cotθ / α: (e^{−a²}/(a√π) − erfc(a)) / 2.
#[inline]
fn beckmann_lambda(a: f32) -> f32 {
    if a >= 6.0 {
        return 0.0; // Λ < 1e-17
    }
    beckmann_lambda_formula(a)
}

/// The formula of [`beckmann_lambda`] without its cut at a ≥ 6: straight-line f64 arithmetic
/// (no branch), so that a lane loop of it runs in SIMD registers; the lanes select 0 where
/// a ≥ 6 themselves.
#[inline(always)]
fn beckmann_lambda_formula(a: f32) -> f32 {
    let a = a as f64;
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    (0.5 * (crate::math::fast::exp_f64(-a * a) * INV_SQRT_PI / a - erfc_pos(a))).max(0.0) as f32
}

impl Microfacet {
    pub fn new(distribution: MicrofacetDistribution, alpha: f32, fresnel: Fresnel) -> Self {
        let alpha2 = alpha * alpha;
        Microfacet { distribution, alpha, fresnel, alpha2, inv_alpha2: 1.0 / alpha2 }
    }

    /// Normal distribution D(h) (per steradian of h, projected-area normalised).
    #[inline]
    pub fn d(&self, h: Vec3) -> f32 {
        let c2 = h.z * h.z;
        if h.z <= 0.0 {
            return 0.0;
        }
        match self.distribution {
            MicrofacetDistribution::Beckmann => {
                let tan2 = (1.0 - c2).max(0.0) / c2;
                crate::math::fast::exp(-tan2 * self.inv_alpha2) * (INV_PI * self.inv_alpha2) / (c2 * c2)
            }
            MicrofacetDistribution::Ggx => {
                let t = (self.alpha2 - 1.0) * c2 + 1.0;
                self.alpha2 * INV_PI / (t * t)
            }
        }
    }

    /// Smith's Λ(ω) (ω in the upper hemisphere).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let c2 = w.z * w.z;
        let s2 = (1.0 - c2).max(0.0);
        if s2 <= 0.0 {
            return 0.0;
        }
        match self.distribution {
            MicrofacetDistribution::Ggx => 0.5 * ((1.0 + self.alpha2 * s2 / c2).sqrt() - 1.0),
            MicrofacetDistribution::Beckmann => beckmann_lambda(w.z.abs() / (self.alpha * s2.sqrt())),
        }
    }

    /// Heitz 2018: visible normal for ω_o (upper hemisphere) from u ∈ [0,1)².
    #[inline]
    fn sample_ggx_vndf(&self, wo: Vec3, u: Vec2) -> Vec3 {
        // Stretch to the hemisphere configuration (α = 1).
        let vh = Vec3::new(self.alpha * wo.x, self.alpha * wo.y, wo.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { Vec3::X };
        let t2 = vh.cross(t1);
        // Uniform disk point, squeezed onto the visible half of the projected hemisphere.
        let r = u.x.sqrt();
        let (sp, cp) = crate::math::fast::sincos_2pi(u.y);
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * sp);
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        // Unstretch.
        Vec3::new(self.alpha * nh.x, self.alpha * nh.y, nh.z.max(0.0)).normalize()
    }

    /// Density of ω_i given h = normalize(ω_o + ω_i), with G1(ω_o) passed in (GGX only uses it).
    #[inline]
    fn pdf_h(&self, wo: Vec3, h: Vec3, d: f32, lambda_o: f32) -> f32 {
        match self.distribution {
            MicrofacetDistribution::Ggx => d / ((1.0 + lambda_o) * 4.0 * wo.z),
            MicrofacetDistribution::Beckmann => d * h.z / (4.0 * wo.dot(h)),
        }
    }
}

impl Bxdf for Microfacet {
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_at(&self.outgoing(wo), wi)
    }

    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        self.sample_at(&self.outgoing(wo), u_lobe, u)
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.pdf_at(&self.outgoing(wo), wi)
    }

    /// Λ(ω_o), which G needs in every sample and eval (and GGX's pdf): once per vertex.
    #[inline]
    fn outgoing(&self, wo: Vec3) -> Outgoing {
        Outgoing { wo, lambda_o: if wo.z > 0.0 { self.lambda(wo) } else { 0.0 } }
    }

    #[inline]
    fn eval_at(&self, o: &Outgoing, wi: Vec3) -> Rgb {
        let wo = o.wo;
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wo + wi).normalize();
        let g = 1.0 / (1.0 + o.lambda_o + self.lambda(wi));
        self.fresnel.eval(wi.dot(h)) * (self.d(h) * g / (4.0 * wo.z))
    }

    #[inline]
    fn sample_at(&self, o: &Outgoing, _u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        let wo = o.wo;
        if wo.z <= 0.0 {
            return None;
        }
        let m = match self.distribution {
            MicrofacetDistribution::Ggx => self.sample_ggx_vndf(wo, u),
            MicrofacetDistribution::Beckmann => {
                let tan2 = -self.alpha2 * crate::math::fast::ln_1p(-u.x);
                let c = 1.0 / (1.0 + tan2).sqrt();
                let s = (1.0 - c * c).max(0.0).sqrt();
                let (sp, cp) = crate::math::fast::sincos_2pi(u.y);
                Vec3::new(s * cp, s * sp, c)
            }
        };
        let wom = wo.dot(m);
        if wom <= 0.0 {
            return None;
        }
        let wi = (2.0 * wom * m - wo).normalize();
        if wi.z <= 0.0 {
            return None;
        }
        // Recompute h from (ω_o, ω_i) as eval/pdf do, so weight == eval/pdf to the rounding.
        let h = (wo + wi).normalize();
        let d = self.d(h);
        let lo = o.lambda_o;
        let pdf = self.pdf_h(wo, h, d, lo);
        if !pdf.is_finite() || pdf <= 0.0 {
            return None;
        }
        let g = 1.0 / (1.0 + lo + self.lambda(wi));
        let f = self.fresnel.eval(wi.dot(h));
        let weight = match self.distribution {
            MicrofacetDistribution::Ggx => f * (g * (1.0 + lo)),
            MicrofacetDistribution::Beckmann => f * (g * wo.dot(h) / (wo.z * h.z)),
        };
        Some(BrdfSample { wi, weight, pdf, delta: false })
    }

    #[inline]
    fn pdf_at(&self, o: &Outgoing, wi: Vec3) -> f32 {
        let wo = o.wo;
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        self.pdf_h(wo, h, self.d(h), o.lambda_o)
    }
}

/// Beckmann's sample, eval, pdf and terms of ω_o for [`LANES`] vertices at once, each lane the
/// bits of the one-vertex method (`outgoing`, `sample_at`, `eval_at`, `pdf_at`; tested). Every
/// lane computes every step, branch-free, on structure-of-arrays `[f32; LANES]` (f64 for Λ's
/// erfc and exp), so that inside the x86-64-v3 copy of the render's tile loop the steps are
/// SIMD instructions; the early returns of the one-vertex code become lane masks, written with
/// the same comparisons (`!(x <= 0 || …)`, not `x > 0 && …`, so that NaN goes the same way). The lanes'
/// vertices must all have this BRDF; `live` marks the lanes to compute (the others return
/// nothing). Beckmann only ([`Microfacet::has_lanes`]): `Brdf`'s lane methods run GGX's lanes
/// through the one-vertex code.
impl Microfacet {
    /// Whether the distribution has the lane functions below (Beckmann).
    #[inline(always)]
    pub fn has_lanes(&self) -> bool {
        self.distribution == MicrofacetDistribution::Beckmann
    }

    /// Beckmann's Λ(ω) of each lane from cosθ = `z` (the bits of [`Microfacet::lambda`]).
    #[inline(always)]
    fn beckmann_lambda_lanes(&self, z: &[f32; LANES]) -> [f32; LANES] {
        let mut a = [0.0f32; LANES];
        let mut zero = [false; LANES];
        for k in 0..LANES {
            let c2 = z[k] * z[k];
            let s2 = (1.0 - c2).max(0.0);
            a[k] = z[k].abs() / (self.alpha * s2.sqrt());
            zero[k] = s2 <= 0.0 || a[k] >= 6.0;
        }
        let mut out = [0.0f32; LANES];
        for k in 0..LANES {
            let v = beckmann_lambda_formula(a[k]);
            out[k] = if zero[k] { 0.0 } else { v };
        }
        out
    }

    /// Beckmann's D(h) of each lane (the bits of [`Microfacet::d`]).
    #[inline(always)]
    fn beckmann_d_lanes(&self, hz: &[f32; LANES]) -> [f32; LANES] {
        let mut out = [0.0f32; LANES];
        for k in 0..LANES {
            let c2 = hz[k] * hz[k];
            let tan2 = (1.0 - c2).max(0.0) / c2;
            let d = crate::math::fast::exp(-tan2 * self.inv_alpha2) * (INV_PI * self.inv_alpha2) / (c2 * c2);
            out[k] = if hz[k] <= 0.0 { 0.0 } else { d };
        }
        out
    }

    /// [`Bxdf::outgoing`] of each live lane.
    #[inline(always)]
    pub(super) fn outgoing_lanes(&self, wo: &[Vec3; LANES], live: &[bool; LANES]) -> [Outgoing; LANES] {
        debug_assert!(self.has_lanes());
        let mut out = [Outgoing::plain(Vec3::ZERO); LANES];
        let mut z = [0.0f32; LANES];
        for k in 0..LANES {
            z[k] = wo[k].z;
        }
        let lambda = self.beckmann_lambda_lanes(&z);
        for k in 0..LANES {
            if live[k] {
                out[k] = Outgoing { wo: wo[k], lambda_o: if wo[k].z > 0.0 { lambda[k] } else { 0.0 } };
            }
        }
        out
    }

    /// [`Bxdf::sample_at`] of each live lane.
    #[inline(always)]
    pub(super) fn sample_at_lanes(
        &self,
        o: &[Outgoing; LANES],
        u: &[Vec2; LANES],
        live: &[bool; LANES],
    ) -> [Option<BrdfSample>; LANES] {
        let mut out = [None; LANES];
        debug_assert!(self.has_lanes());
        let (mut wi, mut h, mut ok) = ([[0.0f32; 3]; LANES], [[0.0f32; 3]; LANES], [false; LANES]);
        let mut wih = [0.0f32; LANES];
        let mut hz = [0.0f32; LANES];
        let mut wiz = [0.0f32; LANES];
        for k in 0..LANES {
            let wo = o[k].wo;
            // m from D(h) cosθ_h: tan²θ_m = −α² ln(1 − u).
            let tan2 = -self.alpha2 * crate::math::fast::ln_1p(-u[k].x);
            let c = 1.0 / (1.0 + tan2).sqrt();
            let s = (1.0 - c * c).max(0.0).sqrt();
            let (sp, cp) = crate::math::fast::sincos_2pi(u[k].y);
            let m = [s * cp, s * sp, c];
            let wom = (wo.x * m[0] + wo.y * m[1]) + wo.z * m[2];
            let t = 2.0 * wom;
            let r = [t * m[0] - wo.x, t * m[1] - wo.y, t * m[2] - wo.z];
            let ri = 1.0 / ((r[0] * r[0] + r[1] * r[1]) + r[2] * r[2]).sqrt();
            wi[k] = [r[0] * ri, r[1] * ri, r[2] * ri];
            let q = [wo.x + wi[k][0], wo.y + wi[k][1], wo.z + wi[k][2]];
            let qi = 1.0 / ((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]).sqrt();
            h[k] = [q[0] * qi, q[1] * qi, q[2] * qi];
            hz[k] = h[k][2];
            wiz[k] = wi[k][2];
            wih[k] = (wi[k][0] * h[k][0] + wi[k][1] * h[k][1]) + wi[k][2] * h[k][2];
            ok[k] = live[k] && !(wo.z <= 0.0 || wom <= 0.0 || wi[k][2] <= 0.0);
        }
        let d = self.beckmann_d_lanes(&hz);
        let lambda_i = self.beckmann_lambda_lanes(&wiz);
        let (mut pdf, mut scale) = ([0.0f32; LANES], [0.0f32; LANES]);
        for k in 0..LANES {
            let wo = o[k].wo;
            let woh = (wo.x * h[k][0] + wo.y * h[k][1]) + wo.z * h[k][2];
            pdf[k] = d[k] * hz[k] / (4.0 * woh);
            // (A finite pdf is not NaN: `> 0` is the one-vertex code's `!(<= 0)` here.)
            ok[k] = ok[k] && pdf[k].is_finite() && pdf[k] > 0.0;
            let g = 1.0 / (1.0 + o[k].lambda_o + lambda_i[k]);
            scale[k] = g * woh / (wo.z * hz[k]);
        }
        for k in 0..LANES {
            if ok[k] {
                let weight = self.fresnel.eval(wih[k]) * scale[k];
                out[k] = Some(BrdfSample { wi: Vec3::from_array(wi[k]), weight, pdf: pdf[k], delta: false });
            }
        }
        out
    }

    /// h = normalize(ω_o + ω_i), its z, ω_o·h and ω_i·h of each lane, and whether both
    /// directions are above the horizon (`!(z <= 0)`), as `eval_at` and `pdf_at` compute them.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn half_vectors_lanes(
        o: &[Outgoing; LANES],
        wi: &[Vec3; LANES],
    ) -> ([f32; LANES], [f32; LANES], [f32; LANES], [bool; LANES]) {
        let (mut hz, mut woh, mut wih, mut above) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES], [false; LANES]);
        for k in 0..LANES {
            let (wo, w) = (o[k].wo, wi[k]);
            let q = [wo.x + w.x, wo.y + w.y, wo.z + w.z];
            let qi = 1.0 / ((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]).sqrt();
            let h = [q[0] * qi, q[1] * qi, q[2] * qi];
            hz[k] = h[2];
            woh[k] = (wo.x * h[0] + wo.y * h[1]) + wo.z * h[2];
            wih[k] = (w.x * h[0] + w.y * h[1]) + w.z * h[2];
            above[k] = !(wo.z <= 0.0 || w.z <= 0.0);
        }
        (hz, woh, wih, above)
    }

    /// [`Bxdf::eval_at`] of each live lane (zero elsewhere).
    #[inline(always)]
    pub(super) fn eval_at_lanes(
        &self,
        o: &[Outgoing; LANES],
        wi: &[Vec3; LANES],
        live: &[bool; LANES],
    ) -> [Rgb; LANES] {
        let mut out = [Rgb::ZERO; LANES];
        debug_assert!(self.has_lanes());
        let (hz, _, wih, above) = Self::half_vectors_lanes(o, wi);
        let d = self.beckmann_d_lanes(&hz);
        let mut wiz = [0.0f32; LANES];
        for k in 0..LANES {
            wiz[k] = wi[k].z;
        }
        let lambda_i = self.beckmann_lambda_lanes(&wiz);
        let mut scale = [0.0f32; LANES];
        for k in 0..LANES {
            let g = 1.0 / (1.0 + o[k].lambda_o + lambda_i[k]);
            scale[k] = d[k] * g / (4.0 * o[k].wo.z);
        }
        for k in 0..LANES {
            if live[k] && above[k] {
                out[k] = self.fresnel.eval(wih[k]) * scale[k];
            }
        }
        out
    }

    /// [`Bxdf::pdf_at`] of each live lane (zero elsewhere).
    #[inline(always)]
    pub(super) fn pdf_at_lanes(&self, o: &[Outgoing; LANES], wi: &[Vec3; LANES], live: &[bool; LANES]) -> [f32; LANES] {
        let mut out = [0.0f32; LANES];
        debug_assert!(self.has_lanes());
        let (hz, woh, _, above) = Self::half_vectors_lanes(o, wi);
        let d = self.beckmann_d_lanes(&hz);
        for k in 0..LANES {
            let pdf = d[k] * hz[k] / (4.0 * woh[k]);
            out[k] = if live[k] && above[k] { pdf } else { 0.0 };
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::testutil::*;
    use MicrofacetDistribution::{Beckmann, Ggx};

    const ALPHAS: [f32; 2] = [0.1, 0.5];
    const THETAS: [f32; 3] = [0.0, 30.0, 70.0];

    /// f32 bits, every NaN alike.
    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn same3(a: Vec3, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// The lane methods give each live lane the bits of the one-vertex method (`outgoing`,
    /// `sample_at`, `eval_at`, `pdf_at`), through `Brdf`'s lane dispatch, for Beckmann (SIMD
    /// lanes), GGX and Lambert (lane by lane), every Fresnel, on random directions and numbers
    /// plus the edge cases of the one-vertex code (below and on the horizon, the normal itself,
    /// u = 0 and u → 1), with random lane masks.
    #[test]
    fn lanes_give_the_one_vertex_bits() {
        use crate::brdf::{Brdf, Lambert};
        use crate::sampling::chi2::TestRng;
        let mut rng = TestRng::new(21);
        let special = [
            Vec3::Z,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.6, 0.0, -0.8),
            Vec3::new(0.0, 0.999_999, 0.001_414_2),
            Vec3::new(0.0, 0.0, -1.0),
        ];
        let dir = |rng: &mut TestRng| -> Vec3 {
            if rng.next_f32() < 0.1 {
                return special[(rng.next_u64() % special.len() as u64) as usize];
            }
            let z = 2.0 * rng.next_f32() - 1.0;
            let (s, p) = ((1.0 - z * z).max(0.0).sqrt(), 2.0 * std::f32::consts::PI * rng.next_f32());
            Vec3::new(s * p.cos(), s * p.sin(), z).normalize()
        };
        let fresnels = [
            Fresnel::None,
            Fresnel::Schlick { f0: Rgb::new(0.04, 0.5, 0.9) },
            Fresnel::Conductor { eta: Rgb::new(0.2, 0.9, 1.1), k: Rgb::new(3.9, 2.4, 2.2) },
        ];
        let mut brdfs = vec![Brdf::Lambert(Lambert::new(Rgb::new(0.8, 0.5, 0.2)))];
        for alpha in [0.02f32, 0.2, 0.7, 1.6] {
            for f in fresnels {
                brdfs.push(Brdf::Microfacet(Microfacet::new(Beckmann, alpha, f)));
            }
            brdfs.push(Brdf::Microfacet(Microfacet::new(Ggx, alpha, Fresnel::None)));
        }
        let mut checked = [0usize; 4];
        for brdf in &brdfs {
            for _ in 0..400 {
                let mut wo = [Vec3::Z; LANES];
                let mut wi = [Vec3::Z; LANES];
                let mut u = [Vec2::ZERO; LANES];
                let mut live = [false; LANES];
                for k in 0..LANES {
                    wo[k] = dir(&mut rng);
                    wi[k] = dir(&mut rng);
                    let pick = |rng: &mut TestRng| match rng.next_u64() % 10 {
                        0 => 0.0,
                        1 => 1.0 - f32::EPSILON / 2.0,
                        _ => rng.next_f32(),
                    };
                    u[k] = Vec2::new(pick(&mut rng), pick(&mut rng));
                    live[k] = rng.next_f32() < 0.8;
                }
                let o = brdf.outgoing_lanes(&wo, &live);
                let s = brdf.sample_at_lanes(&o, &[0.0; LANES], &u, &live);
                let f = brdf.eval_at_lanes(&o, &wi, &live);
                let p = brdf.pdf_at_lanes(&o, &wi, &live);
                for k in 0..LANES {
                    if !live[k] {
                        assert!(
                            s[k].is_none() && f[k] == Rgb::ZERO && p[k] == 0.0,
                            "{brdf:?}: a lane that is not live"
                        );
                        continue;
                    }
                    let o1 = brdf.outgoing(wo[k]);
                    assert!(same3(o[k].wo, o1.wo) && same(o[k].lambda_o, o1.lambda_o), "{brdf:?} outgoing {:?}", wo[k]);
                    match (s[k], brdf.sample_at(&o1, 0.0, u[k])) {
                        (None, None) => {}
                        (Some(a), Some(b)) => {
                            assert!(
                                same3(a.wi, b.wi)
                                    && same3(a.weight, b.weight)
                                    && same(a.pdf, b.pdf)
                                    && a.delta == b.delta,
                                "{brdf:?} sample wo {:?} u {:?}: {a:?} against {b:?}",
                                wo[k],
                                u[k]
                            );
                            checked[1] += 1;
                        }
                        (a, b) => panic!("{brdf:?} sample wo {:?} u {:?}: {a:?} against {b:?}", wo[k], u[k]),
                    }
                    assert!(same3(f[k], brdf.eval_at(&o1, wi[k])), "{brdf:?} eval {:?} {:?}", wo[k], wi[k]);
                    assert!(same(p[k], brdf.pdf_at(&o1, wi[k])), "{brdf:?} pdf {:?} {:?}", wo[k], wi[k]);
                    checked[0] += 1;
                    checked[2] += (f[k] != Rgb::ZERO) as usize;
                    checked[3] += (o1.lambda_o > 0.0) as usize;
                }
            }
        }
        // The comparisons were not vacuous. Uniform directions put ω_o above the horizon in half
        // the lanes and both ω_o and ω_i in a quarter, so about a third of the live lanes draw a
        // sample (u and ω_o·m permitting), a fifth have a nonzero value (measured 36 % and 19 %
        // of 43,438), and a third a nonzero Λ(ω_o) (Lambert's is 0).
        let n = checked[0];
        assert!(checked[1] > n / 4 && checked[2] > n / 8 && checked[3] > n / 4, "{checked:?}");
    }

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
