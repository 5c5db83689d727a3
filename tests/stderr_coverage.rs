//! Issue 9, item 9: are the error bars honest under a heavy-tailed estimator?
//!
//! The `env-sun` case (`../shared/cases/env-sun`): a Lambertian sphere seen through the normal probe
//! under a 64 × 32 map with one texel of 20000 on a background of 0.05. Some pixels' estimates are
//! heavy-tailed: a rare sample carries much of their variance (before the light samples were
//! compensated, a light sample that missed the sun, 0.3 % of them; now every light sample goes to the
//! sun, and at 256 spp 0.8 % of the (seed, pixel) pairs are still flagged). Such a pixel's own error
//! bar is either dominated by the rare event (when it was drawn: the pixel is flagged) or blind to it
//! (when it was not). `Partial::finish_pooled` bounds the error bar of every pixel near a flag by
//! the pooled error of its neighbourhood (`renderer::film`, "Standard error and its reliability flag").
//!
//! The test renders the case at 256 spp with `SEEDS` seeds (independent sampler) and, per seed,
//! pixel and channel G, forms z = (x − x̄₋ₛ) / √(σ² + σ̄₋ₛ²), where x̄₋ₛ is the mean of the other seeds
//! (the leave-one-out reference, 63 × 256 spp) and σ̄₋ₛ its standard error. An honest error bar gives
//! |z| < 3 for 99.73 % of the (seed, pixel) pairs. Each render's statistics are finished twice, with
//! the pooled error bars (`Partial::finish_pooled`) and with the pixels' own (`Partial::finish_own`, what
//! renders write at ≥ 16 spp today, see `renderer::film`: the planted error, which must fail).
//!
//! Below 16 spp (`low_spp_error_bars_cover`, `analyze_at_4_spp_sees_no_model_inadequacy`) renders write
//! the bound for every pixel (`Partial::finish`): the own σ of 4 or 8 samples is itself heavy-tailed.

use renderer::film::Film;
use renderer::render::{RenderOptions, render_range};
use renderer::scene::{Scene, SceneFile};
use std::path::PathBuf;

const SEEDS: u64 = 64;
/// Nominal coverage of |z| < 3 for a normal z.
const NOMINAL: f64 = 0.9973;

/// The scene of the env-sun case `file`, edited, built once (its map loaded and its sampling tables
/// built once per test, not once per seed: the seed is a render setting, see [`renders`]); `None`
/// when the case is missing.
fn case_scene(file: &str, edit: &dyn Fn(String) -> String) -> Option<Scene> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/cases/env-sun");
    let text = edit(std::fs::read_to_string(dir.join(file)).ok()?);
    let file = SceneFile::parse(&text).unwrap();
    Some(Scene::build(file, &dir).unwrap())
}

/// (bounded films, own films) of `SEEDS` renders of `scene` at seeds 1, 2, …: `stderr` the bound
/// (`Partial::finish_pooled`; what renders write at < 16 spp, `Partial::finish`), and the pixels' own
/// σ (`Partial::finish_own`, the planted error). The seed only enters the sampler at render time, so
/// one built scene serves every seed.
fn renders(mut scene: Scene) -> (Vec<Film>, Vec<Film>) {
    (1..=SEEDS)
        .map(|s| {
            (scene.settings.seed, scene.description.render.seed) = (s, s);
            let spp = scene.settings.spp as u64;
            let p = render_range(&scene, &RenderOptions::default(), 0, spp).0.unwrap();
            if p.low_batch_count() {
                assert_eq!(p.finish().pixels, p.finish_pooled().pixels, "renders write the bound at low spp");
            }
            (p.finish_pooled(), p.finish_own())
        })
        .unzip()
}

/// Coverage counts over the object's (seed, pixel) pairs with σ > 0, channel G.
#[derive(Debug, Default)]
struct Coverage {
    flagged: (usize, usize),
    unflagged: (usize, usize),
    worst_unflagged: f64,
    mean_z2: f64,
}

