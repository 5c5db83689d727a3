//! Renders against closed forms for a branch no other test compares: an SH-defined light on a
//! Lambertian sphere.
//!
//! Under L(ω) = Σ_lm L_lm Y_lm(ω), a convex Lambertian surface of albedo a with normal n reflects
//! B(n) = (a/π) E(n) = a Σ_lm (Â_l / π) L_lm Y_lm(n), with the paper's clamped-cosine coefficients
//! Â_0 = π, Â_1 = 2π/3, Â_2 = π/4 (eq. 26 of Part 2; l ≤ 2 here, so the sum is exact). A normal-probe
//! camera without jitter sees one normal per pixel (the film's normal AOV, constant over the pixel's
//! samples), so each covered pixel's expectation is B(n) exactly.
//!
//! Tolerance: every covered pixel and channel within k σ of B (σ the `stderr` layer; k Šidák's for a
//! family-wise false-alarm rate of 10⁻³ over all the comparisons, widened to Student's t with the
//! error bar's degrees of freedom: spp − 1 for the independent sampler, 15 for Sobol's 16 replicates),
//! plus 10⁻⁵ B for f32 rounding; and each channel's image-wide difference Σ (v − B) within ±4 of its
//! standard error √(Σ σ²) (the pixels are independent), which sees a small bias no single pixel shows.

mod common;
use common::*;

/// L_lm (R, G, B) in index order k = l(l+1) + m, l ≤ 2, with orders 1 and 2 large enough that an
/// error in Â_1 or Â_2 shows, and positive everywhere: L_00 Y_00 = 1.69 exceeds the largest
/// magnitude of the rest, |L_1| · 0.489 + Σ_m |L_2m| max |Y_2m| ≤ 0.3 + 1.3.
const COEFFS: [[f64; 3]; 9] = [
    [6.0, 5.5, 5.0],
    [0.4, -0.3, 0.2],
    [0.3, 0.4, -0.4],
    [-0.3, 0.2, 0.3],
    [0.25, -0.25, 0.2],
    [-0.2, 0.25, 0.25],
    [0.25, 0.2, -0.25],
    [0.2, -0.25, 0.25],
    [-0.25, 0.2, 0.2],
];
const ALBEDO: [f64; 3] = [0.8, 0.6, 0.4];
/// Â_l / π, l = 0, 1, 2.
const LAMBERT: [f64; 3] = [1.0, 2.0 / 3.0, 0.25];

fn sh_scene(sampler: &str, spp: u32, seed: u64) -> String {
    let coeffs: Vec<String> = COEFFS.iter().map(|c| format!("[{}, {}, {}]", c[0], c[1], c[2])).collect();
    format!(
        r#"
[render]
width = 48
height = 48
spp = {spp}
seed = {seed}
max_depth = 1
sampler = "{sampler}"

[camera]
type = "normal-probe"
theta_o_deg = 30.0
phi_o_deg = 40.0

[lighting]
type = "sh"
coefficients = [{}]

[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
brdf = {{ type = "lambert", albedo = [{}, {}, {}] }}
"#,
        coeffs.join(", "),
        ALBEDO[0],
        ALBEDO[1],
        ALBEDO[2]
    )
}

/// B(n) of the module docs, per channel.
fn lambert_under_sh(n: [f64; 3]) -> [f64; 3] {
    let y = analysis::sh::basis::ShBasis::new(2).eval(n);
    let mut b = [0.0; 3];
    for (k, yk) in y.iter().enumerate() {
        let l = analysis::sh::basis::lm(k).0;
        for c in 0..3 {
            b[c] += ALBEDO[c] * LAMBERT[l] * COEFFS[k][c] * yk;
        }
    }
    b
}

#[test]
fn lambert_sphere_under_an_sh_light_is_the_irradiance_closed_form() {
    for (sampler, spp, dof_samples, seed) in [("independent", 256u32, 256u32, 11u64), ("sobol", 256, 16, 11)] {
        let film = render_scene(&scene(&sh_scene(sampler, spp, seed)));
        let covered: Vec<_> = film.pixels.iter().filter(|p| p.mask == 1.0).collect();
        assert!(covered.len() > 1000, "{sampler}: {} covered pixels", covered.len());
        let k = analysis::special::pixel_family_k(3 * covered.len(), dof_samples, 1e-3);
        // Σ (v − B) and Σ σ² per channel.
        let (mut dsum, mut var) = ([0.0; 3], [0.0; 3]);
        for p in &covered {
            let nrm = p.normal.map(|x| x as f64);
            let b = lambert_under_sh(nrm);
            for c in 0..3 {
                let (v, se) = (p.rgb[c] as f64, p.stderr[c] as f64);
                assert!(se > 0.0 && se.is_finite(), "{sampler}: σ {se}");
                assert!(
                    (v - b[c]).abs() <= k * se + 1e-5 * b[c],
                    "{sampler}: normal {nrm:?} channel {c}: {v} ± {se}, closed form {} (k = {k:.2})",
                    b[c]
                );
                dsum[c] += v - b[c];
                var[c] += se * se;
            }
        }
        // Per channel (the channels share their paths; the pixels are independent): the image's mean
        // difference in units of its standard error. Not Σ z / √n, which a skewed estimator shifts by
        // E[z] · √n (a pixel's mean and its σ are correlated) even without a bias.
        let pooled: Vec<f64> = (0..3).map(|c| dsum[c] / var[c].sqrt()).collect();
        eprintln!("{sampler} seed {seed}: {} pixels, k = {k:.2}, pooled z per channel {pooled:.2?}", covered.len());
        assert!(pooled.iter().all(|z| z.abs() < 4.0), "{sampler} seed {seed}: pooled z {pooled:?}");
    }
}
