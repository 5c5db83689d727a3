//! BRDFs exactly as docs/src/conventions.md §4 defines them.
//!
//! Every model works in the local shading frame (normal = +z, see [`crate::math::Frame`]) with
//! ω_o and ω_i pointing away from the surface. `eval` returns the *transfer function*
//! ρ̂(ω_o, ω_i) = BRDF · cosθ'_i of the paper (eq. 1), so an estimator multiplies it by the incident
//! radiance only. A `sample` returns ρ̂/pdf as its weight.

pub mod lambert;
pub mod microfacet;
pub mod mirror;
pub mod mix;
pub mod phong;
pub mod torrance_sparrow;

pub mod fresnel;
#[cfg(test)]
pub(crate) mod testutil;

pub use lambert::Lambert;
pub use microfacet::{Fresnel, Microfacet, MicrofacetDistribution};
pub use mirror::Mirror;
pub use mix::Mix;
pub use phong::Phong;
pub use torrance_sparrow::TorranceSparrow;

use crate::math::{Rgb, Vec2, Vec3};
use crate::scene::build::color;
use crate::simd::{Float, Float3, Isa, Mask, Sse2};
use vocab::FresnelKind;
use vocab::scene::BrdfSection;

/// Whether a lobe sees light from below the local horizon (docs/src/conventions.md §4, paper sec. 3.6), defined in
/// `vocab`.
pub use vocab::Horizon;

/// A direction drawn from a BRDF.
#[derive(Clone, Copy, Debug)]
pub struct BrdfSample {
    /// Incident direction, local frame, pointing away from the surface.
    pub wi: Vec3,
    /// ρ̂(ω_o, ω_i) / pdf (for a delta lobe: the lobe's weight itself).
    pub weight: Rgb,
    /// Solid-angle density of `wi` (for a delta lobe: the probability of choosing that lobe).
    pub pdf: f32,
    /// Drawn from a Dirac lobe (mirror): `eval`/`pdf` do not contain it, no MIS applies.
    pub delta: bool,
}

/// `N` draws of a BRDF, one per lane ([`Bxdf::sample_at`]); lane k is a [`BrdfSample`] where
/// `valid` holds and no sample elsewhere (its other fields are then unspecified).
#[derive(Clone, Copy, Debug)]
pub struct BrdfSamples<const N: usize, S: Isa = Sse2> {
    pub wi: Float3<N, S>,
    pub weight: Float3<N, S>,
    pub pdf: Float<N, S>,
    pub delta: Mask<N, S>,
    pub valid: Mask<N, S>,
}

impl<const N: usize, S: Isa> BrdfSamples<N, S> {
    /// No sample in any lane.
    pub const NONE: Self =
        BrdfSamples { wi: Float3::ZERO, weight: Float3::ZERO, pdf: Float::ZERO, delta: Mask::NONE, valid: Mask::NONE };

    /// Lane `k`.
    #[inline(always)]
    pub fn lane(&self, k: usize) -> Option<BrdfSample> {
        self.valid.lane(k).then(|| BrdfSample {
            wi: self.wi.lane(k),
            weight: self.weight.lane(k),
            pdf: self.pdf.lane(k),
            delta: self.delta.lane(k),
        })
    }

    /// Writes lane `k` from a one-lane draw.
    #[inline(always)]
    pub fn set_lane(&mut self, k: usize, s: &BrdfSamples<1>) {
        self.wi.set_lane(k, s.wi.lane(0));
        self.weight.set_lane(k, s.weight.lane(0));
        self.pdf.0[k] = s.pdf.0[0];
        self.delta.set(k, s.delta.lane(0));
        self.valid.set(k, s.valid.lane(0));
    }

    /// The same lanes, operated on in the instruction set `T` (no instruction).
    #[inline(always)]
    pub fn with_isa<T: Isa>(self) -> BrdfSamples<N, T> {
        BrdfSamples {
            wi: self.wi.with_isa(),
            weight: self.weight.with_isa(),
            pdf: self.pdf.with_isa(),
            delta: self.delta.with_isa(),
            valid: self.valid.with_isa(),
        }
    }

