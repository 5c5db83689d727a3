//! Transfer coefficients Λ_l ρ̂_l of radially symmetric (or reparameterized) BRDFs, unit albedo /
//! k_s, l = 0 … l_max (CONVENTIONS §4). With them B_lm = Λ_l ρ̂_l L_lm (eq. 15).
//!
//! - [`lambert`]: eq. 38 in closed form (÷ π for BRDF = albedo/π); [`lambert::irradiance_kernel`]
//!   is the BRDF = 1 kernel A_l of eq. 39.
//! - [`phong`]: eq. 43 by a ratio recurrence (no overflow, no cancellation) and eq. 46.
//! - [`mirror`]: eq. 33, Λ_l ρ̂_l = 1.
//! - [`torrance_sparrow`]: eq. 50 by quadrature and eq. 57 at normal exitance; at exitance θ_o the
//!   q = 0 coefficient by 2D quadrature over the reparameterized lobe (eq. 49) and eq. 59.
//! - [`microfacet`]: the Beckmann microfacet lobe and its Λ_l ρ̂_l at normal exitance.
//! - [`radial`]: any radially symmetric ρ̂(θ) by quadrature of eq. 13.

pub mod lambert;
pub mod microfacet;
pub mod mirror;
pub mod phong;
pub mod radial;
pub mod torrance_sparrow;

use crate::error::{Error, Result};

/// Horizon handling of `phong` and `torrance-sparrow` (CONVENTIONS §4), defined in `vocab`.
pub use vocab::Horizon;

/// A BRDF model whose transfer coefficients we can compute.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TransferModel {
    Lambert,
    Phong { s: f64 },
    Mirror,
    TorranceSparrow { sigma: f64, theta_o: f64 },
}

/// The exitance angle θ_o (radians) of every command and header: 0 ≤ θ_o < π/2 (at 90° the
/// Torrance–Sparrow lobe's 1/cos θ_o diverges and a `normal-probe` camera looks along the
/// surface). The one check, used by [`TransferModel::validate`], by the EXR-header readers of the
/// CLI and by the inverse fits.
pub fn validate_exitance(theta_o: f64) -> Result<()> {
    if (0.0..std::f64::consts::FRAC_PI_2).contains(&theta_o) {
        Ok(())
    } else {
        Err(Error::new(format!("theta_o must be in [0°, 90°), got {}°", theta_o.to_degrees())))
    }
}

/// Below this σ (l_max + 1), Torrance–Sparrow's Λ_l ρ̂_l equals the mirror's 1 to within
/// (σ (l+1))² < 1e-18 (eq. 55: 1 − l(l+1)σ² − 2σ²/3 + O(σ⁴ l⁴)), so the mirror limit is returned.
pub const MIRROR_LIMIT_SIGMA_L: f64 = 1e-9;

impl TransferModel {
    /// Checks the parameters, the one validation of BRDF parameters for every command and header:
    /// Phong `s` finite and > 0, Torrance–Sparrow `σ` finite and > 0, 0 ≤ θ_o < π/2
    /// ([`validate_exitance`]). Every such value gives finite Λ_l ρ̂_l (σ → 0 and s → ∞ tend to
    /// the mirror's 1).
    pub fn validate(&self) -> Result<()> {
        match *self {
            TransferModel::Phong { s } if !(s > 0.0 && s.is_finite()) => {
                Err(Error::new(format!("phong exponent s must be finite and > 0, got {s}")))
            }
            TransferModel::TorranceSparrow { sigma, theta_o } => {
                if !(sigma > 0.0 && sigma.is_finite()) {
                    Err(Error::new(format!("torrance-sparrow sigma must be finite and > 0, got {sigma}")))
                } else {
                    validate_exitance(theta_o)
                }
            }
            _ => Ok(()),
        }
    }

    /// Λ_l ρ̂_l, l = 0 … lmax, by the exact (or numerically exact) formula. Torrance–Sparrow uses the
    /// paper's horizon (`ignore` beyond π/2 at normal exitance, eq. 50; `clamp` off normal); when
    /// σ (l_max + 1) < [`MIRROR_LIMIT_SIGMA_L`] it is the mirror limit 1 (to rounding).
    pub fn lambda_rho(&self, lmax: usize) -> Vec<f64> {
        match *self {
            TransferModel::Lambert => lambert::lambert(lmax),
            TransferModel::Phong { s } => phong::phong(s, lmax),
            TransferModel::Mirror => mirror::mirror(lmax),
            TransferModel::TorranceSparrow { sigma, .. } if sigma * (lmax as f64 + 1.0) < MIRROR_LIMIT_SIGMA_L => {
                mirror::mirror(lmax)
            }
            TransferModel::TorranceSparrow { sigma, theta_o } => {
                if theta_o == 0.0 {
                    torrance_sparrow::normal_exitance(sigma, lmax)
                } else {
                    torrance_sparrow::exitance(sigma, theta_o, lmax, Horizon::Clamp)
                }
            }
        }
    }

    /// The paper's approximation, when it has one: eq. 46 (Phong), eq. 57 (TS, normal exitance),
    /// eq. 59 (TS at θ_o).
    pub fn approximation(&self, lmax: usize) -> Option<(&'static str, Vec<f64>)> {
        match *self {
            TransferModel::Phong { s } => Some(("eq. 46", phong::gaussian(s, lmax))),
            TransferModel::TorranceSparrow { sigma, theta_o: 0.0 } => {
                Some(("eq. 57", torrance_sparrow::gaussian(sigma, lmax)))
            }
            TransferModel::TorranceSparrow { sigma, theta_o } => {
                Some(("eq. 59", torrance_sparrow::eq59(sigma, theta_o, lmax)))
            }
            _ => None,
        }
    }
}
