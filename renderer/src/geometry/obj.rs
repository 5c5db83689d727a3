//! Wavefront OBJ loading into one [`TriangleMesh`].
//!
//! The geometry subset of the format (Wavefront "Object Files (.obj)", Appendix B1 of the Advanced
//! Visualizer manual) is parsed here rather than through `tobj`, because the mesh must follow the
//! file's own vertices: `tobj` re-indexes every `g`/`o`/`usemtl` group separately (so smooth
//! normals split along group borders, and differently whether the `.mtl` file is found), does not
//! expose smoothing groups, and drops the first statement after a UTF-8 byte-order mark.
//!
//! What is read:
//! - Text: an optional UTF-8 byte-order mark, LF or CRLF line ends, spaces or tabs between tokens,
//!   `#` comments, `\` line continuation. Bytes that are not UTF-8 only matter inside numbers.
//! - `v x y z [w | r g b]` (the first three numbers), `vn x y z`, and `f` with `v`, `v/vt`,
//!   `v//vn` or `v/vt/vn` corners, 1-based or negative (relative) indices. Polygons are
//!   triangulated as fans (v0, v_k, v_{k+1}), keeping the file's winding.
//! - `s N` / `s off` (smoothing groups). `l` and `p` (polylines and points) are not surfaces:
//!   they are skipped with a warning and never become faces. Everything else (`vt`, `g`, `o`,
//!   `usemtl`, `mtllib`, free-form statements) is ignored: materials come from the scene file.
//! - `smooth = false`: flat shading, `normals` left empty (the face normal is used).
//! - `smooth = true`: a corner with a `vn` uses the file's normal (normalised). Other corners get
//!   the angle-weighted normal (Thürmer & Wüthrich 1998) of the faces that share their file vertex
//!   *and* their smoothing group; faces in group 0 (`s off`/`s 0`) are flat. A file without any `s`
//!   statement is one smoothing group. Groups `g` and materials never split normals.
//! - Only vertices that faces use are kept.
//! - Errors (missing or unreadable file, malformed number, index 0 or out of range, a face with
//!   fewer than 3 corners, non-finite coordinate, no faces) are one-line [`crate::Error`]s naming
//!   the file and the line; nothing panics. Memory is linear in the file size.

use super::TriangleMesh;
use crate::math::Vec3;
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// Loads an OBJ file as one mesh. `smooth`: keep/compute vertex normals. Warnings (skipped lines and
/// points, orientation problems) are printed to stderr, one line each, naming the file.
pub fn load_obj(path: &Path, smooth: bool) -> crate::Result<TriangleMesh> {
    let (mesh, warnings) = load_obj_with_warnings(path, smooth)?;
    for w in warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(mesh)
}

/// [`load_obj`] returning the warnings (without the file name) instead of printing them.
pub fn load_obj_with_warnings(path: &Path, smooth: bool) -> crate::Result<(TriangleMesh, Vec<String>)> {
    let err = |msg: String| crate::Error::file(path, msg);
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read OBJ file: {e}")))?;
    let obj = parse(&bytes).map_err(err)?;
    let mut warnings = Vec::new();
    if obj.skipped_lines + obj.skipped_points > 0 {
        warnings.push(format!(
            "{} line (l) and {} point (p) elements skipped: they are not surfaces",
            obj.skipped_lines, obj.skipped_points
        ));
    }
    let mesh = obj.into_mesh(smooth).map_err(err)?;
    warnings.extend(mesh.orientation_warnings());
    Ok((mesh, warnings))
}

/// One face corner: 0-based position index and optional 0-based normal index.
#[derive(Clone, Copy, Debug)]
struct Corner {
    v: u32,
    vn: Option<u32>,
}

/// The parsed geometry statements of a file.
#[derive(Default, Debug)]
struct ObjFile {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    /// Triangles (fan-triangulated faces) of corners, with their smoothing group (0: off).
    triangles: Vec<([Corner; 3], u32)>,
    /// The file has at least one `s` statement.
    has_smoothing_groups: bool,
    skipped_lines: usize,
    skipped_points: usize,
}

