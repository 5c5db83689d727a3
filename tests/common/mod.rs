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
