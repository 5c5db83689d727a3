//! Prediction of the reflected light field from lighting and BRDF: B_lm = Λ_l ρ̂_l L_lm (eq. 15),
//! and maps reconstructed from it — e.g. the irradiance map of a Lambertian sphere from its
//! 9 terms (l ≤ 2) against the full-order result.
//!
//! Parameters: lighting coefficients `L` (RGB, index order k), transfer coefficients Λ_l ρ̂_l
//! (l = 0 …), an RGB albedo / k_s scale.

pub mod orthographic;

pub use orthographic::{OrthoScene, PredictedImage, predict_orthographic, predict_scene};

use crate::sh::{lm, reconstruct_latlong};

/// B_lm = albedo · Λ_l ρ̂_l · L_lm for every k of `lighting` (orders beyond `lambda_rho` are 0).
pub fn predict(lighting: &[[f64; 3]], lambda_rho: &[f64], albedo: [f64; 3]) -> Vec<[f64; 3]> {
    lighting
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let (l, _) = lm(k);
            let f = lambda_rho.get(l).copied().unwrap_or(0.0);
            [albedo[0] * f * c[0], albedo[1] * f * c[1], albedo[2] * f * c[2]]
        })
        .collect()
}

/// Truncates (or zero-pads) a coefficient vector to `lmax`.
pub fn truncate(coeffs: &[[f64; 3]], lmax: usize) -> Vec<[f64; 3]> {
    let n = (lmax + 1) * (lmax + 1);
    (0..n).map(|k| coeffs.get(k).copied().unwrap_or([0.0; 3])).collect()
}

/// Error of a low-order reconstruction against a higher-order one on a W × H lat-long grid.
#[derive(Clone, Copy, Debug)]
pub struct MapError {
    /// max |low − high| / max |high| over pixels and channels.
    pub max_rel: f64,
    /// RMS (solid-angle weighted) of low − high, over the RMS of high.
    pub rms_rel: f64,
}

/// Compares the map reconstructed from the first (l_low + 1)² coefficients of `b` with the map
/// from all of `b`.
pub fn truncation_error(b: &[[f64; 3]], l_low: usize, width: usize, height: usize) -> MapError {
    let high = reconstruct_latlong(b, width, height);
    let low = reconstruct_latlong(&truncate(b, l_low), width, height);
    let (mut max_d, mut max_h, mut se, mut sh) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for r in 0..height {
        let theta = std::f64::consts::PI * (r as f64 + 0.5) / height as f64;
        let w = theta.sin();
        for c in 0..width {
            let (a, h) = (low[r * width + c], high[r * width + c]);
            for ch in 0..3 {
                max_d = max_d.max((a[ch] - h[ch]).abs());
                max_h = max_h.max(h[ch].abs());
                se += w * (a[ch] - h[ch]).powi(2);
                sh += w * h[ch].powi(2);
            }
        }
    }
    MapError { max_rel: max_d / max_h.max(f64::MIN_POSITIVE), rms_rel: (se / sh.max(f64::MIN_POSITIVE)).sqrt() }
}
