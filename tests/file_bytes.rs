//! The same inputs give the same file bytes, for every writer of the binary: a render, its shards
//! (partial renders), merges of them (flat and in a tree), and the PNG preview. Each command runs
//! several times in separate processes on an image of several 64² EXR tiles, where the `exr` crate's
//! compression threads could finish in any order; the files must be equal byte for byte.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn ok(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).output().unwrap();
    assert!(o.status.success(), "reflect {args:?} failed: {}", String::from_utf8_lossy(&o.stderr));
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A scene of the default sphere at 200 × 136 (4 × 3 tiles), 8 spp.
fn scene_file(dir: &Path) -> PathBuf {
    let mut f = renderer::scene::SceneFile::parse(renderer::scene::build::DEFAULT_SCENE).unwrap();
    f.render.width = 200;
    f.render.height = 136;
    f.render.spp = 8;
    let p = dir.join("scene.toml");
    std::fs::write(&p, toml::to_string(&f).unwrap()).unwrap();
    p
}

/// Runs `make(i)` (which writes file i) `n` times and asserts that all the files are the same bytes.
fn same_bytes(what: &str, n: usize, make: impl Fn(usize) -> PathBuf) {
    let files: Vec<(PathBuf, Vec<u8>)> = (0..n)
        .map(|i| {
            let p = make(i);
            let b = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p, b)
        })
        .collect();
    for (p, b) in &files[1..] {
        assert!(b == &files[0].1, "{what}: {} and {} differ", files[0].0.display(), p.display());
    }
}

#[test]
fn every_writer_gives_the_same_bytes_for_the_same_inputs() {
    let dir = common::temp_dir("file-bytes");
    let scene = scene_file(&dir);
    let at = |name: String| dir.join(name);
    same_bytes("render", 3, |i| {
        let out = at(format!("render{i}.exr"));
        ok(&["render", s(&scene), "--out", s(&out), "--threads", "2", "--quiet"]);
        out
    });
    // Shards: 3 parts, each written twice.
    for k in 0..3 {
        same_bytes("shard", 2, |i| {
            let out = at(format!("part{k}-{i}.exr"));
            ok(&["render", s(&scene), "--shard", &format!("{k}/3"), "--out", s(&out), "--quiet"]);
            out
        });
    }
    let part = |k: usize| at(format!("part{k}-0.exr"));
    same_bytes("flat merge", 6, |i| {
        let out = at(format!("merge{i}.exr"));
        ok(&["merge", s(&part(0)), s(&part(1)), s(&part(2)), "--out", s(&out), "--quiet"]);
        out
    });
    same_bytes("partial merge", 4, |i| {
        let out = at(format!("mid{i}.exr"));
        ok(&["merge", s(&part(2)), s(&part(1)), "--partial", "--out", s(&out), "--quiet"]);
        out
    });
    same_bytes("tree merge", 4, |i| {
        let out = at(format!("tree{i}.exr"));
        ok(&["merge", s(&part(0)), s(&at("mid0.exr".into())), "--out", s(&out), "--quiet"]);
        out
    });
    same_bytes("png", 3, |i| {
        let out = at(format!("preview{i}.png"));
        ok(&["png", s(&at("render0.exr".into())), "--out", s(&out)]);
        out
    });
    // The merged image is the render itself, byte for byte (same pixels, same header).
    same_bytes("merge = render", 2, |i| at(if i == 0 { "render0.exr".into() } else { "merge0.exr".into() }));
    let _ = std::fs::remove_dir_all(&dir);
}
