//! The errors of [`super::analyze`]: each one sentence whose `Display` is the line a front-end
//! prints after `error: ` (a file's path first when there is one, as [`vocab::Error`]).

use std::path::Path;

/// Why a set of images could not be analysed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum Error {
    /// An error of one file: its path, then the problem.
    #[error("{}: {error}", path.display())]
    InFile { path: std::path::PathBuf, error: Box<Error> },
    /// An error of a lower layer (a projection, a fit, a lighting file).
    #[error(transparent)]
    Vocab(#[from] vocab::Error),
    /// The images' description (camera, sphere, BRDF, lighting) failed.
    #[error(transparent)]
    Observation(#[from] crate::observation::Error),
    /// An order above what the analysis supports ([`crate::sh::MAX_LMAX`]).
    #[error("--lmax {lmax} is above the supported maximum {max}", max = crate::sh::MAX_LMAX)]
    LmaxAbove { lmax: usize },
    /// A normal-probe image given with other images; `what` is the command's verb ("analysed").
    #[error("a normal-probe render must be {what} on its own (one image)")]
    ProbeNotAlone { what: &'static str },
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
