//! Renders of every scene in `scenes/` agree with a stored reference within Monte Carlo noise.
//!
//! The performance work (issue 10) must keep what is computed. The reference
//! (`tests/data/render_reference.json`) holds, for each scene at 64 × 64 pixels, the mean of every
//! 8 × 8-pixel block per channel with its standard error, from a render at 128 spp and seed 1000 by
//! the renderer as it was before that work (commit 7115800; see `write_reference` for the command).
//! Both use the independent sampler, whose per-pixel standard error is an honest estimate (with
//! Sobol points the sample variance overstates the error, and the test would be blunt: Σ z² came
//! out near half its degrees of freedom).
//! The test renders each scene at 32 spp, seed 1, with today's code, and for every block and channel
//! forms z = (ours − reference) / √(σ_ours² + σ_ref²), σ the standard error of the block mean
//! (√(Σ σ_pixel²) / 64, pixels independent). Per scene, Σ z² of the green channel over the blocks
//! with σ > 0 must pass a χ² test at α = 1e-3 / (number of scenes) (Šidák over the scenes): one
//! channel, because the three channels of a block share their samples and their z are strongly
//! correlated (Σ z² over all three was ≈ 3 χ²₆₄, far wider than χ²₁₉₂). Blocks with σ = 0 on both
//! sides (all samples equal, e.g. a constant background) must agree to 1e-5 relative in every
//! channel.
//!
//! A changed estimator that stays unbiased passes; a bias of ≳ 1 % on a lit region fails (the
//! test was seen to reject a planted 2 % albedo error and a missing MIS weight: see the report of
//! issue 10).

use analysis::image::read_image;
use renderer::render::{RenderOptions, render};
use renderer::sampling::chi2::chi2_survival;
use renderer::scene::{Scene, SceneFile};
use std::path::{Path, PathBuf};

const SIZE: u32 = 64;
const BLOCK: usize = 8;
const SPP: u32 = 32;
const SEED: u64 = 1;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn reference_path() -> PathBuf {
    root().join("tests/data/render_reference.json")
}

/// The scene files, sorted by name.
fn scenes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    v
}

/// Block means and their standard errors, `[block][channel]`, from pixel means and pixel stderrs.
fn blocks(
    w: usize,
    h: usize,
    rgb: impl Fn(usize, usize) -> [f32; 3],
    se: impl Fn(usize, usize) -> [f32; 3],
) -> Vec<[(f64, f64); 3]> {
    let mut out = Vec::new();
    for by in 0..h / BLOCK {
        for bx in 0..w / BLOCK {
            let mut sum = [0.0f64; 3];
            let mut var = [0.0f64; 3];
            for r in by * BLOCK..(by + 1) * BLOCK {
                for c in bx * BLOCK..(bx + 1) * BLOCK {
                    let (v, s) = (rgb(r, c), se(r, c));
                    for ch in 0..3 {
                        sum[ch] += v[ch] as f64;
                        var[ch] += (s[ch] as f64).powi(2);
                    }
                }
            }
            let n = (BLOCK * BLOCK) as f64;
            out.push(std::array::from_fn(|ch| (sum[ch] / n, var[ch].sqrt() / n)));
        }
    }
    out
}

fn render_blocks(path: &Path) -> Vec<[(f64, f64); 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut file = SceneFile::parse(&text).unwrap();
    file.render.width = SIZE;
    file.render.height = SIZE;
    file.render.spp = SPP;
    file.render.seed = SEED;
    file.render.sampler = vocab::Sampler::Independent;
    let scene = Scene::build(file, path.parent().unwrap()).unwrap();
    let film = render(&scene, &RenderOptions::default()).0;
    let px = |r: usize, c: usize| film.get(r as u32, c as u32);
    blocks(SIZE as usize, SIZE as usize, |r, c| px(r, c).rgb, |r, c| px(r, c).stderr)
}

type Reference = std::collections::BTreeMap<String, Vec<[(f64, f64); 3]>>;

