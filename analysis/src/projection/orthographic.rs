//! SH coefficients of the reflected radiance from one or more orthographic images of a sphere, by
//! weighted least squares over the covered part of the sphere.
//!
//! Parameters:
//! - [`OrthoCamera`]: `from`, `to`, `up`, `extent` (docs/src/conventions.md §5 pixel → ray mapping);
//! - [`Sphere`]: centre and radius: which pixels are covered, and the normals when the image has no
//!   `normal.X/Y/Z` layer (so EXR files of any renderer with only R, G, B work); with the layer, its
//!   normalized per-pixel normal is used;
//! - [`Param`]: the direction a pixel's radiance is attributed to: the normal n (radially symmetric
//!   about n, e.g. Lambertian: B(n)) or the reflection vector R = 2(n·ω_o)n − ω_o (reparameterized
//!   reflective BRDFs, e.g. Phong, mirror: B(R));
//! - `lmax`.
//!
//! A pixel is used when its whole footprint lies on the sphere (centre distance + half diagonal
//! < radius) and, if the image has `mask.Y`, the mask is ≥ 0.999. The fit minimizes
//! Σ_j w_j (B_j − Σ_k c_k Y_k(d_j))² with w_j the solid angle the pixel covers in the fitted
//! direction domain (normal: ΔA / (r² n·ω_o); reflection: 4 ΔA / r², since dω_R = 4 (n·ω_o) dω_n),
//! so that on the full sphere it tends to the L² projection. Coefficient covariance is the sandwich
//! G⁻¹ (Σ w² σ² y yᵀ) G⁻¹ with G = Σ w y yᵀ, σ from the `stderr` layer, or, without one, a common
//! per-channel σ² estimated from the weighted-fit residuals (homoscedastic model).

use crate::error::{Error, Result};
use crate::image::Image;
use crate::lsq::Cholesky;
use crate::sh::{ShBasis, num_coefficients};
use glam::DVec3;
use rayon::prelude::*;

/// Orthographic camera of docs/src/conventions.md §5.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoCamera {
    pub from: [f64; 3],
    pub to: [f64; 3],
    pub up: [f64; 3],
    pub extent: f64,
}

impl OrthoCamera {
    /// The camera's orthonormal frame (forward f, right, up) of docs/src/conventions.md §5: f = unit(to − from),
    /// right = unit(f × up), up' = right × f. Errors: `from` equals `to`, or `up` is parallel to f.
    pub fn basis(&self) -> Result<[[f64; 3]; 3]> {
        let (from, to, up) = (DVec3::from(self.from), DVec3::from(self.to), DVec3::from(self.up));
        let f = normalize(to - from).ok_or_else(|| Error::new("camera 'from' equals 'to'"))?;
        let right =
            normalize(f.cross(up)).ok_or_else(|| Error::new("camera 'up' is parallel to the view direction"))?;
        Ok([f.to_array(), right.to_array(), right.cross(f).to_array()])
    }

    /// Whether two cameras make the same image (docs/src/conventions.md §5): the same forward and
    /// right vectors, extent and line through the image centre, to the relative precision 1e-5 of
    /// values stored as f32 (headers). `from` may slide along the view direction and `up` tilt
    /// within the plane of forward and up', as neither changes a ray. A degenerate camera (no
    /// basis) is the same as no other.
    pub fn same_view(&self, other: &OrthoCamera) -> bool {
        const AGREE: f64 = 1e-5;
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= AGREE * scale.max(a.abs()).max(b.abs()).max(1.0);
        let (Ok([fa, ra, _]), Ok([fb, rb, _])) = (self.basis(), other.basis()) else { return false };
        let (fa, fb, ra, rb) = (DVec3::from(fa), DVec3::from(fb), DVec3::from(ra), DVec3::from(rb));
        let d = DVec3::from(self.from) - DVec3::from(other.from);
        let perp = d - fa * d.dot(fa);
        let s = self.extent.abs().max(other.extent.abs());
        (0..3).all(|i| close(fa[i], fb[i], 1.0) && close(ra[i], rb[i], 1.0) && close(perp[i], 0.0, s))
            && close(self.extent, other.extent, s)
    }
}

/// A sphere in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: [f64; 3],
    pub radius: f64,
}

impl Default for Sphere {
    fn default() -> Self {
        Sphere { center: [0.0; 3], radius: 1.0 }
    }
}

