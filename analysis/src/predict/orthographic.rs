//! The image the theory predicts: a sphere of known BRDF under known distant lighting, seen by an
//! orthographic camera, pixel by pixel from eq. 15, B(d) = Σ_l A_l Σ_m L_lm Y_lm(d), with A_l the
//! BRDF's Λ_l ρ̂_l times its albedo (or k_s) and d the pixel's normal (`lambert`) or reflection vector
//! (`phong`). `reflect compare IMAGE --prediction` compares a render with it (guide "Comparing two
//! renderers", "Against the theory").
//!
//! The prediction is exact only where B really is such a series: a Lambertian sphere (any lighting
//! of finite energy), and Phong with `horizon = "ignore"` (eq. 43 holds without a horizon). Models
//! whose transfer depends on the exitance angle (Torrance–Sparrow, microfacet) vary over an
//! orthographic view and are refused, as is a mirror (Λ_l ρ̂_l = 1 never converges).
//!
//! - **Pixels.** A pixel is predicted when its whole footprint lies on the sphere (the fits' rule:
//!   centre distance + half diagonal < radius). Its value is the mean of B over the footprint (a box
//!   pixel filter, as our film), by the 2 × 2 Gauss–Legendre rule on the image plane (exact for
//!   bicubic B; the curvature term a centre value would miss is (h²/24) ∇²B). Its coverage (for the
//!   comparison's alignment check) is the share of a 4 × 4 grid of the footprint on the sphere.
//! - **Order.** The series is summed to l_max = [`prediction_order`] of the transfer (the first
//!   even order ≥ 8 from which |A_l| < [`TRANSFER_FLOOR`] |A_0| for two consecutive orders), then
//!   doubled while the truncation bound below exceeds [`TRUNCATION_TARGET`] of the mean radiance,
//!   up to [`LMAX_CAP`] ([`LMAX_CAP_ANGULAR`] for an angular map, whose projection costs
//!   O(pixels · l²) rather than O(pixels · l)). A Lambertian sphere under a map with small bright
//!   sources converges slowly (its A_l falls only as l^{−5/2}): under the Grace probe the largest
//!   truncation error is ≈ 0.3 % of B at l = 48.
//! - **Truncation bound.** The band of orders (l', l_max], l' = ⌊3 l_max / 4⌋, changes pixel i by
//!   Δ_i = B_{l_max} − B_{l'}. The tail beyond l_max of an error falling as l^{−p} with p ≥ 1.5 is
//!   at most 1.85 Δ; the bound of pixel i is 2 max |Δ| over the window of pixels within about half
//!   an oscillation of order l_max (Δ changes sign across the image, and where it crosses 0 says
//!   nothing about the tail). It is a bound on a systematic error, not noise: a comparison adds it
//!   without averaging it down ([`crate::compare::CompareParams::b_systematic`]).

use crate::error::{Error, Result};
use crate::image::Image;
use crate::lighting::Lighting;
use crate::projection::{OrthoCamera, Param, Sphere};
use crate::sh::ShBasis;
use crate::transfer::{Horizon, TransferModel};
use glam::DVec3;
use rayon::prelude::*;

/// The highest order a prediction is summed to.
pub const LMAX_CAP: usize = 128;

/// The highest order under an angular environment map (its projection is O(pixels · l²)).
pub const LMAX_CAP_ANGULAR: usize = 64;

/// The order is raised while the largest truncation bound exceeds this share of the mean radiance.
pub const TRUNCATION_TARGET: f64 = 1e-3;

/// A transfer coefficient below this share of |A_0| counts as negligible ([`prediction_order`]).
pub const TRANSFER_FLOOR: f64 = 1e-4;

