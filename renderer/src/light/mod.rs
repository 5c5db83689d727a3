//! Distant lights (CONVENTIONS §1, §6): radiance L(ω) arriving *from* direction ω, the same at
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

/// The interface of every distant light.
pub trait DistantLight {
    /// Radiance arriving from world direction `wi` (0 for a delta light).
    fn eval(&self, wi: Vec3) -> Rgb;
    /// Draws a direction with density `pdf`, proportional (where possible) to |L|.
    fn sample(&self, u: Vec2) -> Option<LightSample>;
    /// Solid-angle density with which `sample` draws `wi` (0 for a delta light).
    fn pdf(&self, wi: Vec3) -> f32;
    fn is_delta(&self) -> bool {
        false
    }
    /// A hint that `eval`/`eval_pdf` of `wi` follows soon: lights backed by large tables start
    /// loading the data from memory. No effect on results.
    #[inline]
    fn prefetch(&self, _wi: Vec3) {}
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
    #[inline]
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
    fn prefetch(&self, wi: Vec3) {
        dispatch!(self, l => l.prefetch(wi))
    }
    #[inline]
    fn prefetch_sample(&self, u: Vec2) {
        dispatch!(self, l => l.prefetch_sample(u))
    }
}

#[cfg(test)]
mod testutil;
