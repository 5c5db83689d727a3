//! The one description of an image to analyse, shared by `reflect analyze` and every `reflect invert`
//! subcommand: its camera, the sphere it shows, that sphere's BRDF and the lighting, from
//!
//! 1. the image's own header: the `reflect:*` attributes our renderer writes, read back into the
//!    typed scene vocabulary ([`vocab::header::Header`]; a malformed value is an error naming the key);
//! 2. a sidecar scene file in our vocabulary (`--scene S.toml`: the image is that scene's render, so its
//!    `[render]` size must be the image's);
//! 3. flags ([`ViewArgs`]: `--from/--to/--up/--extent` or `--theta-o/--phi-o` per image,
//!    `--center/--radius`; BRDF flags
//!    [`BrdfFlags`]).
//!
//! Every value may come from several of them; where two give it they must agree (a flag fills in
//! what the header and scene leave open, it never silently replaces a different value): a
//! contradiction is an error naming both values and where each came from. Everything is in our world
//! frame (docs/src/conventions.md §1, §5): an image from a renderer with another up axis is described by flags
//! in our frame.

use super::Error;
use super::args::{BrdfFlags, CameraFlags, ViewArgs};
use analysis::image::Image;
use analysis::lighting::Lighting;
use analysis::projection::{Mapping, OrthoCamera, Sphere, camera_of_matrices, mirror_columns};
use analysis::transfer::{BrdfTransfer, ParamValue, TransferModel};
use renderer::render_file::read_image_notes;
use std::path::{Path, PathBuf};
use vocab::BrdfKind;
use vocab::header::Header;
use vocab::scene::{BrdfSection, CameraSection, LightingSection, ObjectSection, SceneFile, decimal, decimal3};

/// The camera of one image, in our world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// docs/src/conventions.md §5 orthographic camera (world units).
    Ortho(OrthoCamera),
    /// docs/src/conventions.md §6 normal-probe camera at exitance (θ_o, φ_o), degrees.
    NormalProbe { theta_o_deg: f64, phi_o_deg: f64 },
}

impl std::fmt::Display for Camera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Camera::Ortho(c) => {
                write!(f, "orthographic from {} to {} up {} extent {}", v3(c.from), v3(c.to), v3(c.up), num(c.extent))
            }
            Camera::NormalProbe { theta_o_deg, phi_o_deg } => {
                write!(f, "normal-probe theta_o_deg {} phi_o_deg {}", num(*theta_o_deg), num(*phi_o_deg))
            }
        }
    }
}

/// A number in a message with the precision cameras and spheres have (headers and matrices store
/// f32): the shortest decimal that reads back as the same f32, so 1.05 and not 1.049999996870756.
fn num(x: f64) -> String {
    format!("{}", x as f32)
}

pub(crate) fn v3(v: [f64; 3]) -> String {
    format!("{},{},{}", num(v[0]), num(v[1]), num(v[2]))
}

impl Camera {
    /// θ_o (degrees) of a normal-probe camera for the per-order analysis of `analyze` and
    /// `invert lighting | brdf`, which reads the q = 0 term at (θ_o, φ_o = 0) (eq. 10): another
    /// azimuth at oblique exitance is refused (`what` names the command's verb in the message).
    pub fn probe_theta_o_deg(theta_o_deg: f64, phi_o_deg: f64, what: &str) -> Result<f64, Error> {
        if theta_o_deg != 0.0 && phi_o_deg.rem_euclid(360.0) != 0.0 {
            return Err(Error::new(format!(
                "a normal-probe render at phi_o_deg = {phi_o_deg} cannot be {what} (only phi_o_deg = 0)"
            )));
        }
        Ok(theta_o_deg)
    }

    /// A scene or header camera table as a [`Camera`]; `what` is the command's verb ("analysed",
    /// "inverted") for the refusal of a camera the analysis does not model (perspective). A
    /// normal-probe θ_o goes through the one exitance check of every command
    /// ([`analysis::transfer::validate_exitance`]: 0 ≤ θ_o < 90°, as the renderer's camera).
    pub fn of_section(c: &CameraSection, what: &str) -> Result<Camera, Error> {
        match c {
            CameraSection::Orthographic { from, to, up, extent } => Ok(Camera::Ortho(OrthoCamera {
                from: decimal3(*from),
                to: decimal3(*to),
                up: decimal3(*up),
                extent: decimal(*extent),
            })),
            CameraSection::NormalProbe { theta_o_deg, phi_o_deg, .. } => {
                let (t, p) = (decimal(*theta_o_deg), decimal(*phi_o_deg));
                analysis::transfer::validate_exitance(t.to_radians())
                    .map_err(|e| Error::new(format!("camera: {}", e.message)))?;
                Ok(Camera::NormalProbe { theta_o_deg: t, phi_o_deg: p })
            }
            CameraSection::Perspective { .. } => Err(Error::new(format!(
                "camera type 'perspective' cannot be {what} (use an orthographic or normal-probe render)"
            ))),
        }
    }
}