impl Coverage {
    fn of(films: &[Film]) -> Coverage {
        let c = 1; // green
        let npix = films[0].pixels.len();
        let n = films.len() as f64;
        let mut sum = vec![0.0f64; npix];
        let mut var = vec![0.0f64; npix];
        for f in films {
            for (p, px) in f.pixels.iter().enumerate() {
                sum[p] += px.rgb[c] as f64;
                var[p] += (px.stderr[c] as f64).powi(2);
            }
        }
        let mut out = Coverage::default();
        let mut z2 = 0.0;
        for f in films {
            for (p, px) in f.pixels.iter().enumerate() {
                let x = px.rgb[c] as f64;
                let reference = (sum[p] - x) / (n - 1.0);
                let ref_var = (var[p] - (px.stderr[c] as f64).powi(2)) / (n - 1.0).powi(2);
                let total = (px.stderr[c] as f64).powi(2) + ref_var;
                // A pixel σ = 0 counts (it claims an exact value); only a pixel no seed gave any noise is left out.
                if px.mask != 1.0 || total == 0.0 {
                    continue;
                }
                let z = (x - reference) / total.sqrt();
                z2 += z * z;
                let ok = (z.abs() < 3.0) as usize;
                if px.unreliable {
                    out.flagged = (out.flagged.0 + 1, out.flagged.1 + ok);
                } else {
                    out.unflagged = (out.unflagged.0 + 1, out.unflagged.1 + ok);
                    out.worst_unflagged = out.worst_unflagged.max(z.abs());
                }
            }
        }
        out.mean_z2 = z2 / (out.flagged.0 + out.unflagged.0) as f64;
        out
    }
    fn rate((n, k): (usize, usize)) -> f64 {
        k as f64 / n.max(1) as f64
    }
    fn all(&self) -> (usize, usize) {
        (self.flagged.0 + self.unflagged.0, self.flagged.1 + self.unflagged.1)
    }
    fn line(&self, what: &str) -> String {
        format!(
            "{what}: |z| < 3 for {:.2} % of {} pairs; {:.2} % of {} flagged, {:.2} % of {} unflagged (worst |z| {:.1}); \
             mean z² {:.3}",
            100.0 * Self::rate(self.all()),
            self.all().0,
            100.0 * Self::rate(self.flagged),
            self.flagged.0,
            100.0 * Self::rate(self.unflagged),
            self.unflagged.0,
            self.worst_unflagged,
            self.mean_z2
        )
    }
}

/// The lowest coverage of `n` pairs consistent with the nominal rate: NOMINAL − 3 binomial σ,
/// σ = √(p (1 − p) / n) (0.041 % for 16,000 pairs). The pairs of one pixel over the seeds share
/// the reference, so they are not quite independent: the bound is a little tight, never widened.
fn lowest_honest(n: usize) -> f64 {
    NOMINAL - 3.0 * (NOMINAL * (1.0 - NOMINAL) / n as f64).sqrt()
}

/// The highest coverage of `n` pairs consistent with the nominal rate: NOMINAL + 3 binomial σ.
fn highest_honest(n: usize) -> f64 {
    NOMINAL + 3.0 * (NOMINAL * (1.0 - NOMINAL) / n as f64).sqrt()
}

#[test]
fn env_sun_error_bars_cover_where_flagged_and_where_not() {
    let sun = case_scene("conv_independent_256.toml", &|t| t)
        .expect("missing data: ../shared/cases/env-sun (the tests need ../shared beside the checkout)");
    let (pooled, own) = renders(sun);
    let (cp, co) = (Coverage::of(&pooled), Coverage::of(&own));
    eprintln!("env-sun, {SEEDS} seeds at 256 spp, channel G");
    eprintln!("{}", co.line("own σ"));
    eprintln!("{}", cp.line("pooled σ"));
    let honest = |c: &Coverage| {
        Coverage::rate(c.unflagged) >= lowest_honest(c.unflagged.0)
            && Coverage::rate(c.flagged) >= lowest_honest(c.flagged.0)
    };
    // Pooled: measured 99.90 % of 16274 unflagged and 100.00 % of 16494 flagged
    // pairs, against a lowest honest rate of ≈ 99.61 %.
    assert!(cp.flagged.0 > 0 && honest(&cp), "{}", cp.line("pooled σ"));
    // Planted error: the pixels' own error bars (measured 91.9 % on the unflagged pixels) must fail.
    assert!(!honest(&co), "the own error bars pass: the test cannot see the fault it is for");
}

