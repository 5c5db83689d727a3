//! The integrator beyond one bounce, and the Sobol sampler's unbiasedness in a render.
//!
//! Generalized white furnace: inside uniform radiance 1, any arrangement of albedo-1 Lambertian
//! objects reflects exactly 1 at every point, however the light bounces between them (the radiance
//! is 1 everywhere, a fixed point of the rendering equation). The scene is a cavity: a thick
//! spherical shell (a closed mesh, inner radius 0.9, outer 1) with an opening of half-angle 45°
//! at the top, a sphere inside it, seen through the opening by an orthographic camera. A
//! cosine-distributed ray from a point of a sphere's inside hits the sphere uniformly by area, so
//! each bounce inside escapes through the opening with probability f = (1 − cos 45°)/2 ≈ 0.146:
//! paths are 1/f ≈ 7 vertices long on average, Russian roulette (from vertex 4, survival 0.95)
//! fires on most of them, and a path survives 64 vertices with probability (1 − f)^63 ≈ 5·10⁻⁵ (the
//! truncation bias at max_depth 64, far below the tolerance). An estimator that drops the roulette
//! weight 1/q loses about 16 % of the cavity's radiance. Every covered pixel must be 1 within kσ
//! for both samplers; the control at max_depth = 1 (direct light only) must come out below 1.

mod common;
use common::*;
use std::path::Path;

/// Renders the cavity scene with `sampler` at `max_depth` and `spp`, writing its shell mesh to `dir`.
fn furnace_film(dir: &Path, sampler: &str, max_depth: u32, spp: u32) -> renderer::film::Film {
    let shell = dir.join("shell.obj");
    std::fs::write(&shell, open_shell_obj(0.9, 1.0, 45f64.to_radians(), 24, 48)).unwrap();
    let toml = format!(
        r#"
[render]
width = 32
height = 32
spp = {spp}
seed = 3
max_depth = {max_depth}
sampler = "{sampler}"

[camera]
type = "orthographic"
from = [0.0, 0.0, 3.0]
to = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
extent = 1.05

[lighting]
type = "uniform"
radiance = 1.0

[[objects]]
shape = "mesh"
file = "{}"
smooth = false
brdf = {{ type = "lambert", albedo = 1.0 }}

[[objects]]
shape = "sphere"
center = [0.0, 0.0, -0.35]
radius = 0.4
brdf = {{ type = "lambert", albedo = 1.0 }}
"#,
        shell.display()
    );
    render_scene(&scene(&toml))
}

/// Pixels whose camera ray hits the inside of the cavity (the inner wall or the inner sphere):
/// the image's central disc, inside the opening's radius 0.9 sin 45° (less a margin for the
/// faceted rim).
fn in_opening(film: &renderer::film::Film, i: usize) -> bool {
    let (w, h) = (film.width as f64, film.height as f64);
    let (x, y) = ((i % film.width as usize) as f64 + 0.5, (i / film.width as usize) as f64 + 0.5);
    let (u, v) = ((2.0 * x / w - 1.0) * 1.05, (2.0 * y / h - 1.0) * 1.05);
    u.hypot(v) < 0.9 * 45f64.to_radians().sin() - 0.05
}

