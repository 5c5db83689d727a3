//! STUB: to be completed.
use super::{BrdfSample, Bxdf};
#[allow(unused_imports)]
use super::Horizon;
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Phong {
    pub ks: Rgb,
    pub s: f32,
    pub horizon: Horizon,
}
impl Phong {
    pub fn new(ks: Rgb, s: f32, horizon: Horizon) -> Self {
        Phong { ks, s, horizon }
    }
}
impl Bxdf for Phong {
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
