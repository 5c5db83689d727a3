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
use crate::sampling::LANES;
use crate::scene::build::color;
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

/// What the sample, eval and pdf of one vertex share: ω_o and the BRDF's terms of ω_o alone,
/// computed once per vertex by [`Bxdf::outgoing`] (a memo: the `*_at` methods return the bits of
/// `sample`, `eval` and `pdf`).
#[derive(Clone, Copy, Debug)]
pub struct Outgoing {
    /// ω_o, local frame.
    pub wo: Vec3,
    /// Smith's Λ(ω_o) of a microfacet BRDF (Beckmann's costs an f64 erfc and exp; the vertex's
    /// sample and its next-event eval both need it); 0 for the others, which do not read it.
    pub lambda_o: f32,
}

impl Outgoing {
    /// ω_o with no precomputed terms.
    #[inline]
    pub fn plain(wo: Vec3) -> Self {
        Outgoing { wo, lambda_o: 0.0 }
    }
}

/// The interface every BRDF implements (local frame, normal = +z).
pub trait Bxdf {
    /// Transfer function ρ̂ = BRDF·cosθ'_i (zero for Dirac components).
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb;
    /// Draws ω_i given ω_o. `u_lobe` selects among lobes (mix), `u` drives the warp.
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample>;
    /// Solid-angle density with which `sample` draws `wi` (non-Dirac part only).
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
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
    /// The terms of ω_o that `sample_at`, `eval_at` and `pdf_at` share at one vertex.
    #[inline]
    fn outgoing(&self, wo: Vec3) -> Outgoing {
        Outgoing::plain(wo)
    }
    /// `sample(o.wo, u_lobe, u)`, bit for bit, with `o = self.outgoing(wo)`.
    #[inline]
    fn sample_at(&self, o: &Outgoing, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        self.sample(o.wo, u_lobe, u)
    }
    /// `eval(o.wo, wi)`, bit for bit, with `o = self.outgoing(wo)`.
    #[inline]
    fn eval_at(&self, o: &Outgoing, wi: Vec3) -> Rgb {
        self.eval(o.wo, wi)
    }
    /// `pdf(o.wo, wi)`, bit for bit, with `o = self.outgoing(wo)`.
    #[inline]
    fn pdf_at(&self, o: &Outgoing, wi: Vec3) -> f32 {
        self.pdf(o.wo, wi)
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
    fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        dispatch!(self, b => b.eval(wo, wi))
    }
    #[inline]
    fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        dispatch!(self, b => b.sample(wo, u_lobe, u))
    }
    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        dispatch!(self, b => b.pdf(wo, wi))
    }
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
    #[inline]
    fn outgoing(&self, wo: Vec3) -> Outgoing {
        dispatch!(self, b => b.outgoing(wo))
    }
    #[inline]
    fn sample_at(&self, o: &Outgoing, u_lobe: f32, u: Vec2) -> Option<BrdfSample> {
        dispatch!(self, b => b.sample_at(o, u_lobe, u))
    }
    #[inline]
    fn eval_at(&self, o: &Outgoing, wi: Vec3) -> Rgb {
        dispatch!(self, b => b.eval_at(o, wi))
    }
    #[inline]
    fn pdf_at(&self, o: &Outgoing, wi: Vec3) -> f32 {
        dispatch!(self, b => b.pdf_at(o, wi))
    }
}

/// The one-vertex methods over [`LANES`] vertices that all have this BRDF (the path tracer's
/// batch, where every live lane hit the same object): each lane gets the bits of the one-vertex
/// method. Beckmann microfacets compute in SIMD lanes (`Microfacet::sample_at_lanes` and the
/// rest); every other model runs its one-vertex method lane by lane. `live` marks the lanes to
/// compute; the others return `None`, zero, or a plain [`Outgoing`].
impl Brdf {
    /// [`Bxdf::outgoing`] of each live lane.
    #[inline(always)]
    pub fn outgoing_lanes(&self, wo: &[Vec3; LANES], live: &[bool; LANES]) -> [Outgoing; LANES] {
        if let Brdf::Microfacet(m) = self
            && m.has_lanes()
        {
            return m.outgoing_lanes(wo, live);
        }
        let mut out = [Outgoing::plain(Vec3::ZERO); LANES];
        for k in 0..LANES {
            if live[k] {
                out[k] = self.outgoing(wo[k]);
            }
        }
        out
    }

    /// [`Bxdf::sample_at`] of each live lane.
    #[inline(always)]
    pub fn sample_at_lanes(
        &self,
        o: &[Outgoing; LANES],
        u_lobe: &[f32; LANES],
        u: &[Vec2; LANES],
        live: &[bool; LANES],
    ) -> [Option<BrdfSample>; LANES] {
        if let Brdf::Microfacet(m) = self
            && m.has_lanes()
        {
            return m.sample_at_lanes(o, u, live);
        }
        let mut out = [None; LANES];
        for k in 0..LANES {
            if live[k] {
                out[k] = self.sample_at(&o[k], u_lobe[k], u[k]);
            }
        }
        out
    }

    /// [`Bxdf::eval_at`] of each live lane (zero elsewhere).
    #[inline(always)]
    pub fn eval_at_lanes(&self, o: &[Outgoing; LANES], wi: &[Vec3; LANES], live: &[bool; LANES]) -> [Rgb; LANES] {
        if let Brdf::Microfacet(m) = self
            && m.has_lanes()
        {
            return m.eval_at_lanes(o, wi, live);
        }
        let mut out = [Rgb::ZERO; LANES];
        for k in 0..LANES {
            if live[k] {
                out[k] = self.eval_at(&o[k], wi[k]);
            }
        }
        out
    }

    /// [`Bxdf::pdf_at`] of each live lane (zero elsewhere).
    #[inline(always)]
    pub fn pdf_at_lanes(&self, o: &[Outgoing; LANES], wi: &[Vec3; LANES], live: &[bool; LANES]) -> [f32; LANES] {
        if let Brdf::Microfacet(m) = self
            && m.has_lanes()
        {
            return m.pdf_at_lanes(o, wi, live);
        }
        let mut out = [0.0f32; LANES];
        for k in 0..LANES {
            if live[k] {
                out[k] = self.pdf_at(&o[k], wi[k]);
            }
        }
        out
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