    /// `a`'s lanes where `m` holds, `b`'s elsewhere.
    #[inline(always)]
    pub fn select(m: Mask<N, S>, a: &Self, b: &Self) -> Self {
        BrdfSamples {
            wi: Float3::select(m, a.wi, b.wi),
            weight: Float3::select(m, a.weight, b.weight),
            pdf: m.select(a.pdf, b.pdf),
            delta: (m & a.delta) | (!m & b.delta),
            valid: (m & a.valid) | (!m & b.valid),
        }
    }
}

/// What the sample, eval and pdf of one vertex share: ω_o and the BRDF's terms of ω_o alone,
/// computed once per vertex by [`Bxdf::outgoing`], for `N` vertices (one per lane).
#[derive(Clone, Copy, Debug)]
pub struct Outgoing<const N: usize, S: Isa = Sse2> {
    /// ω_o, local frame.
    pub wo: Float3<N, S>,
    /// Smith's Λ(ω_o) of a microfacet BRDF (the vertex's sample and its next-event eval both
    /// need it); 0 for the others, which do not read it.
    pub lambda_o: Float<N, S>,
}

impl<const N: usize, S: Isa> Outgoing<N, S> {
    /// ω_o with no precomputed terms.
    #[inline(always)]
    pub fn plain(wo: Float3<N, S>) -> Self {
        Outgoing { wo, lambda_o: Float::ZERO }
    }

    /// The same lanes, operated on in the instruction set `T` (no instruction).
    #[inline(always)]
    pub fn with_isa<T: Isa>(self) -> Outgoing<N, T> {
        Outgoing { wo: self.wo.with_isa(), lambda_o: self.lambda_o.with_isa() }
    }

    /// Lane `k` as one vertex.
    #[inline(always)]
    pub fn lane(&self, k: usize) -> Outgoing<1> {
        Outgoing { wo: Float3::splat(self.wo.lane(k)), lambda_o: Float::splat(self.lambda_o.lane(k)) }
    }

    /// Writes one vertex into lane `k`.
    #[inline(always)]
    pub fn set_lane(&mut self, k: usize, o: &Outgoing<1>) {
        self.wo.set_lane(k, o.wo.lane(0));
        self.lambda_o.0[k] = o.lambda_o.0[0];
    }
}

/// The interface every BRDF implements (local frame, normal = +z).
///
/// Each model writes its terms of ω_o, sample, eval and pdf once, over `N` lanes
/// ([`crate::simd`]): the batched path tracer calls them at `N` = [`crate::sampling::LANES`], the
/// one-sample methods (`sample`, `eval`, `pdf`: the tests and the reference path tracer) at
/// `N = 1`, and lane k of a call has the bits of the one-lane call on lane k's inputs.
pub trait Bxdf {
    /// The terms of ω_o that `sample_at`, `eval_at` and `pdf_at` share at one vertex.
    #[inline(always)]
    fn outgoing<const N: usize, S: Isa>(&self, wo: Float3<N, S>) -> Outgoing<N, S> {
        Outgoing::plain(wo)
    }
    /// Draws ω_i given ω_o in each lane. `u_lobe` selects among lobes (mix), `u` drives the warp.
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        u_lobe: Float<N, S>,
        u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S>;
    /// Transfer function ρ̂ = BRDF·cosθ'_i of each lane (zero for Dirac components).
    fn eval_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float3<N, S>;
    /// Solid-angle density with which `sample_at` draws `wi` (non-Dirac part only), each lane.
    fn pdf_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float<N, S>;

    /// True when the BRDF gathers light below the horizon (horizon = "ignore"): the integrator then
    /// does not test those directions for self-occlusion.
    fn ignores_horizon(&self) -> bool {
        false
    }
    /// True when the BRDF is purely Dirac (mirror): light sampling cannot help.
    fn is_delta(&self) -> bool {
        false
    }
    /// True when `sample` reads its `u_lobe` (a choice among lobes: the mix). The path tracer
    /// skips drawing that number for the others (its sampler dimension stays reserved, so every
    /// other number of the path is the same).
    fn uses_lobe_choice(&self) -> bool {
        false
    }

