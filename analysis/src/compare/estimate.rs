//! One side of a comparison: per pixel and channel, an estimate of the radiance, the variance of
//! that estimate and its degrees of freedom, from a render with an error layer or from several
//! seeds of one renderer.

use super::CompareError;
use vocab::image::Image;

/// Why a pixel takes no part in the comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Excluded {
    /// `stderr` = +inf: fewer than two samples, no variance estimate.
    NoEstimate,
}

/// Per-pixel estimates of one side, row-major, `width * height` long.
#[derive(Clone, Debug)]
pub struct Estimate {
    pub width: usize,
    pub height: usize,
    /// The estimate of each pixel (the image, or the mean of the seeds).
    pub mean: Vec<[f64; 3]>,
    /// The variance of `mean` (σ², the square of the error layer, or s²/n over n seeds); 0 for an
    /// image without error layer (taken as exact).
    pub var: Vec<[f64; 3]>,
    /// Degrees of freedom of `var`: from a render's header, its sampler's (15 for Sobol's 16
    /// replicates, spp − 1 for the independent sampler), n − 1 for n seeds, ∞ when unknown (an
    /// error layer of another renderer, taken as exact σ).
    pub dof: f64,
    /// Pixels left out, and why.
    pub excluded: Vec<Option<Excluded>>,
    /// Pixels with `stderr_flag.Y` = 1 (one rare heavy sample dominates their own error bar, guide
    /// "Error bars"). They are compared, not left out: the flag depends on the pixel's own samples
    /// and so correlates with its value (under a map with small bright regions the flagged pixels
    /// are mostly the darker ones), so leaving them out of one side selects on its values and
    /// biases the scale. The caller bounds the error bars near them as every analysis reads a
    /// render (`reflect`'s `bound_near_flags`).
    pub flagged: Vec<bool>,
    /// The seeds' own values (n images), for variances of block means and sums that include the
    /// correlation of neighbouring pixels (a Gaussian film); empty for a single image.
    pub seeds: Vec<Vec<[f64; 3]>>,
    /// The object's coverage (`mask.Y`, else an alpha channel `A`), when the image has one.
    pub mask: Option<Vec<f32>>,
    /// How the variance was obtained, for the report ("stderr layer, 64 spp", "8 seeds").
    pub source: String,
    /// Whether the side has any error estimate (an error layer or seeds).
    pub has_error: bool,
    /// A bound on the systematic error of each pixel (a prediction's truncation), coherent between
    /// pixels: see [`super::CompareParams::b_systematic`].
    pub systematic: Option<Vec<[f64; 3]>>,
}

/// The RGB layout of an image: three channels, or one (`Y`, replicated), or none.
fn layout(img: &Image) -> Option<&'static str> {
    if img.rgb_layer("").is_some() {
        Some("R, G, B")
    } else if img.channel("Y").is_some() {
        Some("Y only")
    } else {
        None
    }
}

/// Checks that `img` (input `index`) has radiance channels and, against `first` (input
/// `first_index`), the same size and channel layout.
pub(super) fn check_alignment(
    img: &Image,
    index: usize,
    first: &Image,
    first_index: usize,
) -> Result<(), CompareError> {
    let lay = layout(img).ok_or(CompareError::NoRadiance { input: index })?;
    if (img.width, img.height) != (first.width, first.height) {
        return Err(CompareError::SizeMismatch {
            input: index,
            width: img.width,
            height: img.height,
            other: first_index,
            other_width: first.width,
            other_height: first.height,
        });
    }
    let first_lay = layout(first).ok_or(CompareError::NoRadiance { input: first_index })?;
    if lay != first_lay {
        return Err(CompareError::ChannelLayout {
            input: index,
            layout: lay,
            other: first_index,
            other_layout: first_lay,
        });
    }
    Ok(())
}

/// The coverage layer of an image: `mask.Y` (ours), else an alpha channel `A` (Mitsuba's and
/// pbrt's RGBA films).
fn coverage(img: &Image) -> Option<Vec<f32>> {
    img.channel("mask.Y").or_else(|| img.channel("A")).map(<[f32]>::to_vec)
}