/// Relative agreement of two lengths or coordinates written as f32 somewhere (headers, scenes).
const AGREE: f64 = 1e-5;

/// Whether two values a header (f32), a scene and a flag give are the same, to the f32 precision
/// headers store (relative to `scale`, the values' size, or 1).
pub(crate) fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= AGREE * scale.max(a.abs()).max(b.abs()).max(1.0)
}

fn same_camera(a: &Camera, b: &Camera) -> bool {
    match (a, b) {
        (Camera::Ortho(x), Camera::Ortho(y)) => x.same_view(y),
        (
            Camera::NormalProbe { theta_o_deg: t1, phi_o_deg: p1 },
            Camera::NormalProbe { theta_o_deg: t2, phi_o_deg: p2 },
        ) => close(*t1, *t2, 90.0) && close((p1 - p2 + 180.0).rem_euclid(360.0) - 180.0, 0.0, 360.0),
        _ => false,
    }
}

/// A value and where it came from ("the header's reflect:camera", "--scene s.toml", "the flags").
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
                Err(Error::new(format!("{sy} gives {y} but {sx} gives {x}: they contradict each other")))
            }
        }
        (a, b) => Ok(a.or(b)),
    }
}

/// The camera flags of one image laid over a base orthographic camera. A `--from` given describes
/// the flags' own camera: `--to` and `--up` then take their documented defaults (0,0,0 and 0,0,1)
/// when absent, as for an image with no camera at all, never the base's (a pbrt matrix camera's `to`
/// is a point on its own view axis, so `--from` with the base's `to` would look elsewhere). Without
/// `--from`, the flags given replace the base's fields and the others are the base's.
fn flags_over(f: &CameraFlags, base: &OrthoCamera) -> OrthoCamera {
    match f.from {
        Some(from) => OrthoCamera {
            from,
            to: f.to.unwrap_or([0.0; 3]),
            up: f.up.unwrap_or([0.0, 0.0, 1.0]),
            extent: f.extent.unwrap_or(base.extent),
        },
        None => OrthoCamera {
            from: base.from,
            to: f.to.unwrap_or(base.to),
            up: f.up.unwrap_or(base.up),
            extent: f.extent.unwrap_or(base.extent),
        },
    }
}

/// The normal-probe camera of `--theta-o/--phi-o` (degrees), through the one exitance check of
/// every command ([`analysis::transfer::validate_exitance`]: 0 ≤ θ_o < 90°).
fn probe_of_flags(theta_o_deg: f64, phi_o_deg: f64) -> Result<Camera, Error> {
    if !phi_o_deg.is_finite() {
        return Err(Error::new(format!("--phi-o must be a finite number of degrees, got {phi_o_deg}")));
    }
    analysis::transfer::validate_exitance(theta_o_deg.to_radians())
        .map_err(|e| Error::new(format!("--theta-o: {}", e.message)))?;
    Ok(Camera::NormalProbe { theta_o_deg, phi_o_deg })
}

impl std::fmt::Display for SphereShown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "sphere center {} radius {}", v3(self.0.center), num(self.0.radius))
    }
}

/// A sphere, displayable in messages.
#[derive(Clone, Copy, Debug)]
struct SphereShown(Sphere);

