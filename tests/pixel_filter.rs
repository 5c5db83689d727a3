//! Noise correlated by a reconstruction filter wider than a pixel (issue 14): `analyze` on an image
//! written as Mitsuba 3 writes it with its default `gaussian` filter (stddev 0.5 px, radius 2 px),
//! R, G, B only, no `reflect:` attributes (the scene by `--scene`).
//!
//! The image: `scenes/lambert-grace.toml` (Lambert 0.8 under Grace) rendered by us at 4 × the
//! resolution (512², 1 spp, independent sampler: every sub-pixel an independent estimate), then
//! every sub-pixel splatted into the 128² pixels its filter reaches with weight k(x)k(y),
//! k(x) = exp(−x²/(2·0.5²)) − exp(−2²/(2·0.5²)) for |x| < 2 (Mitsuba's `ImageBlock::put`), each
//! pixel the normalized weighted sum — 16 samples per pixel, as Mitsuba's 16 spp. Seeds 1…48.
//!
//! Measured (48 seeds, orders l ≤ 2, R channel; `cargo test --release --test pixel_filter -- --nocapture`;
//! 2026-12-06, compensated light samples):
//! - the kernel's F = 3.134 (√F = 1.77); measured from the residuals F̂ = 3.160 (2.73 … 3.55 per seed);
//! - scatter of the estimates over the seeds divided by the printed noise error bar (pooled over
//!   the orders): `--pixel-filter gaussian:0.5` 0.798, measured 0.789 (below 1: σ² from the
//!   residuals holds some truncation, and F slightly overstates the edge pixels' share — both
//!   conservative), and the first with its error bars not inflated (pixels treated as independent:
//!   the planted error) 1.413;
//! - coverage of the truth 0.8 Λ_l ρ̂_l by the printed total error bars, |z| < 2, over 48 seeds × 3
//!   orders × 3 channels: 99.5 % with the flag, 99.8 % measured (98.6 % without the inflation,
//!   where the truncation term still carries part of the bar: the scatter ratio is the sharper test).
//!
//! Samples: 1 spp a sub-pixel, so that the noise outweighs the truncation in the residuals. At 2 spp
//! the compensated light samples (docs/src/conventions.md §2), with less noise, left the truncation a
//! larger share of σ² from the residuals: the ratios fell to 0.702 / 0.692 and the planted error's to
//! 1.243, inside the bounds below (it was 0.855 / 0.853 / 1.514 with the light sampled by luminance).
//!
//! Seeds: 16 were too few. The scatter over 16 seeds swings more than the normal theory's ±18 % per
//! order says: three disjoint sets of 16 gave flag ratios 0.54, 0.85 and 1.10 (and 0.84, 1.12, 1.00
//! with the light sampled by the largest channel), so the first set failed the bounds below when the
//! light sampling changed the renders' bits.
//!
//! Cost (CI): the analyses read the lighting as Grace's L_lm up to l = 16
//! ([`TRUNCATION_LMAX_CAP`], the highest order any fit or truncation estimate here uses), projected
//! once in the test ([`grace_sh`]): the same numbers as the map to 1e-8, without projecting the
//! 2.5 MB probe in each of the 96 analyses (two a seed, 2.5 s each; with 16 seeds that was 68 s of the test's 70 s).
//!
//! Tolerances: the channels share their paths, so the independent comparisons are 48 seeds × 3
//! orders = 144. The ratio of a standard deviation over 48 seeds to the true one has a relative
//! standard error of 1/√(2·47) = 10 % per order, ≈ 6 % pooled over 3 orders (more in practice, as
//! above): honest bars give 1 ± 0.06, accepted within [0.7, 1.35]; bars missing √F give 1.77, which
//! the upper bound rejects. Coverage at 2σ: binomial standard error √(0.954·0.046/144) = 1.7 %,
//! accepted down to 86 % (bars too wide are conservative, not wrong).