/// The order a prediction with transfer coefficients `lambda_rho` (Λ_l ρ̂_l, l = 0 … at least
/// [`LMAX_CAP`] + 1) is summed to: the first even l ≥ 8 with |Λ_l ρ̂_l| and |Λ_{l+1} ρ̂_{l+1}| both
/// below [`TRANSFER_FLOOR`] |Λ_0 ρ̂_0|, else [`LMAX_CAP`] (a lobe too sharp to converge: the
/// truncation estimate then says how far off it is).
pub fn prediction_order(lambda_rho: &[f64]) -> usize {
    let floor = TRANSFER_FLOOR * lambda_rho.first().map_or(0.0, |a| a.abs());
    let small = |l: usize| lambda_rho.get(l).is_none_or(|a| a.abs() < floor);
    (8..LMAX_CAP).step_by(2).find(|&l| small(l) && small(l + 1)).unwrap_or(LMAX_CAP)
}

/// What is seen: the camera, the sphere and the image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoScene {
    pub camera: OrthoCamera,
    pub sphere: Sphere,
    pub width: usize,
    pub height: usize,
}

/// A predicted image, row-major, `width × height`.
#[derive(Clone, Debug, PartialEq)]
pub struct PredictedImage {
    pub width: usize,
    pub height: usize,
    /// RGB radiance B summed to `lmax`, the mean over the pixel's footprint; 0 where not predicted.
    pub radiance: Vec<[f64; 3]>,
    /// The bound on the truncation error per pixel and channel (module docs); 0 where not predicted.
    pub systematic: Vec<[f64; 3]>,
    /// The share of the pixel's footprint on the sphere (4 × 4 points), in [0, 1].
    pub coverage: Vec<f32>,
    /// Whether the pixel's whole footprint lies on the sphere (only those are predicted).
    pub predicted: Vec<bool>,
    pub lmax: usize,
    /// The lower order the truncation is estimated against, ⌊3 lmax / 4⌋.
    pub lmax_check: usize,
}

impl PredictedImage {
    /// As an image to compare with: `R`, `G`, `B` the prediction, `stderr.R/G/B` 0 (no noise; the
    /// truncation bound is systematic, [`PredictedImage::systematic`]) and +inf where not predicted
    /// (which leaves the pixel out of a comparison), `mask.Y` the coverage.
    pub fn to_image(&self) -> Image {
        let mut img = Image { width: self.width, height: self.height, ..Default::default() };
        for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
            img.channels.insert(name.into(), self.radiance.iter().map(|p| p[c] as f32).collect());
            let se = self.predicted.iter().map(|&p| if p { 0.0 } else { f32::INFINITY }).collect();
            img.channels.insert(format!("stderr.{name}"), se);
        }
        img.channels.insert("mask.Y".into(), self.coverage.clone());
        img
    }

    /// The largest truncation bound over the predicted pixels relative to the mean |B| of its
    /// channel there (0 with no pixel predicted, or a black channel).
    pub fn max_relative_systematic(&self) -> f64 {
        let used: Vec<usize> = (0..self.predicted.len()).filter(|&i| self.predicted[i]).collect();
        (0..3)
            .map(|c| {
                let mean = used.iter().map(|&i| self.radiance[i][c].abs()).sum::<f64>() / used.len().max(1) as f64;
                let top = used.iter().map(|&i| self.systematic[i][c]).fold(0.0, f64::max);
                if mean > 0.0 { top / mean } else { 0.0 }
            })
            .fold(0.0, f64::max)
    }
}

