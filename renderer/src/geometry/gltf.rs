//! STUB: to be completed.
use super::TriangleMesh;
use std::path::Path;

/// Loads every triangle primitive of a glTF/GLB scene (node transforms applied) into one mesh.
pub fn load_gltf(_path: &Path, _smooth: bool) -> crate::Result<TriangleMesh> {
    todo!()
}
