//! Writing results: float OpenEXR with the layers of CONVENTIONS §5 and the scene's camera, render
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
fn stage(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<Staged> {
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

/// Stages the film as 32-bit float OpenEXR: R, G, B, normal.X/Y/Z, mask.Y, stderr.R/G/B.
pub fn stage_exr(path: &Path, film: &Film, attributes: &[(String, String)]) -> Result<Staged> {
    use exr::prelude::*;
    let (w, h) = (film.width as usize, film.height as usize);
    let chan = |name: &str, f: &dyn Fn(&crate::film::Pixel) -> f32| {
        AnyChannel::new(name, FlatSamples::F32(film.pixels.iter().map(f).collect()))
    };
    let list: smallvec::SmallVec<[AnyChannel<FlatSamples>; 4]> = smallvec::smallvec![
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
    ];
    let mut layer = Layer::new((w, h), LayerAttributes::default(), Encoding::FAST_LOSSLESS, AnyChannels::sort(list));
    for (k, v) in attributes {
        if let (Some(k), Some(v)) = (Text::new_or_none(k), Text::new_or_none(v)) {
            layer.attributes.other.insert(k, AttributeValue::Text(v));
        }
    }
    let image = Image::from_layer(layer);
    stage(path, |tmp| image.write().to_file(tmp).map_err(|e| format!("cannot write OpenEXR: {e}")))
}

/// sRGB transfer of a linear value in [0, 1].
fn srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// Writes a preview PNG (atomically, see [`stage_png`]).
pub fn write_png(path: &Path, film: &Film, exposure: f32) -> Result<()> {
    stage_png(path, film, exposure)?.commit()
}

/// Stages a preview PNG: linear radiance × `exposure`, clamped, sRGB-encoded. Not for analysis.
pub fn stage_png(path: &Path, film: &Film, exposure: f32) -> Result<Staged> {
    let mut buf = Vec::with_capacity(film.pixels.len() * 3);
    for p in &film.pixels {
        for c in p.rgb {
            buf.push((srgb((c * exposure).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8);
        }
    }
    let img =
        image::RgbImage::from_raw(film.width, film.height, buf).ok_or_else(|| Error::file(path, "bad image size"))?;
    stage(path, |tmp| img.save_with_format(tmp, image::ImageFormat::Png).map_err(|e| format!("cannot write PNG: {e}")))
}
