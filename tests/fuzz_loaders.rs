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

/// A disc as one OBJ polygon of `n` corners (fan-triangulated into slivers sharing its first
/// corner: the `mesh-long-fan` kind at a fuzzable size).
fn long_polygon_obj(n: usize) -> String {
    let mut s = String::new();
    for i in 0..n {
        let a = std::f32::consts::TAU * i as f32 / n as f32;
        s.push_str(&format!("v 0 {:?} {:?}\n", a.cos(), a.sin()));
    }
    s.push('f');
    for i in 1..=n {
        s.push_str(&format!(" {i}"));
    }
    s.push('\n');
    s
}

/// The same disc as a GLB with one TRIANGLE_FAN primitive of `n` vertices.
fn long_fan_glb(n: usize) -> Vec<u8> {
    let bin: Vec<u8> = (0..n)
        .flat_map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            [0.0, a.cos(), a.sin()]
        })
        .flat_map(|x: f32| x.to_le_bytes())
        .collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":6}}]}}],"buffers":[{{"byteLength":{}}}],
"bufferViews":[{{"buffer":0,"byteLength":{}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{n},"type":"VEC3","min":[0,-1,-1],"max":[0,1,1]}}]}}"#,
        bin.len(),
        bin.len()
    );
    glb(json.as_bytes(), Some(&bin))
}

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
    seeds.push(long_polygon_obj(2000).into_bytes());
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
    b"\"weights\": [0.5, 1], ",
    b"\"weights\": [1e39], ",
    b"\"targets\": [{\"POSITION\": 0, \"NORMAL\": 1}], ",
    b"\"skin\": 0, ",
    b"\"skins\": [{\"joints\": [0]}], ",
    b"\"extensionsRequired\": [\"EXT_foo\"], ",
    b"\"extensions\": {\"EXT_mesh_gpu_instancing\": {\"attributes\": {\"TRANSLATION\": 0, \"ROTATION\": 1}}}, ",
    b"\"extensions\": {\"KHR_draco_mesh_compression\": {}}, ",
];

/// GLB seeds of the geometry-changing features (issue 33): a triangle with two morph targets (one
/// sparse, without a buffer view; NORMAL displacements) under mesh and node weights, and the
/// triangle instanced three times by `EXT_mesh_gpu_instancing` (ROTATION as normalized i16).
fn morph_and_instancing_seeds() -> Vec<Vec<u8>> {
    let f32s = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let tri = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.];
    let mut morph = f32s(&tri);
    morph.extend(f32s(&[0., 0., 1., 0., 0., 1., 0., 0., 1.]));
    morph.extend(f32s(&[0., 0., 1., 0., 0., 1., 0., 0., 1.]));
    morph.extend([2, 0, 0, 0]);
    morph.extend(f32s(&[1., 0., 0.]));
    morph.extend(f32s(&[1., 0., 0., 1., 0., 0., 1., 0., 0.]));
    let morph_json = br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],
"nodes":[{"mesh":0},{"mesh":0,"weights":[1,0.5],"translation":[2,0,0]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"targets":[{"POSITION":2,"NORMAL":4},{"POSITION":3}]}],"weights":[0.5,0.25]}],
"buffers":[{"byteLength":160}],
"bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":36},{"buffer":0,"byteOffset":72,"byteLength":36},
{"buffer":0,"byteOffset":108,"byteLength":1},{"buffer":0,"byteOffset":112,"byteLength":12},{"buffer":0,"byteOffset":124,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"},
{"bufferView":2,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,1],"max":[0,0,1]},
{"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,0,0],"sparse":{"count":1,"indices":{"bufferView":3,"componentType":5121},"values":{"bufferView":4}}},
{"bufferView":5,"componentType":5126,"count":3,"type":"VEC3"}]}"#;
    let mut inst = f32s(&tri);
    inst.extend(f32s(&[0., 0., 0., 2., 0., 0., 0., 2., 0.]));
    inst.extend([0i16, 0, 0, 32767, 0, 0, 23170, 23170, 0, 0, 0, 32767].iter().flat_map(|x| x.to_le_bytes()));
    inst.extend(f32s(&[1., 1., 1., 1., 1., 1., 2., 2., 2.]));
    let inst_json = br#"{"asset":{"version":"2.0"},"extensionsUsed":["EXT_mesh_gpu_instancing"],"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":1,"ROTATION":2,"SCALE":3}}}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"buffers":[{"byteLength":132}],
"bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":36},{"buffer":0,"byteOffset":72,"byteLength":24},{"buffer":0,"byteOffset":96,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"},
{"bufferView":2,"componentType":5122,"normalized":true,"count":3,"type":"VEC4"},
{"bufferView":3,"componentType":5126,"count":3,"type":"VEC3"}]}"#;
    vec![glb(morph_json, Some(&morph)), glb(inst_json, Some(&inst))]
}

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
    seeds.push(long_fan_glb(2000));
    let dir = work_dir("gltf");
    for (k, seed) in morph_and_instancing_seeds().into_iter().enumerate() {
        let p = dir.join(format!("seed{k}.glb"));
        std::fs::write(&p, &seed).expect("write seed");
        load_gltf(&p, true).unwrap_or_else(|e| panic!("seed {k} loads: {e}"));
        seeds.push(seed);
    }
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
    b"file = \"fan.obj\"\n",
    b"radius = 1e10\n",
    b"scale = 1e9\n",
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
    let mut seeds = read_seeds(&paths);
    let dir = work_dir("scene");
    // Mesh files the seeds name, next to the mutated scene (other referenced files are missing,
    // which must be a clean error).
    for p in seed_files(&cases(), &[".obj", ".gltf"], 16 << 10) {
        let _ = std::fs::copy(&p, dir.join(p.file_name().expect("file name")));
    }
    // Extreme scale and long fans: spheres about the reach limit, and a fan of slivers large
    // enough for the BVH's degenerate-input path, scaled about the limit.
    std::fs::write(dir.join("fan.obj"), long_polygon_obj(5000)).expect("fan seed");
    for (shape, size) in
        [("sphere", "1e9"), ("sphere", "1e10"), ("sphere", "1.1e10"), ("sphere", "3e38"), ("mesh", "4e9")]
    {
        let object = if shape == "sphere" {
            format!("shape = \"sphere\"\ncenter = [0.0, 0.0, -{size}]\nradius = {size}")
        } else {
            format!("shape = \"mesh\"\nfile = \"fan.obj\"\nsmooth = false\nscale = {size}")
        };
        seeds.push(
            format!(
                "[render]\nwidth = 8\nheight = 8\nspp = 1\n[camera]\ntype = \"orthographic\"\nfrom = [5.0, 0.0, 1.0]\n\
                 to = [0.0, 0.0, 0.0]\nextent = 2.0\n[lighting]\ntype = \"uniform\"\nradiance = 1.0\n[[objects]]\n{object}\n\
                 brdf = {{ type = \"lambert\", albedo = 0.5 }}\n[[objects]]\nshape = \"sphere\"\n\
                 brdf = {{ type = \"lambert\", albedo = 0.5 }}\n"
            )
            .into_bytes(),
        );
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

// ---------------------------------------------------------------- images (.hdr, .exr)

/// Bytes a Radiance file may cost: its pixels (allocated once a first scanline decoded, at most
/// 2048 × the file with a 1 MiB floor, times the decoder's copy and ours) plus the default budget.
fn hdr_budget(input: &[u8]) -> usize {
    (4 << 20) + 64 * input.len() + 3 * (input.len() * 2048).max(1 << 20)
}

/// Bytes an OpenEXR file may cost: 3 × the decoded samples its headers claim (the reader's own
/// count, `vocab::image::exr_claimed_bytes`, which it refuses above `EXR_MAX_DECODED_BYTES`; a
/// file whose headers do not parse claims nothing) plus the default budget. So a file may allocate
/// what it declares and no more, whatever its compression ratio.
fn exr_budget(input: &[u8]) -> usize {
    let claim = analysis::image::exr_claimed_bytes(input).unwrap_or(0);
    let claim = if claim > analysis::image::EXR_MAX_DECODED_BYTES { 0 } else { claim as usize };
    (4 << 20) + 64 * input.len() + 3 * claim
}

/// Small Radiance files: flat, adaptive run-length and old run-length scanlines, every orientation
/// form, EXPOSURE and COLORCORR lines.
fn hdr_seeds() -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let px = |i: usize| [(i * 37 % 256) as u8, (i * 11 % 256) as u8, 200, 128 + (i % 5) as u8];
    for (res, w, n) in [("-Y 3 +X 4", 4, 3), ("+X 4 -Y 3", 3, 4), ("+Y 2 -X 2", 2, 2)] {
        let mut f =
            format!("#?RADIANCE\nEXPOSURE=2\nCOLORCORR=1 1 0.5\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes();
        (0..w * n).for_each(|i| f.extend(px(i)));
        out.push(f);
    }
    // Adaptive run-length encoding, 16 wide: a run and literals in each channel.
    let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 16\n".to_vec();
    for _ in 0..2 {
        f.extend([2, 2, 0, 16]);
        for ch in 0..4u8 {
            f.extend([128 + 12, 100 + ch, 4, 1, 2, 3, 4]);
        }
    }
    out.push(f);
    // Declared primaries: ACES AP0 (converted), Rec. 709 (kept as stored).
    for prims in ["0.7347 0.2653 0 1 0.0001 -0.077 0.32168 0.33767", "0.64 0.33 0.3 0.6 0.15 0.06 0.3127 0.329"] {
        let mut f = format!("#?RADIANCE\nPRIMARIES={prims}\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n").into_bytes();
        (0..6).for_each(|i| f.extend(px(i)));
        out.push(f);
    }
    // Old run-length encoding.
    let mut f = b"#?RGBE\n\n-Y 2 +X 300\n".to_vec();
    for _ in 0..2 {
        f.extend([128, 64, 32, 129, 1, 1, 1, 43, 1, 1, 1, 1]);
    }
    out.push(f);
    out
}

const HDR_DICT: &[&[u8]] = &[
    b"#?RADIANCE\n",
    b"FORMAT=32-bit_rle_rgbe\n",
    b"FORMAT=32-bit_rle_xyze\n",
    b"EXPOSURE=",
    b"COLORCORR=",
    b"PRIMARIES=",
    b" 0.3127 0.329",
    b" -0.077",
    b"\n\n",
    b"-Y ",
    b"+Y ",
    b" +X ",
    b" -X ",
    b"32768",
    b"65535",
    b"\x02\x02\x00\x10",
    b"\x02\x02\x7f\xff",
    b"\x01\x01\x01\xff",
    b"\xff",
];

#[test]
fn fuzz_hdr() {
    fuzz::set_hard_cap(HARD_CAP);
    let mut seeds = read_seeds(&seed_files(&cases(), &[".hdr"], 64 << 10));
    seeds.extend(hdr_seeds());
    let dir = work_dir("hdr");
    let path = dir.join("input.hdr");
    let cfg = FuzzConfig { seed: 41, alloc_budget: hdr_budget, ..FuzzConfig::new("hdr") };
    fuzz::run(&cfg, &seeds, HDR_DICT, move |bytes| {
        std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
        match analysis::image::read_image(&path) {
            Ok(img) => check_image(&img),
            Err(e) => check_error_line(&e.to_string(), "input"),
        }
    });
}

/// An accepted image has consistent channel sizes and finite values (the loader's contract).
fn check_image(img: &analysis::image::Image) -> Result<bool, String> {
    for (name, v) in &img.channels {
        if v.len() != img.width * img.height {
            return Err(format!("channel {name} has {} samples for {}×{}", v.len(), img.width, img.height));
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("channel {name} has a non-finite value"));
        }
    }
    Ok(true)
}

