//! Writes a render in another renderer's conventions, to try `reflect analyze` and `reflect invert`
//! on an image `reflect` did not write (guide "Analysing another renderer's images").
//!
//! The scene is `scenes/lambert-grace.toml` (a Lambert 0.8 unit sphere under Grace's light probe,
//! orthographic from (3, 0, 1), extent 1.05). The file has
//! - no `reflect:` attribute: the camera is only in pbrt-v4's standard `worldToCamera` / `worldToNDC`
//!   matrices (m44f), with pbrt's mirrored image axis (its LookAt camera's x is up × forward);
//! - RGBA in a Blender-style layer `ViewLayer.Combined.{R,G,B,A}` beside an auxiliary
//!   `ViewLayer.Depth.Z`; alpha is the sphere's coverage;
//! - pixels reconstructed as Mitsuba 3 does by default: every sample splatted into each pixel
//!   within its `gaussian` filter's reach (stddev 0.5 px, radius 2 px), weight
//!   k(x)k(y), k(x) = exp(−x²/(2·0.5²)) − exp(−2²/(2·0.5²)), each pixel the weighted mean. The
//!   samples are our renderer's, taken 4 × 4 per pixel (a 4× finer render, `SPP` samples each), so
//!   neighbouring pixels share samples and their noise is correlated (ρ(1, 0) ≈ 0.37).
//!
//! ```sh
//! cargo run --release --example foreign_render -- OUT.exr [SIZE [SPP [SEED]]]   # defaults 256 2 1
//! ```

use analysis::image::{Image, write_exr};
use reflect::cli::render::{RenderArgs, load_scene};
use renderer::render::{RenderOptions, render};
use std::path::{Path, PathBuf};

/// Sub-pixels per pixel along each axis.
const SUB: usize = 4;
/// The camera of `scenes/lambert-grace.toml`.
const FROM: [f64; 3] = [3.0, 0.0, 1.0];
const EXTENT: f64 = 1.05;

/// Mitsuba 3's `gaussian` reconstruction filter at its defaults (stddev 0.5 px, radius 2 px).
fn gaussian(x: f64) -> f64 {
    let g = |t: f64| (-t * t / (2.0 * 0.25)).exp();
    if x.abs() < 2.0 { (g(x) - g(2.0)).max(0.0) } else { 0.0 }
}

/// pbrt-v4's `worldToCamera` and `worldToNDC` of an orthographic LookAt camera looking at the
/// origin with +z up (row by row, column vectors): camera x = normalize(up × forward), y = forward ×
/// x, z = forward; NDC = ½ screen + ½, screen = camera xy / extent, z over [0, 10].
fn pbrt_matrices() -> ([f32; 16], [f32; 16]) {
    let n = (FROM[0] * FROM[0] + FROM[1] * FROM[1] + FROM[2] * FROM[2]).sqrt();
    let fwd = [-FROM[0] / n, -FROM[1] / n, -FROM[2] / n];
    let up = [0.0, 0.0, 1.0];
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let x = cross(up, fwd);
    let xn = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    let x = [x[0] / xn, x[1] / xn, x[2] / xn];
    let y = cross(fwd, x);
    let (mut cam, mut ndc) = ([0f32; 16], [0f32; 16]);
    for (i, r) in [x, y, fwd].iter().enumerate() {
        let t = -(r[0] * FROM[0] + r[1] * FROM[1] + r[2] * FROM[2]);
        let s = if i < 2 { 0.5 / EXTENT } else { 0.5 / 10.0 };
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

/// Renders the scene (`root` is the repository, for `scenes/`) and writes the image as described in
/// the module docs: `size`² pixels from (4 `size`)² sub-pixels of `spp` samples each.
pub fn write_foreign_render(root: &Path, out: &Path, size: usize, spp: u32, seed: u64) -> Result<(), String> {
    let fine_size = (SUB * size) as u32;
    let a = RenderArgs {
        scene: Some(root.join("scenes/lambert-grace.toml")),
        spp: Some(spp),
        seed: Some(seed),
        size: Some((fine_size, fine_size)),
        sampler: Some("independent".parse().map_err(|e| format!("{e:?}"))?),
        quiet: true,
        ..Default::default()
    };
    let scene = load_scene(&a).map_err(|e| e.to_string())?;
    let (film, _) = render(&scene, &RenderOptions::default());
    let fw = film.width as usize;
    let s = SUB as f64;
    // R, G, B, alpha (coverage), depth along the view (the sphere's, else 0).
    let mut planes = vec![vec![0f32; size * size]; 5];
    for py in 0..size {
        for px in 0..size {
            let (cx, cy) = (px as f64 + 0.5, py as f64 + 0.5);
            let lo = |c: f64| ((c - 2.0) * s).floor().max(0.0) as usize;
            let hi = |c: f64| (((c + 2.0) * s).ceil() as usize).min(fw);
            let (mut acc, mut wsum) = ([0.0f64; 4], 0.0);
            for fy in lo(cy)..hi(cy) {
                let wy = gaussian((fy as f64 + 0.5) / s - cy);
                for fx in lo(cx)..hi(cx) {
                    let w = wy * gaussian((fx as f64 + 0.5) / s - cx);
                    if w == 0.0 {
                        continue;
                    }
                    let p = &film.pixels[fy * fw + fx];
                    for (a, v) in acc.iter_mut().zip(p.rgb) {
                        *a += w * v as f64;
                    }
                    acc[3] += w * p.mask as f64;
                    wsum += w;
                }
            }
            // pbrt's image x axis is mirrored relative to ours: column px is written at size − 1 − px.
            let i = py * size + (size - 1 - px);
            for ch in 0..4 {
                planes[ch][i] = (acc[ch] / wsum) as f32;
            }
            // An auxiliary layer a renderer writes beside the radiance (depth of the sphere's
            // front along the view, 0 off it): ignored by the analysis, with a note.
            let x = EXTENT * (2.0 * cx / size as f64 - 1.0);
            let y = EXTENT * (1.0 - 2.0 * cy / size as f64);
            let r2 = x * x + y * y;
            planes[4][i] = if r2 < 1.0 { (10f64.sqrt() - (1.0 - r2).sqrt()) as f32 } else { 0.0 };
        }
    }
    let mut img = Image { width: size, height: size, ..Default::default() };
    for (name, plane) in ["R", "G", "B", "A"].iter().zip(planes.iter()) {
        img.channels.insert(format!("ViewLayer.Combined.{name}"), plane.clone());
    }
    img.channels.insert("ViewLayer.Depth.Z".into(), planes[4].clone());
    let (cam, ndc) = pbrt_matrices();
    img.matrices.insert("worldToCamera".into(), cam);
    img.matrices.insert("worldToNDC".into(), ndc);
    write_exr(out, &img).map_err(|e| e.to_string())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out) = args.first().map(PathBuf::from) else {
        eprintln!("usage: foreign_render OUT.exr [SIZE [SPP [SEED]]]");
        std::process::exit(2);
    };
    let num = |i: usize, default: u64| args.get(i).map_or(default, |s| s.parse().expect("a whole number"));
    let (size, spp, seed) = (num(1, 256) as usize, num(2, 2) as u32, num(3, 1));
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    if let Err(e) = write_foreign_render(&root, &out, size, spp, seed) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    println!(
        "{}: {size}² Lambert 0.8 sphere under Grace, RGBA layer ViewLayer.Combined, pbrt-v4 camera matrices, \
         Mitsuba's default gaussian pixel filter (samples {SUB} × {SUB} per pixel, {spp} spp each: a {}² render; seed {seed})",
        out.display(),
        SUB * size
    );
}