#[test]
fn generalized_white_furnace_both_samplers() {
    let dir = temp_dir("furnace");
    // `sobol-single`'s error bar is its samples' own σ as the independent sampler's (conservative).
    for sampler in ["independent", "sobol", "sobol-single"] {
        let film = furnace_film(&dir, sampler, 64, 256);
        let covered: Vec<_> = film.pixels.iter().filter(|p| p.mask == 1.0).collect();
        let inside: Vec<_> =
            (0..film.pixels.len()).filter(|&i| in_opening(&film, i)).map(|i| &film.pixels[i]).collect();
        assert!(
            covered.len() > 600 && inside.len() > 250,
            "{sampler}: {} covered, {} inside",
            covered.len(),
            inside.len()
        );
        // Šidák k over the covered pixels × 3 channels at family rate 1e-3, Student t for σ estimated
        // from 256 samples (for Sobol the sample variance overstates the error: conservative); + 1e-5
        // for f32 rounding.
        let k = analysis::special::pixel_family_k(3 * covered.len(), 256, 1e-3);
        for p in &covered {
            for c in 0..3 {
                let tol = k * p.stderr[c] as f64 + 1e-5;
                assert!(
                    (p.rgb[c] as f64 - 1.0).abs() <= tol,
                    "{sampler}: pixel {} ± {} (k = {k:.2})",
                    p.rgb[c],
                    p.stderr[c]
                );
            }
        }
        // Pooled over the cavity (the sensitive test for a small bias): mean 1 within 4σ_pooled.
        let (mean, sd) = pooled_mean(&inside);
        assert!((mean - 1.0).abs() <= 4.0 * sd + 1e-5, "{sampler}: cavity mean {mean} ± {sd}");

        // Control: direct light only; inside the cavity only the opening is seen, so the image
        // is darker than 1 by far more than its error.
        let film1 = furnace_film(&dir, sampler, 1, 64);
        let inside1: Vec<_> =
            (0..film1.pixels.len()).filter(|&i| in_opening(&film1, i)).map(|i| &film1.pixels[i]).collect();
        let (mean1, sd1) = pooled_mean(&inside1);
        assert!(mean1 < 1.0 - 4.0 * sd1 - 0.01, "{sampler}: max_depth 1 mean {mean1} ± {sd1} is not below 1");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The mean of the red channel over `pixels` and its standard error (independent pixels).
fn pooled_mean(pixels: &[&renderer::film::Pixel]) -> (f64, f64) {
    let n = pixels.len() as f64;
    let mean = pixels.iter().map(|p| p.rgb[0] as f64).sum::<f64>() / n;
    let sd = pixels.iter().map(|p| (p.stderr[0] as f64).powi(2)).sum::<f64>().sqrt() / n;
    (mean, sd)
}

/// Sobol (the default sampler) against independent sampling on a scene with structure (a
/// Lambertian and a glossy sphere under the Grace probe, shadows between them, max_depth 4): the
/// per-pixel difference within k √(σ_s² + σ_i²) (Šidák–Student over the pixels), and the
/// image-wide mean difference within 4σ of its pooled error — a biased sampler (e.g. a dimension
/// reused between bounces or a scrambling that is not uniform) shifts the mean.
#[test]
fn sobol_agrees_with_independent_sampling() {
    let toml = |sampler: &str, seed: u64| {
        format!(
            r#"
[render]
width = 32
height = 32
spp = 64
seed = {seed}
max_depth = 4
sampler = "{sampler}"
[camera]
type = "orthographic"
from = [3.0, 0.0, 1.0]
to = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
extent = 1.3
[lighting]
type = "envmap"
file = "{}"
mapping = "angular"
[[objects]]
shape = "sphere"
center = [0.0, -0.55, 0.0]
radius = 0.5
brdf = {{ type = "lambert", albedo = 0.8 }}
[[objects]]
shape = "sphere"
center = [0.0, 0.55, 0.0]
radius = 0.5
brdf = {{ type = "phong", s = 20.0 }}
"#,
            grace().display()
        )
    };
    let s = render_scene(&scene(&toml("sobol", 5)));
    let i = render_scene(&scene(&toml("independent", 6)));
    let pairs: Vec<_> = s.pixels.iter().zip(&i.pixels).filter(|(a, b)| a.mask == 1.0 && b.mask == 1.0).collect();
    assert!(pairs.len() > 150, "{}", pairs.len());
    let k = analysis::special::pixel_family_k(3 * pairs.len(), 64, 1e-3);
    let (mut d, mut v) = ([0.0f64; 3], [0.0f64; 3]);
    for (a, b) in &pairs {
        for c in 0..3 {
            let sd = (a.stderr[c] as f64).hypot(b.stderr[c] as f64);
            let diff = a.rgb[c] as f64 - b.rgb[c] as f64;
            assert!(
                diff.abs() <= k * sd + 1e-5 * (a.rgb[c] as f64).abs(),
                "{} vs {} (σ {sd:.2e}, k {k:.2})",
                a.rgb[c],
                b.rgb[c]
            );
            d[c] += diff;
            v[c] += sd * sd;
        }
    }
    for c in 0..3 {
        let n = pairs.len() as f64;
        assert!(
            (d[c] / n).abs() <= 4.0 * v[c].sqrt() / n,
            "channel {c}: mean difference {} ± {}",
            d[c] / n,
            v[c].sqrt() / n
        );
    }
}
