//! Inverse rendering from images of a sphere (paper sec. 2.2, sec. 3), as parameters → reports:
//! the analyses of `reflect invert lighting` ([`lighting()`]) and `reflect invert brdf`
//! ([`brdf()`]) on images and their [`Observation`] (the linear algebra is [`crate::inverse`]'s).
//!
//! Images are projected as in [`crate::analyze`]: one `normal-probe` render (lat-long quadrature;
//! at θ_o = 0 the normal is the reflection vector, so every BRDF's B is in its own
//! parameterization), or orthographic views (weighted least squares, in the normal
//! parameterization for lambert and the reflection one otherwise). An `lmax` above the highest
//! order the images carry is refused (`lmax_carried` in the reports).

pub mod brdf;
mod error;
pub mod lighting;

pub use brdf::{BrdfParams, FitModel, InvertBrdfReport, brdf};
pub use error::Error;
pub use lighting::{InvertLightingReport, LightingParams, lighting};

use crate::image::Image;
use crate::noise::PixelFilter;
use crate::observation::pixels::PixelNoise;
use crate::observation::{Camera, Observation};
use crate::projection::{
    OrthoView, Param, Sample, fit_orthographic, latlong_max_order, ortho_samples, project_normal_probe,
};
use std::path::PathBuf;

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Projected B_lm with standard errors, θ_o of a normal-probe image, and the first image.
struct Projected {
    b: Vec<[f64; 3]>,
    stderr: Option<Vec<[f64; 3]>>,
    method: String,
    theta_o: f64,
    first: Image,
    /// A normal-probe image (lat-long quadrature), not orthographic views.
    probe: bool,
    /// The highest order the input carries (`project` refuses an l_max above it).
    lmax_carried: usize,
    /// Orthographic views: their used pixels and whether every view has a `stderr` layer.
    samples: Option<(Vec<Sample>, bool)>,
    /// Orthographic views: the correlation of neighbouring pixels' noise and the variance
    /// inflation every pixel fit applies ([`crate::observation::pixels::prepare`]).
    noise: Option<PixelNoise>,
    /// The notes of the pixel-noise decision (`note: …` lines for stderr).
    notes: Vec<String>,
}

/// Checks `lmax` against [`crate::sh::MAX_LMAX`].
fn check_lmax(lmax: usize) -> Result<(), Error> {
    if lmax > crate::sh::MAX_LMAX {
        return Err(Error::LmaxAbove { lmax });
    }
    Ok(())
}

/// Projects `images` (named `paths`) described by `observed` to order `lmax`; `param` is the
/// parameterization of orthographic views, `filter` the renderer's pixel filter.
fn project(
    mut images: Vec<Image>,
    paths: &[PathBuf],
    observed: &Observation,
    lmax: usize,
    param: Param,
    filter: Option<PixelFilter>,
) -> Result<Projected, Error> {
    check_lmax(lmax)?;
    let in_first = |e: Error| if paths.len() == 1 { e.in_file(&paths[0]) } else { e };
    let (noise, notes) =
        crate::observation::pixels::prepare(&mut images, &observed.cameras, &observed.sphere, param, lmax, filter)
            .map_err(|e| in_first(e.into()))?;
    let mut ortho = Vec::new();
    let mut probe = None;
    for (c, p) in observed.cameras.iter().zip(paths) {
        match *c {
            Camera::NormalProbe { theta_o_deg, phi_o_deg } => {
                probe = Some(Camera::probe_theta_o_deg(theta_o_deg, phi_o_deg, "inverted").map_err(|e| e.in_file(p))?)
            }
            Camera::Ortho(o) => ortho.push(o),
        }
    }
    if let Some(theta_o_deg) = probe {
        if images.len() != 1 {
            return Err(Error::ProbeNotAlone);
        }
        let (b, stderr) = project_normal_probe(&images[0], lmax).map_err(|e| e.in_file(&paths[0]))?;
        let lmax_carried = latlong_max_order(images[0].width, images[0].height).unwrap_or(0);
        let first = images.into_iter().next().unwrap_or_default();
        return Ok(Projected {
            b,
            stderr,
            method: format!("normal-probe quadrature (theta_o {theta_o_deg}°)"),
            theta_o: theta_o_deg.to_radians(),
            first,
            probe: true,
            lmax_carried,
            samples: None,
            noise: None,
            notes,
        });
    }
    let sphere = observed.sphere;
    let views: Vec<OrthoView> =
        images.iter().zip(&ortho).map(|(image, camera)| OrthoView { image, camera: *camera }).collect();
    let mut fit = fit_orthographic(&views, &sphere, param, lmax).map_err(|e| in_first(e.into()))?;
    let method =
        format!("weighted least squares over {} orthographic view(s), {} parameterization", views.len(), param.name());
    let samples = ortho_samples(&views, &sphere, param).map_err(|e| in_first(e.into()))?;
    if let Some(n) = &noise {
        fit.stderr.iter_mut().flatten().for_each(|s| *s *= n.stderr_scale);
    }
    drop(views);
    let first = images.into_iter().next().unwrap_or_default();
    Ok(Projected {
        b: fit.coefficients,
        stderr: Some(fit.stderr),
        method,
        theta_o: 0.0,
        first,
        probe: false,
        lmax_carried: fit.lmax_carried,
        samples: Some(samples),
        noise,
        notes,
    })
}

/// A number of a text report with five significant digits, "—" when absent or not finite.
fn fmt_opt(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite()).map_or("—".to_string(), |x| format!("{x:.4e}"))
}

/// A standard error with the two digits it has.
fn fmt_se(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite()).map_or("—".to_string(), |x| format!("{x:.1e}"))
}
