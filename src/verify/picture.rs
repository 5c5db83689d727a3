//! Pictures of the renders in the report: for one render, the measured image, the image the
//! paper's model predicts for the same pixels, and the signed z-score map
//! z = (measured − predicted)/σ, written as PNG files beside the plots.
//!
//! # The per-check picture API
//!
//! A check attaches one [`Picture`] per render it wants shown (`check.pictures.push(…)`); the report
//! does the rest (files, captions, colour scales). Build one with
//!
//! - [`Picture::new`]: any image — `measured`, `predicted` and `sigma` as row-major W × H slices
//!   (top row first), with `NaN` in `measured` or `predicted` for pixels without data (a camera
//!   miss, a masked pixel: drawn transparent);
//! - [`Picture::probe_filter`]: a `normal-probe` render of a radially symmetric BRDF under a known
//!   SH lighting, predicted as B(n) = Σ_l A_l Σ_m L_lm Y_lm(n) with the paper's filter A_l
//!   (eq. 8/9 with Λ_l ρ̂_l), the form most checks compare in coefficient space;
//! - [`Picture::normals_filter`]: the same prediction at each pixel's `normal` layer, for any
//!   camera (orthographic views of a sphere or a mesh); pixels not fully covered have no data.
//!
//! `stem` names the files (`<stem>_measured.png`, `<stem>_predicted.png`, `<stem>_z.png`) and
//! must be unique in the report: prefix it with the check's name. `sigma` is the standard error
//! of the difference: the render's per-pixel `stderr` layer, combined in quadrature with any error
//! of the prediction (e.g. the f32 rounding floor of a noise-free mirror render). A pixel with
//! σ = 0 and a non-zero difference shows at full saturation; with σ = 0 and no difference, white.
//!
//! Scales (stated in the report's captions): measured and predicted share one linear grey scale
//! ([`Picture::grey_scale`]: black and white at the 0.5th and 99.5th percentiles of the prediction);
//! the z map uses ColorBrewer's diverging RdBu map (blue z < 0, white z = 0, red z > 0), saturated
//! at |z| = [`Z_SCALE`].

use super::fit::{Channel, dot, latlong_dir, normalize, order_parts};
use analysis::sh::{ShBasis, num_coefficients};
use image::{Rgba, RgbaImage};
use serde::Serialize;
use std::path::Path;

/// |z| at which the z map saturates (full red or blue).
pub const Z_SCALE: f64 = 5.0;

/// The shorter side of a picture file is enlarged (nearest neighbour, whole factor) to at least
/// this many pixels, so small quick-mode renders are legible without viewer scaling.
const MIN_SIDE: usize = 192;

/// One render shown in the report: measured, predicted and per-pixel σ (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct Picture {
    /// File stem, unique in the report (prefix with the check name).
    pub stem: String,
    /// Caption, e.g. "Lambert sphere, SH lighting l ≤ 8 (normal probe, green channel)".
    pub title: String,
    /// What the predicted image is, e.g. "eq. 38 filter applied to the lighting".
    pub model: String,
    pub width: usize,
    pub height: usize,
    /// Measured radiance, row-major W × H, top row first; NaN = no data.
    pub measured: Vec<f64>,
    /// Predicted radiance on the same pixels; NaN = no prediction.
    pub predicted: Vec<f64>,
    /// Standard error of measured − predicted per pixel (≥ 0).
    pub sigma: Vec<f64>,
}

/// Summary numbers of a picture's z map (over pixels with data and σ > 0), for captions and JSON.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct ZStats {
    /// Pixels with data and σ > 0.
    pub pixels: usize,
    /// Mean of z.
    pub mean: f64,
    /// Root mean square of z (≈ 1 when the prediction and σ are right).
    pub rms: f64,
    /// Largest |z|.
    pub max_abs: f64,
    /// Fraction of pixels with |z| > 3 (0.27 % for Gaussian noise).
    pub frac_above_3: f64,
}

/// A picture as listed in `report.json`: the files written and the z-map summary (no pixels).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PictureDoc {
    pub title: String,
    pub model: String,
    pub width: usize,
    pub height: usize,
    pub measured_png: String,
    pub predicted_png: String,
    pub z_png: String,
    pub z: ZStats,
    /// Radiance drawn black in the measured and predicted PNGs (linear grey scale).
    pub black: f64,
    /// Radiance drawn white.
    pub white: f64,
}

