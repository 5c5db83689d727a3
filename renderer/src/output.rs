//! Writing results: float OpenEXR with the layers of docs/src/conventions.md §5 and the scene's camera, render
//! settings, lighting and objects as JSON string attributes in the header (`reflect:camera`,
//! `reflect:render`, `reflect:lighting`, `reflect:objects`, the whole scene as `reflect:scene` and
//! `reflect:integrator`; written and read back by [`vocab::header`]), so an analysis can read the
//! geometry back from the file alone; and an optional tone-mapped sRGB PNG preview.
//!
//! Files are written atomically: to a temporary file in the same directory, then renamed, so a
//! failed or interrupted write never leaves a partial output.

use crate::film::Film;
use crate::scene::Scene;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// The integrator's description written as `reflect:integrator`.
pub const INTEGRATOR: &str = "path (NEE + BRDF sampling, MIS power heuristic)";

/// The header attributes describing how an image was made ([`vocab::header::attributes`]).
pub fn header_attributes(scene: &Scene) -> Vec<(String, String)> {
    vocab::header::attributes(&scene.description, INTEGRATOR)
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// An output written under a hidden temporary name next to its destination, not yet in place.
/// [`Staged::commit`] renames it onto the destination; dropping it uncommitted removes it. Several
/// outputs of one command are staged first and committed together, so a failure in any of them
/// leaves none behind.
#[must_use = "a staged output is removed unless committed"]
pub struct Staged {
    tmp: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl Staged {
    /// Moves the staged file into place.
    pub fn commit(mut self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.path)
            .map_err(|e| Error::file(&self.path, format!("cannot move output into place: {e}")))?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `write(tmp)` to a temporary file next to `path`; removes it on failure.
pub fn stage(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<Staged> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::file(path, format!("cannot create output directory: {e}")))?;
    }
    let staged = Staged { tmp: temp_path(path), path: path.to_path_buf(), committed: false };
    write(&staged.tmp).map_err(|m| Error::file(path, m))?;
    Ok(staged)
}

/// Writes the film as 32-bit float OpenEXR (atomically, see [`stage_exr`]).
pub fn write_exr(path: &Path, film: &Film, attributes: &[(String, String)]) -> Result<()> {
    stage_exr(path, film, attributes)?.commit()
}

/// Stages the film as 32-bit float OpenEXR: R, G, B, normal.X/Y/Z, mask.Y, stderr.R/G/B (the bound,
/// [`crate::film::Pixel::stderr`]), stderr_flag.Y (1 where the pixel's own error bar cannot be trusted,
/// see [`crate::film::Pixel::unreliable`]) and stderr_own.R/G/B (the pixel's own error bar,
/// [`crate::film::Pixel::stderr_own`]).
pub fn stage_exr(path: &Path, film: &Film, attributes: &[(String, String)]) -> Result<Staged> {
    use exr::prelude::*;
    let (w, h) = (film.width as usize, film.height as usize);
    let list: smallvec::SmallVec<[AnyChannel<FlatSamples>; 4]> = film_channels(film)
        .into_iter()
        .map(|(name, samples)| AnyChannel::new(name, FlatSamples::F32(samples)))
        .collect();
    let mut layer =
        Layer::new((w, h), LayerAttributes::default(), vocab::exr_order::FAST_LOSSLESS, AnyChannels::sort(list));
    for (k, v) in attributes {
        if let (Some(k), Some(v)) = (Text::new_or_none(k), Text::new_or_none(v)) {
            layer.attributes.other.insert(k, AttributeValue::Text(v));
        }
    }
    let image = Image::from_layer(layer);
    stage(path, |tmp| vocab::exr_order::write_exr_canonical(tmp, |c| image.write().to_buffered(c)))
}

/// The channels a render writes ([`stage_exr`]), by name, each row-major: what the file holds and
/// what a reader of it gets back (`crate::render_file` builds the image of a partial render from it).
pub fn film_channels(film: &Film) -> Vec<(&'static str, Vec<f32>)> {
    let chan = |name: &'static str, f: &dyn Fn(&crate::film::Pixel) -> f32| (name, film.pixels.iter().map(f).collect());
    vec![
        chan("R", &|p| p.rgb[0]),
        chan("G", &|p| p.rgb[1]),
        chan("B", &|p| p.rgb[2]),
        chan("normal.X", &|p| p.normal[0]),
        chan("normal.Y", &|p| p.normal[1]),
        chan("normal.Z", &|p| p.normal[2]),
        chan("mask.Y", &|p| p.mask),
        chan("stderr.R", &|p| p.stderr[0]),
        chan("stderr.G", &|p| p.stderr[1]),
        chan("stderr.B", &|p| p.stderr[2]),
        chan("stderr_flag.Y", &|p| if p.unreliable { 1.0 } else { 0.0 }),
        chan("stderr_own.R", &|p| p.stderr_own[0]),
        chan("stderr_own.G", &|p| p.stderr_own[1]),
        chan("stderr_own.B", &|p| p.stderr_own[2]),
    ]
}

/// sRGB transfer of a linear value in [0, 1].
fn srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// Tone map of the PNG previews (`reflect png`, `reflect render --png`), per channel: the linear
/// value v is scaled by 2^EV, compressed by Reinhard's x/(1 + x) (so nothing clips: highlights
/// approach white smoothly, 1.0 maps to 0.5), then sRGB-encoded and quantized to 8 bits (round
/// to nearest). Negative values show as 0. Not for analysis (docs/src/conventions.md §5).
pub fn tone_map(v: f32, exposure_ev: f64) -> u8 {
    let x = (v as f64 * exposure_ev.exp2()).max(0.0);
    let y = if x.is_finite() { x / (1.0 + x) } else { 1.0 };
    (srgb(y as f32) * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(rgb: [f32; 3]) -> f64 {
    0.2126 * rgb[0] as f64 + 0.7152 * rgb[1] as f64 + 0.0722 * rgb[2] as f64
}

/// The automatic exposure of the previews: the EV that maps the median luminance of the object's
/// pixels (`mask` > 0 where a mask is given, every pixel otherwise) to 0.18, photographic mid-grey
/// (before the Reinhard curve, which shows 0.18 as 0.153, sRGB 110). `None` when that median is ≤ 0
/// (nothing to scale: a black image, or a 0/1 layer whose median pixel is 0), or there are no pixels.
/// Median: nearest rank (`noise::nearest_rank`).
pub fn auto_exposure(pixels: &[[f32; 3]], mask: Option<&[f32]>) -> Option<f64> {
    let mut y: Vec<f64> = pixels
        .iter()
        .enumerate()
        .filter(|(i, _)| mask.is_none_or(|m| m[*i] > 0.0))
        .map(|(_, p)| luminance(*p))
        .filter(|v| v.is_finite())
        .collect();
    y.sort_by(f64::total_cmp);
    crate::noise::nearest_rank(&y, 0.5).filter(|&m| m > 0.0).map(|m| (0.18 / m).log2())
}

/// Stages a W × H preview PNG (8-bit sRGB, [`tone_map`] at `exposure_ev`): written to a temporary
/// file beside `path`, moved onto it by [`Staged::commit`]. Not for analysis.
pub fn stage_png_rgb(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]], exposure_ev: f64) -> Result<Staged> {
    let buf: Vec<u8> = pixels.iter().flat_map(|p| p.map(|c| tone_map(c, exposure_ev))).collect();
    let img = image::RgbImage::from_raw(width, height, buf).ok_or_else(|| Error::file(path, "bad image size"))?;
    stage(path, |tmp| img.save_with_format(tmp, image::ImageFormat::Png).map_err(|e| format!("cannot write PNG: {e}")))
}

/// Writes a W × H preview PNG atomically (see [`stage_png_rgb`]).
pub fn write_png_rgb(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]], exposure_ev: f64) -> Result<()> {
    stage_png_rgb(path, width, height, pixels, exposure_ev)?.commit()
}

