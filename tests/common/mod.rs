//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod json;

use renderer::film::Film;
use renderer::render::{RenderOptions, render};
use renderer::scene::{Scene, SceneFile};
use std::path::{Path, PathBuf};

/// The repository root (where Cargo.toml is).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

pub fn grace() -> PathBuf {
    root().join("../shared/data/grace_probe.hdr")
}

/// Builds a scene from TOML text, paths relative to the repository root.
pub fn scene(toml: &str) -> Scene {
    let file = SceneFile::parse(toml).unwrap_or_else(|e| panic!("test scene does not parse: {e}\n{toml}"));
    Scene::build(file, &root()).unwrap_or_else(|e| panic!("test scene does not build: {e}"))
}

pub fn render_scene(s: &Scene) -> Film {
    render(s, &RenderOptions::default()).0
}

pub fn render_with_threads(s: &Scene, n: usize) -> Film {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    pool.install(|| render_scene(s))
}

/// A fresh temporary directory for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("reflect-it-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs the `reflect` binary: (exit code, −1 if killed; stdout; stderr).
pub fn reflect_out(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).output().expect("run reflect");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs the `reflect` binary: (exit code, stderr).
pub fn reflect(args: &[&str]) -> (i32, String) {
    let (code, _, err) = reflect_out(args);
    (code, err)
}

/// Runs the `reflect` binary, which must succeed, and parses its stdout as one JSON document.
pub fn reflect_json(args: &[&str]) -> serde_json::Value {
    let (code, stdout, stderr) = reflect_out(args);
    assert_eq!(code, 0, "{args:?}: {stderr}");
    serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("{args:?}: bad JSON ({e}): {stdout}"))
}

/// Bad input through the binary: exit 2, one line on stderr naming `names` and mentioning
/// `mentions` (case-insensitive), and no file at `out`.
pub fn assert_bad_input(args: &[&str], names: &str, mentions: &str, out: &Path) {
    let (code, err) = reflect(args);
    assert_eq!(code, 2, "exit code for {args:?}; stderr: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line expected for {args:?}, got: {err}");
    assert!(lines[0].contains(names), "error should name {names}: {err}");
    assert!(lines[0].to_lowercase().contains(&mentions.to_lowercase()), "error should mention {mentions:?}: {err}");
    assert!(!out.exists(), "no output file may be written for {args:?}");
}

/// Writes `toml` to `dir/NAME.toml` and renders it with the binary to `dir/NAME` (an `.exr` name);
/// returns the EXR's path.
pub fn render_to(dir: &Path, name: &str, toml: &str) -> String {
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, toml).unwrap();
    let out = dir.join(name);
    let (code, err) = reflect(&["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--quiet"]);
    assert_eq!(code, 0, "{err}");
    out.to_str().unwrap().to_string()
}

pub fn exists(p: &Path) -> bool {
    p.exists()
}