/// Which direction the pixel's radiance is a function of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    Normal,
    Reflection,
}

impl Param {
    pub fn name(&self) -> &'static str {
        match self {
            Param::Normal => "normal",
            Param::Reflection => "reflection",
        }
    }
}

/// One image with its camera.
#[derive(Clone, Copy, Debug)]
pub struct OrthoView<'a> {
    pub image: &'a Image,
    pub camera: OrthoCamera,
}

/// Result of a least-squares fit.
#[derive(Clone, Debug)]
pub struct Fit {
    pub coefficients: Vec<[f64; 3]>,
    pub stderr: Vec<[f64; 3]>,
    /// `"stderr-layer"` or `"residuals"`.
    pub stderr_source: &'static str,
    pub pixels_used: usize,
    /// The highest order the views carry (`fit_orthographic` refuses any l_max above it).
    pub lmax_carried: usize,
    /// Weighted RMS residual per channel (√(Σ w r² / Σ w)).
    pub rms_residual: [f64; 3],
}

/// `a / |a|`, or `None` for a zero or non-finite vector.
fn normalize(a: DVec3) -> Option<DVec3> {
    let n = a.length();
    (n > 0.0 && n.is_finite()).then(|| a * (1.0 / n))
}

/// One covered pixel: fit direction, weight, radiance and variance.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// The direction the radiance is attributed to (unit; normal or reflection vector, [`Param`]).
    pub dir: [f64; 3],
    /// Solid angle (sr) the pixel covers in the fitted direction domain (module docs).
    pub w: f64,
    /// RGB radiance.
    pub b: [f64; 3],
    /// RGB variance from the `stderr` layer (1 without one).
    pub var: [f64; 3],
}

/// The covered pixels of all `views` (same selection, directions and weights as
/// [`fit_orthographic`]) and whether every view has a `stderr` layer (without one, `var` is 1).
/// Errors: an image without R, G, B, a degenerate camera, a non-positive extent or radius.
pub fn ortho_samples(views: &[OrthoView], sphere: &Sphere, param: Param) -> Result<(Vec<Sample>, bool)> {
    let mut samples = Vec::new();
    let mut all_have_stderr = true;
    for v in views {
        all_have_stderr &= collect_samples(v, sphere, param, &mut samples, &mut Vec::new())?;
    }
    if !all_have_stderr {
        samples.iter_mut().for_each(|s| s.var = [1.0; 3]);
    }
    Ok((samples, all_have_stderr))
}

/// The pixel (view index, row, column) of each sample of [`ortho_samples`], in the same order: where
/// per-pixel quantities (residuals) sit on the image grid, for statistics over neighbouring pixels
/// ([`crate::noise`]).
pub fn ortho_sample_pixels(views: &[OrthoView], sphere: &Sphere, param: Param) -> Result<Vec<[usize; 3]>> {
    let mut at = Vec::new();
    for (k, v) in views.iter().enumerate() {
        let mut pix = Vec::new();
        collect_samples(v, sphere, param, &mut Vec::new(), &mut pix)?;
        at.extend(pix.into_iter().map(|[r, c]| [k, r, c]));
    }
    Ok(at)
}

/// The `stderr` layer of `img` when it carries an error estimate: `None` without the layer and
/// also when it is 0 at every pixel of an image that does not say it was rendered with at least 2
/// samples per pixel (`reflect:render`'s `spp`) — one sample per pixel (a 1-spp render) has no
/// spread to estimate σ from, and a σ of 0 would print ± 0 — so the fits take σ from their
/// residuals, as for an image without the layer. A layer that is 0 everywhere in a render of
/// ≥ 2 spp is an exact zero (a deterministic estimator, e.g. a pixel-centre normal probe under a
/// directional source: every sample agreed) and is kept. Errors as [`Image::stderr_layer`].
pub fn stderr_estimate(img: &Image) -> Result<Option<crate::image::RgbImage>> {
    let Some(layer) = img.stderr_layer()? else { return Ok(None) };
    if layer.pixels.iter().any(|p| p.iter().any(|&v| v > 0.0)) {
        return Ok(Some(layer));
    }
    // A malformed render header is reported by the header's own reader; here it only means "unknown".
    let spp = vocab::header::read_key::<vocab::scene::RenderSection>(&img.attributes, vocab::header::RENDER)
        .ok()
        .flatten()
        .map(|r| r.spp);
    Ok(spp.is_some_and(|n| n >= 2).then_some(layer))
}

