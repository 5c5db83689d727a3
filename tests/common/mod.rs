//! Helpers shared by the integration tests.
#![allow(dead_code)]

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
