//! glTF 2.0 loading (`.gltf` with embedded or external buffers, and binary `.glb`) into one
//! [`TriangleMesh`], using the `gltf` crate.
//!
//! - Scene: the default scene (or the first one); every node is visited from the scene roots and
//!   its world transform is the product of the local TRS/matrix transforms along the parent chain.
//! - Every primitive with mode `Triangles` of every visited node's mesh is transformed to world
//!   space ([`TriangleMesh::transform`]: normals by the inverse transpose, winding flipped by
//!   mirroring transforms) and appended. Other modes (points, lines, strips, fans) are skipped.
//! - `smooth = false`: flat (no normals). `smooth = true`: the primitive's NORMAL attribute if
//!   present, else angle-weighted normals computed in world space.
//! - Images are not decoded (only buffers are imported). Every accessor range is checked against
//!   its buffer before reading, and indices against the vertex count, so a malformed file gives a
//!   one-line [`crate::Error`] naming the file instead of a panic.

use super::TriangleMesh;
use crate::math::Vec3;
use glam::{Affine3A, Mat4};
use std::path::Path;

/// Maximum node nesting depth (guards against cyclic node graphs in malformed files).
const MAX_DEPTH: usize = 256;

/// Loads every triangle primitive of a glTF/GLB scene (node transforms applied) into one mesh.
pub fn load_gltf(path: &Path, smooth: bool) -> crate::Result<TriangleMesh> {
    let err = |msg: String| crate::Error::file(path, msg);
    let gltf = gltf::Gltf::open(path).map_err(|e| err(format!("cannot read glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = gltf::import_buffers(&gltf.document, Some(base), gltf.blob)
        .map_err(|e| err(format!("cannot load glTF buffers: {e}")))?;
    let doc = &gltf.document;
    check_accessors(doc, &buffers).map_err(err)?;

    let scene =
        doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| err("glTF file has no scene".into()))?;
    let mut out = TriangleMesh::default();
    for node in scene.nodes() {
        visit(&node, Mat4::IDENTITY, 0, &buffers, smooth, &mut out).map_err(err)?;
    }
    if out.triangles.is_empty() {
        return Err(err("glTF scene contains no triangles".into()));
    }
    out.validate().map_err(err)?;
    if !smooth {
        out.normals.clear();
    }
    Ok(out)
}

/// Appends the triangle primitives of `node` and its descendants; `parent` is the parent's world
/// transform.
fn visit(
    node: &gltf::Node,
    parent: Mat4,
    depth: usize,
    buffers: &[gltf::buffer::Data],
    smooth: bool,
    out: &mut TriangleMesh,
) -> Result<(), String> {
    if depth > MAX_DEPTH {
        return Err(format!("node hierarchy deeper than {MAX_DEPTH} (cycle?)"));
    }
    let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
    if !world.is_finite() {
        return Err(format!("node {} has a non-finite transform", node.index()));
    }
    if let Some(mesh) = node.mesh() {
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let mut part = read_primitive(&prim, buffers, smooth)
                .map_err(|e| format!("mesh {} primitive {}: {e}", mesh.index(), prim.index()))?;
            part.transform(Affine3A::from_mat4(world));
            if smooth && part.normals.is_empty() {
                part.compute_smooth_normals();
            }
            append(out, part);
        }
    }
    for child in node.children() {
        visit(&child, world, depth + 1, buffers, smooth, out)?;
    }
    Ok(())
}

/// Reads positions, indices (or the implicit 0..n) and, if `smooth`, normals of one primitive.
fn read_primitive(
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    smooth: bool,
) -> Result<TriangleMesh, String> {
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<Vec3> = reader.read_positions().ok_or("no POSITION attribute")?.map(Vec3::from_array).collect();
    let n = positions.len() as u32;
    let indices: Vec<u32> = match reader.read_indices() {
        Some(ix) => ix.into_u32().collect(),
        None => (0..n).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(format!("{} indices is not a multiple of 3", indices.len()));
    }
    if let Some(&bad) = indices.iter().find(|&&k| k >= n) {
        return Err(format!("vertex index {bad} out of range ({n} vertices)"));
    }
    let triangles = indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut normals = Vec::new();
    if smooth && let Some(ns) = reader.read_normals() {
        normals = ns.map(|v| Vec3::from_array(v).normalize_or_zero()).collect();
        if normals.len() != positions.len() {
            return Err(format!("{} normals for {} vertices", normals.len(), positions.len()));
        }
    }
    Ok(TriangleMesh { positions, normals, triangles })
}

/// Appends `part` to `out`. Normals stay one per vertex: with `smooth` every part has them
/// (read or computed), without it none has.
fn append(out: &mut TriangleMesh, part: TriangleMesh) {
    let base = out.positions.len() as u32;
    out.positions.extend_from_slice(&part.positions);
    out.normals.extend_from_slice(&part.normals);
    out.triangles.extend(part.triangles.iter().map(|t| t.map(|k| k + base)));
}

/// Verifies that every accessor's byte range lies inside its buffer view and every view inside its
/// buffer, so that reading cannot index out of bounds.
fn check_accessors(doc: &gltf::Document, buffers: &[gltf::buffer::Data]) -> Result<(), String> {
    for view in doc.views() {
        let len = buffers.get(view.buffer().index()).map_or(0, |b| b.0.len());
        if view.offset().checked_add(view.length()).is_none_or(|end| end > len) {
            return Err(format!("buffer view {} exceeds its buffer ({len} bytes)", view.index()));
        }
    }
    for acc in doc.accessors() {
        let Some(view) = acc.view() else { continue };
        if acc.count() == 0 {
            continue;
        }
        let stride = view.stride().unwrap_or(acc.size());
        let end = (acc.count() - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(acc.offset()))
            .and_then(|x| x.checked_add(acc.size()));
        if end.is_none_or(|end| end > view.length()) {
            return Err(format!("accessor {} exceeds buffer view {}", acc.index(), view.index()));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir() -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("reflect-geom-gltf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        dir
    }

    fn base64(bytes: &[u8]) -> String {
        const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in bytes.chunks(3) {
            let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
            let v = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
            for k in 0..4 {
                if k <= c.len() {
                    s.push(A[(v >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    s.push('=');
                }
            }
        }
        s
    }

    /// Tetrahedron (0,0,0),(1,0,0),(0,1,0),(0,0,1): positions (48 B), normals (48 B, the corner
    /// normals of the unit directions), u16 indices (24 B).
    fn tetra_buffer() -> Vec<u8> {
        let p: [f32; 12] = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.];
        let n: [f32; 12] = [-1., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1.];
        let idx: [u16; 12] = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
        let mut b = Vec::new();
        p.iter().chain(n.iter()).for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
        idx.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
        b
    }

    /// glTF JSON: node 0 (parent: translation (0,0,5), scale 2) has child node 1 (translation
    /// (1,0,0), mesh 0). A second scene-less node 2 is not in the scene and must be ignored.
    fn tetra_json(uri: Option<&str>, max_index: u32) -> String {
        let uri = uri.map(|u| format!(r#""uri": "{u}", "#)).unwrap_or_default();
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"translation": [0, 0, 5], "scale": [2, 2, 2], "children": [1]}},
    {{"translation": [1, 0, 0], "mesh": 0}},
    {{"mesh": 0}}
  ],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 2}}]}}],
  "buffers": [{{{uri}"byteLength": 120}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 96}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 24}}
  ],
  "accessors": [
    {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]}},
    {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR", "max": [{max_index}], "min": [0]}}
  ]
}}"#
        )
    }

    fn expected_world(v: Vec3) -> Vec3 {
        2.0 * (v + Vec3::X) + Vec3::new(0.0, 0.0, 5.0)
    }

    fn check_tetra(m: &TriangleMesh, smooth: bool) {
        assert_eq!(m.triangles.len(), 4);
        assert_eq!(m.positions.len(), 4);
        let local = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        for (p, l) in m.positions.iter().zip(local) {
            assert!((*p - expected_world(l)).length() < 1e-6, "{p} vs {}", expected_world(l));
        }
        // Uniform scale 2: volume × 8, winding still outward.
        assert!((m.signed_volume() - 8.0 / 6.0).abs() < 1e-5);
        if smooth {
            // Uniform scale and translation leave the file's normals unchanged.
            assert_eq!(m.normals.len(), 4);
            assert!((m.normals[0] + Vec3::X).length() < 1e-6 && (m.normals[3] - Vec3::Z).length() < 1e-6);
        } else {
            assert!(m.normals.is_empty());
        }
    }

    #[test]
    fn embedded_external_and_glb() {
        let dir = temp_dir();
        let buf = tetra_buffer();
        // Embedded base64 data URI.
        let uri = format!("data:application/octet-stream;base64,{}", base64(&buf));
        let p = dir.join("tetra_embedded.gltf");
        std::fs::write(&p, tetra_json(Some(&uri), 3)).expect("write");
        check_tetra(&load_gltf(&p, true).expect("embedded"), true);
        check_tetra(&load_gltf(&p, false).expect("embedded flat"), false);
        // External .bin.
        std::fs::write(dir.join("tetra.bin"), &buf).expect("write");
        let p = dir.join("tetra_external.gltf");
        std::fs::write(&p, tetra_json(Some("tetra.bin"), 3)).expect("write");
        check_tetra(&load_gltf(&p, true).expect("external"), true);
        // GLB: header, JSON chunk (space-padded), BIN chunk.
        let mut json = tetra_json(None, 3).into_bytes();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let total = 12 + 8 + json.len() + 8 + buf.len();
        let mut glb = Vec::new();
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&(total as u32).to_le_bytes());
        glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.extend_from_slice(&json);
        glb.extend_from_slice(&(buf.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"BIN\0");
        glb.extend_from_slice(&buf);
        let p = dir.join("tetra.glb");
        std::fs::write(&p, glb).expect("write");
        check_tetra(&load_gltf(&p, true).expect("glb"), true);
    }

    #[test]
    fn smooth_without_normals_computes_them() {
        let dir = temp_dir();
        let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
        let json = tetra_json(Some(&uri), 3).replace(r#", "NORMAL": 1"#, "");
        let p = dir.join("tetra_nonormals.gltf");
        std::fs::write(&p, json).expect("write");
        let m = load_gltf(&p, true).expect("load");
        // Corner at the (transformed) origin: angle-weighted normal −(1,1,1)/√3.
        assert!((m.normals[0] + Vec3::ONE.normalize()).length() < 1e-6);
    }

    #[test]
    fn errors_name_the_file() {
        let dir = temp_dir();
        let missing = dir.join("nope.gltf");
        assert!(load_gltf(&missing, true).unwrap_err().to_string().contains("nope.gltf"));

        let garbage = dir.join("garbage.gltf");
        std::fs::write(&garbage, "{ this is not json").expect("write");
        let e = load_gltf(&garbage, true).unwrap_err().to_string();
        assert!(e.contains("garbage.gltf") && !e.contains('\n'), "{e}");

        // Index 7 with 4 vertices.
        let mut buf = tetra_buffer();
        buf[96 + 2 * 11] = 7;
        let uri = format!("data:application/octet-stream;base64,{}", base64(&buf));
        let p = dir.join("badindex.gltf");
        std::fs::write(&p, tetra_json(Some(&uri), 7)).expect("write");
        let e = load_gltf(&p, true).unwrap_err().to_string();
        assert!(e.contains("badindex.gltf") && e.contains("out of range"), "{e}");

        // Missing external buffer.
        let p = dir.join("nobin.gltf");
        std::fs::write(&p, tetra_json(Some("missing.bin"), 3)).expect("write");
        assert!(load_gltf(&p, true).unwrap_err().to_string().contains("nobin.gltf"));

        // Accessor overrunning its view.
        let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
        let json = tetra_json(Some(&uri), 3).replace(r#""count": 12"#, r#""count": 30"#);
        let p = dir.join("overrun.gltf");
        std::fs::write(&p, json).expect("write");
        let e = load_gltf(&p, true).unwrap_err().to_string();
        assert!(e.contains("overrun.gltf"), "{e}");
    }
}