/// Reads the images of an analysis command and describes them ([`describe`]): each image's radiance
/// layer is chosen by `view.image.layer` ([`Image::select_layer`]; a note on stderr names the layer taken
/// and the layers ignored), and a camera recovered from the standard `worldToNDC` / `worldToCamera`
/// attributes ([`analysis::projection::camera_of_matrices`]) is said on stderr; an image whose matrix camera sees the mirror
/// image of ours has its columns mirrored here, once, for every command. An orthographic camera not
/// from the image's own `reflect:camera` is checked against the sphere's silhouette
/// ([`super::pixels::check_silhouette`]: a mismatch is an error; an image with nothing to check
/// against gives a warning in [`Description::warnings`]). The pixels' noise correlation is decided
/// after this, by [`super::pixels::prepare`]. With `--pixel-filter`, the
/// pixels whose filter footprint reaches the silhouette are masked out ([`super::pixels::edge_margin`]).
pub fn load(paths: &[PathBuf], view: &ViewArgs, what: &str) -> Result<(Vec<Image>, Description), Error> {
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
            && let Some(w) =
                super::pixels::check_silhouette(img, view.image.layer.as_deref(), c, &d.sphere, view.pixel_filter)
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

/// Everything known about a set of images (see the module docs).
#[derive(Clone, Debug)]
pub struct Description {
    /// The camera of each image, in the order of the images.
    pub cameras: Vec<Camera>,
    /// The sphere analysed: flags, scene or header; else the unit sphere at the origin.
    pub sphere: Sphere,
    /// The BRDF of the first sphere of the scene or header (the flags' BRDF is resolved by
    /// [`Description::transfer`]).
    pub brdf: Option<(BrdfSection, String)>,
    /// The number of objects of the scene or header (0 when neither says).
    pub object_count: usize,
    /// The lighting table of the scene or header, with the file relative paths in it are relative to.
    pub lighting: Option<(LightingSection, PathBuf, String)>,
    /// Per image: its camera came from `worldToNDC` and sees the mirror image of ours ([`load`]
    /// mirrors the columns).
    pub mirrored: Vec<bool>,
    /// Warnings about the images (from [`load`]: a camera that cannot be checked against the
    /// sphere's silhouette), each one sentence naming the file.
    pub warnings: Vec<String>,
    /// One note per image with pixels flagged in a `stderr_flag.Y` layer (set by [`load`]; the
    /// commands add them to their warnings, text and JSON).
    pub stderr_notes: Vec<String>,
    /// Where each image's camera came from when not said by its header (`note: FILE: …` lines),
    /// printed on stderr by [`load`] once the description succeeded.
    pub notes: Vec<String>,
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

/// Whether the sidecar scene gives cameras, size, objects and lighting.
fn scene_of(view: &ViewArgs) -> Result<Option<(PathBuf, SceneFile)>, Error> {
    view.image.scene.as_ref().map(|p| read_scene(p).map(|s| (p.clone(), s))).transpose()
}

/// Describes `images` (read from `paths`) from their headers, `view.image.scene` and the flags of
/// `view` (module docs). `what` is the command's verb for refusals ("analysed", "inverted").
///
/// Errors (each one line naming the file where there is one): a malformed header value (naming the
/// key), a scene whose `[render]` size is not the image's (naming both sizes), a camera no source
/// gives or one the analysis does not model (perspective), and two sources that contradict each
/// other (naming both values).
pub fn describe(images: &[Image], paths: &[PathBuf], view: &ViewArgs, what: &str) -> Result<Description, Error> {
    let scene = scene_of(view)?;
    let headers: Vec<Header> = images
        .iter()
        .zip(paths)
        .map(|(img, p)| Header::read(&img.attributes).map_err(|e| e.in_file(p)))
        .collect::<Result<_, _>>()?;
    if let Some((sp, s)) = &scene {
        for (img, p) in images.iter().zip(paths) {
            let (w, h) = (s.render.width as usize, s.render.height as usize);
            if (w, h) != (img.width, img.height) {
                return Err(Error::file(
                    p,
                    format!(
                        "the image is {}×{} but the [render] size of {} is {w}×{h}: --scene must be the scene this image is a render of",
                        img.width,
                        img.height,
                        sp.display()
                    ),
                ));
            }
        }
    }
    let flags = view.per_image(images.len())?;
    let mut cameras = Vec::with_capacity(images.len());
    let mut mirrored = Vec::with_capacity(images.len());
    let mut notes = Vec::new();
    for (((hd, p), f), img) in headers.iter().zip(paths).zip(&flags).zip(images) {
        let in_p = |e: Error| e.in_file(p);
        let from_header = hd
            .camera
            .as_ref()
            .map(|c| Camera::of_section(c, what).map(|c| (c, "the header's reflect:camera".to_string())));
        let matrix = camera_of_matrices(img).map_err(in_p)?.map(|m| (m.camera, m.mirrored));
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
                if view.probe_only { "pass --theta-o/--phi-o or --scene" } else { "pass --from/--to/--up/--extent" }
            ));
        }
        mirrored.push(matrix.is_some_and(|(_, m)| m));
        let from_header = merge(
            from_header.transpose().map_err(in_p)?,
            matrix.map(|(c, _)| (Camera::Ortho(c), "the header's worldToNDC".to_string())),
            same_camera,
        )
        .map_err(in_p)?;
        let from_scene = scene
            .as_ref()
            .map(|(sp, s)| {
                Camera::of_section(&s.camera, what).map(|c| (c, format!("the [camera] of {}", sp.display())))
            })
            .transpose()
            .map_err(in_p)?;
        // A sidecar's normal-probe camera describes a set of views of one scene, each at its own
        // exitance (a light field, a separation): the image's header or --theta-o/--phi-o give this
        // image's angles, the scene's are the default.
        let template = matches!(from_scene, Some((Camera::NormalProbe { .. }, _)));
        let base = match (from_header, from_scene) {
            (Some(h @ (Camera::NormalProbe { .. }, _)), Some(_)) if template => Some(h),
            (h, s) => merge(h, s, same_camera).map_err(in_p)?,
        };
        let base_is_template = template && base.as_ref().is_some_and(|(_, src)| src.starts_with("the [camera]"));
        if f.ortho_given() && f.probe().is_some() {
            return Err(Error::file(
                p,
                "--from/--to/--up/--extent describe an orthographic camera and --theta-o/--phi-o a normal-probe camera: give one of them",
            ));
        }
        let camera = match (base, f.probe()) {
            (None, Some((t, ph))) => probe_of_flags(t, ph).map_err(in_p)?,
            (None, None) => f.camera().map(Camera::Ortho).ok_or_else(|| {
                // The hint names only the flags this command accepts.
                let flags = if view.probe_only {
                    "pass --theta-o (and --phi-o) of its normal-probe camera once per image, or --scene S.toml"
                } else {
                    "pass --from x,y,z and --extent (orthographic camera), --theta-o (normal-probe camera), or --scene S.toml"
                };
                Error::file(p, format!("no reflect:camera in the header: {flags}"))
            })?,
            (Some((Camera::NormalProbe { .. }, _)), Some((t, ph))) if base_is_template => {
                probe_of_flags(t, ph).map_err(in_p)?
            }
            (Some((b @ Camera::NormalProbe { .. }, src)), Some((t, ph))) => {
                let c = probe_of_flags(t, ph).map_err(in_p)?;
                if !same_camera(&c, &b) {
                    return Err(Error::file(
                        p,
                        format!("--theta-o/--phi-o give {c} but {src} gives {b}: they contradict each other"),
                    ));
                }
                b
            }
            (Some((Camera::Ortho(_), src)), Some(_)) => {
                return Err(Error::file(
                    p,
                    format!("--theta-o/--phi-o describe a normal-probe camera but {src} is an orthographic camera"),
                ));
            }
            (Some((Camera::Ortho(b), src)), None) if f.ortho_given() => {
                let c = flags_over(f, &b);
                if !c.same_view(&b) {
                    return Err(Error::file(
                        p,
                        format!(
                            "the camera flags give {} but {src} gives {}: they contradict each other",
                            Camera::Ortho(c),
                            Camera::Ortho(b)
                        ),
                    ));
                }
                Camera::Ortho(b)
            }
            (Some((Camera::NormalProbe { .. }, src)), None) if f.ortho_given() => {
                return Err(Error::file(
                    p,
                    format!("--from/--to/--up/--extent describe an orthographic camera but {src} is a normal-probe camera"),
                ));
            }
            (Some((c, _)), None) => c,
        };
        cameras.push(camera);
    }

    // The sphere and its BRDF: the first sphere of the first image's header and of the scene.
    let first_sphere = |objs: &[ObjectSection]| {
        objs.iter().find_map(|o| match o {
            ObjectSection::Sphere { center, radius, brdf, .. } => {
                Some((Sphere { center: decimal3(*center), radius: decimal(*radius) }, brdf.clone()))
            }
            _ => None,
        })
    };
    let hd0 = headers.first().cloned().unwrap_or_default();
    let in0 = |e: Error| match paths.first() {
        Some(p) => e.in_file(p),
        None => e,
    };
    // A textured sphere's radiance is T(n) times a uniform sphere's: every analysis here assumes one
    // albedo, so such a render is refused rather than analysed as uniform (issue 19).
    let textured = |objs: &[ObjectSection]| {
        objs.iter().find(|o| matches!(o, ObjectSection::Sphere { .. })).is_some_and(|o| o.texture().is_some())
    };
    let refuse = "the sphere has an albedo texture, and analyze and invert assume a uniform albedo";
    if hd0.objects.as_deref().is_some_and(textured) {
        return Err(in0(Error::new(format!("header reflect:objects: {refuse}"))));
    }
    if let Some((sp, s)) = &scene
        && textured(&s.objects)
    {
        return Err(Error::file(sp, refuse));
    }
    let h_sphere = hd0.objects.as_deref().and_then(first_sphere);
    let s_sphere = scene.as_ref().and_then(|(sp, s)| first_sphere(&s.objects).map(|x| (x, sp.display().to_string())));
    let same_sphere = |a: &SphereShown, b: &SphereShown| {
        let s = a.0.radius.abs().max(b.0.radius.abs());
        (0..3).all(|i| close(a.0.center[i], b.0.center[i], s)) && close(a.0.radius, b.0.radius, s)
    };
    let base = merge(
        h_sphere.as_ref().map(|(s, _)| (SphereShown(*s), "the header's reflect:objects".to_string())),
        s_sphere.as_ref().map(|((s, _), sp)| (SphereShown(*s), format!("the [[objects]] of {sp}"))),
        same_sphere,
    )
    .map_err(in0)?;
    let default = base.as_ref().map_or(Sphere { center: [0.0; 3], radius: 1.0 }, |(s, _)| s.0);
    let flagged =
        Sphere { center: view.center.unwrap_or(default.center), radius: view.radius.unwrap_or(default.radius) };
    if let Some((b, src)) = &base
        && (view.center.is_some() || view.radius.is_some())
        && !same_sphere(&SphereShown(flagged), b)
    {
        return Err(in0(Error::new(format!(
            "--center/--radius give {} but {src} gives {b}: they contradict each other",
            SphereShown(flagged)
        ))));
    }
    let json = |b: &BrdfSection| serde_json::to_value(b).unwrap_or_default();
    struct Shown(BrdfSection);
    impl std::fmt::Display for Shown {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "the BRDF {}", serde_json::to_string(&self.0).unwrap_or_default())
        }
    }
    let brdf = merge(
        h_sphere.map(|(_, b)| (Shown(b), "the header's reflect:objects".to_string())),
        s_sphere.map(|((_, b), sp)| (Shown(b), format!("the [[objects]] of {sp}"))),
        |a, b| json(&a.0) == json(&b.0),
    )
    .map_err(in0)?
    .map(|(b, s)| (b.0, s));
    let object_count = match (&scene, hd0.objects.as_ref()) {
        (_, Some(o)) => o.len(),
        (Some((_, s)), None) => s.objects.len(),
        (None, None) => 0,
    };
    // The lighting: the scene's (it describes this render), else the header's.
    let lighting = match (&scene, hd0.lighting, paths.first()) {
        (Some((sp, s)), _, _) => Some((s.lighting.clone(), sp.clone(), format!("[lighting] of {}", sp.display()))),
        (None, Some(l), Some(p)) => Some((l, p.clone(), "reflect:lighting header".to_string())),
        _ => None,
    };
    Ok(Description {
        cameras,
        sphere: flagged,
        brdf,
        object_count,
        lighting,
        mirrored,
        warnings: Vec::new(),
        stderr_notes: Vec::new(),
        notes,
    })
}

