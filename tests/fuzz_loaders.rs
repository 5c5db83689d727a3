//! Bounded mutation fuzzing of the loaders (scene TOML, OBJ, glTF/GLB), on stable Rust: seeds from
//! `../shared/cases`, `scenes/` and small inline files; a few thousand mutated inputs per loader;
//! each input in a worker thread with a time bound; a counting global allocator with a budget per
//! input and a hard cap per request. No input may panic, hang, allocate more than it can justify,
//! or fail with anything but a one-line error naming the file.
//!
//! Longer run: `REFLECT_FUZZ_ITERS=100000 cargo test --release --test fuzz_loaders -- --nocapture`.

#[path = "common/fuzz.rs"]
mod fuzz;

use fuzz::{FuzzConfig, check_error_line, seed_files};
use renderer::geometry::{gltf::load_gltf, obj::load_obj};
use renderer::scene::Scene;
use std::path::{Path, PathBuf};

#[global_allocator]
static ALLOC: fuzz::CountingAlloc = fuzz::CountingAlloc;

/// No single allocation of the loaders may exceed this (the files are at most a few KB).
const HARD_CAP: usize = 1 << 30;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn cases() -> PathBuf {
    root().join("../shared/cases")
}

fn read_seeds(paths: &[PathBuf]) -> Vec<Vec<u8>> {
    paths.iter().filter_map(|p| std::fs::read(p).ok()).collect()
}

fn work_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("fuzz work dir");
    d
}

/// Small OBJ files with the features the parser must handle (BOM, CRLF, tabs, negative indices,
/// smoothing groups, lines and points, texture coordinates, continuation lines).
const OBJ_SEEDS: &[&str] = &[
    "\u{feff}v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 0 0 1\r\nf 1 3 2\r\nf 1 2 4\r\nf 1 4 3\r\nf 2 3 4\r\n",
    "v\t0 0 0\nv 1\t0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\ns 1\nf -3/-2/-1 -2/-1/-1 -1/-1/-1\ns off\nl 1 2 3\np 1\n",
    "o a\ng x\nusemtl m\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 \\\n 3 4\n",
];

const OBJ_DICT: &[&[u8]] = &[
    b"v ",
    b"vn ",
    b"vt ",
    b"f ",
    b"l ",
    b"p ",
    b"s ",
    b"s off\n",
    b"g ",
    b"o ",
    b"usemtl ",
    b"mtllib ",
    b"/",
    b"//",
    b"\n",
    b"\r\n",
    b"\\\n",
    b"\xef\xbb\xbf",
    b"-",
];

#[test]
fn fuzz_obj() {
    fuzz::set_hard_cap(HARD_CAP);
    let mut seeds = read_seeds(&seed_files(&cases(), &[".obj"], 64 << 10));
    seeds.extend(read_seeds(&seed_files(&root().join("scenes"), &[".obj"], 64 << 10)));
    seeds.extend(OBJ_SEEDS.iter().map(|s| s.as_bytes().to_vec()));
    let dir = work_dir("obj");
    let run = |smooth: bool, seed: u64| {
        let path = dir.join(format!("input{}.obj", smooth as u8));
        let cfg = FuzzConfig { seed, ..FuzzConfig::new(if smooth { "obj-smooth" } else { "obj-flat" }) };
        fuzz::run(&cfg, &seeds, OBJ_DICT, move |bytes| {
            std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
            match load_obj(&path, smooth) {
                Ok(m) => m.validate().map(|_| true).map_err(|e| format!("accepted an invalid mesh: {e}")),
                Err(e) => check_error_line(&e.to_string(), "input"),
            }
        })
    };
    run(false, 11);
    run(true, 12);
}

const GLTF_DICT: &[&[u8]] = &[
    b"\"mode\": 5, ",
    b"\"mode\": 6, ",
    b"\"mode\": 1, ",
    b"\"children\": [0], ",
    b"\"byteStride\": 4, ",
    b"\"normalized\": true, ",
    b"\"componentType\": 5121, ",
    b"\"componentType\": 5122, ",
    b"\"componentType\": 5120, ",
    b"\"sparse\": {\"count\": 1, \"indices\": {\"bufferView\": 0, \"componentType\": 5123}, \"values\": {\"bufferView\": 0}}, ",
    b"\"matrix\": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1], ",
    b"\"scale\": [-1, 1, 1], ",
    b"\"NORMAL\": 0, ",
    b"\"uri\": \"%ff.bin\", ",
    b"\"extensionsRequired\": [\"KHR_mesh_quantization\"], ",
    b"\"type\": \"VEC2\"",
    b"\"type\": \"MAT4\"",
    b"{\"mesh\": 0}, ",
];

