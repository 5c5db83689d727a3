#![allow(clippy::needless_range_loop)]
//! Projection: SH-defined lighting recovered from sampled maps (lat-long, angular, function grid),
//! lat-long projection of an analytic function converging as the image grows, the normal-probe
//! projection with standard errors, and least-squares fits of synthetic orthographic views.

mod common;
use analysis::image::{Image, RgbImage};
use analysis::projection::envmap::angular_pixel;
use analysis::projection::{
    Mapping, OrthoCamera, OrthoView, Param, Sphere, fit_orthographic, project_envmap, project_function,
    project_normal_probe,
};
use analysis::sh::{Reconstructor, latlong_direction, num_coefficients, reconstruct_latlong};
use common::Rng;
use std::f64::consts::PI;

/// A positive SH-defined lighting: a constant plus random low orders.
fn sh_lighting(lmax: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = Rng(seed);
    let mut c: Vec<[f64; 3]> = (0..num_coefficients(lmax))
        .map(|_| [0.3 * (rng.next() - 0.5), 0.3 * (rng.next() - 0.5), 0.3 * (rng.next() - 0.5)])
        .collect();
    c[0] = [3.0, 2.5, 2.0];
    c
}

/// Two-sided χ² test at level 1e-3: P(χ²_ν ≥ x) must lie in [5e-4, 1 − 5e-4]. The lower quantile
/// matters: standard errors too large by any factor make χ² small, and must fail too.
fn assert_chi2_two_sided(chi2: f64, dof: f64, what: &str) {
    let p = analysis::special::chi2_survival(chi2, dof);
    assert!((5e-4..=1.0 - 5e-4).contains(&p), "{what}: χ² = {chi2:.1} for {dof} dof, P(χ² ≥ x) = {p:.2e}");
}

fn max_err(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |ch| (x[ch] - y[ch]).abs())).fold(0.0, f64::max)
}

fn latlong_image(c: &[[f64; 3]], w: usize, h: usize) -> RgbImage {
    let px = reconstruct_latlong(c, w, h);
    RgbImage { width: w, height: h, pixels: px.iter().map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]).collect() }
}

#[test]
fn function_grid_recovers_sh_lighting_exactly() {
    let c = sh_lighting(6, 1);
    let got = project_function(6, 7, |d| Reconstructor::new(6).eval(&c, d));
    assert!(max_err(&got, &c) < 1e-13, "{}", max_err(&got, &c));
}

#[test]
fn latlong_recovers_sh_lighting_and_converges_at_second_order() {
    let c = sh_lighting(6, 2);
    // Row-midpoint quadrature in θ has error O((π/H)²); f32 pixels add ~1e-7 relative.
    let mut errs = Vec::new();
    for h in [256usize, 512, 1024, 2048] {
        let img = latlong_image(&c, 2 * h, h);
        let got = project_envmap(&img, Mapping::LatLong, 6).unwrap();
        errs.push(max_err(&got, &c));
    }
    eprintln!("lat-long SH recovery errors: {errs:?}");
    for i in 1..errs.len() {
        let ratio = errs[i - 1] / errs[i];
        assert!((3.5..4.5).contains(&ratio), "convergence ratio {ratio} (errors {errs:?})");
    }
    assert!(errs[3] < 2e-6, "2048-row map: {}", errs[3]);
}

#[test]
fn angular_map_recovers_sh_lighting() {
    let c = sh_lighting(4, 3);
    let w = 1024;
    let mut rec = Reconstructor::new(4);
    let mut pixels = vec![[0.0f32; 3]; w * w];
    for r in 0..w {
        for col in 0..w {
            if let Some((d, _)) = angular_pixel(r, col, w) {
                let v = rec.eval(&c, d);
                pixels[r * w + col] = [v[0] as f32, v[1] as f32, v[2] as f32];
            }
        }
    }
    let img = RgbImage { width: w, height: w, pixels };
    let got = project_envmap(&img, Mapping::Angular, 4).unwrap();
    let e = max_err(&got, &c);
    eprintln!("angular SH recovery error at 1024²: {e}");
    // The projection is exact for the piecewise-constant map the renderer lights with; that map
    // differs from the smooth lighting sampled at pixel centres by O(pixel²): measured 6.2e-6.
    assert!(e < 1e-5, "{e}");
}

