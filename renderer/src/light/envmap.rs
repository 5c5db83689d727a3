//! STUB: to be completed.
use super::{DistantLight, LightSample};
use crate::math::{Rgb, Vec2, Vec3};
use analysis::image::RgbImage;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mapping {
    LatLong,
    Angular,
}

#[derive(Clone, Debug)]
pub struct Envmap {
    pub image: RgbImage,
    pub mapping: Mapping,
    pub scale: f32,
    /// Applied to the map's directions (CONVENTIONS §6 `rotate_deg`): world = rotation · map.
    pub rotation: glam::Mat3,
}
impl Envmap {
    pub fn new(image: RgbImage, mapping: Mapping, scale: f32, rotation: glam::Mat3) -> crate::Result<Self> {
        Ok(Envmap { image, mapping, scale, rotation })
    }
}
impl DistantLight for Envmap {
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
