//! The renderer's environment rotation (`rotate_deg`, docs/src/conventions.md §6) against the analysis crate's
//! rotation of SH coefficients. Every example scene uses zero rotation, so a disagreement between
//! the two (axis order, transpose, degrees) would pass every other test.

mod common;
use analysis::image::{Image, write_exr};
use analysis::quadrature::gauss_legendre;
use analysis::sh::{Reconstructor, Rotation, ShBasis, num_coefficients, rotate_coefficients};
use common::*;
use renderer::light::DistantLight;
use renderer::math::Vec3;
use std::f64::consts::PI;

const LMAX: usize = 4;
const ROT: [f64; 3] = [30.0, -50.0, 75.0];

/// A band-limited environment f = Σ c_k Y_k (l ≤ 4) written as a 512 × 256 lat-long EXR (each pixel
/// f at its centre); returns its coefficients and the image.
fn environment(path: &std::path::Path) -> (Vec<[f64; 3]>, Image) {
    let n = num_coefficients(LMAX);
    // Deterministic coefficients; c_00 large enough that f > 0 everywhere (|Σ_{l>0}| ≤ 24 · 0.25 · 1.5).
    let c: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            if k == 0 {
                [40.0, 35.0, 30.0]
            } else {
                [0, 1, 2].map(|ch| 0.25 * (((7 * k + 3 * ch) % 11) as f64 / 5.0 - 1.0))
            }
        })
        .collect();
    let (w, h) = (512usize, 256usize);
    let mut rec = Reconstructor::new(LMAX);
    let mut img = Image { width: w, height: h, ..Default::default() };
    let px: Vec<[f64; 3]> = (0..w * h)
        .map(|i| {
            let (r, col) = (i / w, i % w);
            let (t, p) = (PI * (r as f64 + 0.5) / h as f64, 2.0 * PI * (col as f64 + 0.5) / w as f64);
            rec.eval(&c, [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()])
        })
        .collect();
    for (ch, name) in ["R", "G", "B"].iter().enumerate() {
        img.channels.insert(name.to_string(), px.iter().map(|v| v[ch] as f32).collect());
    }
    write_exr(path, &img).unwrap();
    (c, img)
}

fn rotated_scene(env: &std::path::Path) -> renderer::scene::Scene {
    scene(&format!(
        "[render]\nwidth = 4\nheight = 4\nspp = 1\n[camera]\ntype = \"normal-probe\"\n[lighting]\ntype = \"envmap\"\n\
         file = \"{}\"\nmapping = \"latlong\"\nrotate_deg = [{:?}, {:?}, {:?}]\n[[objects]]\nshape = \"sphere\"\n\
         brdf = {{ type = \"lambert\", albedo = 1.0 }}\n",
        env.display(),
        ROT[0],
        ROT[1],
        ROT[2]
    ))
}