/// A BRDF's transfer model, scale and kind, and the table it came from (for the report).
#[derive(Clone, Debug)]
pub struct Resolved {
    pub transfer: Option<BrdfTransfer>,
    pub kind: BrdfKind,
    /// The BRDF as JSON: the scene's or header's table, or the flags as a table.
    pub table: serde_json::Value,
    /// Where it came from: "the header's reflect:objects", "the `[[objects]]` of S", "--brdf".
    pub source: String,
}

impl Description {
    /// The BRDF of the sphere seen at exitance θ_o (radians): the flags ([`BrdfFlags`]) where given,
    /// else the scene's or header's table, through the one BRDF → transfer-model mapping
    /// ([`TransferModel::from_named`], [`TransferModel::of_brdf`]). Flags and a table that
    /// contradict each other (another kind, exponent, roughness or albedo) are an error naming both.
    /// `Ok(None)` when no source names a BRDF.
    pub fn transfer(&self, flags: &BrdfFlags, theta_o: f64) -> Result<Option<Resolved>, Error> {
        let table = match &self.brdf {
            Some((b, src)) => {
                let t = TransferModel::of_brdf(b, theta_o).map_err(|e| Error::new(format!("{src}: {}", e.message)))?;
                Some((b, src, t))
            }
            None => None,
        };
        let params = !flags.params().is_empty();
        if table.is_none() && flags.brdf.is_none() && (params || flags.albedo.is_some()) {
            return Err(Error::new(
                "--s, --sigma, --brdf-param and --albedo need --brdf (no header or scene names the BRDF)",
            ));
        }
        // --s / --sigma without --brdf are parameters of the table's kind, checked against it below.
        let kind = match (flags.brdf, &table) {
            (Some(k), _) => k,
            (None, Some((b, _, _))) if params => b.kind(),
            (None, _) => {
                return Ok(table.map(|(b, src, t)| {
                    let mut t = t;
                    if let Some(a) = flags.albedo
                        && let Some(t) = t.as_mut()
                    {
                        t.scale = a;
                    }
                    Resolved {
                        transfer: t,
                        kind: b.kind(),
                        table: serde_json::to_value(b).unwrap_or_default(),
                        source: src.clone(),
                    }
                }))
                .and_then(|r| self.check_albedo(r, flags));
            }
        };
        let model = TransferModel::from_named(kind, &flags.params(), None)?.at_exitance(theta_o);
        model.validate()?;
        let scale = flags.albedo.or(table.as_ref().and_then(|(_, _, t)| t.map(|t| t.scale))).unwrap_or([1.0; 3]);
        if let Some((b, src, t)) = &table {
            let agrees = b.kind() == kind && t.is_none_or(|t| same_model(&t.model, &model));
            if !agrees {
                return Err(Error::new(format!(
                    "--brdf {kind}{} but {src} gives the BRDF {}: they contradict each other",
                    param_text(flags),
                    serde_json::to_string(b).unwrap_or_default()
                )));
            }
        }
        let horizon = table.as_ref().and_then(|(_, _, t)| t.map(|t| t.horizon)).unwrap_or_default();
        let mut flags_table = serde_json::json!({ "type": kind.name() });
        for (key, v) in flags.params() {
            flags_table[key] = serde_json::to_value(&v).unwrap_or_default();
        }
        flags_table["albedo"] = serde_json::json!(scale);
        let r = Resolved {
            transfer: Some(BrdfTransfer { model, scale, horizon }),
            kind,
            table: flags_table,
            source: "--brdf".into(),
        };
        self.check_albedo(Some(r), flags)
    }

