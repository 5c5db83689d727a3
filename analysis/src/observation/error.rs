//! The errors of describing an observation: each one sentence whose `Display` is the line a
//! front-end prints after `error: ` (a file's path first when there is one, as [`vocab::Error`]).

use std::path::{Path, PathBuf};

/// Why an image could not be described (the camera, sphere, BRDF or lighting it shows).
#[derive(Debug, Clone, thiserror::Error)]
pub enum Error {
    /// An error of one file: its path, then the problem.
    #[error("{}: {error}", path.display())]
    InFile { path: PathBuf, error: Box<Error> },
    /// An error of a lower layer (a header value, a scene or lighting file, a transfer model).
    #[error(transparent)]
    Vocab(#[from] vocab::Error),
    /// Two sources give different values of one thing; `one` and `other` each say a source and its
    /// value ("--albedo 0.5,0.5,0.5", "the header's reflect:camera gives …").
    #[error("{one} but {other}: they contradict each other")]
    Contradiction { one: String, other: String },
    /// A camera the analysis does not model; `what` is the command's verb ("analysed").
    #[error("camera type 'perspective' cannot be {what} (use an orthographic or normal-probe render)")]
    Perspective { what: String },
    /// A normal-probe view at oblique exitance and an azimuth other than 0.
    #[error("a normal-probe render at phi_o_deg = {phi_o_deg} cannot be {what} (only phi_o_deg = 0)")]
    ProbeAzimuth { phi_o_deg: f64, what: String },
    /// A header's or scene's normal-probe exitance out of range.
    #[error("camera: {0}")]
    CameraExitance(String),
    /// An explicit exitance θ_o out of range.
    #[error("--theta-o: {0}")]
    ExitanceValue(String),
    /// An explicit azimuth φ_o that is not a finite number.
    #[error("--phi-o must be a finite number of degrees, got {0}")]
    AzimuthValue(f64),
    /// A sidecar scene whose `[render]` size is not the image's.
    #[error(
        "the image is {width}×{height} but the [render] size of {} is {scene_width}×{scene_height}: --scene must be the scene this image is a render of",
        scene.display()
    )]
    SceneSize { width: usize, height: usize, scene: PathBuf, scene_width: usize, scene_height: usize },
    /// No source gives an image's camera; `probe_only` when only normal-probe values are accepted;
    /// what to pass is named in the front-end's `spelling` (the CLI's flags; Python's `scene=` or an
    /// array with `camera=`, a file having no camera keyword).
    #[error("no reflect:camera in the header: {}", match (spelling, probe_only) {
        (super::brdf::Spelling::Keywords, _) =>
            "pass scene= (the scene this image is a render of), or its pixels as an array with camera=",
        (super::brdf::Spelling::Flags, true) =>
            "pass --theta-o (and --phi-o) of its normal-probe camera once per image, or --scene S.toml",
        (super::brdf::Spelling::Flags, false) =>
            "pass --from x,y,z and --extent (orthographic camera), --theta-o (normal-probe camera), or --scene S.toml",
    })]
    NoCamera { probe_only: bool, spelling: super::brdf::Spelling },
    /// Explicit values of both an orthographic and a normal-probe camera for one image.
    #[error(
        "--from/--to/--up/--extent describe an orthographic camera and --theta-o/--phi-o a normal-probe camera: give one of them"
    )]
    TwoCameraKinds,
    /// Explicit normal-probe angles for an image whose `src` gives an orthographic camera.
    #[error("--theta-o/--phi-o describe a normal-probe camera but {src} is an orthographic camera")]
    ProbeValuesForOrtho { src: String },
    /// Explicit orthographic values for an image whose `src` gives a normal-probe camera.
    #[error("--from/--to/--up/--extent describe an orthographic camera but {src} is a normal-probe camera")]
    OrthoValuesForProbe { src: String },
    /// A sphere with an albedo texture (every analysis assumes one albedo), in an image's header
    /// (`in_header`) or in a scene file (which [`Error::InFile`] names).
    #[error("{}the sphere has an albedo texture, and analyze and invert assume a uniform albedo",
        if *in_header { "header reflect:objects: " } else { "" })]
    Textured { in_header: bool },
    /// A BRDF table whose transfer model is refused, with the source of the table.
    #[error("{src}: {message}")]
    BrdfTable { src: String, message: String },
    /// BRDF parameters or an albedo without a BRDF kind, where no header or scene names one.
    #[error("{} need {} (no header or scene names the BRDF)", if *spelling == super::brdf::Spelling::Flags {
        "--s, --sigma, --brdf-param and --albedo"
    } else {
        "s=, sigma=, brdf_params= and albedo="
    }, spelling.name("brdf"))]
    BrdfParamsWithoutKind { spelling: super::brdf::Spelling },
    /// The sphere's silhouette in an orthographic view is not where the camera and sphere put it:
    /// what was measured, the camera and sphere told (`told`), what they predict, and the
    /// assumption most likely wrong.
    #[error("the sphere's silhouette in the image has {measured}, but {told} predict {predicted}: {suspect}")]
    Silhouette { measured: String, told: String, predicted: String, suspect: String },
    /// A mapping given without an environment map to apply it to.
    #[error("--mapping applies only to an environment map given with --lighting")]
    MappingWithoutLighting,
}

impl Error {
    /// Attaches a file's path if the error does not already name one.
    pub fn in_file(self, path: impl AsRef<Path>) -> Error {
        match self {
            Error::InFile { .. } | Error::Vocab(vocab::Error { path: Some(_), .. }) => self,
            e => Error::InFile { path: path.as_ref().to_path_buf(), error: Box::new(e) },
        }
    }

    /// The error of `path` that `e` is (a shorthand of [`Error::in_file`]).
    pub fn file(path: impl AsRef<Path>, e: Error) -> Error {
        e.in_file(path)
    }
}

impl From<Error> for vocab::Error {
    /// The one-line error of the front-ends, with the same text.
    fn from(e: Error) -> vocab::Error {
        match e {
            Error::Vocab(v) => v,
            Error::InFile { path, error } => vocab::Error::from(*error).in_file(path),
            e => vocab::Error::new(e.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_error_reads_as_the_front_ends_line() {
        let e = Error::NoCamera { probe_only: true, spelling: super::super::brdf::Spelling::Flags }.in_file("a.exr");
        let v: vocab::Error = e.clone().into();
        assert_eq!(e.to_string(), v.to_string());
        assert!(v.to_string().starts_with("a.exr: no reflect:camera in the header: pass --theta-o"), "{v}");
        // A path is attached once: the innermost file is the one named.
        assert_eq!(e.in_file("b.exr").to_string(), v.to_string());
        let inner = Error::Vocab(vocab::Error::file("h.exr", "bad")).in_file("b.exr");
        assert_eq!(inner.to_string(), "h.exr: bad");
    }
}
