//! The integrator beyond one bounce, and the Sobol sampler's unbiasedness in a render.
//!
//! Generalized white furnace: inside uniform radiance 1, any arrangement of albedo-1 Lambertian
//! objects reflects exactly 1 at every point, however the light bounces between them (the radiance
//! is 1 everywhere, a fixed point of the rendering equation). Two spheres and a flat-shaded mesh
//! (the icosphere OBJ) close enough to see each other much of the hemisphere, max_depth 64 with
//! Russian roulette, multiple importance sampling and shadow rays: every covered pixel must be 1
//! within kσ for both samplers. The control at max_depth = 1 (direct light only, shadowed by the
//! neighbours) must come out below 1.

mod common;
use common::*;

fn furnace_scene(sampler: &str, max_depth: u32, spp: u32) -> String {
    format!(
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
from = [3.0, 0.0, 1.0]
to = [0.0, 0.0, -0.2]
up = [0.0, 0.0, 1.0]
extent = 1.3

[lighting]
type = "uniform"
radiance = 1.0

[[objects]]
shape = "sphere"
center = [0.0, -0.55, 0.0]
radius = 0.5
brdf = {{ type = "lambert", albedo = 1.0 }}

[[objects]]
shape = "sphere"
center = [0.0, 0.55, 0.0]
radius = 0.5
brdf = {{ type = "lambert", albedo = 1.0 }}

[[objects]]
shape = "mesh"
file = "scenes/meshes/icosphere.obj"
smooth = false
scale = 0.4
translate = [0.0, 0.0, -0.95]
brdf = {{ type = "lambert", albedo = 1.0 }}
"#
    )
}

#[test]
fn generalized_white_furnace_both_samplers() {
    for sampler in ["independent", "sobol"] {
        let film = render_scene(&scene(&furnace_scene(sampler, 64, 64)));
        let covered: Vec<_> = film.pixels.iter().filter(|p| p.mask == 1.0).collect();
        assert!(covered.len() > 200, "{sampler}: {} covered pixels", covered.len());
        // Šidák k over the covered pixels × 3 channels at family rate 1e-3, Student t for σ estimated
        // from 64 samples (for Sobol the sample variance overstates the error: conservative); + 1e-5
        // for f32 rounding.
        let k = analysis::special::pixel_family_k(3 * covered.len(), 64, 1e-3);
        let mut sum = 0.0;
        let mut var = 0.0;
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
            sum += p.rgb[0] as f64;
            var += (p.stderr[0] as f64).powi(2);
        }
        // Pooled over the image (the sensitive test for a small bias): mean 1 within 4σ_pooled.
        let n = covered.len() as f64;
        let (mean, sd) = (sum / n, var.sqrt() / n);
        assert!((mean - 1.0).abs() <= 4.0 * sd + 1e-5, "{sampler}: mean {mean} ± {sd}");
        // The paths do bounce: some pixels carry noise (a single-bounce-exact render would have none).
        assert!(covered.iter().any(|p| p.stderr[0] > 1e-3), "{sampler}: no pixel has variance");

        // Control: direct light only; the neighbours shadow part of each hemisphere, so the image
        // is darker than 1 by far more than its error.
        let film1 = render_scene(&scene(&furnace_scene(sampler, 1, 64)));
        let c1: Vec<_> = film1.pixels.iter().filter(|p| p.mask == 1.0).collect();
        let n1 = c1.len() as f64;
        let mean1 = c1.iter().map(|p| p.rgb[0] as f64).sum::<f64>() / n1;
        let sd1 = c1.iter().map(|p| (p.stderr[0] as f64).powi(2)).sum::<f64>().sqrt() / n1;
        assert!(mean1 < 1.0 - 4.0 * sd1 - 0.01, "{sampler}: max_depth 1 mean {mean1} ± {sd1} is not below 1");
    }
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
