//! Distant lights (docs/src/conventions.md §1, §6): radiance L(ω) arriving *from* direction ω, the same at
//! every point of the scene. Each light has `eval`, `sample` and `pdf` over directions; the
//! integrator combines light samples with BRDF samples by multiple importance sampling.

pub mod axial;
pub mod directional;
pub mod envmap;
mod latlong_grid;
pub mod sh;
pub mod uniform;

pub use axial::Axial;
pub use directional::Directional;
pub use envmap::{Envmap, Mapping};
pub use sh::ShLight;
pub use uniform::Uniform;

use crate::math::{Rgb, Vec2, Vec3};
use crate::simd::{Float, Float3, Isa, Mask, Sse2};

/// A direction drawn from a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// World direction toward the light (ω_i, pointing away from the surface).
    pub wi: Vec3,
    /// L(ω_i)/pdf; for a delta light the irradiance it delivers perpendicular to `wi`.
    /// May be negative for SH lighting, which is sampled by |L| and keeps its sign.
    pub value: Rgb,
    /// Solid-angle density of `wi` (0 for a delta light).
    pub pdf: f32,
    pub delta: bool,
}

/// [`LightSample`]s of `N` lanes in structure of arrays, from [`DistantLight::sample_each`]. A
/// lane without a sample (not wanted, or the light drew none) holds `valid` false, `wi` = +z,
/// `value` 0, `pdf` 0 and `delta` false, so that the integrator's stages can run over every lane.
#[derive(Clone, Copy, Debug)]
pub struct LightSamples<const N: usize, S: Isa = Sse2> {
    /// World directions toward the light ([`LightSample::wi`]).
    pub wi: Float3<N, S>,
    /// L(ω_i)/pdf, or a delta light's irradiance ([`LightSample::value`]).
    pub value: Float3<N, S>,
    /// Solid-angle densities ([`LightSample::pdf`]).
    pub pdf: Float<N, S>,
    /// The lanes that hold a sample.
    pub valid: Mask<N, S>,
    /// The lanes whose sample is a delta light's.
    pub delta: Mask<N, S>,
}

impl<const N: usize, S: Isa> LightSamples<N, S> {
    /// No lane holds a sample.
    pub const NONE: Self = LightSamples {
        wi: Float3 { x: Float::ZERO, y: Float::ZERO, z: Float::ONE },
        value: Float3::ZERO,
        pdf: Float::ZERO,
        valid: Mask::NONE,
        delta: Mask::NONE,
    };

    /// Writes `s` into lane `k` (a lane with a sample).
    #[inline(always)]
    pub fn set_lane(&mut self, k: usize, s: &LightSample) {
        self.wi.set_lane(k, s.wi);
        self.value.set_lane(k, s.value);
        self.pdf.0[k] = s.pdf;
        self.valid.set(k, true);
        self.delta.set(k, s.delta);
    }

    /// Lane `k`'s sample, if it holds one.
    #[inline]
    pub fn lane(&self, k: usize) -> Option<LightSample> {
        self.valid.lane(k).then(|| LightSample {
            wi: self.wi.lane(k),
            value: self.value.lane(k),
            pdf: self.pdf.0[k],
            delta: self.delta.lane(k),
        })
    }
}

/// A direction and where a light keeps its data for it, from [`DistantLight::locate`].
#[derive(Clone, Copy, Debug)]
pub struct Located {
    /// The world direction located (unit).
    pub wi: Vec3,
    /// Environment map: index of the texel (row-major); unused by other lights.
    pub(crate) index: usize,
    /// Angular environment map: θ of the direction (its solid-angle Jacobian); unused otherwise.
    pub(crate) theta: f32,
}

impl Located {
    /// A placeholder for lanes that locate nothing.
    pub(crate) const NONE: Located = Located { wi: Vec3::ZERO, index: 0, theta: 0.0 };
}

