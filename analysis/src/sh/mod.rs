//! Real spherical harmonics in the convention of CONVENTIONS §3 (orthonormal, no Condon–Shortley
//! phase, flat index k = l(l+1) + m).

pub mod basis;

pub use basis::{index, lm, num_coefficients, ShBasis};