    /// An `--albedo` that contradicts the table's albedo / k_s / k_r is an error naming both.
    fn check_albedo(&self, r: Option<Resolved>, flags: &BrdfFlags) -> Result<Option<Resolved>, Error> {
        if let (Some(a), Some((b, src))) = (flags.albedo, &self.brdf)
            && let Ok(Some(t)) = TransferModel::of_brdf(b, 0.0)
            && !(0..3).all(|i| close(a[i], t.scale[i], 1.0))
        {
            return Err(Error::new(format!(
                "--albedo {} but {src} gives {}: they contradict each other",
                v3(a),
                v3(t.scale)
            )));
        }
        Ok(r)
    }
}

fn same_model(a: &TransferModel, b: &TransferModel) -> bool {
    match (a, b) {
        (TransferModel::Phong { s: x }, TransferModel::Phong { s: y }) => close(*x, *y, 1.0),
        (TransferModel::TorranceSparrow { sigma: x, .. }, TransferModel::TorranceSparrow { sigma: y, .. }) => {
            close(*x, *y, 1.0)
        }
        (TransferModel::Microfacet { lobe: x, .. }, TransferModel::Microfacet { lobe: y, .. }) => {
            x.distribution == y.distribution && close(x.alpha, y.alpha, 1.0) && x.fresnel == y.fresnel
        }
        (a, b) => std::mem::discriminant(a) == std::mem::discriminant(b),
    }
}