#[test]
fn renders_agree_with_the_reference_within_noise() {
    let reference: Reference = serde_json::from_str(&std::fs::read_to_string(reference_path()).unwrap()).unwrap();
    let scenes = scenes();
    assert_eq!(reference.len(), scenes.len(), "every scene has a reference (regenerate: see write_reference)");
    let alpha = 1e-3 / scenes.len() as f64;
    let mut failures = Vec::new();
    for path in &scenes {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let want = &reference[&name];
        let got = match std::env::var("REFLECT_CANDIDATE_BIN") {
            // Calibration: the same test with another binary's renders in place of today's code.
            Ok(bin) => cli_blocks(&bin, path, SPP, SEED),
            Err(_) => render_blocks(path),
        };
        assert_eq!(got.len(), want.len());
        let (mut stat, mut dof) = (0.0, 0usize);
        for (g, w) in got.iter().zip(want) {
            for ch in 0..3 {
                let ((a, sa), (b, sb)) = (g[ch], w[ch]);
                let var = sa * sa + sb * sb;
                if var == 0.0 && (a - b).abs() > 1e-5 * a.abs().max(b.abs()) {
                    failures.push(format!("{name}: noiseless block differs: {a} vs {b}"));
                }
                if var > 0.0 && ch == 1 {
                    stat += (a - b).powi(2) / var;
                    dof += 1;
                }
            }
        }
        let p = if dof > 0 { chi2_survival(stat, dof as f64) } else { 1.0 };
        eprintln!("{name}: χ² = {stat:.1} over {dof} blocks, p = {p:.3}");
        if p < alpha {
            failures.push(format!("{name}: χ² = {stat:.1}, dof {dof}, p = {p:.2e} < {alpha:.1e}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Blocks of a render by a `reflect` binary through its command line (independent sampler).
fn cli_blocks(bin: &str, path: &Path, spp: u32, seed: u64) -> Vec<[(f64, f64); 3]> {
    let dir = std::env::temp_dir().join(format!("reflect-reference-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join(path.file_name().unwrap()).with_extension("exr");
    let size = format!("{SIZE}x{SIZE}");
    let status = std::process::Command::new(bin)
        .args(["render", path.to_str().unwrap(), "--size", &size, "-q", "--sampler", "independent"])
        .args(["--spp", &spp.to_string(), "--seed", &seed.to_string()])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success(), "{}", path.display());
    let img = read_image(&out).unwrap();
    let _ = std::fs::remove_file(&out);
    let ch = |n: &str| img.channel(n).unwrap().to_vec();
    let (r, g, b) = (ch("R"), ch("G"), ch("B"));
    let (sr, sg, sb) = (ch("stderr.R"), ch("stderr.G"), ch("stderr.B"));
    let w = img.width;
    blocks(
        w,
        img.height,
        |y, x| [r[y * w + x], g[y * w + x], b[y * w + x]],
        |y, x| [sr[y * w + x], sg[y * w + x], sb[y * w + x]],
    )
}

/// Regenerates the reference by running a `reflect` binary (the renderer to compare against) on
/// every scene: `REFLECT_REFERENCE_BIN=/path/to/reflect cargo test --release --test render_regression
/// -- --ignored write_reference`. `REFLECT_CANDIDATE_BIN=/path/to/reflect` makes the test itself
/// compare that binary's renders instead of today's code (to calibrate the test: the reference's
/// own binary at another seed must pass). `REFLECT_REFERENCE_SCENES=a.toml,b.toml` rewrites only
/// those entries.
#[test]
#[ignore]
fn write_reference() {
    let bin = std::env::var("REFLECT_REFERENCE_BIN").expect("set REFLECT_REFERENCE_BIN to a reflect binary");
    let only: Option<Vec<String>> =
        std::env::var("REFLECT_REFERENCE_SCENES").ok().map(|s| s.split(',').map(str::to_string).collect());
    let mut reference: Reference = match (&only, std::fs::read_to_string(reference_path())) {
        (Some(_), Ok(text)) => serde_json::from_str(&text).unwrap(),
        _ => Reference::new(),
    };
    for p in scenes() {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if only.as_ref().is_none_or(|o| o.contains(&name)) {
            reference.insert(name, cli_blocks(&bin, &p, 128, 1000));
        }
    }
    std::fs::write(reference_path(), serde_json::to_string(&reference).unwrap()).unwrap();
}
