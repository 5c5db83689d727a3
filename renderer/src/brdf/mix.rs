//! STUB: to be completed.
use super::{BrdfSample, Bxdf};
#[allow(unused_imports)]
use super::Horizon;
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Mix {
    pub layers: Vec<(f32, super::Brdf)>,
}
impl Mix {
    pub fn new(layers: Vec<(f32, super::Brdf)>) -> Self {
        Mix { layers }
    }
}
impl Bxdf for Mix {
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
