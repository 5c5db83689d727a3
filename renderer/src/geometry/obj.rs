//! Wavefront OBJ loading (via `tobj`) into one [`TriangleMesh`].
//!
//! - All models (`o`/`g` groups) of the file are merged into one mesh; polygons are triangulated
//!   as fans; points and lines are ignored; materials are ignored.
//! - `smooth = false`: flat shading, `normals` left empty (the face normal is used).
//! - `smooth = true`: if every face has `vn` normals they are used (a vertex is split where one
//!   position carries different normals, e.g. at creases); otherwise angle-weighted vertex
//!   normals are computed ([`TriangleMesh::compute_smooth_normals`]).
//! - Errors (missing or unreadable file, parse error, index out of range, non-finite coordinate,
//!   no triangles) are returned as one-line [`crate::Error`]s naming the file; nothing panics.

use super::TriangleMesh;
use crate::math::Vec3;
use std::collections::HashMap;
use std::path::Path;

/// Loads all models of an OBJ file into one mesh. `smooth`: keep/compute vertex normals.
pub fn load_obj(path: &Path, smooth: bool) -> crate::Result<TriangleMesh> {
    let err = |msg: String| crate::Error::file(path, msg);
    if let Err(e) = std::fs::metadata(path) {
        return Err(err(format!("cannot open OBJ file: {e}")));
    }
    let options = tobj::LoadOptions { triangulate: true, single_index: false, ignore_points: true, ignore_lines: true };
    // Materials are irrelevant here (BRDFs come from the scene file); a missing .mtl is not an error.
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| err(format!("invalid OBJ: {e}")))?;

    let mut mesh = TriangleMesh::default();
    // Per-corner (position index, normal index) of the whole file, used for the smooth-with-normals case.
    let mut corner_normals: Vec<Vec3> = Vec::new();
    let mut corner_normal_idx: Vec<u32> = Vec::new();
    let mut all_have_normals = true;

    for model in &models {
        let m = &model.mesh;
        if !m.indices.len().is_multiple_of(3) {
            return Err(err(format!("model '{}' is not triangulated", model.name)));
        }
        let base = mesh.positions.len() as u32;
        let nv = (m.positions.len() / 3) as u32;
        mesh.positions.extend(m.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        for tri in m.indices.chunks_exact(3) {
            if let Some(&bad) = tri.iter().find(|&&k| k >= nv) {
                return Err(err(format!("model '{}': vertex index {bad} out of range ({nv} vertices)", model.name)));
            }
            mesh.triangles.push([base + tri[0], base + tri[1], base + tri[2]]);
        }
        let has_normals = !m.normals.is_empty() && m.normal_indices.len() == m.indices.len();
        all_have_normals &= has_normals;
        if smooth && has_normals {
            let nbase = corner_normals.len() as u32;
            let nn = (m.normals.len() / 3) as u32;
            corner_normals.extend(m.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
            for &k in &m.normal_indices {
                if k >= nn {
                    return Err(err(format!("model '{}': normal index {k} out of range ({nn} normals)", model.name)));
                }
                corner_normal_idx.push(nbase + k);
            }
        }
    }

    if mesh.triangles.is_empty() {
        return Err(err("OBJ file contains no triangles".into()));
    }
    mesh.validate().map_err(err)?;
    if let Some(i) = corner_normals.iter().position(|n| !n.is_finite()) {
        return Err(err(format!("normal {i} has a non-finite coordinate")));
    }

    if smooth {
        if all_have_normals {
            mesh = split_by_normals(&mesh, &corner_normals, &corner_normal_idx);
        } else {
            mesh.compute_smooth_normals();
        }
    }
    Ok(mesh)
}

/// Builds a mesh whose vertices are the distinct (position, normal) pairs of the triangle corners.
fn split_by_normals(mesh: &TriangleMesh, normals: &[Vec3], corner_normal_idx: &[u32]) -> TriangleMesh {
    let mut out = TriangleMesh::default();
    let mut map: HashMap<(u32, u32), u32> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let mut new_tri = [0u32; 3];
        for k in 0..3 {
            let key = (tri[k], corner_normal_idx[3 * t + k]);
            new_tri[k] = *map.entry(key).or_insert_with(|| {
                out.positions.push(mesh.positions[key.0 as usize]);
                out.normals.push(normals[key.1 as usize].normalize_or_zero());
                (out.positions.len() - 1) as u32
            });
        }
        out.triangles.push(new_tri);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_file(name: &str, content: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("reflect-geom-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let p = dir.join(name);
        std::fs::write(&p, content).expect("write temp file");
        p
    }

    /// A unit cube [0,1]³ as 6 quads (outward CCW), without normals.
    const CUBE: &str = "# cube\n\
        v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
        o cube\n\
        f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 2 3 7 6\nf 1 5 8 4\n";

    /// A tetrahedron with one normal per face (flat normals given explicitly) in two groups.
    const TETRA_VN: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n\
        vn 0 0 -1\nvn 0 -1 0\nvn -1 0 0\nvn 1 1 1\n\
        g a\nf 1//1 3//1 2//1\nf 1//2 2//2 4//2\n\
        g b\nf 1//3 4//3 3//3\nf 2//4 3//4 4//4\n";

    #[test]
    fn cube_flat_and_smooth() {
        let p = temp_file("cube.obj", CUBE);
        let flat = load_obj(&p, false).expect("load");
        assert_eq!(flat.triangles.len(), 12);
        assert!(flat.normals.is_empty());
        assert!((flat.signed_volume() - 1.0).abs() < 1e-6, "outward winding kept");
        let smooth = load_obj(&p, true).expect("load");
        assert_eq!(smooth.normals.len(), smooth.positions.len());
        // Corner (1,1,1): the angle-weighted normal of three perpendicular faces is (1,1,1)/√3.
        let i = smooth.positions.iter().position(|&v| v == Vec3::ONE).expect("corner");
        assert!((smooth.normals[i] - Vec3::ONE.normalize()).length() < 1e-6);
    }

    #[test]
    fn tetra_with_normals() {
        let p = temp_file("tetra.obj", TETRA_VN);
        let m = load_obj(&p, true).expect("load");
        assert_eq!(m.triangles.len(), 4);
        // Each corner carries its face's normal: 12 distinct (position, normal) pairs.
        assert_eq!(m.positions.len(), 12);
        for t in 0..4 {
            let ng = m.face_normal_area(t).normalize();
            for &k in &m.triangles[t] {
                assert!((m.normals[k as usize] - ng).length() < 1e-6, "file normals normalised and kept");
            }
        }
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-6);
        // Flat ignores the file normals.
        let f = load_obj(&p, false).expect("load");
        assert!(f.normals.is_empty() && f.triangles.len() == 4);
        assert!((f.signed_volume() - 1.0 / 6.0).abs() < 1e-6);
    }

    #[test]
    fn errors_name_the_file() {
        let missing = std::env::temp_dir().join("reflect-geom-obj-does-not-exist.obj");
        let e = load_obj(&missing, true).unwrap_err();
        assert!(e.to_string().contains("does-not-exist.obj"), "{e}");

        let cases = [
            ("garbage.obj", "v 1 2 x\nf 1 2 3\n"),
            ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"),
            ("empty.obj", "# nothing\nv 0 0 0\n"),
            ("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
        ];
        for (name, content) in cases {
            let p = temp_file(name, content);
            let e = load_obj(&p, false).expect_err(name);
            let s = e.to_string();
            assert!(s.contains(name) && !s.contains('\n'), "{s}");
        }
    }
}
