//! The renderer's environment rotation (`rotate_deg`, CONVENTIONS §6) against the analysis crate's
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

    // (1) Pointwise: the rotated light at ω is the map's pixel containing Rᵀω (CONVENTIONS §2
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
