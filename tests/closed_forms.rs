//! Renders against closed forms for branches no other test compares: an SH-defined light on a
//! Lambertian sphere, an SH albedo texture, a Phong lobe with `horizon = "ignore"`, and Schlick's
//! Fresnel on a microfacet model (the last three described at their tests).
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

/// Checks every covered pixel of `film` against `expected(normal)` (module docs: per pixel within k σ,
/// and per channel the image-wide difference within 4 of its standard error); `dof_samples` is the
/// number of independent estimates each σ rests on.
fn check_closed_form(
    film: &renderer::film::Film,
    expected: &dyn Fn([f64; 3]) -> [f64; 3],
    dof_samples: u32,
    what: &str,
) {
    let covered: Vec<_> = film.pixels.iter().filter(|p| p.mask == 1.0).collect();
    assert!(covered.len() > 1000, "{what}: {} covered pixels", covered.len());
    let k = analysis::special::pixel_family_k(3 * covered.len(), dof_samples, 1e-3);
    // Σ (v − B), Σ σ² and Σ B per channel.
    let (mut dsum, mut var, mut bsum) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    for p in &covered {
        let nrm = p.normal.map(|x| x as f64);
        let b = expected(nrm);
        for c in 0..3 {
            let (v, se) = (p.rgb[c] as f64, p.stderr[c] as f64);
            assert!(se.is_finite(), "{what}: σ {se}");
            assert!(
                (v - b[c]).abs() <= k * se + 1e-5 * b[c],
                "{what}: normal {nrm:?} channel {c}: {v} ± {se}, closed form {} (k = {k:.2})",
                b[c]
            );
            dsum[c] += v - b[c];
            var[c] += se * se;
            bsum[c] += b[c];
        }
    }
    // Per channel (the channels share their paths; the pixels are independent): the image's mean
    // difference in units of its standard error. Not Σ z / √n, which a skewed estimator shifts by
    // E[z] · √n (a pixel's mean and its σ are correlated) even without a bias. f32 rounding: 10⁻⁵ Σ B.
    let pooled: Vec<f64> = (0..3).map(|c| dsum[c].abs() / (var[c].sqrt() + 2.5e-6 * bsum[c])).collect();
    eprintln!("{what}: {} pixels, k = {k:.2}, pooled |z| per channel {pooled:.2?}", covered.len());
    assert!(pooled.iter().all(|z| *z < 4.0), "{what}: pooled |z| {pooled:?}");
}

#[test]
fn lambert_sphere_under_an_sh_light_is_the_irradiance_closed_form() {
    for (sampler, dof_samples) in [("independent", 256u32), ("sobol", 16)] {
        let film = render_scene(&scene(&sh_scene(sampler, 256, 11)));
        check_closed_form(&film, &lambert_under_sh, dof_samples, &format!("SH light, {sampler}"));
    }
}

/// An SH albedo texture T(n) (l ≤ 2, positive) on a Lambertian sphere under uniform radiance L: the
/// texture multiplies the BRDF (`renderer::texture`), so B(n) = a T(n) L (the cosine integrates to π
/// against a/π).
#[test]
fn textured_lambert_sphere_under_uniform_light_is_albedo_times_texture() {
    const T: [[f64; 3]; 9] = [
        [2.0, 1.8, 1.6],
        [0.3, -0.2, 0.1],
        [0.2, 0.3, -0.2],
        [-0.3, 0.1, 0.2],
        [0.2, -0.15, 0.1],
        [-0.1, 0.2, 0.15],
        [0.15, 0.1, -0.2],
        [0.1, -0.2, 0.15],
        [-0.2, 0.1, 0.1],
    ];
    const L: [f64; 3] = [1.5, 1.2, 1.0];
    let text: Vec<String> = T.iter().map(|c| format!("[{}, {}, {}]", c[0], c[1], c[2])).collect();
    let expected = |n: [f64; 3]| {
        let y = analysis::sh::basis::ShBasis::new(2).eval(n);
        let mut b = [0.0; 3];
        for (k, yk) in y.iter().enumerate() {
            for c in 0..3 {
                b[c] += ALBEDO[c] * T[k][c] * yk * L[c];
            }
        }
        b
    };
    for (sampler, dof_samples) in [("independent", 256u32), ("sobol", 16)] {
        let toml = sh_scene(sampler, 256, 5)
            .replace(
                &format!(
                    "type = \"sh\"\ncoefficients = [{}]",
                    COEFFS.map(|c| format!("[{}, {}, {}]", c[0], c[1], c[2])).join(", ")
                ),
                &format!("type = \"uniform\"\nradiance = [{}, {}, {}]", L[0], L[1], L[2]),
            )
            .replace(
                "brdf = {",
                &format!("texture = {{ type = \"sh\", coefficients = [{}] }}\nbrdf = {{", text.join(", ")),
            );
        assert!(toml.contains("uniform") && toml.contains("texture"), "{toml}");
        let film = render_scene(&scene(&toml));
        check_closed_form(&film, &expected, dof_samples, &format!("texture, {sampler}"));
    }
}