mod common;
use analysis::image::{Image, read_image, write_exr};
use analysis::inverse::views::TRUNCATION_LMAX_CAP;
use analysis::lighting::Lighting;
use common::*;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Lambert Λ_l ρ̂_l (albedo 1), l ≤ 2, docs/src/conventions.md §4.
const LAMBERT: [f64; 3] = [1.0, 2.0 / 3.0, 0.25];
const N: usize = 128;
const SUB: usize = 4;
const SEEDS: u64 = 48;

/// Mitsuba 3's `gaussian` reconstruction filter at its defaults (stddev 0.5, radius 4 stddev).
fn mitsuba_gaussian(x: f64) -> f64 {
    let g = |t: f64| (-t * t / (2.0 * 0.25)).exp();
    if x.abs() < 2.0 { (g(x) - g(2.0)).max(0.0) } else { 0.0 }
}

/// Splats a SUB× finer render into N² pixels with Mitsuba's default filter: R, G, B only.
fn splat(fine: &Image) -> Image {
    let fw = fine.width;
    let chans: Vec<&[f32]> = ["R", "G", "B"].iter().map(|c| fine.channel(c).unwrap()).collect();
    let mut out: Vec<Vec<f32>> = vec![vec![0.0; N * N]; 3];
    let s = SUB as f64;
    for py in 0..N {
        for px in 0..N {
            let (cx, cy) = (px as f64 + 0.5, py as f64 + 0.5);
            let lo = |c: f64| (((c - 2.0) * s).floor().max(0.0)) as usize;
            let hi = |c: f64| (((c + 2.0) * s).ceil() as usize).min(fw);
            let (mut acc, mut wsum) = ([0.0f64; 3], 0.0);
            for fy in lo(cy)..hi(cy) {
                let wy = mitsuba_gaussian((fy as f64 + 0.5) / s - cy);
                if wy == 0.0 {
                    continue;
                }
                for fx in lo(cx)..hi(cx) {
                    let w = wy * mitsuba_gaussian((fx as f64 + 0.5) / s - cx);
                    for (a, c) in acc.iter_mut().zip(&chans) {
                        *a += w * c[fy * fw + fx] as f64;
                    }
                    wsum += w;
                }
            }
            for ch in 0..3 {
                out[ch][py * N + px] = (acc[ch] / wsum) as f32;
            }
        }
    }
    let mut img = Image { width: N, height: N, ..Default::default() };
    for (n, v) in ["R", "G", "B"].iter().zip(out) {
        img.channels.insert(n.to_string(), v);
    }
    img
}

/// Grace's lighting (`scenes/lambert-grace.toml`'s angular map) as a `[lighting]` table of its
/// L_lm up to l = [`TRUNCATION_LMAX_CAP`]: every order the analyses use (module docs).
fn grace_sh() -> String {
    let c =
        Lighting::from_envmap_file(&grace(), Some(vocab::Mapping::Angular)).coefficients(TRUNCATION_LMAX_CAP).unwrap();
    let rows: Vec<String> = c.iter().map(|v| format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])).collect();
    format!("[lighting]\ntype = \"sh\"\ncoefficients = [{}]\n", rows.join(", "))
}

