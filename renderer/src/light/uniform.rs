//! STUB: to be completed.
use super::{DistantLight, LightSample};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Uniform {
    pub radiance: Rgb,
}
impl Uniform {
    pub fn new(radiance: Rgb) -> Self {
        Uniform { radiance }
    }
}
impl DistantLight for Uniform {
    fn eval(&self, _wi: Vec3) -> Rgb {
        todo!()
    }
    fn sample(&self, _u: Vec2) -> Option<LightSample> {
        todo!()
    }
    fn pdf(&self, _wi: Vec3) -> f32 {
        todo!()
    }
}