    /// Transfer function ρ̂ of one pair of directions: `eval_at` at one lane.
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.eval_at(&self.outgoing::<1, Sse2>(Float3::splat(wo)), Float3::splat(wi)).lane(0)
    }
    /// One draw: `sample_at` at one lane.
    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        let o = self.outgoing::<1, Sse2>(Float3::splat(wo));
        self.sample_at(&o, Float::splat(u_lobe), [Float::splat(u.x), Float::splat(u.y)]).lane(0)
    }
    /// One density: `pdf_at` at one lane.
    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.pdf_at(&self.outgoing::<1, Sse2>(Float3::splat(wo)), Float3::splat(wi)).lane(0)
    }
}

/// Enum dispatch over all models: the integrator's hot path sees one concrete type.
#[derive(Clone, Debug)]
pub enum Brdf {
    Mirror(Mirror),
    Lambert(Lambert),
    Phong(Phong),
    TorranceSparrow(TorranceSparrow),
    Microfacet(Microfacet),
    Mix(Mix),
}

macro_rules! dispatch {
    ($self:ident, $b:ident => $e:expr) => {
        match $self {
            Brdf::Mirror($b) => $e,
            Brdf::Lambert($b) => $e,
            Brdf::Phong($b) => $e,
            Brdf::TorranceSparrow($b) => $e,
            Brdf::Microfacet($b) => $e,
            Brdf::Mix($b) => $e,
        }
    };
}

impl Bxdf for Brdf {
    #[inline]
    fn ignores_horizon(&self) -> bool {
        dispatch!(self, b => b.ignores_horizon())
    }
    #[inline]
    fn is_delta(&self) -> bool {
        dispatch!(self, b => b.is_delta())
    }
    #[inline]
    fn uses_lobe_choice(&self) -> bool {
        dispatch!(self, b => b.uses_lobe_choice())
    }
    #[inline(always)]
    fn outgoing<const N: usize, S: Isa>(&self, wo: Float3<N, S>) -> Outgoing<N, S> {
        dispatch!(self, b => b.outgoing(wo))
    }
    #[inline(always)]
    fn sample_at<const N: usize, S: Isa>(
        &self,
        o: &Outgoing<N, S>,
        u_lobe: Float<N, S>,
        u: [Float<N, S>; 2],
    ) -> BrdfSamples<N, S> {
        dispatch!(self, b => b.sample_at(o, u_lobe, u))
    }
    #[inline(always)]
    fn eval_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float3<N, S> {
        dispatch!(self, b => b.eval_at(o, wi))
    }
    #[inline(always)]
    fn pdf_at<const N: usize, S: Isa>(&self, o: &Outgoing<N, S>, wi: Float3<N, S>) -> Float<N, S> {
        dispatch!(self, b => b.pdf_at(o, wi))
    }
}

/// A lobe parameter, checked finite and positive (`what` names it).
fn positive(v: f32, what: &str) -> std::result::Result<f32, String> {
    if v > 0.0 && v.is_finite() { Ok(v) } else { Err(format!("{what} must be positive, got {v}")) }
}

