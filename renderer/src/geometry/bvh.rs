//! STUB: to be completed.
use super::{Hit, Ray, Shape};

pub struct SceneGeometry {
    pub shapes: Vec<Shape>,
}
impl SceneGeometry {
    /// Builds the BVH over all objects; `shapes[i]` is object i.
    pub fn new(shapes: Vec<Shape>) -> Self {
        SceneGeometry { shapes }
    }
    /// Closest hit with t in (0, ray.t_max).
    pub fn intersect(&self, _ray: &Ray) -> Option<Hit> {
        todo!()
    }
    /// Any hit with t in (0, ray.t_max).
    pub fn occluded(&self, _ray: &Ray) -> bool {
        todo!()
    }
}

impl SceneGeometry {
    /// True when the scene is exactly one sphere (no occlusion above any hit's horizon).
    pub fn is_single_sphere(&self) -> bool {
        self.shapes.len() == 1 && matches!(self.shapes[0], super::Shape::Sphere(_))
    }
}
