//! `analysis`: the frequency-space half of `reflect`.
//!
//! Turns environment maps, BRDFs and rendered images into the spherical-harmonic quantities of
//! Ramamoorthi & Hanrahan, "A Signal-Processing Framework for Reflection, Part 2": lighting
//! coefficients L_lm, transfer coefficients Λ_l ρ̂_l, reflected-light coefficients B_lm, and the
//! comparison B_lm = Λ_l ρ̂_l L_lm (eq. 15). It does not depend on the renderer, so it can analyse
//! any renderer's EXR files. Conventions: docs/src/conventions.md §2, §3, §4, §7.
//!
//! - [`sh`]: basis, reconstruction, rotation;
//! - [`projection`]: environment maps, functions, `normal-probe` and orthographic renders;
//! - [`transfer`]: Λ_l ρ̂_l of Lambert, Phong, mirror, Torrance–Sparrow, any radial lobe;
//! - [`fit`]: pixel-space least squares (filter fits, SH fits, covariances) shared by every command;
//! - [`predict`], [`filter`]: B_lm from L_lm and the per-order filter measured from renders;
//! - [`inverse`]: inverse lighting (eq. 17) and inverse BRDF (eq. 16) with their conditioning;
//! - [`lighting`]: the scene's lighting description → L_lm;
//! - [`observation`]: what a set of images shows (camera, sphere, BRDF, lighting) from headers,
//!   a sidecar scene and explicit values;
//! - [`noise`]: pixel noise correlated by a reconstruction filter, and the error-bar inflation it implies;
//! - [`verdict`]: whether an image contradicts the lighting, BRDF and camera it was told, and which
//!   assumption most likely is wrong;
//! - [`separate`]: diffuse + specular separation (sec. 3.5) as parameters → report;
//! - [`factor`]: light-field factorization into lighting and BRDF (eq. 18) as parameters → report;
//! - [`compare`]: is image A image B up to noise (per-pixel z, scale, blocks, a Šidák verdict);
//! - [`analyze`]: projection into SH and comparison with the lighting and eq. 15, as parameters →
//!   report (`reflect analyze`);
//! - [`invert`]: inverse lighting and inverse BRDF as parameters → reports (`reflect invert lighting |
//!   brdf`), on the linear algebra of [`inverse`];
//! - [`lsq`], [`quadrature`]: numerical building blocks.

// `!(x > 0.0)` is deliberate: it also rejects NaN. Index loops mirror the equations' indices.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod analyze;
pub mod compare;
pub mod factor;
pub mod filter;
pub mod fit;
pub mod inverse;
pub mod invert;
pub mod lighting;
pub mod lsq;
pub mod noise;
pub mod observation;
pub mod predict;
pub mod projection;
pub mod quadrature;
pub mod separate;
pub mod sh;
pub mod special;
pub mod transfer;
pub mod truncation;
pub mod verdict;

/// The shared error type and image I/O live in `vocab` (re-exported under their old paths).
pub use vocab::{error, image};

pub use error::Error;