/// A Phong lobe with `horizon = "ignore"` (paper sec. 3.6: the whole lobe, also below the surface)
/// under the SH light, seen at θ_o = 60° (so the lobe about R crosses the horizon): by Funk–Hecke,
/// B = Σ_lm k_s f_l L_lm Y_lm(R) with f_l = (s + 1) ∫₀¹ t^s P_l(t) dt: f_0 = 1, f_1 = (s + 1)/(s + 2),
/// f_2 = s/(s + 3). R = 2 (n·ω_o) n − ω_o, ω_o = cos θ_o n + sin θ_o t (the camera's tangent t of
/// increasing θ, `renderer::camera::normal_probe`).
#[test]
fn phong_ignoring_the_horizon_under_an_sh_light_is_the_funk_hecke_closed_form() {
    const KS: [f64; 3] = [0.9, 0.8, 0.7];
    const S: f64 = 8.0;
    let f = [1.0, (S + 1.0) / (S + 2.0), S / (S + 3.0)];
    let theta_o = 60f64.to_radians();
    let expected = |n: [f64; 3]| {
        let (th, ph) = (n[2].clamp(-1.0, 1.0).acos(), n[1].atan2(n[0]));
        let t = [th.cos() * ph.cos(), th.cos() * ph.sin(), -th.sin()];
        let wo: Vec<f64> = (0..3).map(|i| theta_o.cos() * n[i] + theta_o.sin() * t[i]).collect();
        let d: f64 = (0..3).map(|i| n[i] * wo[i]).sum();
        let r = [2.0 * d * n[0] - wo[0], 2.0 * d * n[1] - wo[1], 2.0 * d * n[2] - wo[2]];
        let y = analysis::sh::basis::ShBasis::new(2).eval(r);
        let mut b = [0.0; 3];
        for (k, yk) in y.iter().enumerate() {
            let l = analysis::sh::basis::lm(k).0;
            for c in 0..3 {
                b[c] += KS[c] * f[l] * COEFFS[k][c] * yk;
            }
        }
        b
    };
    for (sampler, dof_samples) in [("independent", 256u32), ("sobol", 16)] {
        let toml =
            sh_scene(sampler, 256, 7).replace("theta_o_deg = 30.0\nphi_o_deg = 40.0", "theta_o_deg = 60.0").replace(
                &format!("brdf = {{ type = \"lambert\", albedo = [{}, {}, {}] }}", ALBEDO[0], ALBEDO[1], ALBEDO[2]),
                &format!(
                    "brdf = {{ type = \"phong\", ks = [{}, {}, {}], s = {S}, horizon = \"ignore\" }}",
                    KS[0], KS[1], KS[2]
                ),
            );
        assert!(toml.contains("ignore") && toml.contains("theta_o_deg = 60.0"), "{toml}");
        let film = render_scene(&scene(&toml));
        check_closed_form(&film, &expected, dof_samples, &format!("Phong, horizon ignored, {sampler}"));
    }
}

/// Schlick's Fresnel on the GGX microfacet model (α 0.6, grey F0 0.3) under uniform radiance 1, seen at
/// θ_o = 60° by the normal probe: every pixel is the directional albedo ∫ D G F / (4 cos θ_o) dω_i,
/// F = F0 + (1 − F0)(1 − ω_i·h)⁵, by the 2-D quadrature of `common::albedo` (error < 1e-5). Pooled over
/// the pixels (all the same configuration): the mean within k σ, σ = √(Σ σ_p²)/N, k Šidák's for the 2
/// samplers at a family rate 10⁻³.
#[test]
fn schlick_fresnel_microfacet_albedo_matches_its_quadrature() {
    let f0 = 0.3;
    let base = microfacet(true, 0.6, true);
    let schlick = move |wi: [f64; 3], wo: [f64; 3]| {
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let c = (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]) / (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        base(wi, wo) * (f0 + (1.0 - f0) * (1.0 - c).powi(5))
    };
    let exact = albedo(60f64.to_radians(), &schlick);
    let k = analysis::special::sidak_k(2, 1e-3);
    for sampler in ["independent", "sobol"] {
        let toml = sh_scene(sampler, 64, 13)
            .replace("theta_o_deg = 30.0\nphi_o_deg = 40.0", "theta_o_deg = 60.0")
            .replace(
                &format!("type = \"sh\"\ncoefficients = [{}]", COEFFS.map(|c| format!("[{}, {}, {}]", c[0], c[1], c[2])).join(", ")),
                "type = \"uniform\"\nradiance = 1.0",
            )
            .replace(
                &format!("brdf = {{ type = \"lambert\", albedo = [{}, {}, {}] }}", ALBEDO[0], ALBEDO[1], ALBEDO[2]),
                "brdf = { type = \"microfacet\", distribution = \"ggx\", alpha = 0.6, fresnel = \"schlick\", f0 = 0.3 }",
            );
        assert!(toml.contains("schlick") && toml.contains("uniform"), "{toml}");
        let film = render_scene(&scene(&toml));
        let n = film.pixels.len() as f64;
        let mean = film.pixels.iter().map(|p| p.rgb[0] as f64).sum::<f64>() / n;
        let sigma = film.pixels.iter().map(|p| (p.stderr[0] as f64).powi(2)).sum::<f64>().sqrt() / n;
        eprintln!("Schlick GGX, {sampler}: albedo {mean} ± {sigma}, quadrature {exact}");
        assert!(
            (mean - exact).abs() <= k * sigma + 1e-5,
            "{sampler}: albedo {mean} ± {sigma}, quadrature {exact} (k = {k:.2})"
        );
    }
}