#[test]
fn latlong_projection_of_an_analytic_function_converges() {
    // f(ω) = exp(4 (ω·a − 1)), a smooth lobe that is not band-limited.
    let a = [0.48, 0.6, 0.64];
    let f = move |d: [f64; 3]| {
        let v = (4.0 * (d[0] * a[0] + d[1] * a[1] + d[2] * a[2] - 1.0)).exp();
        [v, 0.5 * v, 0.25 * v]
    };
    let lmax = 10;
    let reference = project_function(lmax, 200, f);
    let mut errs = Vec::new();
    for h in [32usize, 64, 128, 256, 512] {
        let w = 2 * h;
        let mut pixels = Vec::with_capacity(w * h);
        for r in 0..h {
            for col in 0..w {
                let v = f(latlong_direction(r, col, w, h));
                pixels.push([v[0] as f32, v[1] as f32, v[2] as f32]);
            }
        }
        let got = project_envmap(&RgbImage { width: w, height: h, pixels }, Mapping::LatLong, lmax).unwrap();
        errs.push(max_err(&got, &reference));
    }
    eprintln!("analytic lat-long errors: {errs:?}");
    for i in 1..errs.len() {
        assert!(errs[i] < errs[i - 1] / 3.0, "not converging: {errs:?}");
    }
    assert!(errs[4] < 1e-5, "{errs:?}");
}

#[test]
fn normal_probe_projection_with_standard_errors() {
    // A normal-probe image is a lat-long image of B; with per-pixel noise σ the coefficient errors
    // must be consistent with the reported standard errors.
    let lmax = 4;
    let c = sh_lighting(lmax, 5);
    let (w, h) = (256usize, 128usize);
    let clean = latlong_image(&c, w, h);
    let sigma = 0.05f32;
    let mut rng = Rng(99);
    let mut img = Image { width: w, height: h, ..Default::default() };
    for (ch, name) in ["R", "G", "B"].iter().enumerate() {
        img.channels
            .insert(name.to_string(), clean.pixels.iter().map(|p| p[ch] + sigma * rng.normal() as f32).collect());
        img.channels.insert(format!("stderr.{name}"), vec![sigma; w * h]);
    }
    let (got, se) = project_normal_probe(&img, lmax).unwrap();
    let se = se.expect("stderr layer present");
    // Each coefficient: error/σ_k is N(0,1) (plus a 1e-4 quadrature bias, 0.1σ); χ² over all of them.
    let mut chi2 = 0.0;
    for k in 0..got.len() {
        for ch in 0..3 {
            chi2 += ((got[k][ch] - c[k][ch]) / se[k][ch]).powi(2);
        }
    }
    let dof = (3 * got.len()) as f64;
    assert_chi2_two_sided(chi2, dof, "one draw");
    // The propagated standard errors against the scatter over 100 independent noisy draws of a
    // 128 × 64 image, errors taken about the projection of the noise-free image (so only the noise
    // counts): Σ (Δ/σ_k)² is χ² with 100 · 75 dof, so a σ_k off by 5 % in either direction fails
    // (relative sd of χ²/ν is √(2/7500) = 1.6 %; the 1e-3 two-sided band is ± 5.4 %).
    let (w2, h2) = (128usize, 64usize);
    let clean2 = latlong_image(&c, w2, h2);
    let mut base = Image { width: w2, height: h2, ..Default::default() };
    for (ch, name) in ["R", "G", "B"].iter().enumerate() {
        base.channels.insert(name.to_string(), clean2.pixels.iter().map(|p| p[ch]).collect());
    }
    let (mean, _) = project_normal_probe(&base, lmax).unwrap();
    let mut chi2 = 0.0;
    let mut rng = Rng(7);
    let draws = 100;
    for _ in 0..draws {
        let mut img = base.clone();
        for (ch, name) in ["R", "G", "B"].iter().enumerate() {
            img.channels
                .insert(name.to_string(), clean2.pixels.iter().map(|p| p[ch] + sigma * rng.normal() as f32).collect());
            img.channels.insert(format!("stderr.{name}"), vec![sigma; w2 * h2]);
        }
        let (got, se) = project_normal_probe(&img, lmax).unwrap();
        let se = se.unwrap();
        for k in 0..got.len() {
            for ch in 0..3 {
                chi2 += ((got[k][ch] - mean[k][ch]) / se[k][ch]).powi(2);
            }
        }
    }
    assert_chi2_two_sided(chi2, (draws * 3 * got.len()) as f64, "100 draws");
    // And the standard error of L_00 in closed form: σ² Y_00² Σ ΔΩ², with ΔΩ ≈ (2π/W)(π/H) sin θ
    // so Σ ΔΩ² ≈ (2π²/WH) ∫ sin θ dω = 2π⁴/(WH): se = σ √(π³ / (2 W H)).
    let expect = sigma as f64 * (PI.powi(3) / (2.0 * (w * h) as f64)).sqrt();
    assert!((se[0][0] / expect - 1.0).abs() < 1e-3, "{} vs {expect}", se[0][0]);
}

