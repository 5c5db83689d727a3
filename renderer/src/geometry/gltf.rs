//! glTF 2.0 loading (`.gltf` with embedded or external buffers, and binary `.glb`) into one
//! [`TriangleMesh`]. The `gltf` crate parses and validates the JSON (references, enums); buffers
//! and accessors are read here, because every byte range, component type and count must be checked
//! before it is used (the crate's readers panic or hit `unreachable!` on some invalid files).
//!
//! What is read (glTF 2.0 specification, §3.6 "Accessors", §3.7.2 "Meshes"):
//! - Scene: the default scene (or the first one). The node hierarchy must be disjoint trees
//!   (§3.5.3): a node listed as a child twice, by two parents, by itself, a cycle, or a scene root
//!   that is someone's child is refused before any mesh is read, naming the node.
//! - Every node's world transform is the product of the local TRS/matrix transforms along its
//!   parent chain; mesh data is transformed to world space ([`TriangleMesh::transform`]: normals
//!   by the inverse transpose, winding flipped by mirroring transforms).
//! - Primitive modes TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN are triangulated exactly as
//!   §3.7.2.1 defines (strip triangle i = (v_i, v_{i+1+i%2}, v_{i+2−i%2}), so the winding of strips
//!   alternates; fan triangle i = (v_{i+1}, v_{i+2}, v_0)). POINTS, LINES, LINE_LOOP and LINE_STRIP
//!   are not surfaces: skipped with a warning naming mesh and primitive.
//! - Indices: unsigned byte, unsigned short or unsigned int (any other component type is refused,
//!   naming the accessor and its type); absent indices mean 0..n.
//! - POSITION (VEC3) and, with `smooth`, NORMAL (VEC3): float; with the `KHR_mesh_quantization`
//!   extension declared, also (normalized) byte/short types as that extension lists. An integer
//!   type without the extension is refused naming the accessor, its type and the extension.
//!   Normalized integers are decoded as the specification defines (c/127 clamped to −1, c/255, …).
//! - Sparse accessors and accessors without a buffer view (zeros) are read.
//! - `smooth = false`: flat (no normals). `smooth = true`: the primitive's NORMAL attribute if
//!   present, else angle-weighted normals of the primitive, computed in world space.
//! - Buffers: the GLB binary chunk, base64 `data:` URIs, or files relative to the glTF file (no
//!   absolute paths, no other URI schemes, regular files only, at most `byteLength` bytes read).
//!   Images are never decoded.
//!
//! Limits: at most [`MAX_TRIANGLES`] instantiated triangles (counted from the accessors before any
//! is read, so a small file instancing a large mesh many times is refused at once); an accessor
//! without a buffer view may hold at most [`MAX_VIEWLESS_BYTES`]. Every other allocation is bounded
//! by the bytes of the file and its buffers. Every failure is a one-line [`crate::Error`] naming the
//! file.

use super::TriangleMesh;
use crate::math::Vec3;
use glam::{Affine3A, Mat4};
use gltf::json;
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;
use gltf::mesh::Mode;
use std::io::Read;
use std::path::Path;

/// Largest number of triangles a glTF scene may instantiate (counting every node that uses a mesh).
pub const MAX_TRIANGLES: usize = 1 << 24;

/// Largest size of an accessor that has no buffer view (its elements start as zeros), in bytes of
/// its elements: such an accessor's size is not backed by any data in the file.
pub const MAX_VIEWLESS_BYTES: usize = 1 << 24;

/// The extension that allows integer positions and normals.
const QUANTIZATION: &str = "KHR_mesh_quantization";

/// Loads every triangle primitive of a glTF/GLB scene (node transforms applied) into one mesh.
/// Warnings (skipped primitives, orientation problems) are printed to stderr, one line each,
/// naming the file.
pub fn load_gltf(path: &Path, smooth: bool) -> crate::Result<TriangleMesh> {
    let (mesh, warnings) = load_gltf_with_warnings(path, smooth)?;
    for w in warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(mesh)
}

/// [`load_gltf`] returning the warnings (without the file name) instead of printing them.
pub fn load_gltf_with_warnings(path: &Path, smooth: bool) -> crate::Result<(TriangleMesh, Vec<String>)> {
    let err = |msg: String| crate::Error::file(path, msg);
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read glTF file: {e}")))?;
    // Parsed without validation first: the crate's validation itself indexes the POSITION
    // accessor before checking that it exists.
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| err(gltf_error(e)))?;
    check_position_references(gltf.document.as_json()).map_err(err)?;
    let mut json = gltf.document.into_json();
    // Required extensions are judged here, not by the crate (which refuses any it does not
    // implement): only those that change how geometry is stored matter to a geometry loader.
    check_required_extensions(&json.extensions_required).map_err(err)?;
    json.extensions_required.clear();
    let document = gltf::Document::from_json(json).map_err(|e| err(gltf_error(e)))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&document, base, gltf.blob).map_err(err)?;
    let mut warnings = Vec::new();
    let mut mesh = build(&document, &buffers, smooth, &mut warnings).map_err(err)?;
    mesh.validate().map_err(err)?;
    if !smooth {
        mesh.normals.clear();
    }
    warnings.extend(mesh.orientation_warnings());
    Ok((mesh, warnings))
}

