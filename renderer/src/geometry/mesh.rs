//! STUB: to be completed.
use crate::math::Vec3;

/// An indexed triangle mesh. `normals` is empty for flat shading or has one unit normal per vertex.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    pub fn transform(&mut self, _m: glam::Affine3A) {
        todo!()
    }
}
