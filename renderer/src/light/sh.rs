//! STUB: to be completed.
use super::{DistantLight, LightSample};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct ShLight {
    /// L_lm in flat index order k = l(l+1) + m (CONVENTIONS §3).
    pub coefficients: Vec<Rgb>,
}
impl ShLight {
    pub fn new(coefficients: Vec<Rgb>) -> Self {
        ShLight { coefficients }
    }
}
impl DistantLight for ShLight {
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