/// Builds a BRDF from its scene-file table (docs/src/conventions.md §4), checking every value: colours finite
/// and non-negative, lobe parameters finite and positive, mix weights finite and non-negative.
/// Errors: one line naming the key (the caller adds the object).
pub fn build_brdf(b: &BrdfSection) -> std::result::Result<Brdf, String> {
    Ok(match b {
        BrdfSection::Mirror { kr } => Brdf::Mirror(Mirror::new(color(*kr, "kr")?)),
        BrdfSection::Lambert { albedo } => Brdf::Lambert(Lambert::new(color(*albedo, "albedo")?)),
        BrdfSection::Phong { ks, s, horizon: hz } => {
            Brdf::Phong(Phong::new(color(*ks, "ks")?, positive(*s, "phong s")?, *hz))
        }
        BrdfSection::TorranceSparrow { ks, sigma, horizon: hz } => Brdf::TorranceSparrow(TorranceSparrow::new(
            color(*ks, "ks")?,
            positive(*sigma, "torrance-sparrow sigma")?,
            *hz,
        )),
        BrdfSection::Microfacet { distribution, alpha, fresnel, f0, eta, k } => {
            let fr = match fresnel {
                FresnelKind::None => Fresnel::None,
                FresnelKind::Schlick => {
                    Fresnel::Schlick { f0: color(f0.ok_or("fresnel = \"schlick\" needs f0")?, "f0")? }
                }
                FresnelKind::Conductor => Fresnel::Conductor {
                    eta: color(eta.ok_or("fresnel = \"conductor\" needs eta")?, "eta")?,
                    k: color(k.ok_or("fresnel = \"conductor\" needs k")?, "k")?,
                },
            };
            Brdf::Microfacet(Microfacet::new(*distribution, positive(*alpha, "microfacet alpha")?, fr))
        }
        BrdfSection::Mix { layers } => {
            if layers.is_empty() {
                return Err("mix needs at least one layer".into());
            }
            let mut v = Vec::with_capacity(layers.len());
            for l in layers {
                if !(l.weight >= 0.0 && l.weight.is_finite()) {
                    return Err(format!("mix weight must be finite and non-negative, got {}", l.weight));
                }
                v.push((l.weight, build_brdf(&l.brdf)?));
            }
            Brdf::Mix(Mix::new(v))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::TestRng;

    /// f32 bits, every NaN alike.
    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn same3(a: Vec3, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// One model of each kind (both horizons, both microfacet distributions, every Fresnel, a mix
    /// with a Dirac layer).
    fn models() -> Vec<Brdf> {
        let mut v =
            vec![Brdf::Lambert(Lambert::new(Rgb::new(0.8, 0.5, 0.2))), Brdf::Mirror(Mirror::new(Rgb::splat(0.9)))];
        for h in [Horizon::Clamp, Horizon::Ignore] {
            v.push(Brdf::Phong(Phong::new(Rgb::ONE, 12.0, h)));
            v.push(Brdf::TorranceSparrow(TorranceSparrow::new(Rgb::ONE, 0.3, h)));
        }
        let fresnels = [
            Fresnel::None,
            Fresnel::Schlick { f0: Rgb::new(0.04, 0.5, 0.9) },
            Fresnel::Conductor { eta: Rgb::new(0.2, 0.9, 1.1), k: Rgb::new(3.9, 2.4, 2.2) },
        ];
        for alpha in [0.02f32, 0.2, 1.6] {
            for f in fresnels {
                v.push(Brdf::Microfacet(Microfacet::new(MicrofacetDistribution::Beckmann, alpha, f)));
                v.push(Brdf::Microfacet(Microfacet::new(MicrofacetDistribution::Ggx, alpha, f)));
            }
        }
        v.push(Brdf::Mix(Mix::new(vec![
            (0.5, Brdf::Lambert(Lambert::new(Rgb::ONE))),
            (0.3, Brdf::Microfacet(Microfacet::new(MicrofacetDistribution::Beckmann, 0.3, Fresnel::None))),
            (0.2, Brdf::Mirror(Mirror::new(Rgb::new(0.9, 0.8, 0.7)))),
        ])));
        v
    }

    /// The precondition of the environment map's compensated light samples (`light::compensated`),
    /// which leave the darker directions to the BRDF's samples: wherever a non-Dirac BRDF reflects
    /// (f ≠ 0), its sampling density is positive. On 50,000 random pairs (ω_o, ω_i) per model, both
    /// hemispheres (a lobe that ignores the horizon reflects from below it).
    #[test]
    fn sampling_covers_what_every_brdf_reflects() {
        let mut rng = TestRng::new(5);
        let dir = |rng: &mut TestRng| {
            let z = 2.0 * rng.next_f32() - 1.0;
            let (s, p) = ((1.0 - z * z).max(0.0).sqrt(), 2.0 * std::f32::consts::PI * rng.next_f32());
            Vec3::new(s * p.cos(), s * p.sin(), z).normalize()
        };
        for brdf in models().iter().filter(|b| !b.is_delta()) {
            let mut reflecting = 0;
            for _ in 0..50_000 {
                let (wo, wi) = (dir(&mut rng), dir(&mut rng));
                // Values below 1e-30 are underflow in the lobe's tail (a sharp microfacet lobe far
                // from its peak), where the density underflows first; they carry no light.
                if brdf.eval(wo, wi).max_element() > 1e-30 {
                    reflecting += 1;
                    let p = brdf.pdf(wo, wi);
                    assert!(p > 0.0, "{brdf:?}: f({wo:?}, {wi:?}) = {:?} but pdf {p}", brdf.eval(wo, wi));
                }
            }
            // Not vacuous: even the sharpest lobe (Beckmann α = 0.02) reflects a few hundred pairs.
            assert!(reflecting > 200, "{brdf:?}: {reflecting} reflecting pairs");
        }
    }

    /// One body, every width: lane k of the eight-lane `outgoing`, `sample_at`, `eval_at` and
    /// `pdf_at` has the bits of the one-lane call on lane k's inputs, for every model, on random
    /// directions and numbers plus the edge cases (below and on the horizon, the normal itself,
    /// u = 0 and u → 1).
    #[test]
    fn eight_wide_is_one_wide() {
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
        let pick = |rng: &mut TestRng| match rng.next_u64() % 10 {
            0 => 0.0,
            1 => 1.0 - f32::EPSILON / 2.0,
            _ => rng.next_f32(),
        };
        let (mut samples, mut values) = (0usize, 0usize);
        for brdf in &models() {
            for _ in 0..300 {
                let wo: [Vec3; 8] = std::array::from_fn(|_| dir(&mut rng));
                let wi: [Vec3; 8] = std::array::from_fn(|_| dir(&mut rng));
                let u: [Vec2; 8] = std::array::from_fn(|_| Vec2::new(pick(&mut rng), pick(&mut rng)));
                let u_lobe: [f32; 8] = std::array::from_fn(|_| pick(&mut rng));
                let o = brdf.outgoing(Float3::<8>::from_vecs(&wo));
                let s = brdf.sample_at(
                    &o,
                    Float::from_array(u_lobe),
                    [Float::from_array(u.map(|u| u.x)), Float::from_array(u.map(|u| u.y))],
                );
                let f = brdf.eval_at(&o, Float3::from_vecs(&wi));
                let p = brdf.pdf_at(&o, Float3::from_vecs(&wi));
                for k in 0..8 {
                    let o1 = brdf.outgoing::<1, Sse2>(Float3::splat(wo[k]));
                    assert!(same(o.lambda_o.lane(k), o1.lambda_o.lane(0)), "{brdf:?} outgoing {:?}", wo[k]);
                    match (s.lane(k), brdf.sample(wo[k], u_lobe[k], u[k])) {
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
                            samples += 1;
                        }
                        (a, b) => panic!("{brdf:?} sample wo {:?} u {:?}: {a:?} against {b:?}", wo[k], u[k]),
                    }
                    assert!(same3(f.lane(k), brdf.eval(wo[k], wi[k])), "{brdf:?} eval {:?} {:?}", wo[k], wi[k]);
                    assert!(same(p.lane(k), brdf.pdf(wo[k], wi[k])), "{brdf:?} pdf {:?} {:?}", wo[k], wi[k]);
                    values += (f.lane(k) != Rgb::ZERO) as usize;
                }
            }
        }
        // Not vacuous: about half the ω_o are above the horizon and a quarter of the pairs both.
        let n = models().len() * 300 * 8;
        assert!(samples > n / 5 && values > n / 10, "{samples} samples, {values} values of {n}");
    }
}