/// The spp a render's header states (`reflect:render`) and the degrees of freedom of its error
/// layer, which depend on the sampler ([`vocab::Sampler::stderr_dof`]: 15 for Sobol from 16 spp
/// on, spp − 1 for the independent sampler), if the header states them.
fn header_dof(img: &Image) -> Option<(u32, vocab::Sampler, u32)> {
    let r = vocab::header::Header::read(&img.attributes).ok()?.render?;
    Some((r.spp, r.sampler, r.sampler.stderr_dof(r.spp)))
}

/// The degrees of freedom another renderer states for its error layer in the attribute
/// [`vocab::header::STDERR_DOF`] (without it, its σ is taken as exact: with the spread of k
/// replicates, u² would have mean about (k − 1)/(k − 3) and the pixel χ² over 10⁵ pixels would
/// reject correct images). A value that is not a number ≥ 1 is bad input.
fn stated_dof(img: &Image, index: usize) -> Result<Option<f64>, CompareError> {
    let Some(text) = img.attributes.get(vocab::header::STDERR_DOF) else { return Ok(None) };
    match text.trim().parse::<f64>() {
        Ok(d) if d >= 1.0 => Ok(Some(d)),
        _ => Err(CompareError::BadStderrDof { input: index, value: text.clone() }),
    }
}

impl Estimate {
    /// One image: its error layer `stderr.R/G/B` when present (σ² per pixel, of the degrees of
    /// freedom its header's sampler and spp give, else taken as exact), else no error (variance 0).
    /// `stderr_flag.Y` > 0 and +inf in the layer exclude the pixel. `index` names the input in
    /// errors.
    pub fn of_image(img: &Image, index: usize) -> Result<Estimate, CompareError> {
        let rgb = img.rgb().ok_or(CompareError::NoRadiance { input: index })?;
        let n = img.width * img.height;
        let mean: Vec<[f64; 3]> = rgb.pixels.iter().map(|p| p.map(f64::from)).collect();
        let mut excluded = vec![None; n];
        let flag = img.channel("stderr_flag.Y");
        let flagged: Vec<bool> = match flag {
            Some(f) => f.iter().map(|&v| v > 0.0).collect(),
            None => vec![false; n],
        };
        let (var, dof, source, has_error) = match img.rgb_layer("stderr.") {
            Some(layer) => {
                let mut var = vec![[0.0; 3]; n];
                for (i, p) in layer.pixels.iter().enumerate() {
                    for c in 0..3 {
                        let s = p[c];
                        if s == f32::INFINITY {
                            excluded[i] = Some(Excluded::NoEstimate);
                        } else if !(s.is_finite() && s >= 0.0) {
                            return Err(CompareError::BadStderr {
                                input: index,
                                value: s as f64,
                                row: i / img.width,
                                column: i % img.width,
                            });
                        } else {
                            var[i][c] = (s as f64) * (s as f64);
                        }
                    }
                }
                let (dof, source) = match (header_dof(img), stated_dof(img, index)?) {
                    (Some((spp, sampler, d)), _) => {
                        (d as f64, format!("stderr layer ({spp} spp, {sampler} sampler: {d} degrees of freedom)"))
                    }
                    (None, Some(d)) => {
                        (d, format!("stderr layer ({d} degrees of freedom, from its reflect:stderr_dof attribute)"))
                    }
                    (None, None) => (f64::INFINITY, "stderr layer (spp unknown: σ taken as exact)".to_string()),
                };
                (var, dof, source, true)
            }
            None => (vec![[0.0; 3]; n], f64::INFINITY, "no error layer: taken as exact".to_string(), false),
        };
        Ok(Estimate {
            width: img.width,
            height: img.height,
            mean,
            var,
            dof,
            excluded,
            flagged,
            seeds: Vec::new(),
            mask: coverage(img),
            source,
            has_error,
            systematic: None,
        })
    }

