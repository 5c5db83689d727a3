//! Projection of a `normal-probe` render (CONVENTIONS §6): a lat-long image whose pixel (r, c) is
//! the reflected radiance B at the sphere point with normal = the lat-long direction of that pixel.
//! Its SH coefficients B_lm follow by plain lat-long quadrature; with a `stderr.R/G/B` layer the
//! per-coefficient standard errors are √(Σ ΔΩ² Y² σ²) (pixels are independent estimates).

use super::envmap::project_latlong;
use crate::error::{Error, Result};
use crate::image::{Image, RgbImage};
use crate::sh::RgbCoeffs;

/// B_lm (RGB) and, when the image has a `stderr` layer, their standard errors.
pub fn project_normal_probe(img: &Image, lmax: usize) -> Result<(RgbCoeffs, Option<RgbCoeffs>)> {
    let rgb = img.rgb().ok_or_else(|| Error::new("normal-probe image has no R, G, B channels"))?;
    if rgb.width != 2 * rgb.height {
        return Err(Error::new(format!(
            "a normal-probe image is a lat-long map with W = 2H, this one is {}×{}",
            rgb.width, rgb.height
        )));
    }
    let var = img.rgb_layer("stderr.").map(|s| RgbImage {
        width: s.width,
        height: s.height,
        pixels: s.pixels.iter().map(|p| [p[0] * p[0], p[1] * p[1], p[2] * p[2]]).collect(),
    });
    let (c, v) = project_latlong(&rgb, var.as_ref(), lmax);
    Ok((c, v.map(|v| v.iter().map(|x| [x[0].sqrt(), x[1].sqrt(), x[2].sqrt()]).collect())))
}