/// Renders B (given by SH coefficients of the fit direction) onto an orthographic view of a sphere,
/// with only R, G, B channels (like an EXR from another renderer), plus optional noise/stderr.
fn ortho_image(
    c: &[[f64; 3]],
    cam: &OrthoCamera,
    sphere: &Sphere,
    param: Param,
    size: usize,
    noise: Option<(f32, u64)>,
) -> Image {
    let lmax = analysis::sh::lmax_of(c.len()).unwrap();
    let mut rec = Reconstructor::new(lmax);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let norm = |a: [f64; 3]| {
        let n = dot(a, a).sqrt();
        [a[0] / n, a[1] / n, a[2] / n]
    };
    let f = norm(sub(cam.to, cam.from));
    let right = norm([
        f[1] * cam.up[2] - f[2] * cam.up[1],
        f[2] * cam.up[0] - f[0] * cam.up[2],
        f[0] * cam.up[1] - f[1] * cam.up[0],
    ]);
    let up = [right[1] * f[2] - right[2] * f[1], right[2] * f[0] - right[0] * f[2], right[0] * f[1] - right[1] * f[0]];
    let mut chans = vec![vec![0.0f32; size * size]; 3];
    let mut rng = noise.map(|(_, s)| Rng(s));
    for r in 0..size {
        for col in 0..size {
            let x = cam.extent * (2.0 * (col as f64 + 0.5) / size as f64 - 1.0);
            let y = cam.extent * (1.0 - 2.0 * (r as f64 + 0.5) / size as f64);
            let o = [
                cam.from[0] + x * right[0] + y * up[0],
                cam.from[1] + x * right[1] + y * up[1],
                cam.from[2] + x * right[2] + y * up[2],
            ];
            let oc = sub(sphere.center, o);
            let t0 = dot(oc, f);
            let d2 = dot(oc, oc) - t0 * t0;
            if d2 >= sphere.radius * sphere.radius {
                continue;
            }
            let t = t0 - (sphere.radius * sphere.radius - d2).sqrt();
            let n = norm(sub([o[0] + t * f[0], o[1] + t * f[1], o[2] + t * f[2]], sphere.center));
            let c_o = -dot(n, f);
            let dir = match param {
                Param::Normal => n,
                Param::Reflection => [2.0 * c_o * n[0] + f[0], 2.0 * c_o * n[1] + f[1], 2.0 * c_o * n[2] + f[2]],
            };
            let v = rec.eval(c, dir);
            for ch in 0..3 {
                let e = match (&mut rng, noise) {
                    (Some(g), Some((s, _))) => s as f64 * g.normal(),
                    _ => 0.0,
                };
                chans[ch][r * size + col] = (v[ch] + e) as f32;
            }
        }
    }
    let mut img = Image { width: size, height: size, ..Default::default() };
    for (ch, name) in ["R", "G", "B"].iter().enumerate() {
        img.channels.insert(name.to_string(), chans[ch].clone());
        if let Some((s, _)) = noise {
            img.channels.insert(format!("stderr.{name}"), vec![s; size * size]);
        }
    }
    img
}

/// Adds `normal.X/Y/Z` (geometric normal at the pixel centre, 0 on a miss) to an orthographic image.
fn add_normal_layer(img: &mut Image, cam: &OrthoCamera, sphere: &Sphere) {
    let size = img.width;
    let norm = |a: [f64; 3]| {
        let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        [a[0] / n, a[1] / n, a[2] / n]
    };
    let f = norm([cam.to[0] - cam.from[0], cam.to[1] - cam.from[1], cam.to[2] - cam.from[2]]);
    let right = norm([
        f[1] * cam.up[2] - f[2] * cam.up[1],
        f[2] * cam.up[0] - f[0] * cam.up[2],
        f[0] * cam.up[1] - f[1] * cam.up[0],
    ]);
    let up = [right[1] * f[2] - right[2] * f[1], right[2] * f[0] - right[0] * f[2], right[0] * f[1] - right[1] * f[0]];
    let mut ch = vec![vec![0.0f32; size * size]; 3];
    for r in 0..size {
        for col in 0..size {
            let x = cam.extent * (2.0 * (col as f64 + 0.5) / size as f64 - 1.0);
            let y = cam.extent * (1.0 - 2.0 * (r as f64 + 0.5) / size as f64);
            let o: Vec<f64> = (0..3).map(|i| cam.from[i] + x * right[i] + y * up[i] - sphere.center[i]).collect();
            let t0 = -(o[0] * f[0] + o[1] * f[1] + o[2] * f[2]);
            let d2 = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - t0 * t0;
            if d2 >= sphere.radius * sphere.radius {
                continue;
            }
            let t = t0 - (sphere.radius * sphere.radius - d2).sqrt();
            for i in 0..3 {
                ch[i][r * size + col] = ((o[i] + t * f[i]) / sphere.radius) as f32;
            }
        }
    }
    for (i, n) in ["normal.X", "normal.Y", "normal.Z"].iter().enumerate() {
        img.channels.insert(n.to_string(), ch[i].clone());
    }
}

