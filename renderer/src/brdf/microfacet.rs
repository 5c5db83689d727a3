//! STUB: to be completed.
use super::{BrdfSample, Bxdf};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetDistribution {
    Beckmann,
    Ggx,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// F = 1.
    None,
    /// Schlick's approximation with normal-incidence reflectance F0.
    Schlick { f0: Rgb },
    /// Exact conductor Fresnel with complex index η + i k (per channel).
    Conductor { eta: Rgb, k: Rgb },
}

#[derive(Clone, Debug)]
pub struct Microfacet {
    pub distribution: MicrofacetDistribution,
    pub alpha: f32,
    pub fresnel: Fresnel,
}
impl Microfacet {
    pub fn new(distribution: MicrofacetDistribution, alpha: f32, fresnel: Fresnel) -> Self {
        Microfacet { distribution, alpha, fresnel }
    }
}
impl Bxdf for Microfacet {
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Rgb {
        todo!()
    }
    fn sample(&self, _wo: Vec3, _u_lobe: f32, _u: Vec2) -> Option<BrdfSample> {
        todo!()
    }
    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        todo!()
    }
}
