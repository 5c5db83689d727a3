//! The highest SH order an image's samples can carry, so that no command reports an order its input
//! does not determine (and no synthesis writes a map too small for its l_max).
//!
//! - Lat-long grid of W × H pixel-centre samples (`normal-probe` renders, lat-long environment
//!   maps written or read with the pixel-centre rule): in φ the W equispaced samples alias e^{imφ}
//!   onto e^{i(m ± W)φ}, and cos(W/2 φ) vanishes at every sample, so only |m| < W/2 is determined;
//!   in θ the H rows determine at most H functions of θ for each m, so the orders l = |m| … l_max
//!   of that m need l_max + 1 ≤ H (m = 0 is the binding case). Together
//!   [`latlong_max_order`] = min(W/2, H) − 1. This is necessary, not sufficient for accuracy: the
//!   midpoint rule's error grows as (π l / H)² near the limit.
//! - Samples attributed to the reflection vector R = 2(n·ω_o)n − ω_o instead of the normal (the
//!   specular views of `invert separate`): R turns twice as fast as n, so the grid's spacing in R is
//!   twice its spacing in n, and [`latlong_max_order_reflection`] = min(W/2, H)/2 − 1.
//! - Orthographic views of a sphere ([`ortho_max_order`]): the visible normals of one view, taken
//!   along a great circle through the view axis, are D = 2r / (pixel size) samples over an angle
//!   π, like H = D rows of a lat-long grid (and the ring at the limb has πD > 2D samples in φ), so
//!   D − 1 in the normal parameterization; in the reflection one R turns twice as fast: D/2 − 1.
//!   Several views sample the same normals no finer, so the limit of a set is that of its finest
//!   view.
//!
//! [`check_order`] turns a limit into the one refusal every command prints.

use crate::error::{Error, Result};

/// Highest order a W × H lat-long pixel-centre grid carries in the direction it samples:
/// min(W/2, H) − 1 (module doc); `None` when it carries not even l = 0 (W < 2 or H < 1).
pub fn latlong_max_order(width: usize, height: usize) -> Option<usize> {
    (width / 2).min(height).checked_sub(1)
}

/// Highest order a W × H lat-long grid of normals carries when its samples are attributed to the
/// reflection vector: min(W/2, H)/2 − 1 (module doc).
pub fn latlong_max_order_reflection(width: usize, height: usize) -> Option<usize> {
    ((width / 2).min(height) / 2).checked_sub(1)
}

/// Highest order an orthographic view carries: `diameter_px` is the sphere's diameter in pixels
/// (2 r / pixel size); D − 1 for the normal parameterization, D/2 − 1 for the reflection one
/// (module doc). `None` below one pixel (or a non-finite size).
pub fn ortho_max_order(diameter_px: f64, reflection: bool) -> Option<usize> {
    if !(diameter_px.is_finite() && diameter_px >= 1.0) {
        return None;
    }
    let d = diameter_px.min(1e6).floor() as usize;
    if reflection { (d / 2).checked_sub(1) } else { d.checked_sub(1) }
}

/// Refuses `lmax` above `carried`, the highest order `what` (e.g. "a 16×8 normal-probe image")
/// carries, with the limit and its rule in the message; `None` = carries no order at all.
pub fn check_order(lmax: usize, carried: Option<usize>, what: &str, rule: &str) -> Result<()> {
    match carried {
        Some(c) if lmax <= c => Ok(()),
        Some(c) => Err(Error::new(format!(
            "--lmax {lmax} is above l = {c}, the highest order {what} carries ({rule}); lower --lmax or use a finer grid"
        ))),
        None => Err(Error::new(format!("{what} carries no SH order at all ({rule})"))),
    }
}

/// [`check_order`] for a W × H lat-long grid of `what` (e.g. "normal-probe image"): returns the
/// highest order it carries.
pub fn check_latlong(lmax: usize, width: usize, height: usize, what: &str) -> Result<usize> {
    let carried = latlong_max_order(width, height);
    check_order(lmax, carried, &format!("a {width}×{height} {what}"), LATLONG_RULE)?;
    Ok(carried.unwrap_or(0))
}

/// The rule of [`latlong_max_order`], for messages.
pub const LATLONG_RULE: &str = "pixel-centre lat-long grid: |m| < W/2 and l < H";
/// The rule of [`latlong_max_order_reflection`], for messages.
pub const LATLONG_REFLECTION_RULE: &str = "normals attributed to the reflection vector: l < min(W/2, H)/2";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::projection::project_latlong;
    use crate::sh::{num_coefficients, reconstruct_latlong};

    #[test]
    fn limits() {
        assert_eq!(latlong_max_order(16, 8), Some(7));
        assert_eq!(latlong_max_order(4, 2), Some(1));
        assert_eq!(latlong_max_order(1, 1), None);
        assert_eq!(latlong_max_order(64, 8), Some(7));
        assert_eq!(latlong_max_order(8, 64), Some(3));
        assert_eq!(latlong_max_order_reflection(16, 8), Some(3));
        assert_eq!(ortho_max_order(20.5, false), Some(19));
        assert_eq!(ortho_max_order(20.5, true), Some(9));
        assert_eq!(ortho_max_order(0.5, false), None);
        assert!(check_order(8, Some(7), "x", "y").unwrap_err().to_string().contains("l = 7"));
        assert!(check_order(7, Some(7), "x", "y").is_ok());
    }

    /// At the limit the samples determine every coefficient (a band-limited map re-projected by
    /// least squares on its own samples returns its coefficients), one order above they do not:
    /// two different coefficient vectors give the same samples.
    #[test]
    fn one_order_above_the_limit_is_aliased() {
        let (w, h) = (16, 8);
        let c = latlong_max_order(w, h).unwrap();
        // Above the limit in θ: Y_{H,0} and a combination of lower m = 0 orders coincide on the
        // rows; in φ: Y_{W/2, ±W/2} vanish or alias. Show the second directly: the sin(W/2 φ)
        // harmonic (m = −W/2) at l = W/2 is the pixel-centre alias of cos, and cos(W/2 φ) is 0.
        let l = w / 2;
        let n = num_coefficients(l);
        let mut coeffs = vec![[0.0; 3]; n];
        coeffs[crate::sh::index(l, l as i64)] = [1.0; 3]; // cos(W/2 φ) part
        let px = reconstruct_latlong(&coeffs, w, h);
        assert!(px.iter().all(|p| p[0].abs() < 1e-12), "cos(W/2 φ) is zero at every pixel centre");
        assert!(l > c);
        // And at the limit the pixel-centre quadrature at least separates every order (no
        // coefficient is zero-projected): project Y_{c,c} and find it again.
        let mut one = vec![[0.0; 3]; num_coefficients(c)];
        one[crate::sh::index(c, c as i64)] = [1.0; 3];
        let img = crate::image::RgbImage {
            width: w,
            height: h,
            pixels: reconstruct_latlong(&one, w, h).iter().map(|p| p.map(|v| v as f32)).collect(),
        };
        let (back, _) = project_latlong(&img, None, c);
        assert!(back[crate::sh::index(c, c as i64)][0] > 0.5, "{:?}", back[crate::sh::index(c, c as i64)]);
    }
}
