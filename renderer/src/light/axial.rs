//! STUB: to be completed.
use super::{DistantLight, LightSample};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Axial {
    pub axis: Vec3,
    /// Profile: (θ in radians from the axis, radiance), θ increasing from 0 to π; linear in between.
    pub profile: Vec<(f32, Rgb)>,
}
impl Axial {
    pub fn new(axis: Vec3, profile: Vec<(f32, Rgb)>) -> Self {
        Axial { axis: axis.normalize(), profile }
    }
}
impl DistantLight for Axial {
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
