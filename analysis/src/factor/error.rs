//! The errors of a light-field factorization: each one sentence whose `Display` is the line a
//! front-end prints after `error: ` (a file's path first when there is one, as [`vocab::Error`]).

use std::path::{Path, PathBuf};

/// Why a light field could not be assembled or factored.
#[derive(Debug, Clone, thiserror::Error)]
pub enum Error {
    /// An error of one file: its path, then the problem.
    #[error("{}: {error}", path.display())]
    InFile { path: PathBuf, error: Box<Error> },
    /// An error of a lower layer (the grid's resolution, the node rule, a header value).
    #[error(transparent)]
    Vocab(#[from] vocab::Error),
    #[error("--max-amplification must be a finite number ≥ 1, got {0}")]
    MaxAmplification(f64),
    #[error("the channel index must be 0, 1 or 2 (R, G, B), got {0}")]
    Channel(usize),
    #[error("no images")]
    NoImages,
    #[error("θ_o = 0 is not a node of the outgoing rule: pass a normal-exitance view with --normal")]
    NormalViewAsNode,
    #[error("--normal needs a θ_o = 0 normal-probe render, this one is at θ_o = {0}°")]
    NormalViewExitance(f64),
    #[error(
        "an orthographic camera cannot be factored (normal-probe renders only; describe a headerless one with --theta-o/--phi-o)"
    )]
    NotProbe,
    #[error(
        "a jittered normal-probe render holds pixel averages, not the pixel-centre samples the quadrature needs (render with jitter = false)"
    )]
    Jittered,
    #[error("image has no {0} channel")]
    NoChannel(&'static str),
    #[error(
        "image is {width}×{height}, but {} is {first_width}×{first_height} (all node images must share one grid)",
        first.display()
    )]
    GridDiffers { width: usize, height: usize, first: PathBuf, first_width: usize, first_height: usize },
    #[error("header {key} differs from {}'s (all renders must be of one scene)", first.display())]
    SceneDiffers { key: &'static str, first: PathBuf },
    /// A rendered view with as many pixels as its grid needs (`what` the view, `got` its pixels).
    #[error("the render of {what} has {got} pixels, the {width}×{height} grid needs {}", width * height)]
    RenderSize { what: String, got: usize, width: usize, height: usize },
}

impl Error {
    /// Attaches a file's path if the error does not already name one.
    pub fn in_file(self, path: impl AsRef<Path>) -> Error {
        match self {
            Error::InFile { .. } | Error::Vocab(vocab::Error { path: Some(_), .. }) => self,
            e => Error::InFile { path: path.as_ref().to_path_buf(), error: Box::new(e) },
        }
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