/// Appends the covered pixels of `view` to `out` and their (row, column) to `at`.
fn collect_samples(
    view: &OrthoView,
    sphere: &Sphere,
    param: Param,
    out: &mut Vec<Sample>,
    at: &mut Vec<[usize; 2]>,
) -> Result<bool> {
    let img = view.image;
    let cam = &view.camera;
    let rgb = img.rgb().ok_or_else(|| Error::new("image has no R, G, B channels"))?;
    let stderr = stderr_estimate(img)?;
    let mask = img.channel("mask.Y");
    let normals = match (img.channel("normal.X"), img.channel("normal.Y"), img.channel("normal.Z")) {
        (Some(x), Some(y), Some(z)) => Some((x, y, z)),
        _ => None,
    };
    let [f, right, up] = cam.basis()?.map(DVec3::from);
    let (from, center) = (DVec3::from(cam.from), DVec3::from(sphere.center));
    if !(cam.extent > 0.0) || !(sphere.radius > 0.0) {
        return Err(Error::new("camera extent and sphere radius must be positive"));
    }
    let (w, h) = (img.width, img.height);
    let pix = 2.0 * cam.extent / w as f64; // square pixels (docs/src/conventions.md §5: y scaled by H/W)
    let d_area = pix * pix;
    let half_diag = pix * std::f64::consts::FRAC_1_SQRT_2;
    let r = sphere.radius;
    let wo = -f;
    for row in 0..h {
        for col in 0..w {
            let i = row * w + col;
            if let Some(m) = mask
                && m[i] < 0.999
            {
                continue;
            }
            let x = cam.extent * (2.0 * (col as f64 + 0.5) / w as f64 - 1.0);
            let y = cam.extent * (h as f64 / w as f64) * (1.0 - 2.0 * (row as f64 + 0.5) / h as f64);
            let o = from + (right * x + up * y);
            let oc = center - o;
            let along = oc.dot(f);
            let perp = oc - f * along;
            let dist = perp.dot(perp).sqrt();
            if dist + half_diag >= r || along <= 0.0 {
                continue;
            }
            let t = along - (r * r - dist * dist).sqrt();
            let hit = o + f * t;
            let mut n = (hit - center) * (1.0 / r);
            // The renderer's normal layer (the pixel's mean first-hit normal) when present: robust
            // to a slightly misplaced sphere; the geometric normal otherwise. A (near-)zero layer
            // normal is a miss (or a pixel mostly off the object): skip it.
            if let Some((nx, ny, nz)) = normals {
                let m = DVec3::new(nx[i] as f64, ny[i] as f64, nz[i] as f64);
                if m.dot(m) <= 0.25 {
                    continue;
                }
                n = normalize(m).unwrap_or(n);
            }
            let cos_o = n.dot(wo);
            let (dir, wt) = match param {
                Param::Normal => (n, d_area / (r * r * cos_o)),
                Param::Reflection => (n * (2.0 * cos_o) - wo, 4.0 * d_area / (r * r)),
            };
            let Some(dir) = normalize(dir) else { continue };
            let px = rgb.pixels[i];
            let var = match &stderr {
                Some(s) => {
                    let e = s.pixels[i];
                    [(e[0] as f64).powi(2), (e[1] as f64).powi(2), (e[2] as f64).powi(2)]
                }
                None => [1.0; 3],
            };
            out.push(Sample { dir: dir.to_array(), w: wt, b: [px[0] as f64, px[1] as f64, px[2] as f64], var });
            at.push([row, col]);
        }
    }
    Ok(stderr.is_some())
}

/// Number of fixed blocks the normal equations are accumulated in (fixed, so the floating-point
/// summation order, hence the result, does not depend on the number of threads).
const BLOCKS: usize = 16;

/// Samples per tile of the normal-equation accumulation (see `fit_orthographic`).
const TILE: usize = 32;

/// Dot product of two tiles with 8 independent partial sums, so that it vectorizes (a single
/// running sum is one long dependency chain, since floating-point addition may not be reordered).
#[inline(always)]
fn dot_tile(a: &[f64; TILE], b: &[f64]) -> f64 {
    let b: &[f64; TILE] = b.try_into().expect("tile length");
    let mut s = [0.0f64; 8];
    for (ca, cb) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        for u in 0..8 {
            s[u] += ca[u] * cb[u];
        }
    }
    (s[0] + s[4]) + (s[1] + s[5]) + ((s[2] + s[6]) + (s[3] + s[7]))
}

