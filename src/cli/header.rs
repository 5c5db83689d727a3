//! Reading the images of `reflect analyze` and every `reflect invert` subcommand, and their
//! description from the flags: the flags ([`ViewArgs`], [`BrdfFlags`]) become the typed explicit
//! values of the observation model ([`analysis::observation`], which resolves the camera, sphere,
//! BRDF and lighting from the headers, a sidecar `--scene` and these values).

use super::Error;
use super::args::{BrdfFlags, ViewArgs};
use analysis::image::Image;
use analysis::observation::{BrdfValues, Camera, Given, Observation};
use analysis::projection::mirror_columns;
use renderer::render_file::read_image_notes;
use std::path::{Path, PathBuf};
use vocab::scene::SceneFile;

/// Describes `images` (read from `paths`) from their headers, `view.image.scene` and the flags of
/// `view` ([`analysis::observation::describe`]). `what` is the command's verb for refusals
/// ("analysed", "inverted").
pub fn describe(images: &[Image], paths: &[PathBuf], view: &ViewArgs, what: &str) -> Result<Observation, Error> {
    let scene = view.image.scene.as_ref().map(|p| read_scene(p).map(|s| (p.clone(), s))).transpose()?;
    let cameras = view.per_image(images.len())?;
    let given = Given {
        scene: scene.as_ref().map(|(p, s)| (p.as_path(), s)),
        cameras: &cameras,
        center: view.center,
        radius: view.radius,
        probe_only: view.probe_only,
        what,
    };
    Ok(analysis::observation::describe(images, paths, &given)?)
}

impl BrdfFlags {
    /// These flags as the observation model's explicit BRDF.
    pub fn values(&self) -> BrdfValues {
        BrdfValues { kind: self.brdf, params: self.params(), albedo: self.albedo }
    }
}

/// Reads the images of an analysis command and describes them ([`describe`]): each image's radiance
/// layer is chosen by `view.image.layer` ([`Image::select_layer`]; a note on stderr names the layer taken
/// and the layers ignored), and a camera recovered from the standard `worldToNDC` / `worldToCamera`
/// attributes ([`analysis::projection::camera_of_matrices`]) is said on stderr; an image whose matrix camera sees the mirror
/// image of ours has its columns mirrored here, once, for every command. An orthographic camera not
/// from the image's own `reflect:camera` is checked against the sphere's silhouette
/// ([`analysis::observation::pixels::check_silhouette`]: a mismatch is an error; an image with nothing to check
/// against gives a warning in [`Observation::warnings`]). The pixels' noise correlation is decided
/// after this, by [`analysis::observation::pixels::prepare`]. With `--pixel-filter`, the
/// pixels whose filter footprint reaches the silhouette are masked out ([`analysis::observation::pixels::edge_margin`]).
pub fn load(paths: &[PathBuf], view: &ViewArgs, what: &str) -> Result<(Vec<Image>, Observation), Error> {
    // Notes go to stderr only once everything is read and described: bad input gets its one line.
    let mut notes = Vec::new();
    // One image named twice (by any path to it) would count its pixels twice: every error bar √2
    // too small and a view the design counts as two.
    let mut seen = std::collections::HashSet::new();
    for p in paths {
        if !seen.insert(std::fs::canonicalize(p).unwrap_or_else(|_| p.clone())) {
            return Err(Error::file(p, "given more than once: its pixels would count twice (name each view once)"));
        }
    }
    let mut images = Vec::with_capacity(paths.len());
    for p in paths {
        let (img, file_notes) = read_image_notes(p)?;
        let (img, note) = img.select_layer(view.image.layer.as_deref()).map_err(|e| e.in_file(p))?;
        for n in file_notes.iter().chain(&note) {
            notes.push(format!("note: {}: {n}", p.display()));
        }
        images.push(img);
    }
    let mut d = describe(&images, paths, view, what)?;
    notes.append(&mut d.notes);
    d.stderr_notes = images.iter().zip(paths).filter_map(|(img, p)| stderr_flag_note(img, p)).collect();
    for img in images.iter_mut() {
        bound_near_flags(img);
    }
    for ((img, p), mirrored) in images.iter_mut().zip(paths).zip(&d.mirrored) {
        if *mirrored {
            mirror_columns(img);
            notes.push(format!(
                "note: {}: the worldToNDC camera sees the mirror image of ours (a left-handed camera, as pbrt-v4's LookAt builds); columns mirrored",
                p.display()
            ));
        }
    }

    for ((img, p), cam) in images.iter().zip(paths).zip(&d.cameras) {
        // Our own renders' header camera is the one that made the image; any other camera (flags,
        // --scene, worldToNDC) is checked against the sphere's silhouette.
        if let Camera::Ortho(c) = cam
            && !img.attributes.contains_key("reflect:camera")
            && let Some(w) = analysis::observation::pixels::check_silhouette(
                img,
                view.image.layer.as_deref(),
                c,
                &d.sphere,
                view.pixel_filter,
            )
            .map_err(|e| e.in_file(p))?
        {
            d.warnings.push(format!("{}: {w}", p.display()));
        }
    }
    notes.iter().for_each(|n| eprintln!("{n}"));
    Ok((images, d))
}

/// Reads a sidecar scene file (`--scene`).
pub fn read_scene(path: &Path) -> Result<SceneFile, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
    SceneFile::parse(&text).map_err(|m| Error::file(path, m))
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
