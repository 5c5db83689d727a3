//! STUB: to be completed.
use super::TriangleMesh;
use std::path::Path;

/// Loads all models of an OBJ file into one mesh. `smooth`: keep/compute vertex normals.
pub fn load_obj(_path: &Path, _smooth: bool) -> crate::Result<TriangleMesh> {
    todo!()
}