/// `scenes/lambert-grace.toml` at N² with the lighting `lighting` (a `[lighting]` table): the
/// `--scene` of the filtered image.
fn sidecar(dir: &Path, lighting: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenes/lambert-grace.toml")).unwrap();
    let text = text.replace("width = 256", &format!("width = {N}")).replace("height = 256", &format!("height = {N}"));
    // The [lighting] table is replaced up to the next table.
    let start = text.find("[lighting]").unwrap();
    let end = start + text[start..].find("\n[").unwrap() + 1;
    let text = format!("{}{lighting}\n{}", &text[..start], &text[end..]);
    let p = dir.join("sidecar.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn analyze(image: &Path, scene: &Path, extra: &[&str]) -> Value {
    let mut args =
        vec!["analyze", image.to_str().unwrap(), "--scene", scene.to_str().unwrap(), "--lmax", "2", "--json"];
    args.extend(extra);
    let (code, out, err) = reflect_out(&args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap()
}

/// Per order l: (estimate, total stderr, noise stderr) of channel `ch`; with `uninflated`, the
/// error bars the same fit prints without the variance inflation (noise / √F ⊕ truncation).
fn orders(doc: &Value, ch: usize, uninflated: bool) -> Vec<(f64, f64, f64)> {
    let scale = if uninflated { doc["pixel_noise"]["stderr_scale"].as_f64().unwrap() } else { 1.0 };
    doc["filter"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            let g = |k: &str| o[k][ch].as_f64().unwrap();
            let noise = g("stderr_noise") / scale;
            (g("estimate"), noise.hypot(g("truncation")), noise)
        })
        .collect()
}

#[test]
fn gaussian_filtered_image_error_bars_are_widened_by_the_correlation() {
    let dir = temp_dir("pixel-filter");
    let scene = sidecar(&dir, &grace_sh());
    let fine_scene = root().join("scenes/lambert-grace.toml");
    let size = format!("{}x{}", N * SUB, N * SUB);
    // [flag, measured, box] × per seed × per order: (estimate, total, noise) of R; and coverage.
    let mut runs: Vec<Vec<Vec<(f64, f64, f64)>>> = vec![vec![]; 3];
    let mut covered = [[0usize; 2]; 3];
    let mut measured_f = vec![];
    for seed in 1..=SEEDS {
        let fine = dir.join(format!("fine{seed}.exr"));
        let (code, err) = reflect(&[
            "render",
            fine_scene.to_str().unwrap(),
            "--seed",
            &seed.to_string(),
            "--size",
            &size,
            "--spp",
            "1",
            "--sampler",
            "independent",
            "--out",
            fine.to_str().unwrap(),
            "-q",
        ]);
        assert_eq!(code, 0, "{err}");
        let img = splat(&read_image(&fine).unwrap());
        let path = dir.join(format!("mitsuba-like{seed}.exr"));
        write_exr(&path, &img).unwrap();
        std::fs::remove_file(&fine).unwrap();
        let flag = analyze(&path, &scene, &["--pixel-filter", "gaussian:0.5"]);
        let measured = analyze(&path, &scene, &[]);
        assert_eq!(flag["pixel_noise"]["source"], "pixel-filter");
        assert_eq!(measured["pixel_noise"]["source"], "residuals", "{}", measured["pixel_noise"]);
        // The filter asked for is information (the report's pixel_noise), not a warning; a
        // correlation measured from the residuals is.
        let correlated = |d: &Value| d["warnings"].to_string().contains("pixel noise correlated");
        assert!(!correlated(&flag), "{}", flag["warnings"]);
        assert!(correlated(&measured), "{}", measured["warnings"]);
        measured_f.push(measured["pixel_noise"]["inflation_measured"].as_f64().unwrap());
        // The planted error: the flag's fit with its error bars not inflated (pixels as independent).
        for (k, (doc, uninflated)) in [(&flag, false), (&measured, false), (&flag, true)].into_iter().enumerate() {
            runs[k].push(orders(doc, 0, uninflated));
            for ch in 0..3 {
                for (l, (e, s, _)) in orders(doc, ch, uninflated).into_iter().enumerate() {
                    covered[k][0] += 1;
                    covered[k][1] += ((e - 0.8 * LAMBERT[l]).abs() < 2.0 * s) as usize;
                }
            }
        }
    }
    let kernel_f = analysis::noise::PixelFilter::Gaussian { stddev: 0.5, radius: 2.0 }.inflation();
    let mean_f = measured_f.iter().sum::<f64>() / measured_f.len() as f64;
    eprintln!("kernel F {kernel_f:.3}, measured F̂ {mean_f:.3} (per seed {measured_f:.2?})");
    // The sub-pixel splat approximates the continuous kernel: measured within 15 %.
    assert!((mean_f / kernel_f - 1.0).abs() < 0.15, "measured F̂ {mean_f} vs the kernel's {kernel_f}");
    let names = ["--pixel-filter gaussian:0.5", "measured", "gaussian:0.5 with the inflation removed"];
    let mut ratios = [0.0; 3];
    for (k, run) in runs.iter().enumerate() {
        // Pooled over the orders: Σ_l var_seeds(estimate_l) / Σ_l mean(noise σ_l²).
        let (mut var, mut pred) = (0.0, 0.0);
        for l in 0..3 {
            let e: Vec<f64> = run.iter().map(|o| o[l].0).collect();
            let m = e.iter().sum::<f64>() / e.len() as f64;
            var += e.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (e.len() - 1) as f64;
            pred += run.iter().map(|o| o[l].2.powi(2)).sum::<f64>() / run.len() as f64;
        }
        ratios[k] = (var / pred).sqrt();
        let rate = covered[k][1] as f64 / covered[k][0] as f64;
        eprintln!("{}: scatter / printed noise σ = {:.3}; |z| < 2 for {:.1} %", names[k], ratios[k], 100.0 * rate);
    }
    for k in 0..2 {
        assert!((0.7..1.35).contains(&ratios[k]), "{}: scatter / printed σ = {}", names[k], ratios[k]);
        let rate = covered[k][1] as f64 / covered[k][0] as f64;
        assert!(rate > 0.86, "{}: 2σ coverage {rate}", names[k]);
    }
    // The planted error: without the inflation the bars are too small by about √F.
    assert!(ratios[2] > 1.35, "uninflated: scatter / printed σ = {} should show the missing √F", ratios[2]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A camera that does not match the image (issue 14): `--extent 1.25` for an image rendered with
/// 1.05 made a fit with residual-σ bars 23–26 σ off and no warning; now the sphere's silhouette
/// (the pixels that differ from the uniform background) against the disc the camera predicts is an
/// error naming both. The right extent passes; an image with no uniform background is a warning.
#[test]
fn a_camera_that_does_not_match_the_silhouette_is_refused() {
    let dir = temp_dir("pixel-filter-silhouette");
    let scene = root().join("scenes/lambert-grace.toml");
    let full = dir.join("full.exr");
    let (code, err) = reflect(&[
        "render",
        scene.to_str().unwrap(),
        "--size",
        "128x128",
        "--spp",
        "4",
        "--out",
        full.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(code, 0, "{err}");
    let src = read_image(&full).unwrap();
    let mut img = Image { width: N, height: N, ..Default::default() };
    for n in ["R", "G", "B"] {
        img.channels.insert(n.to_string(), src.channel(n).unwrap().to_vec());
    }
    let bare = dir.join("bare.exr");
    write_exr(&bare, &img).unwrap();
    let lighting = dir.join("grace-sh.toml");
    std::fs::write(&lighting, grace_sh()).unwrap();
    let run = |path: &Path, extent: &str| {
        reflect_out(&[
            "analyze",
            path.to_str().unwrap(),
            "--from",
            "3,0,1",
            "--extent",
            extent,
            "--lighting",
            lighting.to_str().unwrap(),
            "--lmax",
            "2",
            "--json",
        ])
    };
    let (code, out, err) = run(&bare, "1.05");
    assert_eq!(code, 0, "{err}");
    let doc: Value = serde_json::from_str(&out).unwrap();
    assert!(!doc["warnings"].to_string().contains("silhouette"), "{}", doc["warnings"]);
    for wrong in ["1.25", "1.02"] {
        let (code, out, err) = run(&bare, wrong);
        assert_eq!(code, 2, "extent {wrong}: {err}");
        assert!(out.is_empty());
        assert!(
            err.contains("bare.exr") && err.contains("silhouette") && err.contains(&format!("extent {wrong}")),
            "{err}"
        );
    }
    // No uniform background (every border pixel different): nothing to check against, said.
    for (i, v) in img.channels.get_mut("R").unwrap().iter_mut().enumerate() {
        *v += 1e-3 * (i % 97) as f32;
    }
    let noisy = dir.join("noisy.exr");
    write_exr(&noisy, &img).unwrap();
    let (code, out, err) = run(&noisy, "1.25");
    assert_eq!(code, 0, "{err}");
    let doc: Value = serde_json::from_str(&out).unwrap();
    assert!(doc["warnings"].to_string().contains("cannot be checked against the sphere's silhouette"), "{}", doc);
    let _ = std::fs::remove_dir_all(&dir);
}