/// Small OpenEXR files of the variants the reader must handle: every compression, scanlines and
/// tiles, a mip map, half and float samples, a data window inside and around the display window,
/// several parts.
fn exr_seeds(dir: &Path) -> Vec<Vec<u8>> {
    use exr::prelude::*;
    let mut out = Vec::new();
    let chans = |w: usize, h: usize, half: bool| {
        let list: Vec<AnyChannel<FlatSamples>> = ["B", "G", "R"]
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let v: Vec<f32> = (0..w * h).map(|i| (i + k) as f32 * 0.5).collect();
                let s = if half {
                    FlatSamples::F16(v.iter().map(|&x| f16::from_f32(x)).collect())
                } else {
                    FlatSamples::F32(v)
                };
                AnyChannel::new(Text::from(*c), s)
            })
            .collect();
        AnyChannels::sort(list.into_iter().collect())
    };
    let p = dir.join("seed.exr");
    let mut push = |img: Image<Layers<AnyChannels<FlatSamples>>>| {
        if img.write().to_file(&p).is_ok() {
            out.extend(std::fs::read(&p).ok());
        }
    };
    let comps = [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP1,
        Compression::ZIP16,
        Compression::PIZ,
        Compression::PXR24,
        Compression::B44,
    ];
    for (i, c) in comps.into_iter().enumerate() {
        let blocks = if i % 2 == 0 { Blocks::ScanLines } else { Blocks::Tiles(Vec2(4, 4)) };
        let enc = Encoding { compression: c, blocks, line_order: LineOrder::Increasing };
        let layer = Layer::new((6, 5), LayerAttributes::default(), enc, chans(6, 5, i % 3 == 0));
        push(Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((6, 5))), vec![layer]));
    }
    // Data window offset inside a larger display window, and two parts.
    let mut attrs = LayerAttributes::named("beauty");
    attrs.layer_position = Vec2(2, 1);
    let a = Layer::new((4, 3), attrs, Encoding::SMALL_LOSSLESS, chans(4, 3, false));
    let z = Layer::new(
        (4, 3),
        LayerAttributes::named("depth"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(
            vec![AnyChannel::new(Text::from("Z"), FlatSamples::F32(vec![1.0; 12]))].into_iter().collect(),
        ),
    );
    push(Image::from_layers(ImageAttributes::new(IntegerBounds::new((0, 0), (8, 6))), vec![z, a]));
    // An AOV part before the beauty part, and a part whose channels already carry its name.
    let aov = Layer::new((4, 3), LayerAttributes::named("diffuse"), Encoding::SMALL_LOSSLESS, chans(4, 3, true));
    let beauty = Layer::new((4, 3), LayerAttributes::named("rgba"), Encoding::UNCOMPRESSED, chans(4, 3, false));
    let named = Layer::new(
        (4, 3),
        LayerAttributes::named("spec"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(
            vec![AnyChannel::new(Text::from("spec.Y"), FlatSamples::F32(vec![0.5; 12]))].into_iter().collect(),
        ),
    );
    push(Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((4, 3))), vec![aov, beauty, named]));
    // Declared chromaticities: ACES AP0 (converted) and Rec. 709 (kept as stored).
    for c in [
        [0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.077, 0.32168, 0.33767],
        [0.64, 0.33, 0.3, 0.6, 0.15, 0.06, 0.3127, 0.329],
    ] {
        let layer = Layer::new((6, 5), LayerAttributes::default(), Encoding::UNCOMPRESSED, chans(6, 5, true));
        let mut attrs = ImageAttributes::new(IntegerBounds::from_dimensions((6, 5)));
        attrs.chromaticities = Some(exr::meta::attribute::Chromaticities {
            red: Vec2(c[0], c[1]),
            green: Vec2(c[2], c[3]),
            blue: Vec2(c[4], c[5]),
            white: Vec2(c[6], c[7]),
        });
        push(Image::from_layers(attrs, vec![layer]));
    }
    // A mip-mapped tiled file.
    let lv = |w: usize, h: usize| FlatSamples::F32(vec![1.5; w * h]);
    let levels = Levels::Mip {
        rounding_mode: exr::math::RoundingMode::Down,
        level_data: vec![lv(8, 4), lv(4, 2), lv(2, 1), lv(1, 1)],
    };
    let list: Vec<AnyChannel<Levels<FlatSamples>>> =
        ["B", "G", "R"].iter().map(|c| AnyChannel::new(Text::from(*c), levels.clone())).collect();
    let enc = Encoding { blocks: Blocks::Tiles(Vec2(4, 4)), ..Encoding::FAST_LOSSLESS };
    let layer = Layer::new((8, 4), LayerAttributes::default(), enc, AnyChannels::sort(list.into_iter().collect()));
    if Image::from_layer(layer).write().to_file(&p).is_ok() {
        out.extend(std::fs::read(&p).ok());
    }
    out
}

