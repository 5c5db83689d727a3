//! The Grace Cathedral probe's SH coefficients L_lm (one channel), by quadrature over the pixels
//! of the angular map with their exact solid angles (docs/src/conventions.md §2), computed once per run.
//!
//! The renderer looks the map up by nearest pixel, so the lighting it integrates is piecewise
//! constant; the pixel-centre quadrature differs from that lighting's exact coefficients by
//! O((l·Δ)²) with Δ = 2π/1000 the pixel's angular size: ≈ 1e-3 relative at l = 16. The checks that
//! use Grace fit Lambert's low-pass filter, whose coefficients there are < 0.2 %, so this is far
//! below their noise.

use super::Ctx;
use super::scenes::grace_path;
use analysis::projection::envmap::angular_pixel;
use analysis::sh::{ShBasis, num_coefficients};
use std::path::Path;
use std::sync::OnceLock;

/// Largest order projected.
pub const LMAX: usize = 16;

/// Channel analysed in the Grace checks (green: the middle of the spectrum).
pub const CHANNEL: usize = 1;

static COEFFS: OnceLock<Result<Vec<f64>, String>> = OnceLock::new();

/// L_lm of the green channel, l ≤ [`LMAX`].
/// Computed once per process: the data folder does not change during a run.
pub fn coefficients(ctx: &Ctx) -> Result<Vec<f64>, String> {
    COEFFS.get_or_init(|| project(&grace_path(ctx))).clone()
}

fn project(path: &Path) -> Result<Vec<f64>, String> {
    let img = analysis::image::read_rgb(path).map_err(|e| e.to_string())?;
    if img.width != img.height {
        return Err(format!("{}: the angular probe must be square", path.display()));
    }
    let w = img.width;
    let n = num_coefficients(LMAX);
    let basis = ShBasis::new(LMAX);
    use rayon::prelude::*;
    // One partial sum per row, added in row order: rayon's reduce would pair them by work stealing,
    // making the last bits depend on the thread schedule.
    let rows: Vec<Vec<f64>> = (0..w)
        .into_par_iter()
        .map(|r| {
            let mut y = vec![0.0; n];
            let mut acc = vec![0.0; n];
            for c in 0..w {
                // The library's pixel-centre direction and exact solid angle (docs/src/conventions.md §2).
                let Some((dir, om)) = angular_pixel(r, c, w) else { continue };
                basis.eval_into(dir, &mut y);
                let val = img.get(r, c)[CHANNEL] as f64 * om;
                for k in 0..n {
                    acc[k] += val * y[k];
                }
            }
            acc
        })
        .collect();
    let sum = rows.iter().fold(vec![0.0; n], |mut a, b| {
        for k in 0..n {
            a[k] += b[k];
        }
        a
    });
    Ok(sum)
}
