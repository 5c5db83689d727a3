//! Reading the images an analysis takes, for every front-end (the CLI's `analyze`, `invert`,
//! `compare`, and Python): the files read as the analysis commands read them (a render's state as
//! the image of its samples, the radiance layer chosen), and the bound our renders' error bars get
//! near flagged pixels. What the images show is then the observation model's to say
//! ([`analysis::observation::observe`]).

use analysis::Error;
use analysis::image::Image;
use renderer::render_file::read_image_notes;
use std::path::{Path, PathBuf};

/// Reads the images at `paths`, each with its radiance layer chosen by `layer`
/// ([`Image::select_layer`]), and the notes a reader says (`note: FILE: …` lines: a render state
/// read as its image, the layer taken and the layers ignored). One image named twice (by any path
/// to it) is refused: its pixels would count twice (every error bar √2 too small, one view counted
/// as two).
pub fn read(paths: &[PathBuf], layer: Option<&str>) -> Result<(Vec<Image>, Vec<String>), Error> {
    let mut seen = std::collections::HashSet::new();
    for p in paths {
        if !seen.insert(std::fs::canonicalize(p).unwrap_or_else(|_| p.clone())) {
            return Err(Error::file(p, "given more than once: its pixels would count twice (name each view once)"));
        }
    }
    let mut notes = Vec::new();
    let mut images = Vec::with_capacity(paths.len());
    for p in paths {
        let (img, file_notes) = read_image_notes(p)?;
        let (img, note) = img.select_layer(layer).map_err(|e| e.in_file(p))?;
        for n in file_notes.iter().chain(&note) {
            notes.push(format!("note: {}: {n}", p.display()));
        }
        images.push(img);
    }
    Ok((images, notes))
}

/// Prepares images of ours for an analysis ([`bound_near_flags`]) and returns the notes of those
/// with flagged pixels ([`stderr_flag_note`]), for [`analysis::observation::Observation::stderr_notes`].
pub fn bound_flagged(images: &mut [Image], paths: &[PathBuf]) -> Vec<String> {
    let notes = images.iter().zip(paths).filter_map(|(img, p)| stderr_flag_note(img, p)).collect();
    for img in images.iter_mut() {
        bound_near_flags(img);
    }
    notes
}

/// Reads a sidecar scene file (the CLI's `--scene`, Python's `scene=` beside files).
pub fn read_scene(path: &Path) -> Result<vocab::scene::SceneFile, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
    vocab::scene::SceneFile::parse(&text).map_err(|m| Error::file(path, m))
}

/// The note for an image whose `stderr_flag.Y` layer flags pixels (`reflect render`'s diagnostic: one
/// rare sample dominated the pixel's own error bar). No pixel is excluded, since dropping the pixels
/// where a rare heavy sample landed would bias the coefficients; their error bars and their
/// neighbours' are bounded instead ([`bound_near_flags`]). `None` without the layer or without a
/// flagged pixel.
pub fn stderr_flag_note(img: &Image, path: &Path) -> Option<String> {
    let n = img.channel("stderr_flag.Y")?.iter().filter(|&&v| v > 0.0).count();
    (n > 0).then(|| {
        format!(
            "{}: {n} pixels have stderr_flag.Y = 1 (one rare sample dominated their own error bar, guide \"Error \
             bars\"); no pixel excluded, the error bars within {} px of them bounded by their {}×{} window's pooled error",
            path.display(),
            renderer::film::POOL_TRIGGER_RADIUS,
            2 * renderer::film::POOL_RADIUS + 1,
            2 * renderer::film::POOL_RADIUS + 1,
        )
    })
}

/// Applies to a render of ours, as every analysis reads it, the bound of the error bars near flagged
/// pixels that `reflect render` does not write (`renderer::film::pool_heavy_tails`, guide "Error
/// bars"; `verify` applies it to every render it judges): each pixel within
/// `renderer::film::POOL_TRIGGER_RADIUS` of one with `stderr_flag.Y` = 1 gets, per channel,
/// `stderr` = max(`stderr`, √(mean of `stderr_own`² over its window)). Without that bound the pixels
/// whose own σ missed a rare heavy sample carry a χ²/ν of 10²–10⁴ (Phong under Grace at 16 spp) and
/// a fixed bias the fit's bars did not include (tests/partial_view_coverage.rs). Only images with
/// `stderr.R/G/B`, `stderr_own.R/G/B` and `stderr_flag.Y` (our renders) are touched; returns the
/// number of pixels whose error bar was raised in some channel.
pub fn bound_near_flags(img: &mut Image) -> usize {
    let Some(flag) = img.channel("stderr_flag.Y") else { return 0 };
    if !flag.iter().any(|&v| v > 0.0) {
        return 0;
    }
    let (Some(own), Some(_)) = (img.rgb_layer("stderr_own."), img.rgb_layer("stderr.")) else { return 0 };
    let mut film = renderer::film::Film::new(img.width as u32, img.height as u32);
    for ((p, o), &f) in film.pixels.iter_mut().zip(&own.pixels).zip(flag) {
        p.stderr_own = *o;
        p.unreliable = f > 0.0;
    }
    renderer::film::pool_heavy_tails(&mut film, false);
    let mut raised = vec![false; film.pixels.len()];
    for (ch, name) in ["stderr.R", "stderr.G", "stderr.B"].iter().enumerate() {
        let data = img.channels.get_mut(*name).expect("checked above");
        for ((v, p), r) in data.iter_mut().zip(&film.pixels).zip(raised.iter_mut()) {
            if p.stderr[ch] > *v {
                *v = p.stderr[ch];
                *r = true;
            }
        }
    }
    raised.iter().filter(|&&r| r).count()
}
