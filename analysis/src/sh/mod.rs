//! Real spherical harmonics in the convention of docs/src/conventions.md §3 (orthonormal, no Condon–Shortley
//! phase, flat index k = l(l+1) + m): evaluation, reconstruction and rotation.

pub mod basis;
pub mod reconstruct;
pub mod rotation;

pub use basis::{ShBasis, index, lm, num_coefficients};
pub use reconstruct::{Reconstructor, latlong_direction, lmax_of, reconstruct_latlong};
pub use rotation::{Rotation, rotate_coefficients, rotation_matrices};

/// Largest l_max the analysis commands accept (the basis is accurate far beyond; this guards
/// against accidental huge allocations).
pub const MAX_LMAX: usize = 200;

/// RGB coefficients in index order k.
pub type RgbCoeffs = Vec<[f64; 3]>;

/// Λ_l = √(4π / (2l + 1)) (eq. 4).
#[inline]
pub fn lambda(l: usize) -> f64 {
    (4.0 * std::f64::consts::PI / (2.0 * l as f64 + 1.0)).sqrt()
}
