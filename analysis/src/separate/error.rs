//! The errors of a diffuse + specular separation: each one sentence whose `Display` is the line a
//! front-end prints after `error: ` (a file's path first when there is one, as [`vocab::Error`]).

use crate::observation::Spelling;
use std::path::{Path, PathBuf};

/// Why a set of views could not be separated.
#[derive(Debug, Clone, thiserror::Error)]
pub enum Error {
    /// An error of one file: its path, then the problem.
    #[error("{}: {error}", path.display())]
    InFile { path: PathBuf, error: Box<Error> },
    /// An error of a lower layer (a layer's weights, the resolution, a singular solve).
    #[error(transparent)]
    Vocab(#[from] vocab::Error),
    #[error("separation needs the diffuse view (θ_o = 0) and at least one specular view (θ_o > 0)")]
    TooFewViews,
    #[error("--lmax {lmax} is above the supported maximum {max} for separation", max = super::MAX_LMAX)]
    LmaxAbove { lmax: usize },
    #[error("--width must be even and in [4, 16384], got {0}")]
    MapWidth(usize),
    #[error("not a normal-probe render (an orthographic camera): separation needs normal-probe views")]
    NotProbe,
    #[error("no R, G, B channels")]
    NoRgb,
    #[error("a normal-probe image is a lat-long map with W = 2H ≥ 8, this one is {width}×{height}")]
    ProbeShape { width: usize, height: usize },
    #[error(
        "the diffuse view (the first image) must be at normal exitance θ_o = 0, this render is at θ_o = {0}° (give the θ_o = 0 render first)"
    )]
    DiffuseExitance(f64),
    #[error("a specular view must be at θ_o > 0 (at θ_o = 0 R = n and the consistency holds for any split)")]
    SpecularAtNormal,
    #[error("a specular view must be at φ_o = 0° or 180° (R on the normal's meridian), this render is at φ_o = {0}°")]
    SpecularAzimuth(f64),
    #[error("image size {width}×{height} differs from the diffuse view's {first_width}×{first_height}")]
    SizeDiffers { width: usize, height: usize, first_width: usize, first_height: usize },
    /// A weight neither given nor in the BRDF table (`flag` is `kd` or `ks`, named in the
    /// front-end's `spelling`: `--kd`, `kd=`).
    #[error(
        "{} is required: the first image's header (or {}) BRDF is not a mix of one lambert and one mirror layer (pass {} and {})",
        spelling.name(flag), spelling.name("scene"), spelling.name("kd"), spelling.name("ks")
    )]
    WeightRequired { flag: &'static str, spelling: Spelling },
    #[error("k_d and k_s must be > 0, got k_d = {kd}, k_s = {ks} in channel {channel}")]
    WeightsNotPositive { kd: f64, ks: f64, channel: &'static str },
    /// A weight given that the BRDF table's mix contradicts (`flag` is `kd` or `ks`, named in the
    /// front-end's `spelling`).
    #[error(
        "{} but {src} gives {} = {table} (its mix of lambert and mirror): they contradict each other",
        spelling.given(flag, given), if *flag == "kd" { "k_d" } else { "k_s" }
    )]
    WeightContradicts { flag: &'static str, spelling: Spelling, given: String, src: String, table: String },
    /// A failure of one channel's fits.
    #[error("channel {channel}: {message}")]
    Channel { channel: &'static str, message: String },
    /// Too few pixels to estimate the noise from one side's residuals (`what`: "diffuse view").
    #[error(
        "channel {channel}: the {what} have no more pixels than fitted coefficients: no residual to estimate the noise from"
    )]
    NoResidual { channel: &'static str, what: &'static str },
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