/// Every primitive's POSITION attribute must name an existing accessor (checked before the crate's
/// validation, which would index out of bounds).
fn check_position_references(root: &json::Root) -> Result<(), String> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, acc) in &prim.attributes {
                if acc.value() >= root.accessors.len() {
                    let name = match semantic {
                        Checked::Valid(s) => s.to_string(),
                        Checked::Invalid => "an invalid attribute".into(),
                    };
                    return Err(format!(
                        "mesh {m} primitive {p}: {name} refers to accessor {}, which does not exist",
                        acc.value()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Refuses the required extensions that store geometry in a way this loader cannot read (mesh
/// compression); `KHR_mesh_quantization` is read, and the others (materials, textures, lights…)
/// do not change the geometry.
fn check_required_extensions(required: &[String]) -> Result<(), String> {
    for ext in required {
        if ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" {
            return Err(format!("the file requires the extension {ext}, which is not supported (compressed meshes)"));
        }
    }
    Ok(())
}

/// One line for a parse/validation error of the `gltf` crate (its validation error lists every
/// problem; the first is enough to act on).
fn gltf_error(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) => match list.first() {
            Some((path, error)) => {
                let more =
                    if list.len() > 1 { format!(" (and {} more problems)", list.len() - 1) } else { String::new() };
                format!("invalid glTF: {path}: {error}{more}")
            }
            None => "invalid glTF".into(),
        },
        e => format!("cannot parse glTF: {e}"),
    }
}

/// Reads every buffer: the GLB binary chunk, a base64 `data:` URI, or a file relative to `base`.
/// Each is checked to hold at least its `byteLength` bytes and cut to that length.
fn load_buffers(doc: &gltf::Document, base: &Path, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for (i, b) in doc.as_json().buffers.iter().enumerate() {
        let need = usize::try_from(b.byte_length.0).map_err(|_| format!("buffer {i}: byteLength too large"))?;
        let mut data = match b.uri.as_deref() {
            None => {
                blob.take().ok_or_else(|| format!("buffer {i} has no uri and there is no (other) GLB binary chunk"))?
            }
            Some(uri) if uri.starts_with("data:") => decode_data_uri(uri).map_err(|e| format!("buffer {i}: {e}"))?,
            Some(uri) => read_relative(base, uri, need).map_err(|e| format!("buffer {i} ({uri:?}): {e}"))?,
        };
        if data.len() < need {
            return Err(format!("buffer {i} holds {} bytes but its byteLength is {need}", data.len()));
        }
        data.truncate(need);
        out.push(data);
    }
    Ok(out)
}

/// Decodes `data:[<media type>];base64,<data>` (RFC 2397).
fn decode_data_uri(uri: &str) -> Result<Vec<u8>, String> {
    use base64::Engine;
    let (head, data) = uri.split_once(',').ok_or("data URI without a comma")?;
    if !head.ends_with(";base64") {
        return Err("data URI is not base64-encoded".into());
    }
    let engine = base64::engine::GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        base64::engine::GeneralPurposeConfig::new()
            .with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent),
    );
    engine.decode(data.trim()).map_err(|e| format!("invalid base64 data URI: {e}"))
}

/// Reads at most `limit` bytes of the regular file at the percent-decoded relative `uri`.
fn read_relative(base: &Path, uri: &str, limit: usize) -> Result<Vec<u8>, String> {
    if uri.contains(':') {
        return Err("unsupported URI scheme (only relative paths and base64 data URIs are read)".into());
    }
    let decoded = percent_decode(uri)?;
    let rel = Path::new(&decoded);
    if rel.is_absolute() {
        return Err("absolute paths are not allowed in glTF URIs".into());
    }
    let p = base.join(rel);
    let file = std::fs::File::open(&p).map_err(|e| format!("cannot open {}: {e}", p.display()))?;
    let meta = file.metadata().map_err(|e| format!("cannot read {}: {e}", p.display()))?;
    if !meta.is_file() {
        return Err(format!("{} is not a regular file", p.display()));
    }
    let cap = (meta.len() as usize).min(limit);
    let mut data = Vec::with_capacity(cap);
    file.take(limit as u64).read_to_end(&mut data).map_err(|e| format!("cannot read {}: {e}", p.display()))?;
    Ok(data)
}

/// `%XX` decoding of a URI path (RFC 3986); the result must be UTF-8.
fn percent_decode(s: &str) -> Result<String, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            let v = hex.and_then(|h| u8::from_str_radix(h, 16).ok()).ok_or("invalid percent-encoding in URI")?;
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "URI is not UTF-8 after percent-decoding".into())
}

