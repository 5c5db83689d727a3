//! The observation model: the one description of a set of images to analyse, shared by `reflect
//! analyze` and every `reflect invert` subcommand: each image's camera, the sphere it shows, that
//! sphere's BRDF and the lighting, from
//!
//! 1. the image's own header: the `reflect:*` attributes our renderer writes, read back into the
//!    typed scene vocabulary ([`vocab::header::Header`]; a malformed value is an error naming the key),
//!    and a camera recovered from the standard `worldToNDC` / `worldToCamera` attributes
//!    ([`crate::projection::camera_of_matrices`]);
//! 2. a sidecar scene file in our vocabulary (the image is that scene's render, so its `[render]`
//!    size must be the image's);
//! 3. explicit values ([`Given`]: an orthographic or normal-probe camera per image, the sphere's
//!    centre and radius; [`BrdfValues`]; an explicit lighting in [`lighting_of`]).
//!
//! Every value may come from several of them; where two give it they must agree (an explicit value
//! fills in what the header and scene leave open, it never silently replaces a different value): a
//! contradiction is an error naming both values and where each came from ([`Error::Contradiction`]).
//! Everything is in our world frame (docs/src/conventions.md §1, §5): an image from a renderer with
//! another up axis is described by explicit values in our frame.
//!
//! - [`camera`]: the camera of one image;
//! - [`sphere`]: the sphere and its BRDF table;
//! - [`brdf`]: the BRDF as a transfer model ([`Observation::transfer`]);
//! - [`lighting`]: the lighting to compare with ([`lighting_of`]);
//! - [`pixels`]: the pixels' noise correlation and the silhouette check of orthographic views;
//! - [`error`]: why an image could not be described.

pub mod brdf;
pub mod camera;
pub mod error;
pub mod lighting;
pub mod pixels;
pub mod sphere;

pub use brdf::{BrdfValues, Resolved, Spelling};
pub use camera::{Camera, CameraValues};
pub use error::Error;
pub use lighting::{LightingInput, lighting_given, lighting_of};

use crate::image::Image;
use crate::projection::{Sphere, camera_of_matrices};
use std::path::{Path, PathBuf};
use vocab::header::Header;
use vocab::scene::{BrdfSection, LightingSection, SceneFile};

/// Everything known about a set of images (see the module docs).
#[derive(Clone, Debug)]
pub struct Observation {
    /// The camera of each image, in the order of the images.
    pub cameras: Vec<Camera>,
    /// The sphere analysed: explicit values, scene or header; else the unit sphere at the origin.
    pub sphere: Sphere,
    /// The BRDF of the first sphere of the scene or header, with where it came from (explicit
    /// values are resolved by [`Observation::transfer`]).
    pub brdf: Option<(BrdfSection, String)>,
    /// The number of objects of the scene or header (0 when neither says).
    pub object_count: usize,
    /// The lighting table of the scene or header, with the file relative paths in it are relative
    /// to, and where it came from.
    pub lighting: Option<(LightingSection, PathBuf, String)>,
    /// Per image: its camera came from `worldToNDC` and sees the mirror image of ours (the reader
    /// mirrors the columns, [`crate::projection::mirror_columns`]).
    pub mirrored: Vec<bool>,
    /// Warnings about the images (a camera that cannot be checked against the sphere's
    /// silhouette), each one sentence naming the file.
    pub warnings: Vec<String>,
    /// One note per image with pixels flagged in a `stderr_flag.Y` layer.
    pub stderr_notes: Vec<String>,
    /// Where each image's camera came from when not said by its header (`note: FILE: …` lines).
    pub notes: Vec<String>,
}

/// The explicit values that describe a set of images besides their headers.
#[derive(Clone, Copy, Debug)]
pub struct Given<'a> {
    /// The sidecar scene the images are renders of: its path (for messages and relative files) and
    /// contents.
    pub scene: Option<(&'a Path, &'a SceneFile)>,
    /// The explicit camera of each image (empty values where none is given), one per image.
    pub cameras: &'a [CameraValues],
    /// The sphere's centre and radius (world units).
    pub center: Option<[f64; 3]>,
    pub radius: Option<f64>,
    /// The front-end accepts only normal-probe cameras: the hint of a missing camera names only those.
    pub probe_only: bool,
    /// The command's verb for refusals ("analysed", "inverted").
    pub what: &'a str,
    /// How the front-end names what to pass where a value is missing (`--scene`, `scene=`).
    pub spelling: Spelling,
}

