//! STUB: to be completed.
use super::{DistantLight, LightSample};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Directional {
    /// Unit direction toward the source.
    pub direction: Vec3,
    /// Irradiance on a surface perpendicular to `direction`.
    pub irradiance: Rgb,
}
impl Directional {
    pub fn new(direction: Vec3, irradiance: Rgb) -> Self {
        Directional { direction: direction.normalize(), irradiance }
    }
}
impl DistantLight for Directional {
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
