//! Geometry: analytic spheres and triangle meshes, all in one BVH ([`SceneGeometry`]).

pub mod bvh;
pub mod gltf;
pub mod icosphere;
pub mod mesh;
pub mod obj;
pub mod shading;
pub mod sphere;

pub use bvh::SceneGeometry;
pub use icosphere::icosphere;
pub use mesh::TriangleMesh;
pub use sphere::Sphere;

use crate::math::Vec3;

/// A ray o + t d, t ∈ (0, t_max). `dir` is unit length.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray { origin, dir, t_max: f32::INFINITY }
    }
}

/// The closest intersection of a ray with the scene.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub p: Vec3,
    /// Shading normal (interpolated for smooth meshes), unit, facing the side the ray came from
    /// is *not* enforced: meshes of closed convex objects have outward normals.
    pub n: Vec3,
    /// Geometric normal, unit, outward.
    pub ng: Vec3,
    /// Index of the object in the scene's object list.
    pub object: u32,
}

/// One object's shape.
#[derive(Clone, Debug)]
pub enum Shape {
    Sphere(Sphere),
    Mesh(TriangleMesh),
}