fn param_text(f: &BrdfFlags) -> String {
    let flag = |k: &str, x: &ParamValue| match k {
        "s" | "sigma" => format!(" --{k} {x}"),
        _ => format!(" --brdf-param {k}={x}"),
    };
    f.params().iter().map(|(k, x)| flag(k, x)).collect()
}

/// The lighting to compare with: `--lighting` (a scene TOML's `[lighting]` table, or an environment
/// map with `--mapping` or a mapping inferred from its aspect ratio), else the described lighting
/// (`--scene`'s, else the first image's `reflect:lighting` header; a relative file there is taken
/// relative to that file).
pub fn lighting_of(
    lighting: Option<&Path>,
    mapping: Option<Mapping>,
    described: &Description,
) -> Result<Option<(Lighting, String)>, Error> {
    if let Some(p) = lighting {
        let flagged = if p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
            Lighting::from_scene_file(p)?
        } else {
            Lighting::from_envmap_file(p, mapping)
        };
        // Unlike the camera, sphere and BRDF (the image's description, where a contradiction is an
        // error), the lighting is what the image is compared with: `--lighting` replaces the
        // sidecar's or header's by rule (guide "Analysing another renderer's images"), to test whether a
        // lighting describes the image. It never does so silently: a different lighting is named
        // with the one it replaces in the report's lighting source.
        // A described lighting the analysis cannot read (axial, a missing map) is replaced as well.
        if let Some((s, file, source)) = &described.lighting {
            let d = Lighting::from_section(s, file.parent()).ok();
            if !d.as_ref().is_some_and(|d| same_lighting(&flagged, d).unwrap_or(false)) {
                let shown = format!(
                    "{} ({}), in place of the {source} ({})",
                    p.display(),
                    lighting_text(&flagged),
                    d.as_ref().map_or_else(|| "not analysable".to_string(), lighting_text)
                );
                return Ok(Some((flagged, shown)));
            }
        }
        return Ok(Some((flagged, p.display().to_string())));
    }
    if mapping.is_some() {
        return Err(Error::new("--mapping applies only to an environment map given with --lighting"));
    }
    match &described.lighting {
        Some((s, file, source)) => {
            Ok(Some((Lighting::from_section(s, file.parent()).map_err(|e| e.in_file(file))?, source.clone())))
        }
        None => Ok(None),
    }
}