#[test]
fn least_squares_recovers_sh_function_from_orthographic_views() {
    let sphere = Sphere { center: [0.2, -0.1, 0.3], radius: 0.8 };
    let lmax = 6;
    let c = sh_lighting(lmax, 8);
    // Normal parameterization: two opposite views cover the sphere except a thin silhouette band.
    let cams = [
        OrthoCamera { from: [3.2, -0.1, 0.3], to: [0.2, -0.1, 0.3], up: [0.0, 0.0, 1.0], extent: 0.85 },
        OrthoCamera { from: [-2.8, -0.1, 0.3], to: [0.2, -0.1, 0.3], up: [0.0, 0.0, 1.0], extent: 0.85 },
    ];
    let imgs: Vec<Image> = cams.iter().map(|cam| ortho_image(&c, cam, &sphere, Param::Normal, 200, None)).collect();
    let views: Vec<OrthoView> =
        imgs.iter().zip(&cams).map(|(image, camera)| OrthoView { image, camera: *camera }).collect();
    let fit = fit_orthographic(&views, &sphere, Param::Normal, lmax).unwrap();
    let e = max_err(&fit.coefficients, &c);
    assert!(e < 1e-5, "normal fit error {e}");
    assert_eq!(fit.stderr_source, "residuals");
    // A single view sees one hemisphere of normals: the fit of the band-limited B is still exact.
    let fit1 = fit_orthographic(&views[..1], &sphere, Param::Normal, 4).unwrap();
    let c4 = analysis::predict::truncate(&c, 4);
    let img4 = ortho_image(&c4, &cams[0], &sphere, Param::Normal, 200, None);
    let fit4 = fit_orthographic(&[OrthoView { image: &img4, camera: cams[0] }], &sphere, Param::Normal, 4).unwrap();
    assert!(max_err(&fit4.coefficients, &c4) < 1e-4, "hemisphere fit error {}", max_err(&fit4.coefficients, &c4));
    assert!(fit1.pixels_used > 20000);
    // A normal layer (as the renderer writes) pointing like the geometry gives the same fit, even
    // when the sphere given for coverage is slightly off.
    let mut with_n = img4.clone();
    add_normal_layer(&mut with_n, &cams[0], &sphere);
    let shifted = Sphere { center: [0.2, -0.1, 0.31], radius: 0.79 };
    let fit_n = fit_orthographic(&[OrthoView { image: &with_n, camera: cams[0] }], &shifted, Param::Normal, 4).unwrap();
    assert!(max_err(&fit_n.coefficients, &c4) < 1e-4, "{}", max_err(&fit_n.coefficients, &c4));
    // Reflection parameterization: one view covers almost every reflection direction.
    let img_r = ortho_image(&c, &cams[0], &sphere, Param::Reflection, 200, None);
    let fit_r =
        fit_orthographic(&[OrthoView { image: &img_r, camera: cams[0] }], &sphere, Param::Reflection, lmax).unwrap();
    assert!(max_err(&fit_r.coefficients, &c) < 1e-5, "reflection fit error {}", max_err(&fit_r.coefficients, &c));
}