/// Checks that the node hierarchy is a set of disjoint trees (glTF 2.0 §3.5.3) and that the scene's
/// roots are roots, listed once. Returns each node's parent.
fn check_node_graph(root: &json::Root, scene: usize) -> Result<Vec<Option<usize>>, String> {
    let n = root.nodes.len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for (p, node) in root.nodes.iter().enumerate() {
        for c in node.children.iter().flatten().map(|c| c.value()) {
            if c >= n {
                return Err(format!("node {p} lists child {c}, which does not exist"));
            }
            if c == p {
                return Err(format!("node {p} lists itself as a child (the node hierarchy must be disjoint trees)"));
            }
            match parent[c] {
                Some(q) if q == p => {
                    return Err(format!(
                        "node {c} is listed twice as a child of node {p} (the node hierarchy must be disjoint trees)"
                    ));
                }
                Some(q) => {
                    return Err(format!(
                        "node {c} has more than one parent (nodes {q} and {p}; the node hierarchy must be disjoint trees)"
                    ));
                }
                None => parent[c] = Some(p),
            }
        }
    }
    // With at most one parent per node, a cycle is a parent chain that returns to itself.
    let mut state = vec![0u8; n]; // 0: unseen, 1: on the chain being followed, 2: known to reach a root
    for start in 0..n {
        let mut chain = Vec::new();
        let mut k = start;
        loop {
            match state[k] {
                2 => break,
                1 => return Err(format!("node {k} is its own ancestor (a cycle in the node hierarchy)")),
                _ => {}
            }
            state[k] = 1;
            chain.push(k);
            match parent[k] {
                Some(p) => k = p,
                None => break,
            }
        }
        for c in chain {
            state[c] = 2;
        }
    }
    let roots: Vec<usize> = root.scenes[scene].nodes.iter().map(|r| r.value()).collect();
    let mut listed = vec![false; n];
    for &r in &roots {
        if r >= n {
            return Err(format!("scene {scene} lists node {r}, which does not exist"));
        }
        if let Some(p) = parent[r] {
            return Err(format!("scene {scene} lists node {r} as a root, but it is a child of node {p}"));
        }
        if std::mem::replace(&mut listed[r], true) {
            return Err(format!("scene {scene} lists node {r} twice"));
        }
    }
    Ok(parent)
}

/// Number of triangles a primitive of `mode` with `n` vertices (indices) makes.
fn triangle_count(mode: Mode, n: usize) -> usize {
    match mode {
        Mode::Triangles => n / 3,
        Mode::TriangleStrip | Mode::TriangleFan => n.saturating_sub(2),
        _ => 0,
    }
}

/// Walks the default scene and assembles the world-space mesh.
fn build(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    smooth: bool,
    warnings: &mut Vec<String>,
) -> Result<TriangleMesh, String> {
    let root = doc.as_json();
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or("glTF file has no scene")?;
    check_node_graph(root, scene.index())?;
    let quantized = root.extensions_used.iter().any(|e| e == QUANTIZATION);

    // Instances (node, world transform) in depth-first order: each node once, the graph is a forest.
    let mut instances: Vec<(gltf::Node, Mat4)> = Vec::new();
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            return Err(format!("node {} has a non-finite transform", node.index()));
        }
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
        // A node scaled to zero (a common way to hide an object) has no area to render, and its
        // normal matrix would not exist.
        if node.mesh().is_some() && glam::Mat3::from_mat4(world).determinant() != 0.0 {
            instances.push((node, world));
        }
    }

    // Count before reading: a small file may instance a large mesh many times.
    let mut total = 0usize;
    for (node, _) in &instances {
        for prim in node.mesh().into_iter().flat_map(|m| m.primitives().collect::<Vec<_>>()) {
            let n = match (prim.indices(), prim.get(&gltf::Semantic::Positions)) {
                (Some(ix), _) => ix.count(),
                (None, Some(pos)) => pos.count(),
                (None, None) => 0,
            };
            total = total.saturating_add(triangle_count(prim.mode(), n));
        }
        if total > MAX_TRIANGLES {
            return Err(format!("the scene instantiates more than {MAX_TRIANGLES} triangles (the limit)"));
        }
    }

    // Read each primitive once (in local space), instance it per node.
    let mut cache: std::collections::HashMap<(usize, usize), Option<TriangleMesh>> = Default::default();
    let mut out = TriangleMesh::default();
    for (node, world) in &instances {
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            let key = (mesh.index(), prim.index());
            let part = match cache.entry(key) {
                std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                std::collections::hash_map::Entry::Vacant(e) => {
                    let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
                    e.insert(read_primitive(root, &prim, buffers, smooth, quantized, &what, warnings)?)
                }
            };
            let Some(part) = part else { continue };
            let mut part = part.clone();
            part.transform(Affine3A::from_mat4(*world));
            if smooth && part.normals.is_empty() {
                part.compute_smooth_normals();
            }
            append(&mut out, part);
        }
    }
    if out.triangles.is_empty() {
        return Err("glTF scene contains no triangles".into());
    }
    Ok(out)
}