const EXR_DICT: &[&[u8]] = &[
    b"dataWindow\0box2i\0",
    b"displayWindow\0box2i\0",
    b"compression\0compression\0",
    b"compression\0compression\0\x01\0\0\0\x0c",
    b"chromaticities\0chromaticities\0",
    b"\x00\x00\x80\x3f",
    b"rgba\0",
    b"channels\0chlist\0",
    b"tiles\0tiledesc\0",
    b"type\0string\0",
    b"deepscanline",
    b"\xff\xff\xff\x7f",
    b"\x00\x00\x00\x80",
    b"\x00\x80\x00\x00",
    b"\x76\x2f\x31\x01\x02\x00\x00\x00",
    b"\x76\x2f\x31\x01\x02\x12\x00\x00",
];

#[test]
fn fuzz_exr() {
    fuzz::set_hard_cap(HARD_CAP);
    let dir = work_dir("exr");
    let mut seeds = read_seeds(&seed_files(&cases(), &[".exr"], 64 << 10));
    seeds.extend(exr_seeds(&dir));
    let path = dir.join("input.exr");
    let cfg = FuzzConfig { seed: 51, alloc_budget: exr_budget, ..FuzzConfig::new("exr") };
    fuzz::run(&cfg, &seeds, EXR_DICT, move |bytes| {
        std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
        match analysis::image::read_image(&path) {
            Ok(img) => check_image(&img),
            Err(e) => check_error_line(&e.to_string(), "input"),
        }
    });
}
