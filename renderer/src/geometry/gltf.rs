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
//! - Morph targets (§3.7.2.2): POSITION and NORMAL displacements, weighted by the node's
//!   `weights`, else the mesh's, else 0, are added to the base attributes (in f64, rounded once).
//!   Every primitive of a mesh must have the same number of targets, every `weights` array one
//!   weight per target, and every target accessor one element per vertex; each is refused
//!   otherwise, naming the mesh or node.
//! - `smooth = false`: flat (no normals). `smooth = true`: the primitive's NORMAL attribute (plus
//!   its weighted morph displacements, then normalized) if present, else angle-weighted normals of
//!   the (morphed) primitive, computed in world space.
//! - `EXT_mesh_gpu_instancing`: each instance's TRANSLATION/ROTATION/SCALE transform is applied
//!   before the node's world transform. `KHR_node_visibility`: a node with `"visible": false` is
//!   left out with its descendants.
//! - Skins are refused, naming the node and the skin: the mesh holds the bind pose, not the pose
//!   the file shows. Animations do not change the static scene (the default pose is the one
//!   without animation); cameras, lights and materials in the file are ignored.
//! - Required extensions: those read here, and those that by their specifications change only
//!   materials, textures, lights or metadata, are accepted; any other is refused by name, since it
//!   may change the geometry. Extensions only in `extensionsUsed` are optional by definition and
//!   ignored (a Draco-compressed primitive then carries its uncompressed fallback, which is read).
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
use glam::{Affine3A, DVec3, Mat4};
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

/// Largest number of weighted vertex displacements (vertices × morph targets of non-zero weight,
/// summed over the distinct weightings of each primitive) a glTF scene may need.
pub const MAX_MORPH_DISPLACEMENTS: usize = 1 << 26;

/// The extension that allows integer positions and normals.
const QUANTIZATION: &str = "KHR_mesh_quantization";

/// The extension that instances a node's mesh with per-instance TRS transforms.
const GPU_INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// The extension that hides a node and its descendants (`"visible": false`).
const VISIBILITY: &str = "KHR_node_visibility";

/// Mesh compression, not read (only an uncompressed fallback is).
const DRACO: &str = "KHR_draco_mesh_compression";
const MESHOPT: &str = "EXT_meshopt_compression";

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

/// Extensions this loader reads.
const IMPLEMENTED: &[&str] = &[QUANTIZATION, GPU_INSTANCING, VISIBILITY];

/// Extensions that by their specifications change only materials, textures, lights, animations or
/// metadata, never the static geometry: ignoring them loads the geometry exactly (materials come
/// from the scene file). Every `KHR_materials_*` extension is of this kind too.
const NOT_GEOMETRY: &[&str] = &[
    "KHR_texture_transform",
    "KHR_texture_basisu",
    "EXT_texture_webp",
    "EXT_texture_avif",
    "MSFT_texture_dds",
    "KHR_lights_punctual",
    "EXT_lights_image_based",
    "KHR_animation_pointer",
    "KHR_xmp_json_ld",
];