/// Reads one primitive in its local space: positions, triangulated indices and, with `smooth`, the
/// file's normals. `None` for a primitive that is not a surface (skipped with a warning).
fn read_primitive(
    root: &json::Root,
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
    smooth: bool,
    quantized: bool,
    what: &str,
    warnings: &mut Vec<String>,
) -> Result<Option<TriangleMesh>, String> {
    let mode = prim.mode();
    if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
        warnings.push(format!("{what} has mode {mode:?}, which is not a surface; skipped"));
        return Ok(None);
    }
    let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
        warnings.push(format!("{what} has no POSITION attribute; skipped"));
        return Ok(None);
    };
    let pos_role = format!("POSITION of {what}");
    let positions = read_vec3(root, pos.index(), buffers, Attribute::Position, quantized, &pos_role)?;
    let n = positions.len();
    let indices: Vec<u32> = match prim.indices() {
        Some(ix) => read_indices(root, ix.index(), buffers, &format!("indices of {what}"))?,
        None => (0..n as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&k| k as usize >= n) {
        return Err(format!("{what}: vertex index {bad} out of range ({n} vertices)"));
    }
    if mode == Mode::Triangles && !indices.len().is_multiple_of(3) {
        return Err(format!("{what}: {} indices is not a multiple of 3 (mode TRIANGLES)", indices.len()));
    }
    let triangles = triangulate(mode, &indices);
    let mut normals = Vec::new();
    if smooth && let Some(nacc) = prim.get(&gltf::Semantic::Normals) {
        let role = format!("NORMAL of {what}");
        normals = read_vec3(root, nacc.index(), buffers, Attribute::Normal, quantized, &role)?
            .into_iter()
            .map(Vec3::normalize_or_zero)
            .collect();
        if normals.len() != n {
            return Err(format!("{what}: {} normals for {n} positions", normals.len()));
        }
    }
    Ok(Some(compact(TriangleMesh { positions, normals, triangles })))
}

/// Keeps only the vertices the triangles use, so that instancing a primitive copies at most three
/// vertices per triangle (the triangle limit then bounds the vertices too).
fn compact(m: TriangleMesh) -> TriangleMesh {
    let mut remap = vec![u32::MAX; m.positions.len()];
    let mut out = TriangleMesh { triangles: Vec::with_capacity(m.triangles.len()), ..Default::default() };
    for t in &m.triangles {
        let t = t.map(|k| {
            let r = &mut remap[k as usize];
            if *r == u32::MAX {
                *r = out.positions.len() as u32;
                out.positions.push(m.positions[k as usize]);
                if !m.normals.is_empty() {
                    out.normals.push(m.normals[k as usize]);
                }
            }
            *r
        });
        out.triangles.push(t);
    }
    out
}

/// Triangles of a primitive (glTF 2.0 §3.7.2.1), dropping those that repeat a vertex (strips use
/// them to stitch and they have no area).
fn triangulate(mode: Mode, ix: &[u32]) -> Vec<[u32; 3]> {
    let n = ix.len();
    let tris: Vec<[u32; 3]> = match mode {
        Mode::Triangles => ix.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => {
            (0..n.saturating_sub(2)).map(|i| [ix[i], ix[i + 1 + i % 2], ix[i + 2 - i % 2]]).collect()
        }
        Mode::TriangleFan => (0..n.saturating_sub(2)).map(|i| [ix[i + 1], ix[i + 2], ix[0]]).collect(),
        _ => Vec::new(),
    };
    tris.into_iter().filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0]).collect()
}

#[derive(Clone, Copy, PartialEq)]
enum Attribute {
    Position,
    Normal,
}

fn type_name(c: ComponentType) -> &'static str {
    match c {
        ComponentType::I8 => "signed byte (5120)",
        ComponentType::U8 => "unsigned byte (5121)",
        ComponentType::I16 => "signed short (5122)",
        ComponentType::U16 => "unsigned short (5123)",
        ComponentType::U32 => "unsigned int (5125)",
        ComponentType::F32 => "float (5126)",
    }
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// The accessor's component type and element type (validated by the crate, checked again here).
fn accessor_kind(acc: &json::Accessor, index: usize) -> Result<(ComponentType, Type), String> {
    match (&acc.component_type, &acc.type_) {
        (Checked::Valid(c), Checked::Valid(t)) => Ok((c.0, *t)),
        _ => Err(format!("accessor {index} has an invalid componentType or type")),
    }
}