#[test]
fn rotated_environment_matches_the_rotated_coefficients() {
    let d = temp_dir("rotation");
    let path = d.join("env.exr");
    let (c, img) = environment(&path);
    let s = rotated_scene(&path);
    let r = Rotation::from_xyz_deg(ROT);
    let rt = r.transpose();
    let (w, h) = (img.width, img.height);
    let eval = |d: [f64; 3]| {
        let v = s.light.eval(Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
        [v.x as f64, v.y as f64, v.z as f64]
    };

    // (1) Pointwise: the rotated light at ω is the map's pixel containing Rᵀω (docs/src/conventions.md §2
    // lat-long, nearest pixel), with R the analysis crate's rotation of the same rotate_deg.
    // Directions within 1e-3 pixel of a pixel edge are skipped (f32 vs f64 may pick the neighbour).
    let (zs, ws) = gauss_legendre(48);
    let nphi = 96;
    let mut compared = 0;
    let mut eps = 0.0f64;
    let mut rec = Reconstructor::new(LMAX);
    for z in &zs {
        let st = (1.0 - z * z).sqrt();
        for j in 0..nphi {
            let p = 2.0 * PI * (j as f64 + 0.25) / nphi as f64;
            let om = [st * p.cos(), st * p.sin(), *z];
            let dd = rt.apply(om);
            let (t, ph) = (dd[2].clamp(-1.0, 1.0).acos(), dd[1].atan2(dd[0]).rem_euclid(2.0 * PI));
            let (rf, cf) = (t / PI * h as f64, ph / (2.0 * PI) * w as f64);
            let got = eval(om);
            let exact = rec.eval(&c, dd);
            eps = eps.max((0..3).map(|k| (got[k] - exact[k]).abs()).fold(0.0, f64::max));
            if (rf - rf.round()).abs() < 1e-3 || (cf - cf.round()).abs() < 1e-3 {
                continue;
            }
            let i = (rf as usize).min(h - 1) * w + (cf as usize).min(w - 1);
            for (k, ch) in ["R", "G", "B"].iter().enumerate() {
                let px = img.channels[*ch][i] as f64;
                assert!((got[k] - px).abs() <= 1e-6 * px, "ω {om:?}: renderer {} vs map pixel {px}", got[k]);
            }
            compared += 1;
        }
    }
    assert!(compared > 48 * nphi * 9 / 10, "{compared}");

    // (2) In SH: project the rotated light by Gauss–Legendre × uniform φ (exact for degree ≤ 95, so
    // exact for f_R·Y_k) and compare with rotate_coefficients(c, R). The light is f_R up to the
    // map's nearest-pixel error ε (measured above against f(Rᵀω) from the unrotated c); by Cauchy–
    // Schwarz |Σ w (L − f_R) Y_k| ≤ ε √(Σw) √(Σ w Y_k²) = ε √(4π). ε itself must be the map's
    // discretization: below the largest step between neighbouring pixels.
    let step = (0..h)
        .flat_map(|r| (0..w).map(move |col| (r, col)))
        .map(|(r, col)| {
            let a = img.channels["R"][r * w + col];
            let right = img.channels["R"][r * w + (col + 1) % w];
            let down = img.channels["R"][(r + 1).min(h - 1) * w + col];
            (a - right).abs().max((a - down).abs()) as f64
        })
        .fold(0.0, f64::max);
    assert!(eps <= step, "pointwise error {eps} exceeds the map's pixel step {step}: not a discretization error");
    let expect = rotate_coefficients(&c, &r);
    let basis = ShBasis::new(LMAX);
    let mut got = vec![[0.0; 3]; num_coefficients(LMAX)];
    let mut y = vec![0.0; num_coefficients(LMAX)];
    for (z, wz) in zs.iter().zip(&ws) {
        let st = (1.0 - z * z).sqrt();
        for j in 0..nphi {
            let p = 2.0 * PI * (j as f64 + 0.25) / nphi as f64;
            let om = [st * p.cos(), st * p.sin(), *z];
            basis.eval_into(om, &mut y);
            let v = eval(om);
            let wgt = wz * 2.0 * PI / nphi as f64;
            for k in 0..y.len() {
                for ch in 0..3 {
                    got[k][ch] += wgt * y[k] * v[ch];
                }
            }
        }
    }
    let tol = eps * (4.0 * PI).sqrt() + 1e-9;
    for k in 0..got.len() {
        for ch in 0..3 {
            assert!(
                (got[k][ch] - expect[k][ch]).abs() <= tol,
                "k {k} ch {ch}: {} vs {} (±{tol})",
                got[k][ch],
                expect[k][ch]
            );
        }
    }
    // Able to fail: the unrotated coefficients are far outside that tolerance.
    assert!((1..got.len()).any(|k| (got[k][0] - c[k][0]).abs() > 10.0 * tol));
}

/// Λ_l ρ̂_l of a Lambertian of albedo 1 for l ≤ 4 (docs/src/conventions.md §4; eq. 26 of the paper).
const LAMBERT: [f64; 5] = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0];

/// Solid angle of a lat-long row r of an H-row map, per column of a W-column map.
fn cell_solid_angle(r: usize, w: usize, h: usize) -> f64 {
    2.0 * PI / w as f64 * ((PI * r as f64 / h as f64).cos() - (PI * (r + 1) as f64 / h as f64).cos())
}

