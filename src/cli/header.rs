//! Reading the images of `reflect analyze` and every `reflect invert` subcommand, and their
//! description from the flags: the flags ([`ViewArgs`], [`BrdfFlags`]) become the typed explicit
//! values of the observation model ([`analysis::observation`], which resolves the camera, sphere,
//! BRDF and lighting from the headers, a sidecar `--scene` and these values).

use super::Error;
use super::args::{BrdfFlags, ViewArgs};
use analysis::image::Image;
use analysis::observation::{BrdfValues, Given, Observation};
use std::path::PathBuf;

impl BrdfFlags {
    /// These flags as the observation model's explicit BRDF.
    pub fn values(&self) -> BrdfValues {
        BrdfValues { kind: self.brdf, params: self.params(), albedo: self.albedo, spelling: Default::default() }
    }
}

/// Reads the images of an analysis command and describes them: the files read with their radiance
/// layer chosen by `view.image.layer` ([`crate::images::read`]), the error bars of our renders
/// bounded near flagged pixels ([`crate::images::bound_flagged`]), then described from their
/// headers, `--scene` and the flags of `view` and made ready for the analysis
/// ([`analysis::observation::observe`]: mirrored columns, the silhouette check). The notes go to
/// stderr once everything is read and described, so bad input gets its one line. The pixels'
/// noise correlation is decided by the analysis.
pub fn load(paths: &[PathBuf], view: &ViewArgs, what: &str) -> Result<(Vec<Image>, Observation), Error> {
    let (mut images, mut notes) = crate::images::read(paths, view.image.layer.as_deref())?;
    let stderr_notes = crate::images::bound_flagged(&mut images, paths);
    let scene = view.image.scene.as_ref().map(|p| crate::images::read_scene(p).map(|s| (p.clone(), s))).transpose()?;
    let cameras = view.per_image(images.len())?;
    let given = Given {
        scene: scene.as_ref().map(|(p, s)| (p.as_path(), s)),
        cameras: &cameras,
        center: view.center,
        radius: view.radius,
        probe_only: view.probe_only,
        what,
        spelling: analysis::observation::Spelling::Flags,
    };
    let mut d =
        analysis::observation::observe(&mut images, paths, &given, view.image.layer.as_deref(), view.pixel_filter)?;
    notes.append(&mut d.notes);
    d.stderr_notes = stderr_notes;
    notes.iter().for_each(|n| eprintln!("{n}"));
    Ok((images, d))
}