/// B(d) = Σ_l filter\[l\] Σ_m L_lm Y_lm(d) for the SH lighting `light` (index order k), as a function
/// of the unit direction d (scratch buffers allocated once).
fn filtered_lighting<'a>(light: &'a [f64], filter: &'a [f64]) -> impl FnMut([f64; 3]) -> f64 + 'a {
    let lmax = filter.len().saturating_sub(1);
    let basis = ShBasis::new(lmax);
    let mut y = vec![0.0; num_coefficients(lmax)];
    let mut parts = vec![0.0; lmax + 1];
    move |d| {
        order_parts(&basis, light, d, &mut y, &mut parts);
        parts.iter().zip(filter).map(|(s, a)| s * a).sum()
    }
}

impl Picture {
    /// A picture from row-major W × H slices (see the module docs). Panics if a slice's length is
    /// not W × H (a programming error in the check).
    pub fn new(
        stem: impl Into<String>,
        title: impl Into<String>,
        model: impl Into<String>,
        (width, height): (usize, usize),
        measured: Vec<f64>,
        predicted: Vec<f64>,
        sigma: Vec<f64>,
    ) -> Picture {
        let n = width * height;
        assert!(
            measured.len() == n && predicted.len() == n && sigma.len() == n,
            "Picture::new: slices must hold W × H = {n} values"
        );
        Picture {
            stem: stem.into(),
            title: title.into(),
            model: model.into(),
            width,
            height,
            measured,
            predicted,
            sigma,
        }
    }

    /// A `normal-probe` render (lat-long in the normal, docs/src/conventions.md §2) of a radially symmetric
    /// BRDF under the SH lighting `light` (coefficients in index order k): predicted
    /// B(n) = Σ_l filter\[l\] Σ_m L_lm Y_lm(n) for l < filter.len(). `extra_sigma(i)` is added in
    /// quadrature to the render's σ of pixel i (the prediction's own error; `|_| 0.0` for none).
    pub fn probe_filter(
        stem: impl Into<String>,
        title: impl Into<String>,
        model: impl Into<String>,
        ch: &Channel,
        light: &[f64],
        filter: &[f64],
        extra_sigma: impl Fn(usize) -> f64,
    ) -> Picture {
        let (w, h) = (ch.width, ch.height);
        let mut at = filtered_lighting(light, filter);
        let predicted = (0..w * h).map(|i| at(latlong_dir(i / w, i % w, w, h))).collect();
        let sigma = ch.sigma.iter().enumerate().map(|(i, s)| s.hypot(extra_sigma(i))).collect();
        Picture::new(stem, title, model, (w, h), ch.value.clone(), predicted, sigma)
    }

    /// Any render with a `normal` layer (e.g. an orthographic view of a convex object) of a radially
    /// symmetric BRDF under the SH lighting `light`: predicted B(n_p) = Σ_l filter\[l\] Σ_m L_lm Y_lm(n_p)
    /// at each pixel's normal n_p; pixels the object does not fully cover (mask < 1) have no data.
    pub fn normals_filter(
        stem: impl Into<String>,
        title: impl Into<String>,
        model: impl Into<String>,
        ch: &Channel,
        light: &[f64],
        filter: &[f64],
    ) -> Picture {
        Picture::filter_at(stem, title, model, ch, light, filter, |n| n)
    }

    /// [`Picture::normals_filter`] in the reflection parameterization (eq. 43 for Phong): the filter
    /// is applied at each pixel's reflection vector R = 2(n·ω_o)n − ω_o, for an orthographic view
    /// whose direction towards the camera is `wo` (unit, world frame).
    pub fn reflected_filter(
        stem: impl Into<String>,
        title: impl Into<String>,
        model: impl Into<String>,
        ch: &Channel,
        light: &[f64],
        filter: &[f64],
        wo: [f64; 3],
    ) -> Picture {
        Picture::filter_at(stem, title, model, ch, light, filter, |n| {
            let c = 2.0 * dot(n, wo);
            [c * n[0] - wo[0], c * n[1] - wo[1], c * n[2] - wo[2]]
        })
    }

