//! Projection of a `normal-probe` render (docs/src/conventions.md §6): a lat-long image whose pixel (r, c) is
//! the reflected radiance B at the sphere point with normal = the lat-long direction of that pixel.
//! Its SH coefficients B_lm follow by plain lat-long quadrature; with a `stderr.R/G/B` layer the
//! per-coefficient standard errors are √(Σ ΔΩ² Y² σ²) (pixels are independent estimates).

use super::envmap::project_latlong;
use crate::error::{Error, Result};
use crate::image::{Image, RgbImage};
use crate::sh::RgbCoeffs;

/// The outgoing direction ω_o of the `normal-probe` camera at normal n (docs/src/conventions.md §6, with the
/// azimuth `phi_o_deg` of our extension): cos θ_o n + sin θ_o (cos φ_o t + sin φ_o b), t the unit
/// tangent of increasing θ and b = n × t. Angles in radians.
pub fn normal_probe_outgoing(n: [f64; 3], theta_o: f64, phi_o: f64) -> [f64; 3] {
    let th = n[2].clamp(-1.0, 1.0).acos();
    let ph = n[1].atan2(n[0]);
    let t = [th.cos() * ph.cos(), th.cos() * ph.sin(), -th.sin()];
    let b = [-ph.sin(), ph.cos(), 0.0];
    let (so, co) = theta_o.sin_cos();
    let (sp, cp) = phi_o.sin_cos();
    std::array::from_fn(|i| co * n[i] + so * (cp * t[i] + sp * b[i]))
}

/// B_lm (RGB) and, when the image has a `stderr` layer (validated by [`Image::stderr_layer`]),
/// their standard errors. An `lmax` above the highest order the W × H grid carries
/// ([`super::resolution::latlong_max_order`], min(W/2, H) − 1) is refused.
pub fn project_normal_probe(img: &Image, lmax: usize) -> Result<(RgbCoeffs, Option<RgbCoeffs>)> {
    let rgb = img.rgb().ok_or_else(|| Error::new("normal-probe image has no R, G, B channels"))?;
    if rgb.width != 2 * rgb.height {
        return Err(Error::new(format!(
            "a normal-probe image is a lat-long map with W = 2H, this one is {}×{}",
            rgb.width, rgb.height
        )));
    }
    super::resolution::check_latlong(lmax, rgb.width, rgb.height, "normal-probe image")?;
    let var = super::orthographic::stderr_estimate(img)?.map(|s| RgbImage {
        width: s.width,
        height: s.height,
        pixels: s.pixels.iter().map(|p| [p[0] * p[0], p[1] * p[1], p[2] * p[2]]).collect(),
    });
    let (c, v) = project_latlong(&rgb, var.as_ref(), lmax);
    Ok((c, v.map(|v| v.iter().map(|x| [x[0].sqrt(), x[1].sqrt(), x[2].sqrt()]).collect())))
}

/// The pixels of a `normal-probe` image as fit samples: direction the pixel's normal (docs/src/conventions.md
/// §2 lat-long grid), weight its exact solid angle, RGB radiance and variance (from the `stderr`
/// layer, else 1), and whether the image has that layer. Errors as [`project_normal_probe`].
pub fn probe_samples(img: &Image) -> Result<(Vec<super::orthographic::Sample>, bool)> {
    let rgb = img.rgb().ok_or_else(|| Error::new("normal-probe image has no R, G, B channels"))?;
    if rgb.width != 2 * rgb.height {
        return Err(Error::new(format!(
            "a normal-probe image is a lat-long map with W = 2H, this one is {}×{}",
            rgb.width, rgb.height
        )));
    }
    let se = super::orthographic::stderr_estimate(img)?;
    let (w, h) = (rgb.width, rgb.height);
    let samples = (0..w * h)
        .map(|i| {
            let (r, c) = (i / w, i % w);
            let px = rgb.pixels[i];
            let var = se.as_ref().map_or([1.0; 3], |s| s.pixels[i].map(|e| (e as f64) * (e as f64)));
            super::orthographic::Sample {
                dir: crate::sh::latlong_direction(r, c, w, h),
                w: crate::fit::latlong_omega(r, w, h),
                b: px.map(|v| v as f64),
                var,
            }
        })
        .collect();
    Ok((samples, se.is_some()))
}