/// Reads a VEC3 position or normal accessor, decoding normalized integers (KHR_mesh_quantization).
fn read_vec3(
    root: &json::Root,
    index: usize,
    buffers: &[Vec<u8>],
    attr: Attribute,
    quantized: bool,
    role: &str,
) -> Result<Vec<Vec3>, String> {
    let acc = &root.accessors[index];
    let (ct, ty) = accessor_kind(acc, index)?;
    if ty != Type::Vec3 {
        return Err(format!("accessor {index} ({role}) has type {ty:?}; VEC3 is required"));
    }
    let normalized = acc.normalized;
    let allowed_with_ext = match attr {
        Attribute::Position => {
            matches!(ct, ComponentType::I8 | ComponentType::U8 | ComponentType::I16 | ComponentType::U16)
        }
        Attribute::Normal => normalized && matches!(ct, ComponentType::I8 | ComponentType::I16),
    };
    if ct == ComponentType::F32 {
        if normalized {
            return Err(format!("accessor {index} ({role}) is float and normalized, which glTF forbids"));
        }
    } else if !allowed_with_ext {
        let t = if normalized { "normalized " } else { "" };
        return Err(format!(
            "accessor {index} ({role}) has component type {t}{}, which glTF does not allow here (not even with {QUANTIZATION})",
            type_name(ct)
        ));
    } else if !quantized {
        return Err(format!(
            "accessor {index} ({role}) has component type {}, which glTF allows only with the {QUANTIZATION} extension, not declared in extensionsUsed",
            type_name(ct)
        ));
    }
    let flat = read_components(root, index, buffers, role)?;
    let decode = |v: f64| -> f32 {
        if !normalized {
            return v as f32;
        }
        // glTF 2.0 §3.11 "Animations"/KHR_mesh_quantization: normalized integer to float.
        (match ct {
            ComponentType::I8 => (v / 127.0).max(-1.0),
            ComponentType::U8 => v / 255.0,
            ComponentType::I16 => (v / 32767.0).max(-1.0),
            ComponentType::U16 => v / 65535.0,
            _ => v,
        }) as f32
    };
    Ok(flat.chunks_exact(3).map(|c| Vec3::new(decode(c[0]), decode(c[1]), decode(c[2]))).collect())
}

/// Reads an index accessor: SCALAR, unsigned byte/short/int, not normalized (glTF 2.0 §3.7.2.1).
fn read_indices(root: &json::Root, index: usize, buffers: &[Vec<u8>], role: &str) -> Result<Vec<u32>, String> {
    let acc = &root.accessors[index];
    let (ct, ty) = accessor_kind(acc, index)?;
    if !matches!(ct, ComponentType::U8 | ComponentType::U16 | ComponentType::U32) {
        return Err(format!(
            "accessor {index} ({role}) has component type {}; glTF allows only unsigned byte, unsigned short or unsigned int for indices",
            type_name(ct)
        ));
    }
    if ty != Type::Scalar {
        return Err(format!("accessor {index} ({role}) has type {ty:?}; indices must be SCALAR"));
    }
    if acc.normalized {
        return Err(format!("accessor {index} ({role}) is normalized, which glTF forbids for indices"));
    }
    Ok(read_components(root, index, buffers, role)?.into_iter().map(|v| v as u32).collect())
}

