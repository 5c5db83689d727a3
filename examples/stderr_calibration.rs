//! How well the `stderr` layer predicts the real error of a pixel, per sampler.
//!
//! For the independent sampler `stderr` is the iid formula √(s²/n) from the pixel's own samples, the
//! standard error of the mean. Owen-scrambled Sobol points of one sequence are not independent (they
//! are stratified: the mean's variance is smaller than s²/n, and that formula overstated the error
//! 1.35–4.55×), so the Sobol sampler draws 16 independently scrambled replicates and `stderr` is the
//! spread of their means (`renderer::film`); `sobol-single` is one such sequence per pixel, whose
//! `stderr` is again √(s²/n) (conservative). This renders a scene with N seeds, measures each
//! pixel's seed-to-seed standard deviation of its mean (the real error), and compares it with the
//! printed stderr (rms over the seeds); the last column compares the samplers' real errors at equal
//! spp.
//!
//! ```sh
//! cargo run --release --example stderr_calibration -- SCENE.toml [SEEDS [SIZE [SPP,SPP,…]]]
//! cargo run --release --example stderr_calibration -- scenes/lambert-grace.toml 32 64 8,64,256
//! ```
//!
//! Printed per sampler and spp, over the object's fully covered pixels (mask = 1 in every seed) with
//! a value > 0, channel G: the median over pixels of printed / real, and the pooled ratio
//! √(mean printed²) / √(mean real²). With N seeds the real error of one pixel is itself known to
//! ≈ 1/√(2(N−1)) (13 % for N = 32); the pooled ratio averages that out over the pixels.

use reflect::cli::render::{RenderArgs, load_scene};
use renderer::render::{RenderOptions, render};
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = PathBuf::from(args.first().expect("usage: stderr_calibration SCENE.toml [SEEDS [SIZE [SPP,…]]]"));
    let seeds: u64 = args.get(1).map_or(32, |s| s.parse().expect("SEEDS"));
    let size: u32 = args.get(2).map_or(64, |s| s.parse().expect("SIZE"));
    let spps: Vec<u32> =
        args.get(3).map_or("8,64,256", String::as_str).split(',').map(|s| s.parse().expect("SPP")).collect();
    println!("{}: {size}², {seeds} seeds, channel G", scene.display());
    println!("sampler      spp  pixels  median(printed/real)  pooled  real rel. error (median)");
    for sampler in ["independent", "sobol", "sobol-single"] {
        for &spp in &spps {
            // values[seed][pixel], stderrs[seed][pixel], masks[seed][pixel]
            let mut values = Vec::new();
            let mut stderrs = Vec::new();
            let mut covered: Option<Vec<bool>> = None;
            for seed in 0..seeds {
                let a = RenderArgs {
                    scene: Some(scene.clone()),
                    spp: Some(spp),
                    seed: Some(seed),
                    size: Some((size, size)),
                    // The CLI's own parsing of `--sampler`.
                    sampler: Some(sampler.parse().expect("sampler")),
                    ..Default::default()
                };
                let s = load_scene(&a).unwrap_or_else(|e| panic!("{e}"));
                let (film, _) = render(&s, &RenderOptions::default());
                let c: Vec<bool> = film.pixels.iter().map(|p| p.mask == 1.0 && p.rgb[1] > 0.0).collect();
                covered = Some(match covered {
                    None => c,
                    Some(prev) => prev.iter().zip(&c).map(|(a, b)| *a && *b).collect(),
                });
                values.push(film.pixels.iter().map(|p| p.rgb[1] as f64).collect::<Vec<_>>());
                stderrs.push(film.pixels.iter().map(|p| p.stderr[1] as f64).collect::<Vec<_>>());
            }
            let covered = covered.unwrap_or_default();
            let n = seeds as f64;
            let (mut ratios, mut rel, mut sum_p2, mut sum_r2) = (Vec::new(), Vec::new(), 0.0, 0.0);
            for p in (0..covered.len()).filter(|&p| covered[p]) {
                let mean = values.iter().map(|v| v[p]).sum::<f64>() / n;
                let real2 = values.iter().map(|v| (v[p] - mean).powi(2)).sum::<f64>() / (n - 1.0);
                let printed2 = stderrs.iter().map(|v| v[p] * v[p]).sum::<f64>() / n;
                if real2 > 0.0 {
                    ratios.push((printed2 / real2).sqrt());
                    rel.push(real2.sqrt() / mean);
                }
                sum_p2 += printed2;
                sum_r2 += real2;
            }
            let median = |v: &mut Vec<f64>| {
                v.sort_by(f64::total_cmp);
                v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
            };
            println!(
                "{sampler:<11} {spp:>4}  {:>6}  {:>20.3}  {:>6.3}  {:>10.3} %",
                ratios.len(),
                median(&mut ratios),
                (sum_p2 / sum_r2).sqrt(),
                100.0 * median(&mut rel)
            );
        }
    }
}