    /// The filter prediction at the direction `dir(n_p)` of each fully covered pixel's unit normal.
    fn filter_at(
        stem: impl Into<String>,
        title: impl Into<String>,
        model: impl Into<String>,
        ch: &Channel,
        light: &[f64],
        filter: &[f64],
        dir: impl Fn([f64; 3]) -> [f64; 3],
    ) -> Picture {
        let mut at = filtered_lighting(light, filter);
        let covered = |i: usize| ch.mask.get(i).is_some_and(|m| *m >= 1.0);
        let predicted =
            (0..ch.value.len()).map(|i| if covered(i) { at(dir(normalize(ch.normal[i]))) } else { f64::NAN }).collect();
        let measured = (0..ch.value.len()).map(|i| if covered(i) { ch.value[i] } else { f64::NAN }).collect();
        Picture::new(stem, title, model, (ch.width, ch.height), measured, predicted, ch.sigma.clone())
    }

    /// z of pixel i: (measured − predicted)/σ; None without data; ±∞ for σ = 0 and a difference.
    pub fn z(&self, i: usize) -> Option<f64> {
        let d = self.measured[i] - self.predicted[i];
        if !d.is_finite() {
            return None;
        }
        let s = self.sigma[i];
        Some(if s > 0.0 {
            d / s
        } else if d == 0.0 {
            0.0
        } else {
            d.signum() * f64::INFINITY
        })
    }

    /// Summary of the z map over pixels with data and σ > 0.
    pub fn z_stats(&self) -> ZStats {
        let zs: Vec<f64> =
            (0..self.measured.len()).filter(|&i| self.sigma[i] > 0.0).filter_map(|i| self.z(i)).collect();
        let n = zs.len();
        if n == 0 {
            return ZStats::default();
        }
        let nf = n as f64;
        ZStats {
            pixels: n,
            mean: zs.iter().sum::<f64>() / nf,
            rms: (zs.iter().map(|z| z * z).sum::<f64>() / nf).sqrt(),
            max_abs: zs.iter().fold(0.0, |a: f64, z| a.max(z.abs())),
            frac_above_3: zs.iter().filter(|z| z.abs() > 3.0).count() as f64 / nf,
        }
    }

    /// Radiances drawn black and white (linear grey scale between): the 0.5th and 99.5th
    /// percentiles of the finite predicted values (of the measured ones when nothing is predicted),
    /// so the structure of the image fills the scale; when those are (nearly) equal, as for a
    /// constant prediction, black = 0 and white = 1.25 × the value.
    pub fn grey_scale(&self) -> (f64, f64) {
        let pick = |v: &[f64]| {
            let mut f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
            f.sort_by(f64::total_cmp);
            let at = |q: f64| f[((f.len() as f64 - 1.0) * q).round() as usize];
            (!f.is_empty()).then(|| (at(0.005), at(0.995)))
        };
        let (lo, hi) = pick(&self.predicted).or_else(|| pick(&self.measured)).unwrap_or((0.0, 1.0));
        if hi - lo > 1e-3 * hi.abs().max(lo.abs()) {
            (lo, hi)
        } else if hi > 0.0 {
            (0.0, 1.25 * hi)
        } else {
            (lo - 1.0, hi + 1.0)
        }
    }

    /// Names of the three files (measured, predicted, z).
    pub fn files(&self) -> [String; 3] {
        ["measured", "predicted", "z"].map(|k| format!("{}_{k}.png", self.stem))
    }

    /// The JSON listing of this picture.
    pub fn doc(&self) -> PictureDoc {
        let [m, p, z] = self.files();
        PictureDoc {
            title: self.title.clone(),
            model: self.model.clone(),
            width: self.width,
            height: self.height,
            measured_png: m,
            predicted_png: p,
            z_png: z,
            z: self.z_stats(),
            black: self.grey_scale().0,
            white: self.grey_scale().1,
        }
    }

    /// Writes the three PNG files into `dir`.
    pub fn write_png(&self, dir: &Path) -> Result<(), String> {
        let (black, white) = self.grey_scale();
        let tone = |v: f64| -> Rgba<u8> {
            if !v.is_finite() {
                return Rgba([0, 0, 0, 0]);
            }
            let g = (((v - black) / (white - black)).clamp(0.0, 1.0) * 255.0).round() as u8;
            Rgba([g, g, g, 255])
        };
        let [fm, fp, fz] = self.files();
        self.save(dir, &fm, |i| tone(self.measured[i]))?;
        self.save(dir, &fp, |i| tone(self.predicted[i]))?;
        self.save(dir, &fz, |i| match self.z(i) {
            None => Rgba([0, 0, 0, 0]),
            Some(z) => z_colour(z),
        })
    }