/// Refuses every required extension that this loader neither reads ([`IMPLEMENTED`]) nor may
/// ignore without changing the geometry ([`NOT_GEOMETRY`]): a required extension the loader does
/// not know may store or change geometry (compression, skinning, visibility…), and the
/// specification (§3.12) forbids loading such a file without it. Extensions only in
/// `extensionsUsed` are by definition optional (the file is valid without them) and are ignored.
fn check_required_extensions(required: &[String]) -> Result<(), String> {
    for ext in required {
        if ext == DRACO || ext == MESHOPT {
            return Err(format!("the file requires the extension {ext}, which is not supported (compressed meshes)"));
        }
        let known = IMPLEMENTED.contains(&ext.as_str())
            || NOT_GEOMETRY.contains(&ext.as_str())
            || ext.starts_with("KHR_materials_");
        if !known {
            return Err(format!(
                "the file requires the extension {ext}, which is not supported (it may change the geometry)"
            ));
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

    // Instances (node, morph weights, world transform) in depth-first order: each node once (the
    // graph is a forest), times its EXT_mesh_gpu_instancing instances. Triangles and morph work are
    // counted as instances are found, before any vertex is read: a small file may instance a large
    // mesh many times.
    let mut instances: Vec<(gltf::Node, usize, Mat4)> = Vec::new();
    let mut weight_sets: Vec<Vec<f32>> = Vec::new();
    let mut mesh_triangles: std::collections::HashMap<usize, usize> = Default::default();
    let mut morph_keys: std::collections::HashSet<PrimitiveKey> = Default::default();
    let (mut total, mut morph_total) = (0usize, 0usize);
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            return Err(format!("node {} has a non-finite transform", node.index()));
        }
        let ext = |name: &str| root.nodes[node.index()].extensions.as_ref().and_then(|e| e.others.get(name));
        if ext(VISIBILITY).and_then(|v| v.get("visible")).is_some_and(|v| *v == serde_json::Value::Bool(false)) {
            continue; // hidden with its descendants
        }
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
        let Some(mesh) = node.mesh() else { continue };
        if let Some(skin) = node.skin() {
            return Err(format!(
                "node {} uses skin {}: skinned meshes are not supported (the mesh's rest pose is not the posed mesh)",
                node.index(),
                skin.index()
            ));
        }
        let weights = morph_weights(root, node.index(), mesh.index())?;
        let per_mesh = match mesh_triangles.entry(mesh.index()) {
            std::collections::hash_map::Entry::Occupied(e) => *e.get(),
            std::collections::hash_map::Entry::Vacant(e) => *e.insert(mesh_triangle_count(&mesh)),
        };
        let transforms = match gpu_instances(root, node.index(), buffers, quantized)? {
            Some(local) => local.into_iter().map(|m| world * m).collect(),
            None => vec![world],
        };
        let w = weight_sets.len();
        for (k, t) in transforms.into_iter().enumerate() {
            if !t.is_finite() {
                return Err(format!("node {} instance {k} has a non-finite transform", node.index()));
            }
            // A node scaled to zero (a common way to hide an object) has no area to render, and its
            // normal matrix would not exist. A mesh without triangles is read once, for its
            // warnings (skipped primitives), however many instances it has.
            if glam::Mat3::from_mat4(t).determinant() == 0.0 || (per_mesh == 0 && k > 0) {
                continue;
            }
            total = total.saturating_add(per_mesh);
            if total > MAX_TRIANGLES {
                return Err(format!("the scene instantiates more than {MAX_TRIANGLES} triangles (the limit)"));
            }
            instances.push((node.clone(), w, t));
        }
        if instances.last().is_some_and(|i| i.1 == w) {
            // Morph work: each distinct (primitive, weights) is read once.
            for prim in mesh.primitives() {
                let key = primitive_key(mesh.index(), prim.index(), &weights);
                let base = prim.get(&gltf::Semantic::Positions).map_or(0, |a| a.count());
                if !key.2.is_empty() && morph_keys.insert(key.clone()) {
                    morph_total = morph_total.saturating_add(base.saturating_mul(key.2.len()));
                    if morph_total > MAX_MORPH_DISPLACEMENTS {
                        return Err(format!(
                            "the scene's morph targets need more than {MAX_MORPH_DISPLACEMENTS} weighted vertex displacements (the limit)"
                        ));
                    }
                }
            }
        }
        weight_sets.push(weights);
    }

    // Read each (primitive, morph weights) once (in local space), instance it per node.
    let mut cache: std::collections::HashMap<PrimitiveKey, Option<TriangleMesh>> = Default::default();
    let mut out = TriangleMesh::default();
    for (node, w, world) in &instances {
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            let key = primitive_key(mesh.index(), prim.index(), &weight_sets[*w]);
            let part = match cache.entry(key) {
                std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                std::collections::hash_map::Entry::Vacant(e) => {
                    let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
                    let morph = e.key().2.iter().map(|&(t, w)| (t, f32::from_bits(w))).collect::<Vec<_>>();
                    e.insert(read_primitive(root, &prim, buffers, smooth, quantized, &morph, &what, warnings)?)
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

/// A primitive (mesh, primitive) with the morph targets of non-zero weight (index, weight bits).
type PrimitiveKey = (usize, usize, Vec<(usize, u32)>);

fn primitive_key(mesh: usize, prim: usize, weights: &[f32]) -> PrimitiveKey {
    let nonzero = weights.iter().enumerate().filter(|(_, w)| **w != 0.0).map(|(t, w)| (t, w.to_bits())).collect();
    (mesh, prim, nonzero)
}

/// Triangles one instance of `mesh` makes (from the accessors' counts; nothing is read).
fn mesh_triangle_count(mesh: &gltf::Mesh) -> usize {
    let mut total = 0usize;
    for prim in mesh.primitives() {
        let n = match (prim.indices(), prim.get(&gltf::Semantic::Positions)) {
            (Some(ix), _) => ix.count(),
            (None, Some(pos)) => pos.count(),
            (None, None) => 0,
        };
        total = total.saturating_add(triangle_count(prim.mode(), n));
    }
    total
}

/// The morph weights of `node`'s instance of `mesh` (glTF 2.0 §3.7.2.2): the node's `weights` if
/// present, else the mesh's, else zeros; one per morph target, which every primitive of the mesh
/// has the same number of.
fn morph_weights(root: &json::Root, node: usize, mesh: usize) -> Result<Vec<f32>, String> {
    let m = &root.meshes[mesh];
    let count = |p: &json::mesh::Primitive| p.targets.as_ref().map_or(0, Vec::len);
    let targets = m.primitives.first().map_or(0, count);
    if let Some((p, prim)) = m.primitives.iter().enumerate().find(|(_, p)| count(p) != targets) {
        return Err(format!(
            "mesh {mesh}: primitive {p} has {} morph targets and primitive 0 has {targets} (all primitives must have the same number)",
            count(prim)
        ));
    }
    let check = |w: &Vec<f32>, owner: String| -> Result<(), String> {
        if w.len() != targets {
            return Err(format!("{owner}: {} morph weights for {targets} morph targets", w.len()));
        }
        if w.iter().any(|x| !x.is_finite()) {
            return Err(format!("{owner} has a non-finite morph weight"));
        }
        Ok(())
    };
    if let Some(w) = &m.weights {
        check(w, format!("mesh {mesh}"))?;
    }
    if let Some(w) = &root.nodes[node].weights {
        check(w, format!("node {node} (mesh {mesh})"))?;
    }
    Ok(root.nodes[node].weights.clone().or_else(|| m.weights.clone()).unwrap_or_else(|| vec![0.0; targets]))
}

/// The local transforms of `node`'s `EXT_mesh_gpu_instancing` instances (applied before the node's
/// world transform), or `None` without the extension.
fn gpu_instances(
    root: &json::Root,
    node: usize,
    buffers: &[Vec<u8>],
    quantized: bool,
) -> Result<Option<Vec<Mat4>>, String> {
    let Some(ext) = root.nodes[node].extensions.as_ref().and_then(|e| e.others.get(GPU_INSTANCING)) else {
        return Ok(None);
    };
    let what = format!("node {node}: {GPU_INSTANCING}");
    let attrs = ext.get("attributes").and_then(|a| a.as_object()).ok_or_else(|| format!("{what} has no attributes"))?;
    let accessor = |name: &str| -> Result<Option<usize>, String> {
        attrs.get(name).map_or(Ok(None), |v| {
            v.as_u64()
                .and_then(|i| usize::try_from(i).ok())
                .filter(|&i| i < root.accessors.len())
                .map(Some)
                .ok_or_else(|| format!("{what}: {name} is not the index of an accessor"))
        })
    };
    let (t, r, s) = (accessor("TRANSLATION")?, accessor("ROTATION")?, accessor("SCALE")?);
    let counts: Vec<u64> = [t, r, s].into_iter().flatten().map(|i| root.accessors[i].count.0).collect();
    let Some(&count) = counts.first() else {
        return Err(format!("{what} has none of TRANSLATION, ROTATION, SCALE"));
    };
    if counts.iter().any(|&c| c != count) {
        return Err(format!("{what}: TRANSLATION, ROTATION and SCALE have different counts {counts:?}"));
    }
    let count = count as usize;
    let vec3 = |i: Option<usize>, name: &str, default: DVec3| -> Result<Vec<DVec3>, String> {
        match i {
            Some(i) => read_vec3(root, i, buffers, Attribute::Instance, quantized, &format!("{name} of {what}")),
            None => Ok(vec![default; count]),
        }
    };
    let translation = vec3(t, "TRANSLATION", DVec3::ZERO)?;
    let scale = vec3(s, "SCALE", DVec3::ONE)?;
    let rotation = match r {
        Some(i) => read_rotations(root, i, buffers, &format!("ROTATION of {what}"))?,
        None => vec![glam::DQuat::IDENTITY; count],
    };
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let q = rotation[k];
        let len = q.length();
        if !(len > 0.0 && len.is_finite()) {
            return Err(format!("{what}: instance {k} has a rotation quaternion of length {len}"));
        }
        let m = glam::DMat4::from_scale_rotation_translation(scale[k], q / len, translation[k]);
        out.push(m.as_mat4());
    }
    Ok(Some(out))
}

/// Reads an `EXT_mesh_gpu_instancing` ROTATION accessor: VEC4 quaternions (x, y, z, w), float or
/// normalized signed byte/short.
fn read_rotations(
    root: &json::Root,
    index: usize,
    buffers: &[Vec<u8>],
    role: &str,
) -> Result<Vec<glam::DQuat>, String> {
    let acc = &root.accessors[index];
    let (ct, ty) = accessor_kind(acc, index)?;
    if ty != Type::Vec4 {
        return Err(format!("accessor {index} ({role}) has type {ty:?}; VEC4 is required"));
    }
    let ok = match ct {
        ComponentType::F32 => !acc.normalized,
        ComponentType::I8 | ComponentType::I16 => acc.normalized,
        _ => false,
    };
    if !ok {
        let t = if acc.normalized { "normalized " } else { "" };
        return Err(format!(
            "accessor {index} ({role}) has component type {t}{}; float or normalized signed byte/short is required",
            type_name(ct)
        ));
    }
    let flat = read_components(root, index, buffers, role)?;
    let decode = |v: f64| decode_normalized(v, ct, acc.normalized);
    Ok(flat
        .chunks_exact(4)
        .map(|c| glam::DQuat::from_xyzw(decode(c[0]), decode(c[1]), decode(c[2]), decode(c[3])))
        .collect())
}

/// Reads one primitive in its local space: positions (morphed by `morph`, the targets of non-zero
/// weight), triangulated indices and, with `smooth`, the file's normals (morphed likewise). `None`
/// for a primitive that is not a surface (skipped with a warning).
#[allow(clippy::too_many_arguments)]
fn read_primitive(
    root: &json::Root,
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
    smooth: bool,
    quantized: bool,
    morph: &[(usize, f32)],
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
    let mut positions = read_vec3(root, pos.index(), buffers, Attribute::Position, quantized, &pos_role)?;
    let n = positions.len();
    // Every target is checked (type, count); only those of non-zero weight are read.
    let targets: Vec<gltf::mesh::MorphTarget> = prim.morph_targets().collect();
    for (t, target) in targets.iter().enumerate() {
        for (acc, attr, name) in [
            (target.positions(), Attribute::TargetPosition, "POSITION"),
            (target.normals(), Attribute::TargetNormal, "NORMAL"),
        ] {
            let Some(acc) = acc else { continue };
            let role = format!("{name} of {what} morph target {t}");
            check_vec3(root, acc.index(), attr, quantized, &role)?;
            if acc.count() != n {
                return Err(format!("accessor {} ({role}) has {} elements for {n} vertices", acc.index(), acc.count()));
            }
        }
    }
    let displace = |base: &mut [DVec3], attr: Attribute| -> Result<(), String> {
        for &(t, w) in morph {
            let (acc, name) = match attr {
                Attribute::TargetPosition => (targets[t].positions(), "POSITION"),
                _ => (targets[t].normals(), "NORMAL"),
            };
            let Some(acc) = acc else { continue };
            let role = format!("{name} of {what} morph target {t}");
            let d = read_vec3(root, acc.index(), buffers, attr, quantized, &role)?;
            for (b, d) in base.iter_mut().zip(d) {
                *b += f64::from(w) * d;
            }
        }
        Ok(())
    };
    displace(&mut positions, Attribute::TargetPosition)?;
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
        let mut file = read_vec3(root, nacc.index(), buffers, Attribute::Normal, quantized, &role)?;
        if file.len() != n {
            return Err(format!("{what}: {} normals for {n} positions", file.len()));
        }
        displace(&mut file, Attribute::TargetNormal)?;
        normals = file.into_iter().map(|v| v.as_vec3().normalize_or_zero()).collect();
    }
    let positions = positions.into_iter().map(DVec3::as_vec3).collect();
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
    /// A morph target's POSITION displacement.
    TargetPosition,
    /// A morph target's NORMAL displacement.
    TargetNormal,
    /// An `EXT_mesh_gpu_instancing` TRANSLATION or SCALE.
    Instance,
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

/// Checks that accessor `index` may hold `attr`: VEC3, float, or an integer type that
/// `KHR_mesh_quantization` lists for it (when the file declares the extension).
fn check_vec3(root: &json::Root, index: usize, attr: Attribute, quantized: bool, role: &str) -> Result<(), String> {
    let acc = &root.accessors[index];
    let (ct, ty) = accessor_kind(acc, index)?;
    if ty != Type::Vec3 {
        return Err(format!("accessor {index} ({role}) has type {ty:?}; VEC3 is required"));
    }
    let normalized = acc.normalized;
    let allowed_with_ext = match attr {
        Attribute::Position | Attribute::Instance => {
            matches!(ct, ComponentType::I8 | ComponentType::U8 | ComponentType::I16 | ComponentType::U16)
        }
        Attribute::TargetPosition => matches!(ct, ComponentType::I8 | ComponentType::I16),
        Attribute::Normal | Attribute::TargetNormal => {
            normalized && matches!(ct, ComponentType::I8 | ComponentType::I16)
        }
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
    Ok(())
}

/// A component as a float: normalized integers decoded as glTF 2.0 §3.11 defines (c/127 clamped
/// to −1, c/255, …), others as they are.
fn decode_normalized(v: f64, ct: ComponentType, normalized: bool) -> f64 {
    if !normalized {
        return v;
    }
    match ct {
        ComponentType::I8 => (v / 127.0).max(-1.0),
        ComponentType::U8 => v / 255.0,
        ComponentType::I16 => (v / 32767.0).max(-1.0),
        ComponentType::U16 => v / 65535.0,
        _ => v,
    }
}

/// Reads a VEC3 accessor of `attr` ([`check_vec3`]), decoding normalized integers
/// (KHR_mesh_quantization), as exact f64s of the stored values.
fn read_vec3(
    root: &json::Root,
    index: usize,
    buffers: &[Vec<u8>],
    attr: Attribute,
    quantized: bool,
    role: &str,
) -> Result<Vec<DVec3>, String> {
    check_vec3(root, index, attr, quantized, role)?;
    let acc = &root.accessors[index];
    let (ct, _) = accessor_kind(acc, index)?;
    let flat = read_components(root, index, buffers, role)?;
    // Rounded to f32 as the stored value is (a float, or the f32 a normalized integer decodes to).
    let decode = |v: f64| decode_normalized(v, ct, acc.normalized) as f32 as f64;
    Ok(flat.chunks_exact(3).map(|c| DVec3::new(decode(c[0]), decode(c[1]), decode(c[2]))).collect())
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
    use crate::math::Vec3;

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
        // The lines as a mesh of their own on a second node (no triangles to instance): still read,
        // and warned about.
        let json2 = json
            .replace(
                r#""scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}]"#,
                r#""scenes": [{"nodes": [0, 1]}], "nodes": [{"mesh": 0}, {"mesh": 1}]"#,
            )
            .replace(
                r#"{"attributes": {"POSITION": 0}}, {"attributes": {"POSITION": 0}, "mode": 1}]}]"#,
                r#"{"attributes": {"POSITION": 0}}]}, {"primitives": [{"attributes": {"POSITION": 0}, "mode": 1}]}]"#,
            );
        assert_ne!(json2, json);
        let (_, w) = load_gltf_with_warnings(&gltf_file("sparse_lines_mesh.gltf", &json2, &buf), false).expect("lines");
        assert!(w.len() == 1 && w[0].contains("mesh 1 primitive 0") && w[0].contains("Lines"), "{w:?}");
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
    fn node_visibility_hides_a_subtree() {
        // Node 0 (the parent of node 1) hidden: only node 2's untransformed tetrahedron remains.
        let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
        let json = tetra_json(Some(&uri), 3)
            .replace(r#""scenes": [{"nodes": [0]}]"#, r#""scenes": [{"nodes": [0, 2]}]"#)
            .replace(
                r#""children": [1]}"#,
                r#""children": [1], "extensions": {"KHR_node_visibility": {"visible": false}}}"#,
            )
            .replacen("{\n", "{\n  \"extensionsUsed\": [\"KHR_node_visibility\"], \"extensionsRequired\": [\"KHR_node_visibility\"],\n", 1);
        let p = temp_dir().join("hidden.gltf");
        std::fs::write(&p, json).expect("write");
        let (m, _) = load_gltf_with_warnings(&p, false).expect("visibility");
        assert_eq!(m.triangles.len(), 4);
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-9 && m.positions.contains(&Vec3::ZERO));
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

    /// One triangle (0,0,0), (1,0,0), (0,1,0) with normals +z and two morph targets: target 0
    /// moves every vertex by +z and turns the normals by +x; target 1 (a sparse accessor without a
    /// buffer view) moves vertex 2 by +x. `NODES` and `WEIGHTS` are replaced by the test.
    const MORPH_JSON: &str = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}], "nodes": NODES,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1},
            "targets": [{"POSITION": 2, "NORMAL": 4}, {"POSITION": 3}]}] WEIGHTS}], BUFFERS,
        "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36},
            {"buffer": 0, "byteOffset": 72, "byteLength": 36}, {"buffer": 0, "byteOffset": 108, "byteLength": 1},
            {"buffer": 0, "byteOffset": 112, "byteLength": 12}, {"buffer": 0, "byteOffset": 124, "byteLength": 36}],
        "accessors": [
          {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
          {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
          {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,1], "max": [0,0,1]},
          {"componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,0,0],
            "sparse": {"count": 1, "indices": {"bufferView": 3, "componentType": 5121}, "values": {"bufferView": 4}}},
          {"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC3"}]}"#;

    fn morph_buffer() -> Vec<u8> {
        let mut b = bytes(&[0f32, 0., 0., 1., 0., 0., 0., 1., 0.], f32::to_le_bytes);
        b.extend(bytes(&[0f32, 0., 1., 0., 0., 1., 0., 0., 1.], f32::to_le_bytes));
        b.extend(bytes(&[0f32, 0., 1., 0., 0., 1., 0., 0., 1.], f32::to_le_bytes));
        b.extend_from_slice(&[2, 0, 0, 0]);
        b.extend(bytes(&[1f32, 0., 0.], f32::to_le_bytes));
        b.extend(bytes(&[1f32, 0., 0., 1., 0., 0., 1., 0., 0.], f32::to_le_bytes));
        b
    }

    fn morph_file(name: &str, nodes: &str, weights: &str) -> std::path::PathBuf {
        gltf_file(name, &MORPH_JSON.replace("NODES", nodes).replace("WEIGHTS", weights), &morph_buffer())
    }

    #[test]
    fn morph_targets_follow_node_then_mesh_weights() {
        // Node 0 takes the mesh's weights (0.5, 0.25); node 1 overrides them with (1, 0).
        let nodes = r#"[{"mesh": 0}, {"mesh": 0, "weights": [1, 0], "translation": [10, 0, 0]}]"#;
        for smooth in [false, true] {
            let p = morph_file("morph.gltf", nodes, r#", "weights": [0.5, 0.25]"#);
            let (m, w) = load_gltf_with_warnings(&p, smooth).expect("morph");
            assert!(w.is_empty(), "{w:?}");
            let want = [
                Vec3::new(0.0, 0.0, 0.5),
                Vec3::new(1.0, 0.0, 0.5),
                Vec3::new(0.25, 1.0, 0.5),
                Vec3::new(10.0, 0.0, 1.0),
                Vec3::new(11.0, 0.0, 1.0),
                Vec3::new(10.0, 1.0, 1.0),
            ];
            assert_eq!(m.positions, want);
            if smooth {
                // The file's normal plus the weighted NORMAL displacements, normalized.
                let n0 = Vec3::new(0.5, 0.0, 1.0).normalize();
                let n1 = Vec3::new(1.0, 0.0, 1.0).normalize();
                for (k, n) in m.normals.iter().enumerate() {
                    let want = if k < 3 { n0 } else { n1 };
                    assert!((*n - want).length() < 1e-6, "normal {k}: {n}");
                }
            }
        }
        // No weights anywhere: weight 0, the base shape.
        let (m, _) = load_gltf_with_warnings(&morph_file("morph_none.gltf", r#"[{"mesh": 0}, {}]"#, ""), true)
            .expect("no weights");
        assert_eq!(m.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert!(m.normals.iter().all(|n| *n == Vec3::Z));
    }

    #[test]
    fn morph_normals_are_recomputed_where_the_file_has_none() {
        // Without NORMAL the smooth normals come from the morphed triangle: target 1 (its sparse
        // value set to +z here) lifts vertex 2 to (0, 1, 1), which tilts the triangle's normal from
        // +z to (0, −1, 1)/√2.
        let json = MORPH_JSON
            .replace(r#", "NORMAL": 1}"#, "}")
            .replace("NODES", r#"[{"mesh": 0, "weights": [0, 1]}, {}]"#)
            .replace("WEIGHTS", "");
        let mut buf = morph_buffer();
        buf[112..124].copy_from_slice(&bytes(&[0f32, 0., 1.], f32::to_le_bytes));
        let (m, _) = load_gltf_with_warnings(&gltf_file("morph_nonormal.gltf", &json, &buf), true)
            .expect("morph without normals");
        assert_eq!(m.positions, vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1.0)]);
        let want = Vec3::new(0.0, -1.0, 1.0).normalize();
        assert!(m.normals.iter().all(|n| (*n - want).length() < 1e-6), "{:?}", m.normals);
    }

    #[test]
    fn morph_inconsistencies_are_refused_naming_mesh_or_node() {
        let cases = [
            (
                "w_mesh.gltf",
                r#"[{"mesh": 0}, {}]"#,
                r#", "weights": [1]"#,
                "mesh 0: 1 morph weights for 2 morph targets",
            ),
            (
                "w_node.gltf",
                r#"[{"mesh": 0, "weights": [1, 0, 0]}, {}]"#,
                "",
                "node 0 (mesh 0): 3 morph weights for 2 morph targets",
            ),
            (
                "w_inf.gltf",
                r#"[{"mesh": 0, "weights": [1e39, 0]}, {}]"#,
                "",
                "node 0 (mesh 0) has a non-finite morph weight",
            ),
        ];
        for (name, nodes, weights, want) in cases {
            let e = load_gltf_with_warnings(&morph_file(name, nodes, weights), false).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(want) && !e.contains('\n'), "{name}: {e}");
        }
        // A target accessor with another count than the base positions.
        let json = MORPH_JSON
            .replace(
                r#""bufferView": 5, "componentType": 5126, "count": 3"#,
                r#""bufferView": 5, "componentType": 5126, "count": 2"#,
            )
            .replace("NODES", r#"[{"mesh": 0}, {}]"#)
            .replace("WEIGHTS", "");
        let e =
            load_gltf_with_warnings(&gltf_file("w_count.gltf", &json, &morph_buffer()), false).unwrap_err().to_string();
        assert!(
            e.contains("accessor 4 (NORMAL of mesh 0 primitive 0 morph target 0) has 2 elements for 3 vertices"),
            "{e}"
        );
        // Primitives with different numbers of targets.
        let json = MORPH_JSON
            .replace(r#"{"POSITION": 3}]}]"#, r#"{"POSITION": 3}]}, {"attributes": {"POSITION": 0}}]"#)
            .replace("NODES", r#"[{"mesh": 0}, {}]"#)
            .replace("WEIGHTS", "");
        let e =
            load_gltf_with_warnings(&gltf_file("w_prims.gltf", &json, &morph_buffer()), false).unwrap_err().to_string();
        assert!(e.contains("mesh 0: primitive 1 has 0 morph targets and primitive 0 has 2"), "{e}");
    }

    #[test]
    fn required_extensions_are_refused_unless_known() {
        let with_ext = |name: &str, used: &str, required: &str| {
            let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
            let json = tetra_json(Some(&uri), 3).replacen(
                "{\n",
                &format!("{{\n  \"extensionsUsed\": {used}, \"extensionsRequired\": {required},\n"),
                1,
            );
            let p = temp_dir().join(name);
            std::fs::write(&p, json).expect("write");
            load_gltf_with_warnings(&p, true)
        };
        let e =
            with_ext("req_unknown.gltf", r#"["KHR_foo_geometry"]"#, r#"["KHR_foo_geometry"]"#).unwrap_err().to_string();
        assert!(e.contains("req_unknown.gltf") && e.contains("requires the extension KHR_foo_geometry"), "{e}");
        let e = with_ext("req_draco.gltf", r#"["KHR_draco_mesh_compression"]"#, r#"["KHR_draco_mesh_compression"]"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("KHR_draco_mesh_compression") && e.contains("compressed"), "{e}");
        // Material and texture extensions do not change the geometry; optional ones are ignored.
        let ok = r#"["KHR_materials_emissive_strength", "KHR_texture_transform", "KHR_texture_basisu"]"#;
        let (m, _) = with_ext("req_materials.gltf", ok, ok).expect("material extensions");
        check_tetra(&m, true);
        let (m, _) = with_ext("used_unknown.gltf", r#"["KHR_foo_geometry"]"#, "[]").expect("optional extension");
        check_tetra(&m, true);
    }

    #[test]
    fn draco_primitive_without_fallback_is_refused() {
        // KHR_draco_mesh_compression only used: the primitive's uncompressed fallback is read, and
        // an accessor without it (no data) is refused.
        let json = r#"{"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_draco_mesh_compression"], "scene": 0,
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}], BUFFERS,
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0},
                "extensions": {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}}]}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": BV "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}]}"#;
        let buf = bytes(&[0f32, 0., 0., 1., 0., 0., 0., 1., 0.], f32::to_le_bytes);
        let e = load_gltf_with_warnings(
            &gltf_file("draco_only.gltf", &json.replace("\"bufferView\": BV", ""), &buf),
            false,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("draco_only.gltf") && e.contains("accessors[0].bufferView: Missing data"), "{e}");
        let (m, _) = load_gltf_with_warnings(&gltf_file("draco_fallback.gltf", &json.replace("BV", "0,"), &buf), false)
            .expect("fallback");
        assert_eq!(m.triangles.len(), 1);
    }

    #[test]
    fn skinned_meshes_are_refused_naming_node_and_skin() {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&tetra_buffer()));
        let json = tetra_json(Some(&uri), 3)
            .replace(r#"{"translation": [1, 0, 0], "mesh": 0}"#, r#"{"translation": [1, 0, 0], "mesh": 0, "skin": 0}"#)
            .replace(r#""meshes""#, r#""skins": [{"joints": [0]}], "meshes""#);
        let p = temp_dir().join("skinned.gltf");
        std::fs::write(&p, json).expect("write");
        let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
        assert!(e.contains("skinned.gltf") && e.contains("node 1 uses skin 0"), "{e}");
    }

    /// The triangle of [`MORPH_JSON`] on a node at (0, 0, 5) with three `EXT_mesh_gpu_instancing`
    /// instances: translations (0,0,0), (2,0,0), (0,2,0); the second turned a quarter about +z
    /// (ROTATION as normalized i16), the third scaled by 2.
    fn instancing_json(rotation_count: u32) -> String {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "extensionsUsed": ["EXT_mesh_gpu_instancing"], "scene": 0,
            "scenes": [{{"nodes": [0]}}], BUFFERS,
            "nodes": [{{"mesh": 0, "translation": [0, 0, 5],
                "extensions": {{"EXT_mesh_gpu_instancing": {{"attributes": {{"TRANSLATION": 1, "ROTATION": 2, "SCALE": 3}}}}}}}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 36}},
                {{"buffer": 0, "byteOffset": 72, "byteLength": 24}}, {{"buffer": 0, "byteOffset": 96, "byteLength": 36}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
              {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"}},
              {{"bufferView": 2, "componentType": 5122, "normalized": true, "count": {rotation_count}, "type": "VEC4"}},
              {{"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3"}}]}}"#
        )
    }

    fn instancing_buffer() -> Vec<u8> {
        let mut b = bytes(&[0f32, 0., 0., 1., 0., 0., 0., 1., 0.], f32::to_le_bytes);
        b.extend(bytes(&[0f32, 0., 0., 2., 0., 0., 0., 2., 0.], f32::to_le_bytes));
        // (x, y, z, w): identity, a quarter turn about +z (sin 45°, cos 45° as i16), identity.
        let h = (std::f64::consts::FRAC_1_SQRT_2 * 32767.0).round() as i16;
        b.extend(bytes(&[0i16, 0, 0, 32767, 0, 0, h, h, 0, 0, 0, 32767], i16::to_le_bytes));
        b.extend(bytes(&[1f32, 1., 1., 1., 1., 1., 2., 2., 2.], f32::to_le_bytes));
        b
    }

    #[test]
    fn gpu_instancing_places_every_instance() {
        let p = gltf_file("instancing.gltf", &instancing_json(3), &instancing_buffer());
        let (m, w) = load_gltf_with_warnings(&p, false).expect("instancing");
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(m.triangles.len(), 3);
        let want = [
            [0.0, 0.0, 5.0],
            [1.0, 0.0, 5.0],
            [0.0, 1.0, 5.0],
            [2.0, 0.0, 5.0],
            [2.0, 1.0, 5.0],
            [1.0, 0.0, 5.0],
            [0.0, 2.0, 5.0],
            [2.0, 2.0, 5.0],
            [0.0, 4.0, 5.0],
        ];
        for (k, (p, w)) in m.positions.iter().zip(want).enumerate() {
            assert!((*p - Vec3::from(w)).length() < 1e-5, "vertex {k}: {p} vs {w:?}");
        }
        // Attribute counts that disagree are refused, naming the node.
        let p = gltf_file("instancing_counts.gltf", &instancing_json(2), &instancing_buffer());
        let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
        assert!(e.contains("node 0: EXT_mesh_gpu_instancing") && e.contains("different counts"), "{e}");
    }

    #[test]
    fn gpu_instances_count_against_the_triangle_limit() {
        // The tetrahedron (4 triangles) instanced 2^22 + 1 times (TRANSLATION as u8 VEC3, zeros):
        // refused by the count before any mesh is read.
        let n = (1usize << 22) + 1;
        let mut buf = tetra_buffer();
        buf.resize(120 + 3 * n, 0);
        let uri = format!("data:application/octet-stream;base64,{}", base64(&buf));
        let json = tetra_json(Some(&uri), 3)
            .replace(r#""byteLength": 120"#, &format!(r#""byteLength": {}"#, buf.len()))
            .replace(
                r#"{"translation": [1, 0, 0], "mesh": 0}"#,
                r#"{"translation": [1, 0, 0], "mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 3}}}}"#,
            )
            .replace(
                r#"{"buffer": 0, "byteOffset": 96, "byteLength": 24}"#,
                &format!(r#"{{"buffer": 0, "byteOffset": 96, "byteLength": 24}}, {{"buffer": 0, "byteOffset": 120, "byteLength": {}}}"#, 3 * n),
            )
            .replace(
                r#""max": [3], "min": [0]}"#,
                &format!(r#""max": [3], "min": [0]}}, {{"bufferView": 2, "componentType": 5121, "count": {n}, "type": "VEC3"}}"#),
            )
            .replacen("{\n", "{\n  \"extensionsUsed\": [\"EXT_mesh_gpu_instancing\", \"KHR_mesh_quantization\"],\n", 1);
        let p = temp_dir().join("instancing_cap.gltf");
        std::fs::write(&p, json).expect("write");
        let e = load_gltf_with_warnings(&p, false).unwrap_err().to_string();
        assert!(e.contains("more than 16777216 triangles"), "{e}");
    }

    #[test]
    fn morph_work_is_capped_before_reading() {
        // 2^20 vertices (a view-less sparse accessor) and 65 targets of weight 1: 65 · 2^20 > 2^26
        // weighted displacements, refused by the counts before any vertex is read.
        let n = 1 << 20;
        let targets = vec![r#"{"POSITION": 0}"#; 65].join(", ");
        let weights = vec!["1"; 65].join(", ");
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}], BUFFERS,
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "targets": [{targets}]}}], "weights": [{weights}]}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 4}}, {{"buffer": 0, "byteOffset": 4, "byteLength": 12}}],
            "accessors": [{{"componentType": 5126, "count": {n}, "type": "VEC3", "min": [0,0,0], "max": [1,0,0],
              "sparse": {{"count": 1, "indices": {{"bufferView": 0, "componentType": 5125}}, "values": {{"bufferView": 1}}}}}}]}}"#
        );
        let mut buf = bytes(&[1u32], u32::to_le_bytes);
        buf.extend(bytes(&[1f32, 0., 0.], f32::to_le_bytes));
        let e = load_gltf_with_warnings(&gltf_file("morph_cap.gltf", &json, &buf), false).unwrap_err().to_string();
        assert!(e.contains("more than 67108864 weighted vertex displacements"), "{e}");
    }

    #[test]
    fn quantized_morph_targets() {
        // Target 0's POSITION as normalized i8 (KHR_mesh_quantization): 127 decodes to 1, so weight
        // 1 lifts the triangle by +z as the float target does.
        let json = MORPH_JSON
            .replace(r#""targets": [{"POSITION": 2,"#, r#""targets": [{"POSITION": 5,"#)
            .replace(
                r#"{"buffer": 0, "byteOffset": 124, "byteLength": 36}]"#,
                r#"{"buffer": 0, "byteOffset": 124, "byteLength": 36}, {"buffer": 0, "byteOffset": 160, "byteLength": 12, "byteStride": 4}]"#,
            )
            .replace(
                r#"{"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC3"}]"#,
                r#"{"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC3"},
                   {"bufferView": 6, "componentType": 5120, "normalized": true, "count": 3, "type": "VEC3"}]"#,
            )
            .replace("NODES", r#"[{"mesh": 0, "weights": [1, 0]}, {}]"#)
            .replace("WEIGHTS", "");
        let mut buf = morph_buffer();
        buf.extend_from_slice(&[0, 0, 127, 0, 0, 0, 127, 0, 0, 0, 127, 0]);
        let ext = r#"{"extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"], "#;
        let p = gltf_file("morph_quantized.gltf", &json.replacen('{', ext, 1), &buf);
        let (m, _) = load_gltf_with_warnings(&p, false).expect("quantized target");
        assert_eq!(m.positions, vec![Vec3::Z, Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)]);
        // Without the extension: refused naming the target's accessor and the extension.
        let e = load_gltf_with_warnings(&gltf_file("morph_quantized_noext.gltf", &json, &buf), false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("accessor 5 (POSITION of mesh 0 primitive 0 morph target 0)") && e.contains(QUANTIZATION),
            "{e}"
        );
    }
}