/// The interface of every distant light.
pub trait DistantLight {
    /// Radiance arriving from world direction `wi` (0 for a delta light).
    fn eval(&self, wi: Vec3) -> Rgb;
    /// Draws a direction with density `pdf`, proportional (where possible) to |L|. An environment
    /// map built by [`Envmap::new`] (the renderer's) follows only its brighter-than-average pixels
    /// (MIS compensation, docs/src/conventions.md §2, "Light sampling") and is zero on the rest: its
    /// samples are meant to be combined by MIS with a technique that covers every direction (the
    /// integrator's BRDF samples); [`Envmap::with_table`] gives one whose samples can be used alone.
    fn sample(&self, u: Vec2) -> Option<LightSample>;
    /// Solid-angle density with which `sample` draws `wi` (0 for a delta light).
    fn pdf(&self, wi: Vec3) -> f32;
    fn is_delta(&self) -> bool {
        false
    }
    /// Finds where `eval_pdf(wi)` reads (the texel of a light backed by a large table) and starts
    /// loading it from memory; [`DistantLight::eval_pdf_located`] of the result then returns exactly
    /// `eval_pdf(wi)` without searching again. The path tracer locates a BRDF-sampled direction
    /// before next-event estimation and evaluates it after.
    #[inline]
    fn locate(&self, wi: Vec3) -> Located {
        Located { wi, index: 0, theta: 0.0 }
    }
    /// [`DistantLight::sample`] of each lane `k` with `want[k]`, in lanes (the same bits; the other
    /// lanes hold no sample). An environment map writes its sample once, over the lanes (its
    /// `sample` is the one-lane call); the other lights run their `sample` lane by lane.
    #[inline(always)]
    fn sample_each<const N: usize, S: Isa>(&self, u: [Float<N, S>; 2], want: Mask<N, S>) -> LightSamples<N, S> {
        let mut out = LightSamples::NONE;
        for k in 0..N {
            if want.lane(k)
                && let Some(s) = self.sample(Vec2::new(u[0].0[k], u[1].0[k]))
            {
                out.set_lane(k, &s);
            }
        }
        out
    }
    /// [`DistantLight::locate`] of each lane `k` with `want[k]` (the same results; the other lanes'
    /// are unspecified). An environment map locates over the lanes (its `locate` is the one-lane
    /// call).
    #[inline(always)]
    fn locate_each<const N: usize, S: Isa>(&self, wi: Float3<N, S>, want: Mask<N, S>) -> [Located; N] {
        let mut out = [Located::NONE; N];
        for (k, o) in out.iter_mut().enumerate() {
            if want.lane(k) {
                *o = self.locate(wi.lane(k));
            }
        }
        out
    }
    /// [`DistantLight::eval`] of each lane `k` with `want[k]` (the same bits; zero elsewhere): the
    /// light seen by a batch's camera rays that miss. An environment map looks its directions up
    /// over the lanes (its `eval` is the one-lane call).
    #[inline(always)]
    fn eval_each<const N: usize, S: Isa>(&self, wi: Float3<N, S>, want: Mask<N, S>) -> [Rgb; N] {
        let mut out = [Rgb::ZERO; N];
        for (k, o) in out.iter_mut().enumerate() {
            if want.lane(k) {
                *o = self.eval(wi.lane(k));
            }
        }
        out
    }
    /// `eval_pdf(at.wi)` for `at` returned by this light's [`DistantLight::locate`] (same bits).
    #[inline]
    fn eval_pdf_located(&self, at: Located) -> (Rgb, f32) {
        self.eval_pdf(at.wi)
    }
    /// A hint that `sample(u)` follows soon: lights with large sampling tables start loading the
    /// entries it will read. No effect on results.
    #[inline]
    fn prefetch_sample(&self, _u: Vec2) {}
    /// `(eval(wi), pdf(wi))` together: lights whose two lookups share work override it.
    #[inline]
    fn eval_pdf(&self, wi: Vec3) -> (Rgb, f32) {
        (self.eval(wi), self.pdf(wi))
    }
}

#[derive(Clone, Debug)]
pub enum Light {
    Uniform(Uniform),
    Directional(Directional),
    Axial(Axial),
    Sh(ShLight),
    Envmap(Envmap),
}

macro_rules! dispatch {
    ($self:ident, $l:ident => $e:expr) => {
        match $self {
            Light::Uniform($l) => $e,
            Light::Directional($l) => $e,
            Light::Axial($l) => $e,
            Light::Sh($l) => $e,
            Light::Envmap($l) => $e,
        }
    };
}