    fn save(&self, dir: &Path, file: &str, pixel: impl Fn(usize) -> Rgba<u8>) -> Result<(), String> {
        let s = scale_factor(self.width, self.height);
        let img = RgbaImage::from_fn((self.width * s) as u32, (self.height * s) as u32, |x, y| {
            pixel(y as usize / s * self.width + x as usize / s)
        });
        let path = dir.join(file);
        img.save(&path).map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// The z colour: RdBu with z = −[`Z_SCALE`] → blue end, 0 → white, +[`Z_SCALE`] → red end.
pub fn z_colour(z: f64) -> Rgba<u8> {
    // colorous' RdBu runs red (t = 0) → blue (t = 1).
    let t = (0.5 - z / (2.0 * Z_SCALE)).clamp(0.0, 1.0);
    let c = colorous::RED_BLUE.eval_continuous(t);
    Rgba([c.r, c.g, c.b, 255])
}

/// Writes the z colour bar (`zscale.png`, 256 × 16, left −[`Z_SCALE`], right +[`Z_SCALE`]).
pub fn write_z_scale(dir: &Path) -> Result<(), String> {
    let img = RgbaImage::from_fn(256, 16, |x, _| z_colour((x as f64 + 0.5) / 256.0 * 2.0 * Z_SCALE - Z_SCALE));
    let path = dir.join(Z_SCALE_FILE);
    img.save(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// File name of the z colour bar.
pub const Z_SCALE_FILE: &str = "zscale.png";

fn scale_factor(w: usize, h: usize) -> usize {
    MIN_SIDE.div_ceil(w.min(h).max(1)).clamp(1, 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn z_map_signs_stats_and_files() {
        // 2 × 2: over-bright (+2σ), under (−1σ), exact, no data.
        let p = Picture::new(
            "t",
            "t",
            "m",
            (2, 2),
            vec![1.2, 0.9, 1.0, f64::NAN],
            vec![1.0, 1.0, 1.0, 1.0],
            vec![0.1, 0.1, 0.1, 0.1],
        );
        assert!((p.z(0).unwrap() - 2.0).abs() < 1e-12 && (p.z(1).unwrap() + 1.0).abs() < 1e-12);
        assert_eq!(p.z(3), None);
        let s = p.z_stats();
        assert_eq!(s.pixels, 3);
        assert!((s.rms - (5.0f64 / 3.0).sqrt()).abs() < 1e-12 && (s.max_abs - 2.0).abs() < 1e-12);
        // Positive z is red, negative blue, zero white-ish.
        let (r, b, w0) = (z_colour(3.0), z_colour(-3.0), z_colour(0.0));
        // (RdBu's centre is a light grey, #f7f7f7 in ColorBrewer's 11-class table.)
        assert!(r[0] > r[2] && b[2] > b[0], "{r:?} {b:?}");
        assert!(w0.0[..3].iter().all(|&c| c > 225) && w0[0].abs_diff(w0[2]) < 12, "{w0:?}");
        let dir = std::env::temp_dir().join(format!("reflect-picture-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        p.write_png(&dir).unwrap();
        let img = image::open(dir.join("t_z.png")).unwrap().to_rgba8();
        assert_eq!(img.width(), 2 * scale_factor(2, 2) as u32);
        assert_eq!(img.get_pixel(0, 0), &z_colour(2.0));
        assert_eq!(img.get_pixel(img.width() - 1, img.height() - 1)[3], 0, "no data is transparent");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn probe_filter_of_the_true_filter_has_zero_residual() {
        let light = super::super::scenes::sh_lighting(2, 0.5, 1);
        let filter = [1.0, 2.0 / 3.0, 0.25];
        let basis = ShBasis::new(2);
        let f = |n| {
            let (mut y, mut s) = (vec![0.0; 9], vec![0.0; 3]);
            order_parts(&basis, &light, n, &mut y, &mut s);
            s.iter().zip(&filter).map(|(a, b)| a * b).sum::<f64>()
        };
        let ch = Channel::synthetic_probe(16, 8, f, 0.0, 1);
        let p = Picture::probe_filter("t", "t", "m", &ch, &light, &filter, |_| 1e-3);
        assert!(p.z_stats().max_abs < 1e-9, "{:?}", p.z_stats());
    }
}