/// The order up to which [`same_lighting`] compares two lightings' L_lm.
const LIGHTING_AGREE_LMAX: usize = 4;

/// Whether two lightings are the same: equal tables (an environment map by its canonical path), or
/// equal L_lm up to l = [`LIGHTING_AGREE_LMAX`] to 1e-4 of the largest (the same map in another
/// file or with its mapping left to inference; a different or rotated map differs far more).
fn same_lighting(a: &Lighting, b: &Lighting) -> Result<bool, analysis::Error> {
    let canonical = |l: &Lighting| match l {
        Lighting::Envmap { file, mapping, scale, rotate_deg, layer } => Lighting::Envmap {
            file: std::fs::canonicalize(file).unwrap_or_else(|_| file.clone()),
            mapping: *mapping,
            scale: *scale,
            rotate_deg: *rotate_deg,
            layer: layer.clone(),
        },
        other => other.clone(),
    };
    if canonical(a) == canonical(b) {
        return Ok(true);
    }
    let (ca, cb) = (a.coefficients(LIGHTING_AGREE_LMAX)?, b.coefficients(LIGHTING_AGREE_LMAX)?);
    let big = ca.iter().chain(&cb).flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    Ok(ca.iter().zip(&cb).all(|(x, y)| (0..3).all(|i| (x[i] - y[i]).abs() <= 1e-4 * big)))
}

/// A lighting in a message: its type and what identifies it.
fn lighting_text(l: &Lighting) -> String {
    match l {
        Lighting::Uniform { radiance } => format!("uniform lighting of radiance {}", v3(*radiance)),
        Lighting::Directional { direction, irradiance } => {
            format!("directional lighting from {} of irradiance {}", v3(*direction), v3(*irradiance))
        }
        Lighting::Sh { coefficients } => format!("SH lighting with {} coefficients", coefficients.len()),
        Lighting::Envmap { file, scale, rotate_deg, layer, .. } => {
            let mut t = format!("the environment map {}", file.display());
            if let Some(l) = layer {
                t.push_str(&format!(" (layer '{l}')"));
            }
            if *scale != 1.0 {
                t.push_str(&format!(" scaled by {}", num(*scale)));
            }
            if *rotate_deg != [0.0; 3] {
                t.push_str(&format!(" rotated by {}°", v3(*rotate_deg)));
            }
            t
        }
    }
}
