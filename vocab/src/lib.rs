//! `vocab`: the vocabulary that every part of `reflect` shares, defined once.
//!
//! - [`scene`]: the scene tables of docs/src/conventions.md §6 as serde types (the renderer builds from them,
//!   the analysis reads its lighting from them, `reflect verify` builds its scenes as values of them);
//! - [`closed`]: every closed set (`sampler`, `horizon`, `distribution`, `fresnel`, `mapping`,
//!   lighting, camera and shape kinds), one spelling each in files, headers and on the command line
//!   (the BRDF kinds, [`BrdfKind`], are derived from the list of [`scene::BrdfSection`] tables);
//! - [`header`]: the `reflect:*` EXR header attributes, written from and read back into those types;
//! - [`error`]: the one user-facing error type (one line naming the file and the problem);
//! - [`image`]: EXR/HDR reading and EXR writing (docs/src/conventions.md §5);
//! - [`exr_order`]: every EXR written with its header attributes in one canonical order.
//!
//! It depends on neither the renderer nor the analysis, so both (and the binary) can use it.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod closed;
pub mod colour;
pub mod error;
pub mod exr_order;
pub mod header;
pub mod image;
pub mod scene;

pub use closed::{CameraKind, Distribution, FresnelKind, Horizon, LightingKind, Mapping, Sampler, ShapeKind};
pub use error::{Error, Result};
pub use scene::{
    BrdfKind, BrdfSection, CameraSection, Color, LightingSection, MixLayer, ObjectSection, RenderSection, SceneFile,
};
