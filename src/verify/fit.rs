//! The verify checks' view of a rendered film: one [`Channel`] (value, standard error, normal,
//! mask per pixel) and the pixel-space analysis of `analysis::fit` applied to it — the same
//! functions `reflect analyze` and `reflect invert` call (issue 11: verify checks what users run).

pub use analysis::fit::{Fit, latlong_omega, lsq, order_parts, order_rms, sh_design};
use glam::DVec3;
use renderer::film::Film;
#[cfg(test)]
use std::f64::consts::PI;

/// Direction of the centre of lat-long pixel (r, c) of a W × H grid (docs/src/conventions.md §2).
pub fn latlong_dir(r: usize, c: usize, w: usize, h: usize) -> [f64; 3] {
    analysis::sh::latlong_direction(r, c, w, h)
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    DVec3::from(a).dot(DVec3::from(b))
}

/// `a / |a|`; a zero vector is returned unchanged.
pub fn normalize(a: [f64; 3]) -> [f64; 3] {
    DVec3::from(a).try_normalize().map_or(a, |n| n.to_array())
}

/// The frame (forward, right, up) of an orthographic camera at `from` looking at the origin
/// (docs/src/conventions.md §5), as `analysis` computes it for the analyses.
pub fn view_basis(from: [f64; 3], up: [f64; 3]) -> [[f64; 3]; 3] {
    let camera = analysis::projection::orthographic::OrthoCamera { from, to: [0.0; 3], up, extent: 1.0 };
    camera.basis().expect("the checks' fixed views have from ≠ origin and up not along the view")
}

/// One channel of a film: value, standard error and (for the normal probe) the pixel's normal and
/// solid angle.
#[derive(Clone, Debug, Default)]
pub struct Channel {
    pub width: usize,
    pub height: usize,
    pub value: Vec<f64>,
    /// The error bar of each pixel (the `stderr` layer: the renderer's bound).
    pub sigma: Vec<f64>,
    /// The pixel's own standard error (the `stderr_own` layer; `sigma` when the image has none), for
    /// debiasing a noise energy (`renderer::film`, "Two layers").
    pub sigma_own: Vec<f64>,
    pub normal: Vec<[f64; 3]>,
    pub mask: Vec<f64>,
}

impl Channel {
    pub fn from_film(f: &Film, c: usize) -> Channel {
        Channel {
            width: f.width as usize,
            height: f.height as usize,
            value: f.pixels.iter().map(|p| p.rgb[c] as f64).collect(),
            sigma: f.pixels.iter().map(|p| p.stderr[c] as f64).collect(),
            sigma_own: f.pixels.iter().map(|p| p.stderr_own[c] as f64).collect(),
            normal: f.pixels.iter().map(|p| p.normal.map(|v| v as f64)).collect(),
            mask: f.pixels.iter().map(|p| p.mask as f64).collect(),
        }
    }

    /// Channel `c` (0 = R, 1 = G, 2 = B) of a render read back from its EXR, as `analyze` reads it:
    /// σ from the `stderr` layer (0 without one), own σ from `stderr_own` (σ without one), the `normal` layer ((0, 0, 0) without one) and
    /// `mask.Y` (1 without one). Missing colour channels read as 0.
    pub fn from_image(img: &analysis::image::Image, c: usize) -> Channel {
        let n = img.width * img.height;
        let layer = |name: &str, default: f64| -> Vec<f64> {
            img.channel(name).map(|v| v.iter().map(|x| *x as f64).collect()).unwrap_or_else(|| vec![default; n])
        };
        let rgb = ["R", "G", "B"][c];
        let (nx, ny, nz) = (layer("normal.X", 0.0), layer("normal.Y", 0.0), layer("normal.Z", 0.0));
        Channel {
            width: img.width,
            height: img.height,
            value: layer(rgb, 0.0),
            sigma: layer(&format!("stderr.{rgb}"), 0.0),
            sigma_own: match img.channel(&format!("stderr_own.{rgb}")) {
                Some(v) => v.iter().map(|x| *x as f64).collect(),
                None => layer(&format!("stderr.{rgb}"), 0.0),
            },
            normal: (0..n).map(|i| [nx[i], ny[i], nz[i]]).collect(),
            mask: layer("mask.Y", 1.0),
        }
    }

    #[cfg(test)]
    /// A synthetic normal-probe image (tests): value f(n) + noise, stderr σ.
    pub fn synthetic_probe(w: usize, h: usize, f: impl Fn([f64; 3]) -> f64, sigma: f64, seed: u64) -> Channel {
        let mut rng = renderer::sampling::chi2::TestRng::new(seed);
        let mut ch = Channel { width: w, height: h, ..Default::default() };
        for r in 0..h {
            for c in 0..w {
                let n = latlong_dir(r, c, w, h);
                // Box–Muller normal noise.
                let mut u = || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
                let (u1, u2) = (u().max(1e-300), u());
                let g = (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos();
                ch.value.push(f(n) + sigma * g);
                ch.sigma.push(sigma);
                ch.normal.push(n);
                ch.mask.push(1.0);
            }
        }
        ch
    }
}

/// SH projection of a normal-probe channel by lat-long quadrature ([`analysis::fit::project_probe`]).
pub fn project_probe(ch: &Channel, lmax: usize) -> (Vec<f64>, Vec<f64>) {
    analysis::fit::project_probe(&ch.value, &ch.sigma, ch.width, ch.height, lmax)
}

/// Per-order filter of a normal-probe channel under a known SH lighting, the order parts at the
/// pixel's normal ([`analysis::fit::fit_filter_grid`]).
pub fn fit_filter_probe(ch: &Channel, light: &[f64], lmax_fit: usize) -> Option<Fit> {
    let (w, h) = (ch.width, ch.height);
    fit_filter_at(ch, light, lmax_fit, |r, c| latlong_dir(r, c, w, h))
}

/// Like [`fit_filter_probe`], the order parts at `dir(r, c)` (e.g. the reflection vector).
pub fn fit_filter_at(
    ch: &Channel,
    light: &[f64],
    lmax_fit: usize,
    dir: impl Fn(usize, usize) -> [f64; 3],
) -> Option<Fit> {
    analysis::fit::fit_filter_grid(&ch.value, &ch.sigma, ch.width, ch.height, light, lmax_fit, dir)
}
