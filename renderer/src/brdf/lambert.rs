//! `lambert`: BRDF = albedo/π. STUB: to be completed.
use super::{BrdfSample, Bxdf};
use crate::math::{Rgb, Vec2, Vec3};

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