/// Parses the geometry statements (see the module documentation).
fn parse(bytes: &[u8]) -> Result<ObjFile, String> {
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    let mut obj = ObjFile::default();
    let mut group = 0u32;
    // Until the first `s` statement every face is in group 1 (smoothed together); the first `s`
    // makes the file's groups authoritative, and faces read before it are then flat (the format's
    // default is "s off").
    let mut face_groups_before_s = Vec::new();
    let mut line_no = 0usize;
    let mut logical = Vec::new();
    let mut start_line = 0usize;
    let mut corners: Vec<Corner> = Vec::new();
    for raw in bytes.split(|&b| b == b'\n') {
        line_no += 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        if logical.is_empty() {
            start_line = line_no;
        }
        if let Some(head) = raw.strip_suffix(b"\\") {
            logical.extend_from_slice(head);
            logical.push(b' ');
            continue;
        }
        logical.extend_from_slice(raw);
        let line = std::mem::take(&mut logical);
        let line = match line.iter().position(|&b| b == b'#') {
            Some(k) => &line[..k],
            None => &line[..],
        };
        let at = |m: String| format!("line {start_line}: {m}");
        let mut tokens = line.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty());
        let Some(keyword) = tokens.next() else { continue };
        match keyword {
            b"v" | b"vn" => {
                let mut xyz = [0f32; 3];
                for c in &mut xyz {
                    let t = tokens.next().ok_or_else(|| at(format!("'{}' needs 3 coordinates", show(keyword))))?;
                    *c = number(t).ok_or_else(|| at(format!("invalid number '{}'", show(t))))?;
                }
                let p = Vec3::from_array(xyz);
                if !p.is_finite() {
                    return Err(at("non-finite coordinate".into()));
                }
                if keyword == b"v" { obj.positions.push(p) } else { obj.normals.push(p) }
            }
            b"f" => {
                corners.clear();
                for t in tokens {
                    corners.push(corner(t, obj.positions.len(), obj.normals.len()).map_err(at)?);
                }
                if corners.len() < 3 {
                    return Err(at(format!("face with {} corners (at least 3 needed)", corners.len())));
                }
                for k in 1..corners.len() - 1 {
                    obj.triangles.push(([corners[0], corners[k], corners[k + 1]], group));
                    if !obj.has_smoothing_groups {
                        face_groups_before_s.push(obj.triangles.len() - 1);
                    }
                }
            }
            b"s" => {
                let t = tokens.next().ok_or_else(|| at("'s' needs a group number or 'off'".into()))?;
                group = if t == b"off" {
                    0
                } else {
                    std::str::from_utf8(t)
                        .ok()
                        .and_then(|s| s.parse::<u32>().ok())
                        .ok_or_else(|| at(format!("invalid smoothing group '{}'", show(t))))?
                };
                obj.has_smoothing_groups = true;
            }
            b"l" => obj.skipped_lines += 1,
            b"p" => obj.skipped_points += 1,
            _ => {}
        }
    }
    if obj.has_smoothing_groups {
        for &i in &face_groups_before_s {
            obj.triangles[i].1 = 0;
        }
    } else {
        for t in &mut obj.triangles {
            t.1 = 1;
        }
    }
    // Positive indices may refer to vertices defined later in the file: check them all now.
    let (nv, nn) = (obj.positions.len(), obj.normals.len());
    for (c, _) in &obj.triangles {
        for c in c {
            if c.v as usize >= nv {
                return Err(format!("vertex index {} out of range ({nv} vertices)", c.v as u64 + 1));
            }
            if let Some(n) = c.vn
                && n as usize >= nn
            {
                return Err(format!("normal index {} out of range ({nn} normals)", n as u64 + 1));
            }
        }
    }
    Ok(obj)
}

fn show(t: &[u8]) -> String {
    let s = String::from_utf8_lossy(t);
    let s: String = s.chars().take(32).collect();
    s.escape_debug().to_string()
}

fn number(t: &[u8]) -> Option<f32> {
    std::str::from_utf8(t).ok()?.parse::<f32>().ok()
}