/// A value and where it came from ("the header's reflect:camera", "the [camera] of s.toml").
type Sourced<T> = Option<(T, String)>;

/// Combines a value from two sources: each may be absent; when both are present they must agree.
fn merge<T: std::fmt::Display>(
    a: Sourced<T>,
    b: Sourced<T>,
    agree: impl Fn(&T, &T) -> bool,
) -> Result<Sourced<T>, Error> {
    match (a, b) {
        (Some((x, sx)), Some((y, sy))) => {
            if agree(&x, &y) {
                Ok(Some((x, sx)))
            } else {
                Err(Error::Contradiction { one: format!("{sy} gives {y}"), other: format!("{sx} gives {x}") })
            }
        }
        (a, b) => Ok(a.or(b)),
    }
}

/// A number in a message with the precision cameras and spheres have (headers and matrices store
/// f32): the shortest decimal that reads back as the same f32, so 1.05 and not 1.049999996870756.
pub fn num(x: f64) -> String {
    format!("{}", x as f32)
}

/// A vector in a message, `x,y,z` each as [`num`].
pub fn v3(v: [f64; 3]) -> String {
    format!("{},{},{}", num(v[0]), num(v[1]), num(v[2]))
}

/// Relative agreement of two lengths or coordinates written as f32 somewhere (headers, scenes).
const AGREE: f64 = 1e-5;

/// Whether two values a header (f32), a scene and an explicit value give are the same, to the f32
/// precision headers store (relative to `scale`, the values' size, or 1).
pub fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= AGREE * scale.max(a.abs()).max(b.abs()).max(1.0)
}

/// Describes `images` (read from `paths`) from their headers and the explicit values `given`
/// (module docs). Notes on the cameras taken from matrices go to [`Observation::notes`]; the
/// warnings and stderr notes are left empty for the reader to fill.
///
/// Errors (each one line naming the file where there is one): a malformed header value (naming the
/// key), a scene whose `[render]` size is not the image's (naming both sizes), a camera no source
/// gives or one the analysis does not model (perspective), and two sources that contradict each
/// other (naming both values).
pub fn describe(images: &[Image], paths: &[PathBuf], given: &Given) -> Result<Observation, Error> {
    let headers: Vec<Header> = images
        .iter()
        .zip(paths)
        .map(|(img, p)| Header::read(&img.attributes).map_err(|e| Error::from(e).in_file(p)))
        .collect::<Result<_, _>>()?;
    if let Some((sp, s)) = given.scene {
        for (img, p) in images.iter().zip(paths) {
            let (w, h) = (s.render.width as usize, s.render.height as usize);
            if (w, h) != (img.width, img.height) {
                let e = Error::SceneSize {
                    width: img.width,
                    height: img.height,
                    scene: sp.to_path_buf(),
                    scene_width: w,
                    scene_height: h,
                };
                return Err(e.in_file(p));
            }
        }
    }
    let mut cameras = Vec::with_capacity(images.len());
    let mut mirrored = Vec::with_capacity(images.len());
    let mut notes = Vec::new();
    let no_values = CameraValues::default();
    for (i, ((hd, p), img)) in headers.iter().zip(paths).zip(images).enumerate() {
        let v = given.cameras.get(i).unwrap_or(&no_values);
        let in_p = |e: Error| e.in_file(p);
        let from_header = hd
            .camera
            .as_ref()
            .map(|c| Camera::of_section(c, given.what).map(|c| (c, "the header's reflect:camera".to_string())));
        let matrix = camera_of_matrices(img).map_err(|e| in_p(e.into()))?.map(|m| (m.camera, m.mirrored));
        if let Some((c, _)) = &matrix {
            notes.push(format!(
                "note: {}: camera from the worldToNDC{} attributes: {}",
                p.display(),
                if img.matrices.contains_key("worldToCamera") { " and worldToCamera" } else { "" },
                Camera::Ortho(*c)
            ));
        } else if img.matrices.contains_key("worldToCamera") && hd.camera.is_none() {
            notes.push(format!(
                "note: {}: worldToCamera without worldToNDC does not give the view's extent: not used ({})",
                p.display(),
                match (given.spelling, given.probe_only) {
                    (Spelling::Keywords, _) => "pass scene= or the pixels as an array with camera=",
                    (Spelling::Flags, true) => "pass --theta-o/--phi-o or --scene",
                    (Spelling::Flags, false) => "pass --from/--to/--up/--extent",
                }
            ));
        }
        mirrored.push(matrix.is_some_and(|(_, m)| m));
        let from_header = merge(
            from_header.transpose().map_err(in_p)?,
            matrix.map(|(c, _)| (Camera::Ortho(c), "the header's worldToNDC".to_string())),
            Camera::same,
        )
        .map_err(in_p)?;
        let from_scene = given
            .scene
            .map(|(sp, s)| {
                Camera::of_section(&s.camera, given.what).map(|c| (c, format!("the [camera] of {}", sp.display())))
            })
            .transpose()
            .map_err(in_p)?;
        cameras.push(camera::resolve(from_header, from_scene, v, given.probe_only, given.spelling).map_err(in_p)?);
    }

    let hd0 = headers.first().cloned().unwrap_or_default();
    let in0 = |e: Error| match paths.first() {
        Some(p) => e.in_file(p),
        None => e,
    };
    let (sphere, brdf) =
        sphere::resolve(hd0.objects.as_deref(), given.scene, given.center, given.radius).map_err(in0)?;
    let object_count = match (given.scene, hd0.objects.as_ref()) {
        (_, Some(o)) => o.len(),
        (Some((_, s)), None) => s.objects.len(),
        (None, None) => 0,
    };
    // The lighting: the scene's (it describes this render), else the header's.
    let lighting = match (given.scene, hd0.lighting, paths.first()) {
        (Some((sp, s)), _, _) => {
            Some((s.lighting.clone(), sp.to_path_buf(), format!("[lighting] of {}", sp.display())))
        }
        (None, Some(l), Some(p)) => Some((l, p.clone(), "reflect:lighting header".to_string())),
        _ => None,
    };
    Ok(Observation {
        cameras,
        sphere,
        brdf,
        object_count,
        lighting,
        mirrored,
        warnings: Vec::new(),
        stderr_notes: Vec::new(),
        notes,
    })
}

