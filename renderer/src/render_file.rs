//! Reading any file a render leaves behind as the image it stands for: a finished render as it is, and
//! a render's state (a checkpoint, a `--state` file, a `reflect merge --partial` of the first shards)
//! as the image `reflect render` would have written had it stopped at the samples the state holds.
//!
//! A state of the samples `[0, n)` of a render planned for N spp is, by the film's fixed dyadic tree
//! ([`crate::film`]), the same bits as the state of a render of n spp (the samples do not depend on
//! the planned N): so its image is [`Partial::finish`](crate::film::Partial::finish) at n spp, and its header the scene's with
//! `render.spp = n`. Both are exactly what a render of the same scene and seed at n spp writes, so
//! `png`, `analyze` and `compare` of a checkpoint taken during a long render say what they would say
//! of a short render of the samples taken so far.
//!
//! A state whose samples do not start at 0 (a shard other than the first, or a merge of such shards)
//! is the noise of a sub-range, not a render of any spp: it is refused, naming the file.

use crate::film::Film;
use crate::shard::{PARTIAL_ATTRIBUTE, PartialFile, read_partial};
use crate::{Error, Result};
use std::path::Path;
use vocab::image::Image;

/// A render's state turned into the image of a render of the samples it holds.
#[derive(Clone, Debug)]
pub struct StateImage {
    /// The finished image: what [`Partial::finish`](crate::film::Partial::finish) gives at `spp`.
    pub film: Film,
    /// The header a render of `spp` samples writes ([`crate::output::header_attributes`]).
    pub attributes: Vec<(String, String)>,
    /// The samples per pixel the state holds (the image's spp).
    pub spp: u32,
    /// The render's planned samples per pixel (the state's header; `spp` when it is complete).
    pub planned_spp: u32,
}

/// Whether `path` is a render's state (an OpenEXR file with a `reflect:partial` header attribute),
/// read from its header alone. Errors: the file cannot be read, or its OpenEXR header is corrupt.
pub fn is_state(path: &Path) -> Result<bool> {
    let attrs = vocab::image::header_attributes(path).map_err(|e| e.in_file(path))?;
    Ok(attrs.contains_key(PARTIAL_ATTRIBUTE))
}

/// The image of the render state `f` (read from `path`, which errors name): see the module docs.
/// Errors: a state that holds no samples, or whose samples do not start at 0, or whose header does
/// not carry the scene it was rendered from.
pub fn state_image(path: &Path, f: PartialFile) -> Result<StateImage> {
    let PartialFile { mut partial, attributes, .. } = f;
    let planned_spp = partial.spp;
    if partial.start != 0 {
        return Err(Error::file(
            path,
            format!(
                "holds samples [{}, {}) of {planned_spp}, not a render's first samples: an image needs samples from 0 \
                 (merge it with the parts before it)",
                partial.start, partial.end
            ),
        ));
    }
    if partial.end == 0 {
        return Err(Error::file(path, format!("holds no samples yet (of {planned_spp} planned); there is no image")));
    }
    let spp = u32::try_from(partial.end).map_err(|_| Error::file(path, "more samples than a render can hold"))?;
    partial.spp = spp;
    let film = partial.finish();
    Ok(StateImage { film, attributes: attributes_at_spp(path, &attributes, spp)?, spp, planned_spp })
}

/// The header attributes of the render of `attributes` (a state's `reflect:*` attributes) at `spp`,
/// rebuilt from its `reflect:scene` as a render builds them, so that they are the same text.
fn attributes_at_spp(path: &Path, attributes: &[(String, String)], spp: u32) -> Result<Vec<(String, String)>> {
    let get = |k: &str| attributes.iter().find(|(key, _)| key == k).map(|(_, v)| v.as_str());
    let missing = |k: &str| Error::file(path, format!("a render state without its {k} header attribute"));
    let scene = get(vocab::header::SCENE).ok_or_else(|| missing(vocab::header::SCENE))?;
    let integrator = get(vocab::header::INTEGRATOR).ok_or_else(|| missing(vocab::header::INTEGRATOR))?;
    let mut scene = crate::scene::SceneFile::parse(scene)
        .map_err(|e| Error::file(path, format!("its {} header attribute does not parse: {e}", vocab::header::SCENE)))?;
    scene.render.spp = spp;
    Ok(vocab::header::attributes(&scene, integrator))
}

/// The image of `film` as a reader of the OpenEXR file `reflect render` writes gets it: the
/// channels of [`crate::output::film_channels`] and the header's string attributes.
pub fn film_image(film: &Film, attributes: &[(String, String)]) -> Image {
    Image {
        width: film.width as usize,
        height: film.height as usize,
        channels: crate::output::film_channels(film).into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
        attributes: attributes.iter().cloned().collect(),
        matrices: Default::default(),
    }
}

/// Reads an image to look at or analyse, as [`vocab::image::read_image_notes`] does, except that a
/// render's state is read as the image of the samples it holds ([`state_image`]), with a note that
/// says so. The one call of the front-ends (`reflect png`, `analyze`, `compare`, Python).
pub fn read_image_notes(path: &Path) -> Result<(Image, Vec<String>)> {
    if !is_state(path)? {
        return vocab::image::read_image_notes(path);
    }
    let s = state_image(path, read_partial(path)?)?;
    let note = if s.spp == s.planned_spp {
        format!("a render state holding all {} spp: its image", s.spp)
    } else {
        format!(
            "a render state holding {} of {} planned spp: the image of a {}-spp render",
            s.spp, s.planned_spp, s.spp
        )
    };
    Ok((film_image(&s.film, &s.attributes), vec![note]))
}

/// [`read_image_notes`] with the notes printed to stderr (`note: FILE: …`).
pub fn read_image(path: &Path) -> Result<Image> {
    let (img, notes) = read_image_notes(path)?;
    for n in notes {
        eprintln!("note: {}: {n}", path.display());
    }
    Ok(img)
}