/// Stages a film's preview PNG at `exposure_ev` (see [`stage_png_rgb`]).
pub fn stage_png(path: &Path, film: &Film, exposure_ev: f64) -> Result<Staged> {
    let px: Vec<[f32; 3]> = film.pixels.iter().map(|p| p.rgb).collect();
    stage_png_rgb(path, film.width, film.height, &px, exposure_ev)
}

/// Writes a film's preview PNG at `exposure_ev` (see [`write_png_rgb`]).
pub fn write_png(path: &Path, film: &Film, exposure_ev: f64) -> Result<()> {
    let px: Vec<[f32; 3]> = film.pixels.iter().map(|p| p.rgb).collect();
    write_png_rgb(path, film.width, film.height, &px, exposure_ev)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known values by hand: 0.25 at EV +2 is x = 1, Reinhard 0.5, sRGB 1.055·0.5^(1/2.4) − 0.055
    /// = 0.735357, × 255 = 187.5 → 188; 1.0 at EV −1 is x = 0.5, 1/3, sRGB 0.612475 → 156.
    #[test]
    fn tone_map_known_values() {
        assert_eq!(tone_map(0.25, 2.0), 188);
        assert_eq!(tone_map(1.0, -1.0), 156);
        assert_eq!(tone_map(0.0, 5.0), 0);
        assert_eq!(tone_map(-3.0, 0.0), 0);
        // No clamp at 1: 1, 4 and 16 stay distinguishable; only an enormous value reaches white.
        let (a, b, c) = (tone_map(1.0, 0.0), tone_map(4.0, 0.0), tone_map(16.0, 0.0));
        assert!(a < b && b < c && c < 255, "{a} {b} {c}");
        assert_eq!(tone_map(1e30, 0.0), 255);
    }

    /// The object's median luminance goes to 0.18: grey 0.72 needs EV −2; background pixels
    /// (mask 0) do not count.
    #[test]
    fn auto_exposure_maps_the_median_to_mid_grey() {
        let mut px = vec![[0.72f32; 3]; 5];
        px.extend([[100.0f32; 3]; 6]);
        let mut mask = vec![1.0f32; 5];
        mask.extend([0.0f32; 6]);
        assert!((auto_exposure(&px, Some(&mask)).unwrap() + 2.0).abs() < 1e-6);
        // Without the mask the bright background is the median: log2(0.18/100).
        assert!((auto_exposure(&px, None).unwrap() - (0.18f64 / 100.0).log2()).abs() < 1e-6);
        assert_eq!(auto_exposure(&[[0.0; 3]; 4], None), None);
    }
}