/// A closed triangle mesh as OBJ text: a spherical shell of inner radius `r_in` and outer radius
/// `r_out` about the origin with an opening of half-angle `theta_open` (radians) about +z, the two
/// walls joined by a conical rim at the opening. Faces are wound so that every geometric normal
/// points out of the shell's material (the inner wall's normals point into the cavity), so the
/// mesh is closed, consistently wound, with positive volume. `n_theta` rings from the rim to the
/// bottom pole, `n_phi` segments around.
pub fn open_shell_obj(r_in: f64, r_out: f64, theta_open: f64, n_theta: usize, n_phi: usize) -> String {
    use std::f64::consts::PI;
    use std::fmt::Write;
    let dir = |theta: f64, phi: f64| [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
    let mut v: Vec<[f64; 3]> = Vec::new();
    // Per wall: n_theta rings of n_phi vertices (ring 0 at the rim), then the pole.
    let mut wall = |r: f64| {
        let base = v.len();
        for i in 0..n_theta {
            let theta = theta_open + (PI - theta_open) * i as f64 / n_theta as f64;
            for j in 0..n_phi {
                v.push(dir(theta, 2.0 * PI * j as f64 / n_phi as f64).map(|c| r * c));
            }
        }
        v.push([0.0, 0.0, -r]);
        base
    };
    let (outer, inner) = (wall(r_out), wall(r_in));
    let ring = |base: usize, i: usize, j: usize| {
        if i == n_theta { base + n_theta * n_phi } else { base + i * n_phi + j % n_phi }
    };
    // (triangle, wall sign): +1 outer (normal along the position), −1 inner, 0 rim.
    let mut faces: Vec<([usize; 3], i32)> = Vec::new();
    for (base, sign) in [(outer, 1), (inner, -1)] {
        for i in 0..n_theta {
            for j in 0..n_phi {
                let (a, b, c, d) =
                    (ring(base, i, j), ring(base, i, j + 1), ring(base, i + 1, j + 1), ring(base, i + 1, j));
                faces.push(([a, b, c], sign));
                if i + 1 < n_theta {
                    faces.push(([a, c, d], sign));
                }
            }
        }
    }
    for j in 0..n_phi {
        let (a, b, c, d) = (ring(outer, 0, j), ring(outer, 0, j + 1), ring(inner, 0, j + 1), ring(inner, 0, j));
        faces.push(([a, b, c], 0));
        faces.push(([a, c, d], 0));
    }
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let mut out = String::new();
    for p in &v {
        writeln!(out, "v {} {} {}", p[0], p[1], p[2]).unwrap();
    }
    for (t, sign) in faces {
        let [a, b, c] = t.map(|k| v[k]);
        let (e1, e2) = (sub(b, a), sub(c, a));
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let m = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
        // Where the face's normal should point: away from the origin (outer), towards it (inner),
        // or out of the rim's cone, −e_θ = (−cos θ cos φ, −cos θ sin φ, sin θ).
        let phi = m[1].atan2(m[0]);
        let want = match sign {
            0 => [-theta_open.cos() * phi.cos(), -theta_open.cos() * phi.sin(), theta_open.sin()],
            s => m.map(|c| s as f64 * c),
        };
        let t = if n[0] * want[0] + n[1] * want[1] + n[2] * want[2] < 0.0 { [t[0], t[2], t[1]] } else { t };
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
    }
    out
}

/// Renders `scenes/{brdf}-grace.toml` as shipped but seen from `from` (a TOML array, e.g.
/// `"[-3.0, 0.0, -1.0]"`) with the binary to `dir/NAME.exr`, with `--seed` when given (the
/// scene's default otherwise); the Grace path is made absolute so the scene may live in `dir`.
/// The partial-view tests' one render helper.
pub fn render_view(dir: &Path, brdf: &str, name: &str, from: &str, seed: Option<u64>) -> PathBuf {
    let text = std::fs::read_to_string(root().join(format!("scenes/{brdf}-grace.toml")))
        .unwrap()
        .replace("from = [3.0, 0.0, 1.0]", &format!("from = {from}"))
        .replace("\"../../shared/data/", &format!("\"{}/", root().join("../shared/data").display()));
    let scene = dir.join(format!("{name}.toml"));
    std::fs::write(&scene, text).unwrap();
    let out = dir.join(format!("{name}.exr"));
    let seed = seed.map(|s| s.to_string());
    let mut args = vec!["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"];
    if let Some(s) = &seed {
        args.extend(["--seed", s.as_str()]);
    }
    let (code, _, err) = reflect_out(&args);
    assert_eq!(code, 0, "{err}");
    out
}

/// ∫ over the upper hemisphere of n = +z of f(ω_i, ω_o) dω_i for ω_o at θ_o (radians) in the
/// xz-plane (f includes the cosine): the directional albedo of a BRDF oracle under uniform radiance 1.
/// Midpoint rule in (θ, φ) with exact cell solid angles; θ = π/2 is a cell edge, so the horizon cut is
/// exact. Error O(h²·w⁻²) for a lobe of width w: < 1e-5 at 1500 × 3000 cells for w ≥ 0.1 (halving h
/// moves the results by < 3e-6).
pub fn albedo(theta_o: f64, f: &dyn Fn([f64; 3], [f64; 3]) -> f64) -> f64 {
    use std::f64::consts::PI;
    let wo = [theta_o.sin(), 0.0, theta_o.cos()];
    let (nt, np) = (1500, 3000);
    let mut sum = 0.0;
    for i in 0..nt {
        let (t0, t1) = (0.5 * PI * i as f64 / nt as f64, 0.5 * PI * (i + 1) as f64 / nt as f64);
        let t = 0.5 * (t0 + t1);
        let dw = (t0.cos() - t1.cos()) * 2.0 * PI / np as f64;
        for j in 0..np {
            let p = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            sum += f([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()], wo) * dw;
        }
    }
    sum
}

/// Oracle of `microfacet` with F = 1 (docs/src/conventions.md §4), times cos θ_i: ρ̂ = D G / (4 cos θ_o),
/// D of Beckmann or GGX, Smith's Λ in closed form, and G height-correlated 1/(1 + Λ_o + Λ_i) or, for
/// the check that the renders can tell them apart, separable 1/((1 + Λ_o)(1 + Λ_i)).
pub fn microfacet(ggx: bool, alpha: f64, height_correlated: bool) -> impl Fn([f64; 3], [f64; 3]) -> f64 {
    use std::f64::consts::PI;
    move |wi: [f64; 3], wo: [f64; 3]| {
        let lambda = |c: f64| {
            let s = (1.0 - c * c).max(0.0).sqrt();
            if s == 0.0 {
                0.0
            } else if ggx {
                0.5 * ((1.0 + alpha * alpha * s * s / (c * c)).sqrt() - 1.0)
            } else {
                let a = c / (alpha * s);
                -0.5 * analysis::special::erfc(a) + (-a * a).exp() / (2.0 * a * PI.sqrt())
            }
        };
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let ch = h[2] / (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let c2 = ch * ch;
        let d = if ggx {
            let t = (alpha * alpha - 1.0) * c2 + 1.0;
            alpha * alpha / (PI * t * t)
        } else {
            (-(1.0 - c2) / (c2 * alpha * alpha)).exp() / (PI * alpha * alpha * c2 * c2)
        };
        let (lo, li) = (lambda(wo[2]), lambda(wi[2]));
        let g = if height_correlated { 1.0 / (1.0 + lo + li) } else { 1.0 / ((1.0 + lo) * (1.0 + li)) };
        d * g / (4.0 * wo[2])
    }
}

/// pbrt-v4's `worldToCamera` and `worldToNDC` for an orthographic LookAt camera (column vectors,
/// stored row by row): camera x = normalize(up × dir) (pbrt's left-handed LookAt), y = dir × x,
/// z = dir; NDC = ½ screen + ½ with screen = camera xy / extent, z over [0, 10]. An image made
/// through it is our image of the same camera with its columns mirrored.
pub fn pbrt_matrices(from: [f64; 3], to: [f64; 3], up: [f64; 3], extent: f64) -> ([f32; 16], [f32; 16]) {
    use glam::DVec3;
    let from = DVec3::from(from);
    let dir = (DVec3::from(to) - from).normalize();
    let x = DVec3::from(up).cross(dir).normalize();
    let y = dir.cross(x);
    let mut cam = [0f32; 16];
    let mut ndc = [0f32; 16];
    let (sx, sz) = (0.5 / extent, 0.5 / 10.0);
    for (i, r) in [x, y, dir].iter().enumerate() {
        let t = -r.dot(from);
        let s = if i < 2 { sx } else { sz };
        for j in 0..3 {
            cam[4 * i + j] = r[j] as f32;
            ndc[4 * i + j] = (s * r[j]) as f32;
        }
        cam[4 * i + 3] = t as f32;
        ndc[4 * i + 3] = (s * t + 0.5) as f32;
    }
    cam[15] = 1.0;
    ndc[15] = 1.0;
    (cam, ndc)
}