/// Little-endian component `c` at the start of `b` (b holds at least its size), exactly as f64.
fn component(b: &[u8], c: ComponentType) -> f64 {
    match c {
        ComponentType::I8 => b[0] as i8 as f64,
        ComponentType::U8 => b[0] as f64,
        ComponentType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
        ComponentType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
        ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// The bytes of buffer view `view`, checked against its buffer.
fn view_bytes<'b>(root: &json::Root, view: usize, buffers: &'b [Vec<u8>]) -> Result<(&'b [u8], Option<usize>), String> {
    let v = root.buffer_views.get(view).ok_or_else(|| format!("buffer view {view} does not exist"))?;
    let buf =
        buffers.get(v.buffer.value()).ok_or_else(|| format!("buffer view {view}: no buffer {}", v.buffer.value()))?;
    let off = v.byte_offset.map_or(0, |o| o.0) as usize;
    let len = v.byte_length.0 as usize;
    let bytes = off.checked_add(len).and_then(|end| buf.get(off..end)).ok_or_else(|| {
        format!("buffer view {view} (offset {off}, length {len}) exceeds its buffer ({} bytes)", buf.len())
    })?;
    Ok((bytes, v.byte_stride.map(|s| s.0).filter(|&s| s != 0)))
}

/// Reads `count` elements of `n` components of type `c` from `bytes` at `offset` with `stride`.
fn read_elements(
    bytes: &[u8],
    offset: usize,
    stride: usize,
    count: usize,
    n: usize,
    c: ComponentType,
    out: &mut Vec<f64>,
) -> Option<()> {
    let cs = component_size(c);
    let elem = n * cs;
    if count == 0 {
        return Some(());
    }
    let end = (count - 1).checked_mul(stride)?.checked_add(offset)?.checked_add(elem)?;
    if end > bytes.len() {
        return None;
    }
    out.reserve(count * n);
    for i in 0..count {
        let at = offset + i * stride;
        for k in 0..n {
            out.push(component(&bytes[at + k * cs..], c));
        }
    }
    Some(())
}

/// Reads every component of a SCALAR/VECn accessor (sparse substitution applied) as exact f64s.
fn read_components(root: &json::Root, index: usize, buffers: &[Vec<u8>], role: &str) -> Result<Vec<f64>, String> {
    let acc = &root.accessors[index];
    let (ct, ty) = accessor_kind(acc, index)?;
    let n = match ty {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 => 4,
        _ => return Err(format!("accessor {index} ({role}) has matrix type {ty:?}")),
    };
    let cs = component_size(ct);
    let elem = n * cs;
    let count = usize::try_from(acc.count.0).map_err(|_| format!("accessor {index} ({role}): count too large"))?;
    let overrun = || format!("accessor {index} ({role}) exceeds its buffer view");
    let mut out = Vec::new();
    match acc.buffer_view {
        Some(view) => {
            let (bytes, stride) = view_bytes(root, view.value(), buffers)?;
            let stride = stride.unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "accessor {index} ({role}): byteStride {stride} is smaller than its element ({elem} bytes)"
                ));
            }
            let offset = acc.byte_offset.map_or(0, |o| o.0) as usize;
            read_elements(bytes, offset, stride, count, n, ct, &mut out).ok_or_else(overrun)?;
        }
        None => {
            if count.checked_mul(elem).is_none_or(|b| b > MAX_VIEWLESS_BYTES) {
                return Err(format!(
                    "accessor {index} ({role}) has no buffer view and {count} elements (limit {MAX_VIEWLESS_BYTES} bytes)"
                ));
            }
            out = vec![0.0; count * n];
        }
    }
    if let Some(sp) = &acc.sparse {
        let k = sp.count.0 as usize;
        if k > count {
            return Err(format!("accessor {index} ({role}): sparse count {k} exceeds the count {count}"));
        }
        let ict = match &sp.indices.component_type {
            Checked::Valid(t) if matches!(t.0, ComponentType::U8 | ComponentType::U16 | ComponentType::U32) => t.0,
            _ => return Err(format!("accessor {index} ({role}): sparse indices must be unsigned byte, short or int")),
        };
        let (ib, _) = view_bytes(root, sp.indices.buffer_view.value(), buffers)?;
        let mut ix = Vec::new();
        let isz = component_size(ict);
        read_elements(ib, sp.indices.byte_offset.0 as usize, isz, k, 1, ict, &mut ix)
            .ok_or_else(|| format!("accessor {index} ({role}): sparse indices exceed their buffer view"))?;
        let (vb, _) = view_bytes(root, sp.values.buffer_view.value(), buffers)?;
        let mut vals = Vec::new();
        read_elements(vb, sp.values.byte_offset.0 as usize, elem, k, n, ct, &mut vals)
            .ok_or_else(|| format!("accessor {index} ({role}): sparse values exceed their buffer view"))?;
        for (j, &i) in ix.iter().enumerate() {
            let i = i as usize;
            if i >= count {
                return Err(format!("accessor {index} ({role}): sparse index {i} out of range ({count} elements)"));
            }
            out[i * n..(i + 1) * n].copy_from_slice(&vals[j * n..(j + 1) * n]);
        }
    }
    Ok(out)
}