/// Predicts the image of `scene` for a sphere of BRDF `model` (unit albedo / k_s, times `scale` per
/// channel, with `horizon`) under `lighting`, summed to [`prediction_order`]: the one entry point
/// of `reflect compare --prediction`.
///
/// Errors: a model without an exact per-pixel prediction (module docs; the message says why),
/// lighting whose coefficients cannot be computed (an unreadable map), and
/// [`predict_orthographic`]'s.
pub fn predict_scene(
    scene: &OrthoScene,
    lighting: &Lighting,
    model: TransferModel,
    scale: [f64; 3],
    horizon: Horizon,
) -> Result<PredictedImage> {
    let param = match model {
        TransferModel::Lambert => Param::Normal,
        TransferModel::Phong { .. } if horizon == Horizon::Ignore => Param::Reflection,
        TransferModel::Phong { .. } => {
            return Err(Error::new(format!(
                "a phong sphere with horizon = \"{horizon}\" has no exact prediction: eq. 43 ignores the horizon \
                 (render with horizon = \"ignore\" to compare with the theory)"
            )));
        }
        TransferModel::Mirror => {
            return Err(Error::new(
                "a mirror's Λ_l ρ̂_l = 1 at every order, so its series does not converge: no prediction by eq. 15",
            ));
        }
        TransferModel::TorranceSparrow { .. } | TransferModel::Microfacet { .. } => {
            return Err(Error::new(
                "this BRDF's transfer depends on the exitance angle, which varies over an orthographic view: no \
                 per-pixel prediction by eq. 15 (analyze a normal-probe render instead)",
            ));
        }
    };
    model.validate()?;
    let lambda_rho = model.lambda_rho(LMAX_CAP + 1);
    let cap = if angular_map(lighting)? { LMAX_CAP_ANGULAR } else { LMAX_CAP };
    let mut lmax = prediction_order(&lambda_rho).min(cap);
    loop {
        let light = lighting.coefficients(lmax)?;
        let transfer: Vec<[f64; 3]> = lambda_rho[..=lmax].iter().map(|a| scale.map(|s| s * a)).collect();
        let p = predict_orthographic(scene, param, &light, &transfer)?;
        if lmax >= cap || p.max_relative_systematic() <= TRUNCATION_TARGET {
            return Ok(p);
        }
        lmax = (2 * lmax).min(cap);
    }
}

/// Whether `lighting` is an angular environment map (stated, or inferred from a square image).
fn angular_map(lighting: &Lighting) -> Result<bool> {
    use vocab::Mapping;
    match lighting {
        Lighting::Envmap { mapping: Some(m), .. } => Ok(*m == Mapping::Angular),
        Lighting::Envmap { file, layer, mapping: None, .. } => {
            let img = crate::image::read_rgb_layer(file, layer.as_deref())?;
            Ok(Mapping::infer(img.width, img.height).map_err(|e| e.in_file(file))? == Mapping::Angular)
        }
        _ => Ok(false),
    }
}

/// One pixel's prediction: radiance, |B_{lmax} − B_{lmax_check}|, coverage, whether predicted.
type PixelPrediction = ([f64; 3], [f64; 3], f32, bool);

/// 2 × the largest `band` value of the predicted pixels within Chebyshev distance `reach` of each
/// predicted pixel (0 elsewhere): a running maximum along rows, then along columns.
fn envelope(band: &[[f64; 3]], predicted: &[bool], w: usize, h: usize, reach: usize) -> Vec<[f64; 3]> {
    let masked: Vec<[f64; 3]> = band.iter().zip(predicted).map(|(b, &p)| if p { *b } else { [0.0; 3] }).collect();
    let max3 = |a: [f64; 3], b: [f64; 3]| [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])];
    let mut rows = vec![[0.0; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(reach), (x + reach).min(w - 1));
            rows[y * w + x] = (x0..=x1).map(|xx| masked[y * w + xx]).fold([0.0; 3], max3);
        }
    }
    (0..w * h)
        .map(|i| {
            if !predicted[i] {
                return [0.0; 3];
            }
            let (y, x) = (i / w, i % w);
            let (y0, y1) = (y.saturating_sub(reach), (y + reach).min(h - 1));
            let m = (y0..=y1).map(|yy| rows[yy * w + x]).fold([0.0; 3], max3);
            m.map(|v| 2.0 * v)
        })
        .collect()
}

/// The 2-point Gauss–Legendre nodes on [−½, ½] (weights ½ each).
const GL2: [f64; 2] = [-0.288_675_134_594_812_9, 0.288_675_134_594_812_9];

