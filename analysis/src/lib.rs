//! `analysis`: the frequency-space half of `reflect`.
//!
//! Turns environment maps, BRDFs and rendered images into the spherical-harmonic quantities of
//! Ramamoorthi & Hanrahan, "A Signal-Processing Framework for Reflection, Part 2": lighting
//! coefficients L_lm, transfer coefficients Λ_l ρ̂_l, reflected-light coefficients B_lm, and the
//! comparison B_lm = Λ_l ρ̂_l L_lm (eq. 15). It does not depend on the renderer, so it can analyse
//! any renderer's EXR files. Conventions: `shared/CONVENTIONS.md` §2, §3, §4, §7.

pub mod error;
pub mod image;
pub mod sh;

pub use error::Error;