/// The map's own SH coefficients for l ≤ LMAX: the map is piecewise constant (nearest pixel), so
/// L_lm = Σ_pixels v ∫_pixel Y_lm dω exactly; each pixel integral by 3 × 3 Gauss–Legendre in (θ, φ)
/// with the sin θ weight (Y_lm is analytic in θ and φ, the error is O(Δ⁶) per pixel: ~1e-13). Also
/// ‖map‖² = Σ v² ΔΩ, exact.
fn map_coefficients(img: &Image) -> (Vec<[f64; 3]>, [f64; 3]) {
    let (w, h) = (img.width, img.height);
    let (x3, w3) = gauss_legendre(3);
    let basis = ShBasis::new(LMAX);
    let n = num_coefficients(LMAX);
    let (mut c, mut norm2) = (vec![[0.0; 3]; n], [0.0; 3]);
    let mut y = vec![0.0; n];
    for r in 0..h {
        // ∫_pixel Y dω for every column at once would need a φ shift per Y; do it per pixel.
        let (t0, dt) = (PI * r as f64 / h as f64, PI / h as f64);
        for col in 0..w {
            let (p0, dp) = (2.0 * PI * col as f64 / w as f64, 2.0 * PI / w as f64);
            let mut integral = vec![0.0; n];
            for (xt, wt) in x3.iter().zip(&w3) {
                let t = t0 + 0.5 * dt * (xt + 1.0);
                for (xp, wp) in x3.iter().zip(&w3) {
                    let p = p0 + 0.5 * dp * (xp + 1.0);
                    basis.eval_into([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()], &mut y);
                    let q = 0.25 * dt * dp * wt * wp * t.sin();
                    for k in 0..n {
                        integral[k] += q * y[k];
                    }
                }
            }
            for (ch, name) in ["R", "G", "B"].iter().enumerate() {
                let v = img.channels[*name][r * w + col] as f64;
                for k in 0..n {
                    c[k][ch] += v * integral[k];
                }
                norm2[ch] += v * v * cell_solid_angle(r, w, h);
            }
        }
    }
    (c, norm2)
}

