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

/// The closest primitive a ray meets, before any shading: what a BVH query gives (as Embree's
/// `rtcIntersect1` or pbrt-v4's `TriangleIntersection`), from [`SceneGeometry::intersect_primitive`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimitiveHit {
    /// Distance along the ray, in units of the ray's direction.
    pub t: f32,
    /// Barycentrics of the point on a triangle, p = v0 + b1 (v1 − v0) + b2 (v2 − v0), with the
    /// vertices in the mesh's order (`TriangleMesh::vertices`); zero for a sphere.
    pub b1: f32,
    pub b2: f32,
    /// Index of the object in the scene's object list.
    pub object: u32,
    /// The primitive's index inside its object: a mesh's triangle; 0 for a sphere.
    pub index: u32,
}

/// One object's shape.
#[derive(Clone, Debug)]
pub enum Shape {
    Sphere(Sphere),
    Mesh(TriangleMesh),
}

impl Shape {
    /// Its primitives in the BVH: 1 for a sphere, a mesh's triangles.
    pub fn primitive_count(&self) -> usize {
        match self {
            Shape::Sphere(_) => 1,
            Shape::Mesh(m) => m.triangles.len(),
        }
    }

    /// How far the shape reaches from the origin: the largest coordinate magnitude of its bounds
    /// (of the sphere's c ± r, of the mesh's vertices), in f64 so that it is finite for any finite
    /// input.
    pub fn reach(&self) -> f64 {
        match self {
            Shape::Sphere(s) => s.center.abs().max_element() as f64 + s.radius.abs() as f64,
            Shape::Mesh(m) => m.positions.iter().map(|p| p.abs().max_element() as f64).fold(0.0, f64::max),
        }
    }

    /// Refuses a shape that reaches beyond [`sphere::MAX_EXTENT`] from the origin, in one line that
    /// says what and how far. The limit bounds what single- and double-precision arithmetic derive
    /// from the shape: the sphere's hit points (see [`sphere`]), and the BVH's box areas and
    /// surface-area costs, Σ half-areas ≤ 2·primitives·3·(2·MAX_EXTENT)² < f32::MAX (obvhs's builder
    /// indexes out of bounds on an infinite cost).
    pub fn check_reach(&self) -> Result<(), String> {
        let reach = self.reach();
        if reach <= sphere::MAX_EXTENT as f64 {
            return Ok(());
        }
        let what = match self {
            Shape::Sphere(s) => format!("sphere (centre {:?}, radius {:e})", s.center.to_array(), s.radius),
            Shape::Mesh(m) => format!("mesh ({} triangles, after its transform)", m.triangles.len()),
        };
        Err(format!(
            "{what} reaches {reach:.3e} from the origin; the limit is {:e} (beyond it hit points cannot be placed \
             near the origin, even in double precision, and the BVH's box areas overflow single precision)",
            sphere::MAX_EXTENT
        ))
    }
}
