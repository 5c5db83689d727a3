//! STUB: to be completed.
use super::TriangleMesh;

/// A unit-radius icosphere centred at the origin with `subdivisions` levels (20·4^n triangles).
pub fn icosphere(_subdivisions: u32) -> TriangleMesh {
    todo!()
}