/// The Grace probe at 64 spp is a milder heavy tail (its bright windows): ≈ 9 % of the pixels are
/// flagged, and there the own σ of a pixel that drew fewer bright samples than expected is low
/// together with its value (z large and negative).
#[test]
fn grace_probe_at_64_spp_flagged_pixels_cover() {
    assert!(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/grace_probe.hdr").exists(),
        "missing data: ../shared/data (the tests need ../shared beside the checkout)"
    );
    let grace = case_scene("conv_independent_256.toml", &|t| {
        t.replace("file = \"sun_latlong.exr\"", "file = \"../../data/grace_probe.hdr\"")
            .replace("mapping = \"latlong\"", "mapping = \"angular\"")
            .replace("spp = 256", "spp = 64")
    })
    .expect("missing data: ../shared/cases/env-sun (the tests need ../shared beside the checkout)");
    let (pooled, own) = renders(grace);
    let (cp, co) = (Coverage::of(&pooled), Coverage::of(&own));
    eprintln!("Grace probe, {SEEDS} seeds at 64 spp, channel G");
    eprintln!("{}", co.line("own σ"));
    eprintln!("{}", cp.line("pooled σ"));
    let honest = |c: &Coverage| Coverage::rate(c.flagged) >= lowest_honest(c.flagged.0);
    // Measured: 99.89 % of 2836 flagged pairs (lowest honest ≈ 99.44 %); all pairs 98.42 % → 99.69 %.
    assert!(cp.flagged.0 > 0 && honest(&cp), "{}", cp.line("pooled σ"));
    // Planted error: the flagged pixels' own error bars (measured 92.49 %) must fail.
    assert!(!honest(&co), "the own error bars pass: {}", co.line("own σ"));
}

/// A plain scene keeps its error bars: the same sphere under the analytic sky of `../shared/data`
/// (`sky_latlong.exr`: smooth, no texel far above the rest), where the estimator has no heavy tail.
#[test]
fn plain_scene_error_bars_are_not_inflated() {
    assert!(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data").exists(),
        "missing data: ../shared/data (the tests need ../shared beside the checkout)"
    );
    let sky = case_scene("conv_independent_256.toml", &|t| {
        t.replace("file = \"sun_latlong.exr\"", "file = \"../../data/sky_latlong.exr\"")
    })
    .expect("missing data: ../shared/cases/env-sun (the tests need ../shared beside the checkout)");
    let (pooled, own) = renders(sky);
    let (cp, co) = (Coverage::of(&pooled), Coverage::of(&own));
    let touched: usize = pooled.iter().map(Film::pooled_count).sum();
    eprintln!("sky, {SEEDS} seeds at 256 spp, channel G; {touched} (seed, pixel) pairs near a flag");
    eprintln!("{}", co.line("own σ"));
    eprintln!("{}", cp.line("pooled σ"));
    // Pixels with no flag within the trigger radius keep their own σ bit for bit (measured: no flag
    // at all in this scene, so every pixel is unchanged).
    for (p, o) in pooled.iter().zip(&own) {
        assert_eq!(p.pixels.len(), o.pixels.len());
        let changed = p.pixels.iter().zip(&o.pixels).filter(|(a, b)| a != b).count();
        assert!(changed <= p.pooled_count(), "{changed} pixels changed, {} near a flag", p.pooled_count());
    }
    // Not inflated: coverage at most NOMINAL + 3 binomial σ (99.82 % for 32768 pairs; measured
    // 99.66 %, mean z² 1.028: the own σ of the independent sampler is right to ≈ 1.4 %). The lower
    // side is not asserted here: a mean of 256 skewed samples has slightly heavier tails than a normal,
    // which puts |z| < 3 a little below 99.73 % whatever the error bar (guide "Error bars").
    let not_inflated = |c: &Coverage| Coverage::rate(c.all()) <= highest_honest(c.all().0);
    assert!(not_inflated(&cp), "{}", cp.line("pooled σ"));
    // Planted error: error bars 1.25× too wide (the median inflation pooling gives a flagged pixel,
    // if it were applied everywhere) must fail.
    let mut wide = pooled.clone();
    for f in &mut wide {
        for p in &mut f.pixels {
            p.stderr = p.stderr.map(|s| 1.25 * s);
        }
    }
    let cw = Coverage::of(&wide);
    assert!(!not_inflated(&cw), "σ × 1.25 passes: {}", cw.line("wide σ"));
}