impl DistantLight for Light {
    #[inline]
    fn eval(&self, wi: Vec3) -> Rgb {
        dispatch!(self, l => l.eval(wi))
    }
    #[inline(always)]
    fn sample(&self, u: Vec2) -> Option<LightSample> {
        dispatch!(self, l => l.sample(u))
    }
    #[inline]
    fn pdf(&self, wi: Vec3) -> f32 {
        dispatch!(self, l => l.pdf(wi))
    }
    #[inline]
    fn is_delta(&self) -> bool {
        dispatch!(self, l => l.is_delta())
    }
    #[inline]
    fn eval_pdf(&self, wi: Vec3) -> (Rgb, f32) {
        dispatch!(self, l => l.eval_pdf(wi))
    }
    #[inline]
    fn locate(&self, wi: Vec3) -> Located {
        dispatch!(self, l => l.locate(wi))
    }
    #[inline(always)]
    fn locate_each<const N: usize, S: Isa>(&self, wi: Float3<N, S>, want: Mask<N, S>) -> [Located; N] {
        dispatch!(self, l => l.locate_each(wi, want))
    }
    #[inline(always)]
    fn sample_each<const N: usize, S: Isa>(&self, u: [Float<N, S>; 2], want: Mask<N, S>) -> LightSamples<N, S> {
        dispatch!(self, l => l.sample_each(u, want))
    }
    #[inline(always)]
    fn eval_each<const N: usize, S: Isa>(&self, wi: Float3<N, S>, want: Mask<N, S>) -> [Rgb; N] {
        dispatch!(self, l => l.eval_each(wi, want))
    }
    #[inline(always)]
    fn eval_pdf_located(&self, at: Located) -> (Rgb, f32) {
        dispatch!(self, l => l.eval_pdf_located(at))
    }
    #[inline(always)]
    fn prefetch_sample(&self, u: Vec2) {
        dispatch!(self, l => l.prefetch_sample(u))
    }
}

/// The scalar every light's sampling table follows for a radiance L: the Rec. 709 luminance of
/// |L| channel by channel, Y = 0.2126 |R| + 0.7152 |G| + 0.0722 |B| (docs/src/conventions.md §2,
/// "Light sampling"). Positive wherever any channel is non-zero, so no direction that gives light
/// is left out. Luminance rather than the largest channel: every channel's variance is lower under
/// coloured light (guide, "Performance notes and their history").
#[inline]
pub(crate) fn sampling_weight(l: Rgb) -> f32 {
    crate::output::luminance(l.abs().to_array()) as f32
}

/// MIS compensation of a sampling table (Karlík et al. 2019, "MIS Compensation: Optimizing
/// Sampling Techniques in Multiple Importance Sampling"; pbrt-v4's image light does the same):
/// max(g_i − ḡ, 0) per cell, ḡ = Σ g_i ΔΩ_i / Σ ΔΩ_i the solid-angle mean of g, `solid_angle(i)`
/// the cell's ΔΩ_i (any common factor; 0 for cells outside the map). Light samples then go only
/// to the cells brighter than the mean, where the BRDF's samples, which the integrator always
/// combines with them, do worst; the darker cells are left to the BRDF's samples, which cover every
/// direction a non-Dirac BRDF reflects (`brdf::tests::sampling_covers_what_every_brdf_reflects`).
/// A table with no cell above its mean (a constant map) is returned unchanged. Shapes: `g` and the
/// result have one entry per cell; entries ≤ 0 or NaN count as 0.
pub(crate) fn compensated(g: &[f32], solid_angle: impl Fn(usize) -> f64) -> Vec<f32> {
    let (mut sum, mut area) = (0.0f64, 0.0f64);
    for (i, &v) in g.iter().enumerate() {
        let a = solid_angle(i);
        area += a;
        if v > 0.0 {
            sum += v as f64 * a;
        }
    }
    let mean = if area > 0.0 { sum / area } else { 0.0 };
    let out: Vec<f32> = g.iter().map(|&v| if v as f64 > mean { (v as f64 - mean) as f32 } else { 0.0 }).collect();
    if out.iter().any(|&v| v > 0.0) { out } else { g.to_vec() }
}

#[cfg(test)]
mod testutil;