/// Predicts the image of `scene` from the lighting's coefficients `light` (RGB, index order, at
/// least (lmax + 1)² long) and the transfer `transfer` (A_l per channel, l = 0 … lmax, albedo or
/// k_s included), B a function of the normal or the reflection vector (`param`): see the module
/// docs. `lmax` = `transfer.len() − 1`.
///
/// Errors: a degenerate camera, a non-positive extent or radius, an empty image, lighting with
/// fewer coefficients than (lmax + 1)², an empty transfer.
pub fn predict_orthographic(
    scene: &OrthoScene,
    param: Param,
    light: &[[f64; 3]],
    transfer: &[[f64; 3]],
) -> Result<PredictedImage> {
    let lmax = transfer.len().checked_sub(1).ok_or_else(|| Error::new("no transfer coefficients"))?;
    let n = (lmax + 1) * (lmax + 1);
    if light.len() < n {
        return Err(Error::new(format!(
            "the lighting has {} coefficients, a prediction to l = {lmax} needs {n}",
            light.len()
        )));
    }
    let (w, h) = (scene.width, scene.height);
    let cam = &scene.camera;
    if w == 0 || h == 0 {
        return Err(Error::new("the image has no pixels"));
    }
    if !(cam.extent > 0.0) || !(scene.sphere.radius > 0.0) {
        return Err(Error::new("camera extent and sphere radius must be positive"));
    }
    let [f, right, up] = cam.basis()?.map(DVec3::from);
    let (from, center, r) = (DVec3::from(cam.from), DVec3::from(scene.sphere.center), scene.sphere.radius);
    let wo = -f;
    let pix = 2.0 * cam.extent / w as f64; // square pixels (docs/src/conventions.md §5)
    let half_diag = pix * std::f64::consts::FRAC_1_SQRT_2;
    let lmax_check = 3 * lmax / 4;
    // Where the ray through the image-plane point (x, y) meets the sphere: the direction B is a
    // function of there, or None on a miss.
    let direction = |x: f64, y: f64| -> Option<DVec3> {
        let o = from + right * x + up * y;
        let oc = center - o;
        let along = oc.dot(f);
        let perp = oc - f * along;
        let d2 = perp.length_squared();
        if d2 >= r * r || along <= 0.0 {
            return None;
        }
        let hit = o + f * (along - (r * r - d2).sqrt());
        let n = (hit - center) / r;
        let d = match param {
            Param::Normal => n,
            Param::Reflection => n * (2.0 * n.dot(wo)) - wo,
        };
        Some(d.normalize())
    };
    let plane = |row: f64, col: f64| {
        (cam.extent * (2.0 * col / w as f64 - 1.0), cam.extent * (h as f64 / w as f64) * (1.0 - 2.0 * row / h as f64))
    };
    let rows: Vec<Vec<PixelPrediction>> = (0..h)
        .into_par_iter()
        .map(|row| {
            let basis = ShBasis::new(lmax);
            let mut y = vec![0.0; n];
            (0..w)
                .map(|col| {
                    let inside = (0..16)
                        .filter(|k| {
                            let (x, yy) = plane(
                                row as f64 + (k / 4) as f64 * 0.25 + 0.125,
                                col as f64 + (k % 4) as f64 * 0.25 + 0.125,
                            );
                            direction(x, yy).is_some()
                        })
                        .count();
                    let coverage = inside as f32 / 16.0;
                    let (xc, yc) = plane(row as f64 + 0.5, col as f64 + 0.5);
                    let oc = center - (from + right * xc + up * yc);
                    let dist = (oc - f * oc.dot(f)).length();
                    if dist + half_diag >= r || oc.dot(f) <= 0.0 {
                        return ([0.0; 3], [0.0; 3], coverage, false);
                    }
                    let (mut full, mut check) = ([0.0; 3], [0.0; 3]);
                    for gy in GL2 {
                        for gx in GL2 {
                            let (x, yy) = plane(row as f64 + 0.5 + gy, col as f64 + 0.5 + gx);
                            let Some(d) = direction(x, yy) else { continue };
                            basis.eval_into(d.to_array(), &mut y);
                            for l in 0..=lmax {
                                let mut s = [0.0; 3];
                                for k in l * l..(l + 1) * (l + 1) {
                                    for c in 0..3 {
                                        s[c] += light[k][c] * y[k];
                                    }
                                }
                                for c in 0..3 {
                                    let term = 0.25 * transfer[l][c] * s[c];
                                    full[c] += term;
                                    if l <= lmax_check {
                                        check[c] += term;
                                    }
                                }
                            }
                        }
                    }
                    let band = [0, 1, 2].map(|c| (full[c] - check[c]).abs());
                    (full, band, coverage, true)
                })
                .collect()
        })
        .collect();
    let mut out = PredictedImage {
        width: w,
        height: h,
        radiance: Vec::with_capacity(w * h),
        systematic: Vec::new(),
        coverage: Vec::with_capacity(w * h),
        predicted: Vec::with_capacity(w * h),
        lmax,
        lmax_check,
    };
    let mut band = Vec::with_capacity(w * h);
    for (b, d, c, p) in rows.into_iter().flatten() {
        out.radiance.push(b);
        band.push(d);
        out.coverage.push(c);
        out.predicted.push(p);
    }
    // Half an oscillation of order lmax on the image: the sphere's radius in pixels times π / lmax.
    let radius_px = r / pix;
    let reach = ((radius_px * std::f64::consts::PI / lmax.max(1) as f64).ceil() as usize).clamp(1, 32);
    out.systematic = envelope(&band, &out.predicted, w, h, reach);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transfer::{lambert, phong};
    use std::f64::consts::PI;

    fn scene(size: usize) -> OrthoScene {
        OrthoScene {
            camera: OrthoCamera { from: [0.0, 0.0, 5.0], to: [0.0; 3], up: [0.0, 1.0, 0.0], extent: 1.2 },
            sphere: Sphere::default(),
            width: size,
            height: size,
        }
    }

    fn rgb(v: &[f64]) -> Vec<[f64; 3]> {
        v.iter().map(|&x| [x; 3]).collect()
    }

    #[test]
    fn the_order_follows_the_transfer() {
        // Lambert: |A_l| / A_0 = l^{-5/2}-ish; 1e-4 is first reached between l = 40 and 50.
        let l = prediction_order(&lambert::lambert(LMAX_CAP + 1));
        assert!((40..=50).contains(&l), "lambert: {l}");
        // Phong s: A_l ≈ exp(−l²/2s), below 1e-4 from l ≈ √(2 s ln 1e4) ≈ 4.3 √s.
        let l = prediction_order(&phong::phong(50.0, LMAX_CAP + 1));
        assert!((28..=34).contains(&l), "phong 50: {l}");
        // A mirror never converges: the cap.
        assert_eq!(prediction_order(&[1.0; LMAX_CAP + 2]), LMAX_CAP);
    }

    #[test]
    fn uniform_light_on_a_lambertian_sphere_is_the_albedo_times_the_radiance() {
        // L_00 = L √(4π), A_0 = albedo: B = albedo · L everywhere on the sphere.
        let (albedo, radiance) = (0.7, 2.0);
        let mut light = vec![[0.0; 3]; 81];
        light[0] = [radiance * (4.0 * PI).sqrt(); 3];
        let transfer: Vec<[f64; 3]> = lambert::lambert(8).iter().map(|a| [albedo * a; 3]).collect();
        let p = predict_orthographic(&scene(24), Param::Normal, &light, &transfer).unwrap();
        let used: Vec<usize> = (0..p.predicted.len()).filter(|&i| p.predicted[i]).collect();
        assert!(used.len() > 200, "{} pixels predicted", used.len());
        for &i in &used {
            assert!((p.radiance[i][0] - albedo * radiance).abs() < 1e-12, "{:?}", p.radiance[i]);
            assert!(p.systematic[i][0] < 1e-12);
            assert_eq!(p.coverage[i], 1.0);
        }
        // The corners miss the sphere: not predicted, coverage 0; the image's stderr is +inf there.
        assert!(!p.predicted[0] && p.coverage[0] == 0.0);
        assert!(p.to_image().channel("stderr.R").unwrap()[0].is_infinite());
    }

    #[test]
    fn a_linear_light_gives_the_closed_form_irradiance() {
        // L(ω) = c + g ω_z (l ≤ 1): a Lambertian sphere of albedo ρ shows ρ (c + (2/3) g n_z) (eq. 38:
        // A_1 = 2/3), averaged over the pixel: the 2 × 2 rule is exact for this polynomial of the
        // image-plane coordinates only approximately (n_z = √(1 − x² − y²)), so compare with a
        // 16 × 16 average of the closed form.
        let (rho, c, g) = (0.8, 1.0, 0.5);
        let mut light = vec![[0.0; 3]; 4];
        light[0] = [c * (4.0 * PI).sqrt(); 3];
        light[2] = [g * (4.0 * PI / 3.0).sqrt(); 3]; // ω_z = √(4π/3) Y_10
        let transfer = rgb(&lambert::lambert(1).iter().map(|a| rho * a).collect::<Vec<_>>());
        let s = scene(16);
        let p = predict_orthographic(&s, Param::Normal, &light, &transfer).unwrap();
        let mut checked = 0;
        for row in 0..16 {
            for col in 0..16 {
                let i = row * 16 + col;
                if !p.predicted[i] {
                    continue;
                }
                let mut mean = 0.0;
                for k in 0..256 {
                    let x = 1.2 * (2.0 * (col as f64 + ((k % 16) as f64 + 0.5) / 16.0) / 16.0 - 1.0);
                    let y = 1.2 * (1.0 - 2.0 * (row as f64 + ((k / 16) as f64 + 0.5) / 16.0) / 16.0);
                    let nz = (1.0 - x * x - y * y).sqrt();
                    mean += rho * (c + 2.0 / 3.0 * g * nz) / 256.0;
                }
                assert!(
                    (p.radiance[i][1] - mean).abs() < 2e-4 * mean,
                    "pixel {row},{col}: {} vs {mean}",
                    p.radiance[i][1]
                );
                checked += 1;
            }
        }
        assert!(checked > 50);
    }

    #[test]
    fn the_reflection_vector_is_the_one_a_phong_sphere_shows() {
        // Light L(ω) = ω_z and a lobe that passes l = 1 unchanged: B(R) = R_z. Seen along −z, the
        // unit sphere's reflection vector at image-plane point (x, y) has R_z = 2 n_z² − 1 =
        // 1 − 2 (x² + y²), a quadratic, which the 2 × 2 rule averages exactly over a pixel of side
        // h: 1 − 2 (x_c² + y_c² + h²/6).
        let mut light = vec![[0.0; 3]; 4];
        light[2] = [(4.0 * PI / 3.0).sqrt(); 3];
        let transfer = rgb(&[0.0, 1.0]);
        let s = scene(15);
        let p = predict_orthographic(&s, Param::Reflection, &light, &transfer).unwrap();
        let h = 2.4 / 15.0;
        let mut checked = 0;
        for i in (0..p.predicted.len()).filter(|&i| p.predicted[i]) {
            let (row, col) = ((i / 15) as f64, (i % 15) as f64);
            let (x, y) = (-1.2 + (col + 0.5) * h, 1.2 - (row + 0.5) * h);
            let want = 1.0 - 2.0 * (x * x + y * y + h * h / 6.0);
            assert!((p.radiance[i][0] - want).abs() < 1e-12, "pixel {i}: {} vs {want}", p.radiance[i][0]);
            checked += 1;
        }
        assert!(checked > 50, "{checked}");
        // The normal parameterization at the centre pixel: n_z ≈ 1, not R_z's 1 − h²/3 … both near 1;
        // off centre they part: at x = 0.64, n_z = 0.77 but R_z = 0.18.
        let normal = predict_orthographic(&scene(15), Param::Normal, &light, &transfer).unwrap();
        let i = 7 * 15 + 11;
        assert!(normal.radiance[i][0] - p.radiance[i][0] > 0.5, "{} vs {}", normal.radiance[i][0], p.radiance[i][0]);
    }

    #[test]
    fn bad_inputs_are_refused() {
        let s = scene(8);
        assert!(predict_orthographic(&s, Param::Normal, &[[0.0; 3]; 3], &rgb(&[1.0, 0.5])).is_err());
        assert!(predict_orthographic(&s, Param::Normal, &[[0.0; 3]; 4], &[]).is_err());
        let mut flat = s;
        flat.sphere.radius = 0.0;
        assert!(predict_orthographic(&flat, Param::Normal, &[[0.0; 3]; 4], &rgb(&[1.0, 0.5])).is_err());
    }
}