/// Fits RGB coefficients up to `lmax` to the covered pixels of all `views` (see module docs).
///
/// Refuses an `lmax` above the highest order the views carry
/// ([`crate::projection::resolution::ortho_max_order`] of the finest view: the sphere's diameter
/// D in pixels, D − 1 in the normal parameterization, D/2 − 1 in the reflection one).
pub fn fit_orthographic(views: &[OrthoView], sphere: &Sphere, param: Param, lmax: usize) -> Result<Fit> {
    let diameter_px = views
        .iter()
        .map(|v| sphere.radius * v.image.width as f64 / v.camera.extent)
        .filter(|d| d.is_finite())
        .fold(0.0f64, f64::max);
    let lmax_carried = super::resolution::ortho_max_order(diameter_px, param == Param::Reflection);
    super::resolution::check_order(
        lmax,
        lmax_carried,
        &format!("an orthographic view with the sphere {diameter_px:.1} pixels across"),
        if param == Param::Reflection {
            "visible normals attributed to the reflection vector: l < D/2, D the sphere's diameter in pixels"
        } else {
            "visible normals: l < D, D the sphere's diameter in pixels"
        },
    )?;
    let (samples, all_have_stderr) = ortho_samples(views, sphere, param)?;
    let p = num_coefficients(lmax);
    if samples.len() < 2 * p {
        return Err(Error::new(format!(
            "only {} pixels lie on the sphere, too few for {p} coefficients (l_max {lmax}); check the camera and sphere or lower --lmax",
            samples.len()
        )));
    }
    let basis = ShBasis::new(lmax);
    // Upper triangle of G (lane 0, weight w) and of H_c (lanes 1–3, weight w² σ_c²), packed by rows.
    let tri = p * (p + 1) / 2;
    let chunk = samples.len().div_ceil(BLOCKS);
    type Partial = (Vec<[f64; 4]>, Vec<[f64; 3]>);
    let parts: Vec<Partial> = samples
        .par_chunks(chunk)
        .map(|ss| {
            let mut acc = vec![[0.0f64; 4]; tri];
            let mut rhs = vec![[0.0f64; 3]; p];
            let mut y = vec![0.0; p];
            // Samples go in tiles of TILE: Y (p × TILE, column per sample) and the four weighted
            // copies lane_ℓ · Y, so that each accumulator entry is updated once per tile by short
            // dot products instead of streaming the whole p² accumulator once per sample.
            let mut yt = vec![0.0f64; p * TILE];
            let mut wyt = vec![[0.0f64; TILE]; 4 * p];
            for tile in ss.chunks(TILE) {
                let t = tile.len();
                for (si, smp) in tile.iter().enumerate() {
                    basis.eval_into(smp.dir, &mut y);
                    let lanes =
                        [smp.w, smp.w * smp.w * smp.var[0], smp.w * smp.w * smp.var[1], smp.w * smp.w * smp.var[2]];
                    for i in 0..p {
                        yt[i * TILE + si] = y[i];
                        for l in 0..4 {
                            wyt[4 * i + l][si] = lanes[l] * y[i];
                        }
                        for ch in 0..3 {
                            rhs[i][ch] += lanes[0] * y[i] * smp.b[ch];
                        }
                    }
                }
                if t < TILE {
                    // Zero the unused tail so full-width dot products stay exact.
                    for i in 0..p {
                        yt[i * TILE + t..(i + 1) * TILE].iter_mut().for_each(|v| *v = 0.0);
                    }
                }
                let mut off = 0;
                for i in 0..p {
                    let (w0, w1, w2, w3) = (&wyt[4 * i], &wyt[4 * i + 1], &wyt[4 * i + 2], &wyt[4 * i + 3]);
                    for j in i..p {
                        let yj = &yt[j * TILE..(j + 1) * TILE];
                        let (s0, s1, s2, s3);
                        if all_have_stderr {
                            s0 = dot_tile(w0, yj);
                            s1 = dot_tile(w1, yj);
                            s2 = dot_tile(w2, yj);
                            s3 = dot_tile(w3, yj);
                        } else {
                            // Without a stderr layer the three variance lanes are identical.
                            s0 = dot_tile(w0, yj);
                            s1 = dot_tile(w1, yj);
                            s2 = s1;
                            s3 = s1;
                        }
                        let a = &mut acc[off + j - i];
                        a[0] += s0;
                        a[1] += s1;
                        a[2] += s2;
                        a[3] += s3;
                    }
                    off += p - i;
                }
            }
            (acc, rhs)
        })
        .collect();
    let mut acc = vec![[0.0f64; 4]; tri];
    let mut rhs = vec![[0.0f64; 3]; p];
    for (a, r) in parts {
        for (x, y) in acc.iter_mut().zip(&a) {
            for l in 0..4 {
                x[l] += y[l];
            }
        }
        for (x, y) in rhs.iter_mut().zip(&r) {
            for ch in 0..3 {
                x[ch] += y[ch];
            }
        }
    }
    let unpack = |lane: usize| {
        let mut m = vec![0.0; p * p];
        let mut off = 0;
        for i in 0..p {
            for j in i..p {
                m[i * p + j] = acc[off + j - i][lane];
                m[j * p + i] = acc[off + j - i][lane];
            }
            off += p - i;
        }
        m
    };
    let g = unpack(0);
    let chol = Cholesky::new(&g, p, 1e-13).map_err(|e| {
        Error::new(format!(
            "{} — the covered part of the sphere does not determine all SH coefficients up to l_max {lmax}; add views or lower --lmax",
            e.message
        ))
    })?;
    let mut coefficients = vec![[0.0; 3]; p];
    for ch in 0..3 {
        let mut b: Vec<f64> = rhs.iter().map(|r| r[ch]).collect();
        chol.solve(&mut b);
        for k in 0..p {
            coefficients[k][ch] = b[k];
        }
    }
    // Residuals (weighted RMS, and the homoscedastic σ² estimate when there is no stderr layer).
    let (rss, rss_w, sum_w) = samples
        .par_chunks(chunk)
        .map(|ss| {
            let mut y = vec![0.0; p];
            let (mut rss, mut rssw, mut sw) = ([0.0f64; 3], [0.0f64; 3], 0.0f64);
            for s in ss {
                basis.eval_into(s.dir, &mut y);
                for ch in 0..3 {
                    let pred: f64 = coefficients.iter().zip(&y).map(|(c, y)| c[ch] * y).sum();
                    let r = s.b[ch] - pred;
                    rss[ch] += r * r;
                    rssw[ch] += s.w * r * r;
                }
                sw += s.w;
            }
            (rss, rssw, sw)
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold(([0.0; 3], [0.0; 3], 0.0), |(a, b, c), (x, y, z)| {
            ([a[0] + x[0], a[1] + x[1], a[2] + x[2]], [b[0] + y[0], b[1] + y[1], b[2] + y[2]], c + z)
        });
    let dof = (samples.len() - p) as f64;
    let ginv = chol.inverse();
    let mut stderr = vec![[0.0; 3]; p];
    for ch in 0..3 {
        let hmat = unpack(ch + 1);
        let sigma2 = if all_have_stderr { 1.0 } else { rss[ch] / dof };
        // diag(G⁻¹ H G⁻¹)_k = Σ_ij G⁻¹_ki H_ij G⁻¹_jk.
        let rows: Vec<f64> = (0..p)
            .into_par_iter()
            .map(|k| {
                let gk = &ginv[k * p..(k + 1) * p];
                let mut s = 0.0;
                for i in 0..p {
                    let hi = &hmat[i * p..(i + 1) * p];
                    let t: f64 = hi.iter().zip(gk).map(|(h, g)| h * g).sum();
                    s += gk[i] * t;
                }
                s
            })
            .collect();
        for k in 0..p {
            stderr[k][ch] = (rows[k] * sigma2).max(0.0).sqrt();
        }
    }
    Ok(Fit {
        coefficients,
        stderr,
        stderr_source: if all_have_stderr { "stderr-layer" } else { "residuals" },
        pixels_used: samples.len(),
        lmax_carried: lmax_carried.unwrap_or(0),
        rms_residual: [(rss_w[0] / sum_w).sqrt(), (rss_w[1] / sum_w).sqrt(), (rss_w[2] / sum_w).sqrt()],
    })
}