/// The renderer's sampling and rotation of an environment map, quantitatively: a Lambertian
/// normal probe (albedo 1, max_depth 1, pixel centres, next-event estimation from the map's
/// importance sampling with MIS) under the rotated map must be B(n) = Σ_l Λ_l ρ̂_l Σ_m L'_lm Y_lm(n)
/// (eq. 26) with L' = rotate_coefficients(L_map, R), the analysis crate's rotation of the map's own
/// coefficients. The map's content above l = 4 (its nearest-pixel steps) adds at most
/// T = ‖map_{>4}‖ · ‖K_{>4}‖ at any normal (Cauchy–Schwarz), with ‖K_{>4}‖² = 2/(3π) − Σ_{l≤4}
/// (2l+1) (Λ_l ρ̂_l)²/4π from Funk–Hecke (∫ K² dω = 2/(3π) for K = max(cos, 0)/π). Checked:
/// every pixel within k σ + T (Šidák–Student over the pixels), and the SH projection of the
/// render against that of the prediction on the same grid within k σ_proj + T Σ|w Y|
/// (σ_proj² = Σ (w Y)² σ², Šidák over the coefficients). Also the light's sampling density is
/// p(ω) = g / Σ g ΔΩ, g = max(Y − Ȳ, 0) of the map pixel containing Rᵀω, Y its luminance and Ȳ the
/// mean luminance over the sphere (an importance sampler that drops ΔΩ from its weights is
/// unbiased, so only this catches it).
#[test]
fn rotated_environment_render_projects_to_the_rotated_coefficients() {
    let d = temp_dir("rotation-render");
    let path = d.join("env.exr");
    let (_, img) = environment(&path);
    let (lmap, norm2) = map_coefficients(&img);
    let r = Rotation::from_xyz_deg(ROT);
    let lrot = rotate_coefficients(&lmap, &r);
    let a = |k: usize| LAMBERT[analysis::sh::lm(k).0];
    let kernel_tail = (2.0 / (3.0 * PI)
        - (0..=LMAX).map(|l| (2 * l + 1) as f64 * LAMBERT[l] * LAMBERT[l] / (4.0 * PI)).sum::<f64>())
    .sqrt();
    let tail: [f64; 3] = std::array::from_fn(|ch| {
        let in_band: f64 = lmap.iter().map(|v| v[ch] * v[ch]).sum();
        (norm2[ch] - in_band).max(0.0).sqrt() * kernel_tail
    });

    let (w, h, spp) = (64u32, 32u32, 64u32);
    let toml = format!(
        "[render]\nwidth = {w}\nheight = {h}\nspp = {spp}\nseed = 11\nmax_depth = 1\n[camera]\ntype = \"normal-probe\"\n\
         [lighting]\ntype = \"envmap\"\nfile = \"{}\"\nmapping = \"latlong\"\nrotate_deg = [{:?}, {:?}, {:?}]\n\
         [[objects]]\nshape = \"sphere\"\nbrdf = {{ type = \"lambert\", albedo = 1.0 }}\n",
        path.display(),
        ROT[0],
        ROT[1],
        ROT[2]
    );
    let s = scene(&toml);
    let film = render_scene(&s);

    let basis = ShBasis::new(LMAX);
    let n = num_coefficients(LMAX);
    let k_pix = analysis::special::pixel_family_k(3 * (w * h) as usize, spp, 1e-3);
    let (mut proj, mut proj_exp, mut var, mut abs_w) =
        (vec![[0.0; 3]; n], vec![[0.0; 3]; n], vec![[0.0; 3]; n], vec![0.0; n]);
    let mut y = vec![0.0; n];
    for row in 0..h as usize {
        let t = PI * (row as f64 + 0.5) / h as f64;
        for col in 0..w as usize {
            let p = 2.0 * PI * (col as f64 + 0.5) / w as f64;
            basis.eval_into([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()], &mut y);
            let px = film.get(row as u32, col as u32);
            let wgt = cell_solid_angle(row, w as usize, h as usize);
            for ch in 0..3 {
                let expect: f64 = (0..n).map(|k| a(k) * lrot[k][ch] * y[k]).sum();
                let (got, sd) = (px.rgb[ch] as f64, px.stderr[ch] as f64);
                assert!(
                    (got - expect).abs() <= k_pix * sd + tail[ch] + 1e-5 * expect,
                    "pixel ({row},{col}) ch {ch}: {got} ± {sd} vs B = {expect} (k {k_pix:.2}, T {:.1e})",
                    tail[ch]
                );
                for k in 0..n {
                    proj[k][ch] += wgt * y[k] * got;
                    proj_exp[k][ch] += wgt * y[k] * expect;
                    var[k][ch] += (wgt * y[k] * sd).powi(2);
                }
            }
            for k in 0..n {
                abs_w[k] += (wgt * y[k]).abs();
            }
        }
    }
    let k_proj = analysis::special::sidak_k(3 * n, 1e-3);
    for k in 0..n {
        for ch in 0..3 {
            let tol = k_proj * var[k][ch].sqrt() + tail[ch] * abs_w[k] + 1e-6 * proj_exp[0][ch].abs();
            assert!(
                (proj[k][ch] - proj_exp[k][ch]).abs() <= tol,
                "B_{k} ch {ch}: render projects to {} , rotated coefficients predict {} (± {tol:.2e})",
                proj[k][ch],
                proj_exp[k][ch]
            );
        }
    }

    // The sampling density: p(ω) = g(pixel ∋ Rᵀω) / Σ g ΔΩ, g = max(Y − Ȳ, 0), Y the luminance and
    // Ȳ its mean over the sphere (docs/src/conventions.md §2, "Light sampling"; f32: relative 1e-4).
    let (iw, ih) = (img.width, img.height);
    let y: Vec<f64> = (0..iw * ih)
        .map(|i| {
            [("R", 0.2126), ("G", 0.7152), ("B", 0.0722)].iter().map(|(c, y)| y * img.channels[*c][i] as f64).sum()
        })
        .collect();
    let mean = (0..iw * ih).map(|i| y[i] * cell_solid_angle(i / iw, iw, ih)).sum::<f64>() / (4.0 * PI);
    let g: Vec<f64> = y.iter().map(|&y| (y - mean).max(0.0)).collect();
    let total: f64 = (0..iw * ih).map(|i| g[i] * cell_solid_angle(i / iw, iw, ih)).sum();
    let mut lit = 0;
    let rt = r.transpose();
    for j in 0..200 {
        // Golden-spiral directions, kept away from pixel edges (f32 lookups may pick the neighbour).
        let z = 1.0 - 2.0 * (j as f64 + 0.5) / 200.0;
        let ph = j as f64 * 2.399_963_229_728_653;
        let om = [(1.0 - z * z).sqrt() * ph.cos(), (1.0 - z * z).sqrt() * ph.sin(), z];
        let dd = rt.apply(om);
        let (t, p) = (dd[2].clamp(-1.0, 1.0).acos(), dd[1].atan2(dd[0]).rem_euclid(2.0 * PI));
        let (rf, cf) = (t / PI * ih as f64, p / (2.0 * PI) * iw as f64);
        if (rf - rf.round()).abs() < 1e-3 || (cf - cf.round()).abs() < 1e-3 {
            continue;
        }
        let i = (rf as usize).min(ih - 1) * iw + (cf as usize).min(iw - 1);
        let expect = g[i] / total;
        let got = s.light.pdf(Vec3::new(om[0] as f32, om[1] as f32, om[2] as f32)) as f64;
        // The f32 rounding of Y is relative to Y, and the subtraction of Ȳ keeps it: 1e-4 of Y's share.
        let tol = 1e-4 * y[i] / total;
        assert!((got - expect).abs() <= tol, "ω {om:?}: light pdf {got} vs g/Σ g ΔΩ = {expect} ± {tol:.1e}");
        lit += (expect > 0.0) as usize;
    }
    // Both kinds of pixel were looked at: above the mean (sampled) and below it (density 0).
    assert!((10..190).contains(&lit), "{lit} of 200 directions above the mean luminance");
}