/// Wraps a glTF JSON document into a GLB container (JSON chunk only, or with `bin`).
fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let mut j = json.to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let bin_len = bin.map_or(0, |b| 8 + b.len().next_multiple_of(4));
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + j.len() + bin_len) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if let Some(b) = bin {
        let mut b = b.to_vec();
        b.resize(b.len().next_multiple_of(4), 0);
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    out
}

#[test]
fn fuzz_gltf() {
    fuzz::set_hard_cap(HARD_CAP);
    let mut paths = seed_files(&cases(), &[".gltf", ".glb"], 64 << 10);
    paths.extend(seed_files(&root().join("scenes"), &[".gltf", ".glb"], 64 << 10));
    let mut seeds = read_seeds(&paths);
    // A GLB seed: the first case's JSON (its buffer stays a data URI) in a binary container, and
    // one with a BIN chunk holding a tiny triangle.
    let bin: Vec<u8> =
        [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|x| x.to_le_bytes()).chain([0u8, 1, 2, 0]).collect();
    let tri = br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],"buffers":[{"byteLength":40}],
"bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":3}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5121,"count":3,"type":"SCALAR"}]}"#;
    seeds.push(glb(tri, Some(&bin)));
    if let Some(first) = seeds.first().cloned() {
        seeds.push(glb(&first, None));
    }
    let dir = work_dir("gltf");
    let run = |ext: &'static str, smooth: bool, seed: u64| {
        let path = dir.join(format!("input{}.{ext}", smooth as u8));
        let cfg = FuzzConfig { seed, ..FuzzConfig::new(if smooth { "gltf-smooth" } else { "gltf-flat" }) };
        fuzz::run(&cfg, &seeds, GLTF_DICT, move |bytes| {
            std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
            match load_gltf(&path, smooth) {
                Ok(m) => m.validate().map(|_| true).map_err(|e| format!("accepted an invalid mesh: {e}")),
                Err(e) => check_error_line(&e.to_string(), "input"),
            }
        })
    };
    run("gltf", false, 21);
    run("glb", true, 22);
}

const TOML_DICT: &[&[u8]] = &[
    b"[render]\n",
    b"[camera]\n",
    b"[lighting]\n",
    b"[[objects]]\n",
    b"width = ",
    b"spp = ",
    b"max_depth = ",
    b"type = \"envmap\"\n",
    b"type = \"sh\"\n",
    b"type = \"normal_probe\"\n",
    b"shape = \"mesh\"\n",
    b"file = \"reference.obj\"\n",
    b"file = \"u16.gltf\"\n",
    b"smooth = true\n",
    b"brdf = { type = \"microfacet\", roughness = 0.3 }\n",
    b"[",
    b"]",
    b"\"",
    b"=",
];

/// The scene loader builds the whole scene (meshes, lights, BVH), so its inputs reference small
/// files copied next to it.
#[test]
fn fuzz_scene_toml() {
    fuzz::set_hard_cap(HARD_CAP);
    let mut paths = seed_files(&cases(), &[".toml"], 16 << 10);
    paths.extend(seed_files(&root().join("scenes"), &[".toml"], 16 << 10));
    let seeds = read_seeds(&paths);
    let dir = work_dir("scene");
    // Mesh files the seeds name, next to the mutated scene (other referenced files are missing,
    // which must be a clean error).
    for p in seed_files(&cases(), &[".obj", ".gltf"], 16 << 10) {
        let _ = std::fs::copy(&p, dir.join(p.file_name().expect("file name")));
    }
    let path = dir.join("input.toml");
    let dir_s = dir.to_string_lossy().into_owned();
    // Scenes may legitimately describe up to 16384² pixels, but building one allocates no film;
    // meshes here are small.
    let cfg = FuzzConfig { seed: 31, ..FuzzConfig::new("scene-toml") };
    fuzz::run(&cfg, &seeds, TOML_DICT, move |bytes| {
        std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
        match Scene::load(&path) {
            Ok(_) => Ok(true),
            // The error names the scene or a file it refers to (possibly by an absolute path
            // elsewhere, e.g. a mutated `file = "/x.exr"`).
            Err(e) => {
                let e = e.to_string();
                if e.starts_with('/') && !e.contains('\n') { Ok(false) } else { check_error_line(&e, &dir_s) }
            }
        }
    });
}

#[test]
fn mutator_is_deterministic() {
    let seed = b"v 0 0 0\nf 1 2 3\n".to_vec();
    let a: Vec<Vec<u8>> = {
        let mut m = fuzz::Mutator::new(7);
        (0..50).map(|_| m.mutate(&seed, &[], OBJ_DICT)).collect()
    };
    let mut m = fuzz::Mutator::new(7);
    let b: Vec<Vec<u8>> = (0..50).map(|_| m.mutate(&seed, &[], OBJ_DICT)).collect();
    assert_eq!(a, b);
    assert!(a.iter().any(|x| x != &seed), "mutations change the input");
    let _ = Path::new("");
}
