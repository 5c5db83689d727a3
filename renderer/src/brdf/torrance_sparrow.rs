//! STUB: to be completed.
use super::{BrdfSample, Bxdf};
#[allow(unused_imports)]
use super::Horizon;
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct TorranceSparrow {
    pub ks: Rgb,
    pub sigma: f32,
    pub horizon: Horizon,
}
impl TorranceSparrow {
    pub fn new(ks: Rgb, sigma: f32, horizon: Horizon) -> Self {
        TorranceSparrow { ks, sigma, horizon }
    }
}
impl Bxdf for TorranceSparrow {
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