/// A 1-based (or negative, relative to the `count` defined so far) OBJ index, 0-based.
fn index(t: &[u8], count: usize, what: &str) -> Result<u32, String> {
    let i: i64 = std::str::from_utf8(t)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("invalid {what} index '{}'", show(t)))?;
    let k = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        return Err(format!("{what} index 0 (OBJ indices start at 1)"));
    };
    if k < 0 || k >= u32::MAX as i64 {
        return Err(format!("{what} index {i} out of range ({count} {what}s so far)"));
    }
    Ok(k as u32)
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`.
fn corner(t: &[u8], nv: usize, nn: usize) -> Result<Corner, String> {
    let mut parts = t.split(|&b| b == b'/');
    let v = index(parts.next().unwrap_or_default(), nv, "vertex")?;
    let _vt = parts.next();
    let vn = match parts.next() {
        Some(p) if !p.is_empty() => Some(index(p, nn, "normal")?),
        _ => None,
    };
    if parts.next().is_some() {
        return Err(format!("invalid face corner '{}'", show(t)));
    }
    Ok(Corner { v, vn })
}

/// What a smooth corner's normal comes from: the file's normal, its smoothing group's normal at the
/// file vertex, or its face (flat).
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum NormalKey {
    File(u32),
    Group(u32),
    Face(u32),
}

impl ObjFile {
    fn into_mesh(self, smooth: bool) -> Result<TriangleMesh, String> {
        if self.triangles.is_empty() {
            return Err("OBJ file contains no faces".into());
        }
        let mut mesh = TriangleMesh::default();
        if !smooth {
            let mut remap: HashMap<u32, u32> = HashMap::new();
            for (c, _) in &self.triangles {
                let t = c.map(|c| {
                    *remap.entry(c.v).or_insert_with(|| {
                        mesh.positions.push(self.positions[c.v as usize]);
                        (mesh.positions.len() - 1) as u32
                    })
                });
                mesh.triangles.push(t);
            }
            mesh.validate()?;
            return Ok(mesh);
        }
        // Angle-weighted normals per (file vertex, smoothing group) for corners without `vn`.
        let mut group_normals: HashMap<(u32, u32), DVec3> = HashMap::new();
        for (c, g) in &self.triangles {
            if *g == 0 {
                continue;
            }
            let p = c.map(|c| self.positions[c.v as usize].as_dvec3());
            let nf = (p[1] - p[0]).cross(p[2] - p[0]);
            let len = nf.length();
            if !(len > 0.0 && len.is_finite()) {
                continue; // degenerate: no direction to contribute
            }
            for k in 0..3 {
                if c[k].vn.is_some() {
                    continue;
                }
                let angle = (p[(k + 1) % 3] - p[k]).angle_between(p[(k + 2) % 3] - p[k]);
                if angle.is_finite() {
                    *group_normals.entry((c[k].v, *g)).or_default() += angle * nf / len;
                }
            }
        }
        let mut vertices: HashMap<(u32, NormalKey), u32> = HashMap::new();
        for (f, (c, g)) in self.triangles.iter().enumerate() {
            let p = c.map(|c| self.positions[c.v as usize]);
            let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            let t = c.map(|c| {
                let key = match (c.vn, *g) {
                    (Some(n), _) => NormalKey::File(n),
                    (None, 0) => NormalKey::Face(f as u32),
                    (None, g) => NormalKey::Group(g),
                };
                *vertices.entry((c.v, key)).or_insert_with(|| {
                    let n = match key {
                        NormalKey::File(n) => self.normals[n as usize].normalize_or_zero(),
                        NormalKey::Face(_) => face,
                        NormalKey::Group(g) => {
                            group_normals.get(&(c.v, g)).map_or(Vec3::ZERO, |n| n.normalize_or_zero().as_vec3())
                        }
                    };
                    mesh.positions.push(self.positions[c.v as usize]);
                    mesh.normals.push(n);
                    (mesh.positions.len() - 1) as u32
                })
            });
            mesh.triangles.push(t);
        }
        mesh.validate()?;
        Ok(mesh)
    }
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

    /// The cube with CRLF line ends, tabs, a byte-order mark, negative indices, a continuation line
    /// and trailing comments: the same mesh as [`CUBE`].
    #[test]
    fn crlf_tabs_bom_negative_indices_and_continuation() {
        let text = "\u{feff}v\t0 0 0\r\nv 1\t0 0\r\nv 1 1 0 # comment\r\nv 0 1 0\r\nv 0 0 1\r\nv 1 0 1\r\nv 1 1 1\r\n\
            v 0 1 1\r\nf -8 -5 -6 -7\r\nf 5 6 \\\r\n 7 8\r\nf 1 2 6 5\r\nf 3 4 8 7\r\nf 2 3 7 6\r\nf\t1\t5\t8\t4\r\n";
        let a = load_obj(&temp_file("crlf.obj", text), false).expect("crlf");
        let b = load_obj(&temp_file("cube_ref.obj", CUBE), false).expect("cube");
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.triangles, b.triangles);
    }

    /// `l` and `p` never become faces (a closed polyline is not a filled polygon), with a warning.
    #[test]
    fn lines_and_points_are_not_surfaces() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nl 1 2 3 4 1\np 1 2\nf 1 2 3\n";
        let (m, w) = load_obj_with_warnings(&temp_file("lines.obj", text), false).expect("load");
        assert_eq!(m.triangles.len(), 1);
        assert!(w.len() == 1 && w[0].contains("1 line (l) and 1 point (p)"), "{w:?}");
        let e = load_obj(&temp_file("only_lines.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2 3 1\n"), false).unwrap_err();
        assert!(e.to_string().contains("no faces"), "{e}");
    }

    /// Smooth normals follow the file's vertices: splitting the cube's faces into `g`/`usemtl`
    /// groups, with or without an existing `.mtl`, changes nothing; smoothing groups do.
    #[test]
    fn smooth_normals_follow_vertices_and_smoothing_groups() {
        let plain = load_obj(&temp_file("cube_plain.obj", CUBE), true).expect("plain");
        let grouped = CUBE
            .replace("f 1 2 6 5", "g side\nusemtl red\nf 1 2 6 5")
            .replace("f 2 3 7 6", "g other\nusemtl blue\nf 2 3 7 6");
        let with_mtl = format!("mtllib cube.mtl\n{grouped}");
        std::fs::write(temp_file("cube.mtl", "newmtl red\nKd 1 0 0\n"), "newmtl red\nKd 1 0 0\n").expect("mtl");
        for (name, text) in [
            ("cube_groups.obj", grouped.clone()),
            ("cube_mtl.obj", with_mtl),
            ("cube_nomtl.obj", format!("mtllib missing.mtl\n{grouped}")),
        ] {
            let m = load_obj(&temp_file(name, &text), true).expect(name);
            assert_eq!(m.positions, plain.positions, "{name}: one vertex per file vertex");
            assert_eq!(m.normals, plain.normals, "{name}: same normals");
        }
        // `s off` everywhere: flat faces (each corner carries its face normal, 4 per quad).
        let flat = load_obj(&temp_file("cube_soff.obj", &format!("s off\n{CUBE}")), true).expect("s off");
        assert_eq!(flat.positions.len(), 6 * 6);
        for t in 0..flat.len() {
            let ng = flat.face_normal_area(t).normalize();
            assert!(flat.triangles[t].iter().all(|&k| (flat.normals[k as usize] - ng).length() < 1e-6));
        }
        // Two smoothing groups: the bottom face alone in group 2 is flat-looking (its own normals),
        // the other five share normals in group 1.
        let text = CUBE.replace("f 1 4 3 2\n", "s 2\nf 1 4 3 2\ns 1\n");
        let m = load_obj(&temp_file("cube_s12.obj", &text), true).expect("s 1/2");
        assert_eq!(m.positions.len(), 8 + 4);
        let bottom = m.triangles[0];
        assert!(bottom.iter().all(|&k| (m.normals[k as usize] + Vec3::Z).length() < 1e-6));
    }
}