/// Appends `part` to `out`. Normals stay one per vertex: with `smooth` every part has them
/// (read or computed), without it none has.
fn append(out: &mut TriangleMesh, part: TriangleMesh) {
    let base = out.positions.len() as u32;
    out.positions.extend_from_slice(&part.positions);
    out.normals.extend_from_slice(&part.normals);
    out.triangles.extend(part.triangles.iter().map(|t| t.map(|k| k + base)));
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
        // Vertices are kept in order of first use by the triangles: find each by position.
        let find = |l: Vec3| {
            m.positions.iter().position(|p| (*p - expected_world(l)).length() < 1e-6).expect("vertex present")
        };
        let ix = local.map(find);
        // Uniform scale 2: volume × 8, winding still outward.
        assert!((m.signed_volume() - 8.0 / 6.0).abs() < 1e-5);
        if smooth {
            // Uniform scale and translation leave the file's normals unchanged.
            assert_eq!(m.normals.len(), 4);
            assert!((m.normals[ix[0]] + Vec3::X).length() < 1e-6 && (m.normals[ix[3]] - Vec3::Z).length() < 1e-6);
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
        let o = m.positions.iter().position(|p| (*p - expected_world(Vec3::ZERO)).length() < 1e-6).expect("origin");
        assert!((m.normals[o] + Vec3::ONE.normalize()).length() < 1e-6);
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

    /// Writes a glTF whose JSON is `json` with `BUFFERS` replaced by one embedded buffer holding `buf`.
    fn gltf_file(name: &str, json: &str, buf: &[u8]) -> std::path::PathBuf {
        let uri = format!("data:application/octet-stream;base64,{}", base64(buf));
        let p = temp_dir().join(name);
        let b = format!(r#""buffers": [{{"uri": "{uri}", "byteLength": {}}}]"#, buf.len());
        std::fs::write(&p, json.replace("BUFFERS", &b)).expect("write");
        p
    }

    fn bytes<T: Copy, const N: usize>(v: &[T], f: fn(T) -> [u8; N]) -> Vec<u8> {
        v.iter().flat_map(|&x| f(x)).collect()
    }

    #[test]
    fn strips_and_fans_follow_the_spec() {
        // Strip triangle i = (v_i, v_{i+1+i%2}, v_{i+2-i%2}): winding alternates so that every
        // triangle of a planar strip faces the same way. Odd and even vertex counts.
        assert_eq!(triangulate(Mode::TriangleStrip, &[0, 1, 2, 3, 4]), vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
        assert_eq!(triangulate(Mode::TriangleStrip, &[0, 1, 2, 3]), vec![[0, 1, 2], [1, 3, 2]]);
        // Fan triangle i = (v_{i+1}, v_{i+2}, v_0).
        assert_eq!(triangulate(Mode::TriangleFan, &[0, 1, 2, 3]), vec![[1, 2, 0], [2, 3, 0]]);
        // Too short, and stitching triangles (a repeated index) dropped.
        assert!(triangulate(Mode::TriangleStrip, &[0, 1]).is_empty());
        assert_eq!(triangulate(Mode::TriangleStrip, &[0, 1, 2, 2, 3, 4, 5]), vec![[0, 1, 2], [2, 4, 3], [3, 4, 5]]);
        assert!(triangulate(Mode::Lines, &[0, 1, 2]).is_empty());
        // A planar zig-zag strip of 7 vertices (5 triangles): all face the same way (−z, the
        // winding of the first triangle).
        let zig: Vec<f32> = (0..7).flat_map(|i| [(i / 2) as f32, (i % 2) as f32, 0.0]).collect();
        let buf = bytes(&zig, f32::to_le_bytes);
        let json = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "mode": 5}]}], BUFFERS,
            "bufferViews": [{"buffer": 0, "byteLength": 84}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 7, "type": "VEC3", "min": [0,0,0], "max": [3,1,0]}]}"#;
        let (m, w) = load_gltf_with_warnings(&gltf_file("zigzag.gltf", json, &buf), false).expect("strip");
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(m.triangles.len(), 5);
        for t in 0..5 {
            let n = m.face_normal_area(t);
            assert!(n.z < 0.0 && n.x == 0.0 && n.y == 0.0, "triangle {t}: {n}");
        }
    }

    /// The tetrahedron with u8 indices and positions stored as normalized u16 (KHR_mesh_quantization)
    /// and normals as normalized i8.
    fn quantized_json(ext: &str, pos_type: u32, normalized: bool) -> String {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, {ext} "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1}}, "indices": 2}}]}}], BUFFERS,
            "bufferViews": [{{"buffer": 0, "byteLength": 32, "byteStride": 8}}, {{"buffer": 0, "byteOffset": 32, "byteLength": 16, "byteStride": 4}},
                            {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
            "accessors": [
              {{"bufferView": 0, "componentType": {pos_type}, "normalized": {normalized}, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]}},
              {{"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"}},
              {{"bufferView": 2, "componentType": 5121, "count": 12, "type": "SCALAR"}}]}}"#
        )
    }

    fn quantized_buffer() -> Vec<u8> {
        let mut b = Vec::new();
        // Positions: u16 × 3 padded to an 8-byte stride.
        for p in [[0u16, 0, 0], [65535, 0, 0], [0, 65535, 0], [0, 0, 65535]] {
            p.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
            b.extend_from_slice(&[0, 0]);
        }
        // Normals: i8 × 3 padded to 4 bytes; −128 decodes to −1 like −127.
        for n in [[-128i8, 0, 0], [127, 0, 0], [0, 127, 0], [0, 0, 127]] {
            b.extend(n.iter().map(|&x| x as u8));
            b.push(0);
        }
        b.extend_from_slice(&[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]);
        b
    }

    #[test]
    fn u8_indices_and_quantized_attributes() {
        let ext = r#""extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"],"#;
        let p = gltf_file("quantized.gltf", &quantized_json(ext, 5123, true), &quantized_buffer());
        let (m, _) = load_gltf_with_warnings(&p, true).expect("quantized");
        assert_eq!(m.triangles.len(), 4);
        // Normalized u16 65535 → exactly 1.0: the unit tetrahedron, outward.
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-9);
        let o = m.positions.iter().position(|p| *p == Vec3::ZERO).expect("origin");
        assert_eq!(m.normals[o], -Vec3::X, "i8 −128 → −1");
        // Non-normalized u16 positions are integers (the node transform would dequantize them).
        let p = gltf_file("quantized_int.gltf", &quantized_json(ext, 5123, false), &quantized_buffer());
        let (m, _) = load_gltf_with_warnings(&p, false).expect("integer positions");
        assert!((m.signed_volume() - 65535f64.powi(3) / 6.0).abs() < 1e3);
        // Without the extension: refused naming the accessor, its type and the extension.
        let p = gltf_file("quantized_noext.gltf", &quantized_json("", 5123, true), &quantized_buffer());
        let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
        assert!(
            e.contains("accessor 0 (POSITION of mesh 0 primitive 0)")
                && e.contains("unsigned short")
                && e.contains("KHR_mesh_quantization"),
            "{e}"
        );
        // u32 positions are not allowed even with the extension.
        let p = gltf_file("quantized_u32.gltf", &quantized_json(ext, 5125, false), &quantized_buffer());
        let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
        assert!(e.contains("accessor 0") && e.contains("unsigned int"), "{e}");
    }

    #[test]
    fn sparse_accessor_and_lines_skipped() {
        // Positions: a view-less accessor of 3 zeros with all three substituted sparsely; a second
        // primitive of mode LINES is skipped with a warning naming it.
        let mut buf = bytes(&[0u16, 1, 2], u16::to_le_bytes);
        buf.extend_from_slice(&[0, 0]);
        buf.extend(bytes(&[0f32, 0., 0., 1., 0., 0., 0., 1., 0.], f32::to_le_bytes));
        let json = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}, {"attributes": {"POSITION": 0}, "mode": 1}]}], BUFFERS,
            "bufferViews": [{"buffer": 0, "byteLength": 6}, {"buffer": 0, "byteOffset": 8, "byteLength": 36}],
            "accessors": [{"componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0],
              "sparse": {"count": 3, "indices": {"bufferView": 0, "componentType": 5123}, "values": {"bufferView": 1}}}]}"#;
        let (m, w) = load_gltf_with_warnings(&gltf_file("sparse.gltf", json, &buf), false).expect("sparse");
        assert_eq!(m.triangles.len(), 1);
        assert!((m.face_normal_area(0) - Vec3::Z).length() < 1e-6);
        assert!(w.len() == 1 && w[0].contains("mesh 0 primitive 1") && w[0].contains("Lines"), "{w:?}");
    }

    #[test]
    fn node_graphs_that_are_not_trees_are_refused() {
        let buf = tetra_buffer();
        let with_nodes = |nodes: &str, roots: &str| {
            let uri = format!("data:application/octet-stream;base64,{}", base64(&buf));
            tetra_json(Some(&uri), 3).replace(
                r#""scenes": [{"nodes": [0]}],
  "nodes": [
    {"translation": [0, 0, 5], "scale": [2, 2, 2], "children": [1]},
    {"translation": [1, 0, 0], "mesh": 0},
    {"mesh": 0}
  ],"#,
                &format!(r#""scenes": [{{"nodes": {roots}}}], "nodes": {nodes},"#),
            )
        };
        let cases = [
            ("self.gltf", r#"[{"mesh": 0, "children": [0]}]"#, "[0]", "node 0 lists itself as a child"),
            ("cycle.gltf", r#"[{"mesh": 0}, {"children": [2]}, {"children": [1]}]"#, "[0]", "cycle"),
            (
                "rootchild.gltf",
                r#"[{"children": [1]}, {"mesh": 0}]"#,
                "[0, 1]",
                "node 1 as a root, but it is a child of node 0",
            ),
            ("tworoots.gltf", r#"[{"mesh": 0}]"#, "[0, 0]", "lists node 0 twice"),
        ];
        for (name, nodes, roots, want) in cases {
            let p = temp_dir().join(name);
            let json = with_nodes(nodes, roots);
            assert!(json.contains(nodes), "test JSON built");
            std::fs::write(&p, json).expect("write");
            let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(want), "{name}: {e}");
        }
    }

    #[test]
    fn zero_scale_node_is_hidden_not_an_error() {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
        let json = tetra_json(Some(&uri), 3)
            .replace(r#""scenes": [{"nodes": [0]}]"#, r#""scenes": [{"nodes": [0, 2]}]"#)
            .replace(r#"{"mesh": 0}"#, r#"{"mesh": 0, "scale": [0, 0, 0]}"#);
        let p = temp_dir().join("zero_scale.gltf");
        std::fs::write(&p, json).expect("write");
        let (m, _) = load_gltf_with_warnings(&p, true).expect("zero scale");
        check_tetra(&m, true);
    }

    #[test]
    fn instanced_triangles_are_capped_before_reading() {
        // One primitive claiming 3 · 2^24 + 3 indices: refused by the count, before its (absent)
        // data is touched.
        let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
        let json = tetra_json(Some(&uri), 3).replace(r#""count": 12"#, &format!(r#""count": {}"#, 3 * (1 << 24) + 3));
        let p = temp_dir().join("cap.gltf");
        std::fs::write(&p, json).expect("write");
        let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
        assert!(e.contains("more than 16777216 triangles"), "{e}");
    }
}