/// `analyze` and `invert` read the `stderr_flag.Y` layer and state the flagged pixels in their
/// warnings (text and JSON).
#[test]
fn analyze_and_invert_state_the_flagged_pixels() {
    let case = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/cases/env-sun/conv_independent_256.toml");
    assert!(case.exists(), "missing data: {} (the tests need ../shared beside the checkout)", case.display());
    let dir = std::env::temp_dir().join(format!("reflect-stderr-flags-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let exr = dir.join("sun.exr");
    let run = |args: &[&str]| -> serde_json::Value {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_reflect")).args(args).output().expect("run reflect");
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice(&o.stdout).expect("JSON")
    };
    let (case, exr_s) = (case.to_str().unwrap(), exr.to_str().unwrap());
    let n = run(&["render", case, "--out", exr_s, "--json", "--quiet"])["unreliable_pixels"].as_u64().unwrap();
    assert!(n > 0, "the case's render has flagged pixels");
    let says = format!("{n} pixels have stderr_flag.Y = 1");
    for args in
        [vec!["analyze", exr_s, "--lmax", "2", "--json"], vec!["invert", "lighting", exr_s, "--lmax", "2", "--json"]]
    {
        let doc = run(&args);
        let warnings = doc["warnings"].as_array().expect("warnings");
        assert!(warnings.iter().any(|w| w.as_str().is_some_and(|w| w.contains(&says))), "{args:?}: {warnings:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The films with each pixel's σ replaced by the spread of its value over the seeds (the error bar an
/// oracle would give; a reference for what a mean of few skewed samples can reach).
fn oracle(films: &[Film]) -> Vec<Film> {
    let n = films.len() as f64;
    let mut out = films.to_vec();
    for p in 0..films[0].pixels.len() {
        for c in 0..3 {
            let mean = films.iter().map(|f| f.pixels[p].rgb[c] as f64).sum::<f64>() / n;
            let var = films.iter().map(|f| (f.pixels[p].rgb[c] as f64 - mean).powi(2)).sum::<f64>() / (n - 1.0);
            for f in &mut out {
                f.pixels[p].stderr[c] = var.sqrt() as f32;
            }
        }
    }
    out
}

/// Below 16 spp the flag is not computed and the own σ is itself noisy (n − 1 degrees of freedom; 0
/// where the few samples agreed): renders bound every pixel by its window ([`renderer::film`]).
#[test]
fn low_spp_error_bars_cover() {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data");
    for (name, file, mapping) in
        [("Grace probe", "../../data/grace_probe.hdr", "angular"), ("sky", "../../data/sky_latlong.exr", "latlong")]
    {
        for spp in [4, 8] {
            assert!(data.exists(), "missing data: ../shared/data (the tests need ../shared beside the checkout)");
            let scene = case_scene("conv_independent_256.toml", &|t| {
                t.replace("file = \"sun_latlong.exr\"", &format!("file = \"{file}\""))
                    .replace("mapping = \"latlong\"", &format!("mapping = \"{mapping}\""))
                    .replace("spp = 256", &format!("spp = {spp}"))
            })
            .expect("missing data: ../shared/cases/env-sun (the tests need ../shared beside the checkout)");
            let (written, own) = renders(scene);
            let (cw, co, cx) = (Coverage::of(&written), Coverage::of(&own), Coverage::of(&oracle(&own)));
            eprintln!("{name}, {SEEDS} seeds at {spp} spp, channel G");
            eprintln!("{}", co.line("own σ"));
            eprintln!("{}", cw.line("written σ"));
            eprintln!("{}", cx.line("oracle σ"));
            // A mean of 4 or 8 skewed samples is far from normal: even the true σ (the oracle's, from
            // the spread over the seeds) covers only 99.16–99.58 % at |z| < 3 (measured). Honest =
            // at least the oracle's rate − 3 binomial σ (√(p (1 − p) / n) ≈ 0.05 % for 32768 pairs).
            // Measured (written / oracle / own): Grace 4 spp 99.60 / 99.16 / 78.10 %, 8 spp 99.88 /
            // 99.41 / 87.54 %; sky 4 spp 99.71 / 99.30 / 88.06 %, 8 spp 99.86 / 99.58 / 93.74 %.
            let p = Coverage::rate(cx.all());
            let honest = |c: &Coverage| Coverage::rate(c.all()) >= p - 3.0 * (p * (1.0 - p) / c.all().0 as f64).sqrt();
            assert!(honest(&cw), "{name} {spp} spp: {} ({})", cw.line("written σ"), cx.line("oracle σ"));
            // Not inflated beyond the max of two estimates: mean z² above 0.6, i.e. the written σ is
            // on average within ≈ 1.3× the true one. Measured 0.79–0.86 with the light sampled by
            // luminance; with the compensated light samples (2026-12-06) Grace 0.87 / 0.85 and the
            // sky 0.69 / 0.66 at 4 / 8 spp (the written σ stays conservative: at 4 spp coverage
            // 99.75 % against the oracle's 99.01 %).
            assert!(cw.mean_z2 > 0.6, "{name} {spp} spp: {}", cw.line("written σ"));
            // Planted error: the own σ of 4 or 8 samples (σ = 0 where they agreed) must fail.
            assert!(!honest(&co), "{name} {spp} spp: the own σ passes: {}", co.line("own σ"));
        }
    }
}

/// `analyze` of `lambert-grace` (128², the scene's Sobol sampler) at 4 spp: with the written bound the
/// filter fit's χ²/ν is near 1 and no noise bar is scaled; with the own σ (planted) χ²/ν is in the
/// hundreds (σ ≈ 0 by chance in many pixels) and the bars are scaled 12–32× as if the model were wrong.
#[test]
fn analyze_at_4_spp_sees_no_model_inadequacy() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("scenes/lambert-grace.toml");
    let mut file = SceneFile::parse(&std::fs::read_to_string(&path).unwrap()).unwrap();
    (file.render.spp, file.render.width, file.render.height) = (4, 128, 128);
    let scene = Scene::build(file, &root.join("scenes"))
        .unwrap_or_else(|e| panic!("scenes/lambert-grace.toml (its Grace map is in ../shared/data): {e}"));
    let p = render_range(&scene, &RenderOptions::default(), 0, 4).0.unwrap();
    let dir = std::env::temp_dir().join(format!("reflect-stderr-4spp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let attrs = renderer::output::header_attributes(&scene);
    let fit = |film: &Film, name: &str| -> (Vec<f64>, Vec<String>) {
        let exr = dir.join(name);
        renderer::output::write_exr(&exr, film, &attrs).unwrap();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_reflect"))
            .args(["analyze", exr.to_str().unwrap(), "--lmax", "8", "--json"])
            .output()
            .expect("run reflect");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
        let chi2 = doc["filter_fit"].as_array().unwrap().iter().map(|f| f["chi2_per_dof"].as_f64().unwrap()).collect();
        let warnings = doc["warnings"].as_array().unwrap().iter().map(|w| w.as_str().unwrap().to_string()).collect();
        (chi2, warnings)
    };
    let (written, written_warnings) = fit(&p.finish(), "written.exr");
    let (own, own_warnings) = fit(&p.finish_own(), "own.exr");
    std::fs::remove_dir_all(&dir).ok();
    eprintln!("lambert-grace 128², 4 spp, filter fit χ²/ν R G B: written σ {written:.3?}, own σ {own:.3?}");
    // The fits' χ² warnings (one per channel when the scatter exceeds the per-pixel σ).
    let scaled = |w: &[String]| {
        w.iter()
            .filter(|w| w.starts_with("filter fit, channel") && w.contains("χ²/ν") && !w.contains("order l"))
            .count()
    };
    // χ²/ν of ν ≈ 11,400 pixels has a sampling σ of √(2/ν) ≈ 0.013; "near 1" allows for the bound's
    // conservatism (the max of two estimates; below 16 spp the Sobol sampler's samples are in distinct
    // replicates, so independent, and its own σ is their sample standard error).
    assert!(written.iter().all(|&x| (0.3..1.5).contains(&x)), "written σ: χ²/ν {written:?}");
    assert_eq!(scaled(&written_warnings), 0, "{written_warnings:?}");
    // Planted error: the own σ of 4 samples.
    assert!(own.iter().all(|&x| x > 10.0) && scaled(&own_warnings) == 3, "own σ: χ²/ν {own:?}, {own_warnings:?}");
}