#[test]
fn least_squares_standard_errors_match_the_noise() {
    let sphere = Sphere::default();
    let lmax = 3;
    let c = sh_lighting(lmax, 21);
    let cam = OrthoCamera { from: [0.0, -3.0, 0.0], to: [0.0; 3], up: [0.0, 0.0, 1.0], extent: 1.05 };
    let sigma = 0.02f32;
    let img = ortho_image(&c, &cam, &sphere, Param::Reflection, 128, Some((sigma, 5)));
    let fit = fit_orthographic(&[OrthoView { image: &img, camera: cam }], &sphere, Param::Reflection, lmax).unwrap();
    assert_eq!(fit.stderr_source, "stderr-layer");
    let mut chi2 = 0.0;
    for k in 0..c.len() {
        for ch in 0..3 {
            chi2 += ((fit.coefficients[k][ch] - c[k][ch]) / fit.stderr[k][ch]).powi(2);
        }
    }
    let dof = (3 * c.len()) as f64;
    assert_chi2_two_sided(chi2, dof, "one draw");
    // Against the scatter over 40 independent draws (errors about the noise-free fit, so only the
    // noise counts): χ² with 40 · 48 dof; relative sd of χ²/ν is √(2/1920) = 3.2 %, so standard
    // errors off by 10 % in either direction fail the 1e-3 two-sided band (± 10.6 % on χ²/ν).
    let clean = ortho_image(&c, &cam, &sphere, Param::Reflection, 128, None);
    let mean = fit_orthographic(&[OrthoView { image: &clean, camera: cam }], &sphere, Param::Reflection, lmax).unwrap();
    let draws = 40;
    let mut chi2 = 0.0;
    for seed in 0..draws {
        let img = ortho_image(&c, &cam, &sphere, Param::Reflection, 128, Some((sigma, 100 + seed)));
        let f = fit_orthographic(&[OrthoView { image: &img, camera: cam }], &sphere, Param::Reflection, lmax).unwrap();
        for k in 0..c.len() {
            for ch in 0..3 {
                chi2 += ((f.coefficients[k][ch] - mean.coefficients[k][ch]) / f.stderr[k][ch]).powi(2);
            }
        }
    }
    assert_chi2_two_sided(chi2, (draws as usize * 3 * c.len()) as f64, "40 draws");
    // Without the stderr layer the residual-based σ must come out ≈ the true σ.
    let mut img2 = img.clone();
    for n in ["stderr.R", "stderr.G", "stderr.B"] {
        img2.channels.remove(n);
    }
    let fit2 = fit_orthographic(&[OrthoView { image: &img2, camera: cam }], &sphere, Param::Reflection, lmax).unwrap();
    assert_eq!(fit2.stderr_source, "residuals");
    for k in 0..c.len() {
        let r = fit2.stderr[k][0] / fit.stderr[k][0];
        // σ̂/σ from ~12000 residuals: relative sd ≈ 1/√(2n) ≈ 0.7%; 5 sd.
        assert!((r - 1.0).abs() < 0.035, "k={k}: ratio {r}");
    }
}

#[test]
fn angular_projection_is_the_exact_integral_of_the_pixel_footprints() {
    // Random (non-symmetric) content: the projection must equal Σ_p L_p ∫_footprint Y dω, the
    // footprint (pixel square ∩ disc, pixels with centre inside) integrated here independently by
    // a fine midpoint grid of sub-pixels in the image plane (error O(1/sub²) ≈ 1e-6 relative).
    for w in [6usize, 7] {
        let mut rng = Rng(w as u64);
        let pixels: Vec<[f32; 3]> =
            (0..w * w).map(|_| [rng.next() as f32, rng.next() as f32, rng.next() as f32]).collect();
        let img = RgbImage { width: w, height: w, pixels };
        let got = project_envmap(&img, Mapping::Angular, 4).unwrap();
        let basis = analysis::sh::ShBasis::new(4);
        let mut expect = vec![[0.0f64; 3]; 25];
        let sub = 600;
        let h = 2.0 / (w * sub) as f64;
        for r in 0..w {
            for c in 0..w {
                if angular_pixel(r, c, w).is_none() {
                    continue;
                }
                let p = img.get(r, c);
                for i in 0..sub {
                    for j in 0..sub {
                        let a = -1.0 + (c * sub + j) as f64 * h + 0.5 * h;
                        let b = 1.0 - (r * sub + i) as f64 * h - 0.5 * h;
                        let rho = (a * a + b * b).sqrt();
                        if rho > 1.0 {
                            continue;
                        }
                        let t = PI * rho;
                        let sinc = if t > 0.0 { t.sin() / t } else { 1.0 };
                        let d = [a * PI * sinc, b * PI * sinc, t.cos()];
                        let dw = h * h * PI * PI * sinc;
                        let y = basis.eval(d);
                        for k in 0..25 {
                            for ch in 0..3 {
                                expect[k][ch] += p[ch] as f64 * dw * y[k];
                            }
                        }
                    }
                }
            }
        }
        let e = max_err(&got, &expect);
        assert!(e < 2e-5, "W={w}: {e}");
    }
}
