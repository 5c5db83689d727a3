//! The errors of [`super::lighting`] and [`super::brdf`]: each one sentence whose `Display` is the
//! line a front-end prints after `error: ` (a file's path first when there is one, as
//! [`vocab::Error`]).

use std::path::{Path, PathBuf};

/// Why a set of images could not be inverted.
#[derive(Debug, Clone, thiserror::Error)]
pub enum Error {
    /// An error of one file: its path, then the problem.
    #[error("{}: {error}", path.display())]
    InFile { path: PathBuf, error: Box<Error> },
    /// An error of a lower layer (a projection, a fit, a lighting file, a singular solve).
    #[error(transparent)]
    Vocab(#[from] vocab::Error),
    /// The images' description (camera, sphere, BRDF, lighting) failed.
    #[error(transparent)]
    Observation(#[from] crate::observation::Error),
    /// An order above what the analysis supports ([`crate::sh::MAX_LMAX`]).
    #[error("--lmax {lmax} is above the supported maximum {max}", max = crate::sh::MAX_LMAX)]
    LmaxAbove { lmax: usize },
    /// A normal-probe image given with other images.
    #[error("a normal-probe render must be inverted on its own (one image)")]
    ProbeNotAlone,
    /// The width of the lighting map asked for.
    #[error("--width must be even and in [4, 16384], got {0}")]
    MapWidth(usize),
    /// `invert lighting` without a BRDF: neither given nor in the observation.
    #[error("no BRDF: pass --brdf (the image header names none)")]
    NoBrdf,
    /// `invert lighting` with a BRDF that has no transfer model (a `mix`, a microfacet with
    /// Fresnel other than none or Schlick).
    #[error("the BRDF '{kind}' of {src} has no transfer model: pass --brdf")]
    NoTransfer { kind: String, src: String },
    /// An albedo / k_s / k_r that is not positive in some channel.
    #[error("albedo must be > 0, got {0:?}")]
    AlbedoNotPositive([f64; 3]),
    /// `invert brdf` without a lighting: neither given nor in the observation.
    #[error("no reflect:lighting in the header: pass --lighting or --scene")]
    NoLighting,
    /// `invert brdf`: no channel of a normal probe's per-order estimates has two observable orders.
    #[error("no channel has two observable orders to fit")]
    NoObservableChannel,
    /// `invert brdf`: no channel of the views' pixel-space filter has two determined orders.
    #[error("no channel has two determined filter orders to fit the model to")]
    NoDeterminedChannel,
}

impl Error {
    /// Attaches a file's path if the error does not already name one.
    pub fn in_file(self, path: impl AsRef<Path>) -> Error {
        match self {
            Error::InFile { .. } => self,
            Error::Vocab(v) => Error::Vocab(v.in_file(path)),
            Error::Observation(o) => Error::Observation(o.in_file(path)),
            e => Error::InFile { path: path.as_ref().to_path_buf(), error: Box::new(e) },
        }
    }
}

impl From<Error> for vocab::Error {
    /// The one-line error of the front-ends, with the same text.
    fn from(e: Error) -> vocab::Error {
        match e {
            Error::Vocab(v) => v,
            Error::Observation(o) => o.into(),
            Error::InFile { path, error } => vocab::Error::from(*error).in_file(path),
            e => vocab::Error::new(e.to_string()),
        }
    }
}