/// Describes `images` held in memory ([`describe`]) and makes them ready for every analysis
/// command, as each front-end must: an image whose `worldToNDC` camera sees the mirror image of
/// ours has its columns mirrored, once ([`crate::projection::mirror_columns`]; a note says so), and
/// an orthographic camera not from the image's own `reflect:camera` is checked against the sphere's
/// silhouette ([`pixels::check_silhouette`] with the radiance `layer` and the renderer's pixel
/// `filter`: a mismatch is an error naming the file; an image with nothing to check against gives a
/// warning in [`Observation::warnings`]). The notes (`note: FILE: …` lines) are in
/// [`Observation::notes`]; [`Observation::stderr_notes`] is left for the reader of the files.
pub fn observe(
    images: &mut [Image],
    paths: &[PathBuf],
    given: &Given,
    layer: Option<&str>,
    filter: Option<crate::noise::PixelFilter>,
) -> Result<Observation, Error> {
    let mut d = describe(images, paths, given)?;
    for ((img, p), mirrored) in images.iter_mut().zip(paths).zip(&d.mirrored) {
        if *mirrored {
            crate::projection::mirror_columns(img);
            d.notes.push(format!(
                "note: {}: the worldToNDC camera sees the mirror image of ours (a left-handed camera, as pbrt-v4's LookAt builds); columns mirrored",
                p.display()
            ));
        }
    }
    for ((img, p), cam) in images.iter().zip(paths).zip(&d.cameras) {
        // Our own renders' header camera is the one that made the image; any other camera (explicit
        // values, a sidecar scene, worldToNDC) is checked against the sphere's silhouette.
        if let Camera::Ortho(c) = cam
            && !img.attributes.contains_key("reflect:camera")
            && let Some(w) = pixels::check_silhouette(img, layer, c, &d.sphere, filter).map_err(|e| e.in_file(p))?
        {
            d.warnings.push(format!("{}: {w}", p.display()));
        }
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headerless(n: usize) -> (Vec<Image>, Vec<PathBuf>) {
        let img = Image { width: 4, height: 2, ..Default::default() };
        (vec![img; n], (0..n).map(|i| PathBuf::from(format!("v{i}.exr"))).collect())
    }

    fn given<'a>(cameras: &'a [CameraValues], scene: Option<(&'a Path, &'a SceneFile)>) -> Given<'a> {
        Given {
            scene,
            cameras,
            center: None,
            radius: None,
            probe_only: false,
            what: "analysed",
            spelling: Spelling::Flags,
        }
    }

    #[test]
    fn explicit_values_describe_a_headerless_image() {
        let (images, paths) = headerless(2);
        let values = [
            CameraValues { from: Some([0.0, -5.0, 0.0]), extent: Some(1.5), ..Default::default() },
            CameraValues { theta_o: Some(30.0), ..Default::default() },
        ];
        let o = describe(&images, &paths, &Given { radius: Some(2.0), ..given(&values, None) }).unwrap();
        assert_eq!(o.cameras[1], Camera::NormalProbe { theta_o_deg: 30.0, phi_o_deg: 0.0 });
        let Camera::Ortho(c) = o.cameras[0] else { panic!("{:?}", o.cameras[0]) };
        assert_eq!((c.from, c.to, c.up, c.extent), ([0.0, -5.0, 0.0], [0.0; 3], [0.0, 0.0, 1.0], 1.5));
        assert_eq!((o.sphere.center, o.sphere.radius, o.object_count), ([0.0; 3], 2.0, 0));
        assert!(o.brdf.is_none() && o.lighting.is_none() && o.notes.is_empty());
    }

    #[test]
    fn a_missing_camera_and_two_camera_kinds_are_refused_naming_the_file() {
        let (images, paths) = headerless(1);
        let e = describe(&images, &paths, &given(&[CameraValues::default()], None)).unwrap_err();
        assert!(e.to_string().starts_with("v0.exr: no reflect:camera in the header: pass --from"), "{e}");
        // Python's spelling: what it can pass (a file has no camera keyword), never a flag.
        let none = [CameraValues::default()];
        let py = Given { spelling: Spelling::Keywords, ..given(&none, None) };
        let e = describe(&images, &paths, &py).unwrap_err().to_string();
        assert_eq!(
            e,
            "v0.exr: no reflect:camera in the header: pass scene= (the scene this image is a render of), or its \
             pixels as an array with camera="
        );
        let both = [CameraValues { from: Some([0.0, 0.0, 5.0]), theta_o: Some(0.0), ..Default::default() }];
        let e = describe(&images, &paths, &given(&both, None)).unwrap_err();
        assert!(matches!(&e, Error::InFile { error, .. } if matches!(**error, Error::TwoCameraKinds)), "{e}");
    }

    #[test]
    fn a_scene_that_contradicts_the_explicit_sphere_is_refused_naming_both() {
        let scene = SceneFile::parse(
            "[render]\nwidth = 4\nheight = 2\n[camera]\ntype = \"orthographic\"\nfrom = [0, 0, 5]\nto = [0, 0, 0]\nup = [0, 1, 0]\nextent = 1.2\n\
             [lighting]\ntype = \"uniform\"\nradiance = [1, 1, 1]\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nbrdf = { type = \"lambert\", albedo = [0.5, 0.5, 0.5] }\n",
        )
        .unwrap();
        let (images, paths) = headerless(1);
        let sp = Path::new("s.toml");
        let values = [CameraValues::default()];
        let o = describe(&images, &paths, &given(&values, Some((sp, &scene)))).unwrap();
        assert_eq!((o.sphere.radius, o.object_count), (1.0, 1));
        assert_eq!(o.brdf.as_ref().map(|(_, s)| s.as_str()), Some("the [[objects]] of s.toml"));
        assert_eq!(o.lighting.as_ref().map(|(_, _, s)| s.as_str()), Some("[lighting] of s.toml"));
        let e =
            describe(&images, &paths, &Given { radius: Some(1.5), ..given(&values, Some((sp, &scene))) }).unwrap_err();
        assert_eq!(
            e.to_string(),
            "v0.exr: --center/--radius give sphere center 0,0,0 radius 1.5 but the [[objects]] of s.toml gives \
             sphere center 0,0,0 radius 1: they contradict each other"
        );
        let small = Image { width: 3, ..images[0].clone() };
        let e = describe(&[small], &paths, &given(&values, Some((sp, &scene)))).unwrap_err();
        assert!(e.to_string().starts_with("v0.exr: the image is 3×2 but the [render] size of s.toml is 4×2"), "{e}");
    }
}