    /// Several seeds (independent renders of one scene by one renderer): per pixel the mean and
    /// s²/n, with n − 1 degrees of freedom; their error layers, if any, are not used (the seeds'
    /// spread includes whatever the layers miss). `first_index` is the index of the first seed
    /// among the inputs. Needs n ≥ 2 (checked by the caller).
    pub fn of_seeds(imgs: &[Image], first_index: usize) -> Result<Estimate, CompareError> {
        let n = imgs.len();
        let mut seeds = Vec::with_capacity(n);
        for (k, img) in imgs.iter().enumerate() {
            let rgb = img.rgb().ok_or(CompareError::NoRadiance { input: first_index + k })?;
            seeds.push(rgb.pixels.iter().map(|p| p.map(f64::from)).collect::<Vec<[f64; 3]>>());
        }
        let px = imgs[0].width * imgs[0].height;
        let nf = n as f64;
        let mut mean = vec![[0.0; 3]; px];
        let mut var = vec![[0.0; 3]; px];
        for i in 0..px {
            for c in 0..3 {
                let m = seeds.iter().map(|s| s[i][c]).sum::<f64>() / nf;
                let ss = seeds.iter().map(|s| (s[i][c] - m).powi(2)).sum::<f64>();
                mean[i][c] = m;
                var[i][c] = ss / (nf - 1.0) / nf;
            }
        }
        Ok(Estimate {
            width: imgs[0].width,
            height: imgs[0].height,
            mean,
            var,
            dof: nf - 1.0,
            excluded: vec![None; px],
            flagged: vec![false; px],
            seeds,
            mask: imgs.iter().find_map(coverage),
            source: format!("{n} seeds (per-pixel spread: {} degrees of freedom)", n - 1),
            has_error: true,
            systematic: None,
        })
    }

    /// The sum over the pixels `idx` of channel `c` and the variance of that sum with its degrees
    /// of freedom: from the seeds' own sums when there are seeds (neighbouring pixels' correlation
    /// included), else Σ σ² (pixels independent, a box film) with Welch–Satterthwaite's ν.
    pub fn sum(&self, idx: &[usize], c: usize) -> (f64, f64, f64) {
        let s: f64 = idx.iter().map(|&i| self.mean[i][c]).sum();
        // A systematic bound adds to the sum's variance as one error of its full size: exact (∞
        // degrees of freedom), so it raises the Welch–Satterthwaite ν of the total.
        let sys = self.systematic.as_ref().map_or(0.0, |t| idx.iter().map(|&i| t[i][c]).sum::<f64>().powi(2));
        let with_sys = |v: f64, dof: f64| {
            let total = v + sys;
            let dof = if dof.is_finite() && v > 0.0 { (dof * total * total / (v * v)).min(1e9) } else { dof };
            (s, total, dof)
        };
        if self.seeds.len() >= 2 {
            let n = self.seeds.len() as f64;
            let sums: Vec<f64> = self.seeds.iter().map(|sd| idx.iter().map(|&i| sd[i][c]).sum()).collect();
            let m = sums.iter().sum::<f64>() / n;
            let v = sums.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0) / n;
            return with_sys(v, n - 1.0);
        }
        let v: f64 = idx.iter().map(|&i| self.var[i][c]).sum();
        // Welch–Satterthwaite over the pixels, all with the same ν: (Σ v)² / Σ (v² / ν).
        let v2: f64 = idx.iter().map(|&i| self.var[i][c].powi(2)).sum();
        let dof = if self.dof.is_finite() && v2 > 0.0 { (v * v / v2 * self.dof).min(1e9) } else { f64::INFINITY };
        with_sys(v, dof)
    }

    /// The variance of pixel `i` with its systematic bound added in quadrature.
    pub fn pixel_var(&self, i: usize) -> [f64; 3] {
        match &self.systematic {
            Some(t) => std::array::from_fn(|c| self.var[i][c] + t[i][c] * t[i][c]),
            None => self.var[i],
        }
    }
}
