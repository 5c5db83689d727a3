//! The analysis of `reflect analyze` ([`analyze`]): images of a sphere projected into SH (B_lm) and
//! compared with the lighting (L_lm) and, when the BRDF is known, with eq. 15. [`AnalyzeParams`],
//! the images and their [`Observation`] in, an [`AnalyzeReport`] out.
//!
//! Images:
//! - a `normal-probe` render: lat-long quadrature; exactly one such image per run;
//! - one or more orthographic images of a sphere: weighted least squares over the covered pixels.
//!   Images with only R, G, B work: normals come from the sphere.
//!
//! The direction B is a function of ([`AnalyzeParams::param`]) defaults from the observed BRDF:
//! `lambert` and `mix` → normal, reflective models → reflection; normal without a BRDF.
//!
//! Lighting: [`AnalyzeParams::lighting`] (a scene file's `[lighting]` table, an environment map,
//! or a lighting held in memory), else the observed one (sidecar scene, else the first image's
//! `reflect:lighting` header).
//!
//! An `lmax` above the highest order the input carries ([`crate::projection::resolution`]: a W × H
//! normal probe min(W/2, H) − 1; orthographic views D − 1 or D/2 − 1, D the sphere's diameter in
//! pixels) is refused; the report states that order (`lmax_carried`).
//!
//! Output ([`AnalyzeReport`]): B_lm ± standard error, L_lm, and the measured filter A_l =
//! albedo · Λ_l ρ̂_l fitted directly in pixel space for the known lighting,
//! B(d) = Σ_l A_l Σ_m L_lm Y_lm(d) over the used pixels ([`crate::filter::fit_filter_pixels`]):
//! right on one view, where dividing fitted B_lm by L_lm is not (one view sees one hemisphere of
//! normals). Its error bars are the propagated noise (the per-pixel σ; a χ²/ν well above 1 is said
//! in a warning, not folded in) and an estimated truncation bias (from a fit to l ≤ l_max + 2),
//! with the design's noise amplification per order; orders the visible directions cannot determine
//! are marked, a design they cannot solve at all is refused. With a known BRDF: its analytic
//! Λ_l ρ̂_l (eq. 38/43/33/50) scaled by the albedo, and eq. 15's B_lm, and the verdict
//! ([`crate::verdict`]) of whether the image contradicts what it was told.
//!
//! Orthographic views: noise correlated between neighbouring pixels by a reconstruction filter
//! ([`AnalyzeParams::pixel_filter`], else measured from the residuals) widens the noise part of
//! every error bar by √F ([`crate::observation::pixels::prepare`], `pixel_noise` in the report).

mod error;
mod report;

pub use error::Error;
pub use report::*;

use crate::filter::fit_filter_pixels;
use crate::image::Image;
use crate::noise::PixelFilter;
use crate::observation::pixels::prepare as pixel_noise_of;
use crate::observation::{BrdfValues, Camera, LightingInput, Observation, lighting_given};
use crate::projection::{
    Mapping, OrthoView, Param, fit_orthographic, ortho_samples, probe_samples, project_normal_probe,
};
use crate::sh::{lm, num_coefficients};
use crate::transfer::{TransferModel, parameterization};
use serde_json::Value;
use std::path::PathBuf;
use vocab::{BrdfKind, Horizon};

/// What an analysis is asked for (the CLI's flags as values).
#[derive(Clone, Debug, Default)]
pub struct AnalyzeParams {
    /// Highest SH order (at most [`crate::sh::MAX_LMAX`] and what the images carry).
    pub lmax: usize,
    /// The lighting to compare with; `None`: the observed one.
    pub lighting: Option<LightingInput>,
    /// The mapping of an environment-map file in `lighting` (default: from its aspect ratio).
    pub mapping: Option<Mapping>,
    /// The direction the radiance is a function of (default: from the BRDF).
    pub param: Option<Param>,
    /// The BRDF of the sphere where the observation does not say it (for the analytic column).
    pub brdf: BrdfValues,
    /// The reconstruction filter of the renderer that made orthographic views.
    pub pixel_filter: Option<PixelFilter>,
    /// When the image contradicts its description, name only the overall scale as an alternative
    /// (skip the refits over rotations, mirroring and the other mapping).
    pub no_diagnosis: bool,
}

impl AnalyzeParams {
    /// Checks the parameters before any image is read: an `lmax` above [`crate::sh::MAX_LMAX`].
    pub fn validate(&self) -> Result<(), Error> {
        if self.lmax > crate::sh::MAX_LMAX {
            return Err(Error::LmaxAbove { lmax: self.lmax });
        }
        Ok(())
    }
}

/// The BRDF of the analysed sphere: transfer model, RGB scale, kind, horizon, table (as the
/// header, scene or explicit values gave it, for the report).
struct Brdf {
    model: Option<TransferModel>,
    scale: [f64; 3],
    kind: BrdfKind,
    horizon: Horizon,
    table: Value,
}

/// Analyses `images` (named `paths` in messages and the report; their radiance layer chosen, each
/// as [`crate::observation::observe`] left it) described by `observed` (see the module docs):
/// the report, or an error naming the file and the problem (bad input, or views that cannot
/// determine what was asked). The notes of the pixel-noise decision are in
/// [`AnalyzeReport::notes`].
pub fn analyze(
    params: &AnalyzeParams,
    mut images: Vec<Image>,
    paths: &[PathBuf],
    observed: &Observation,
) -> Result<AnalyzeReport, Error> {
    params.validate()?;
    let lmax = params.lmax;
    let cameras = &observed.cameras;
    let mut warnings = observed.stderr_notes.clone();
    warnings.extend(observed.warnings.iter().cloned());
    if observed.object_count > 1 {
        warnings.push(format!("the scene has {} objects; analysing the first sphere", observed.object_count));
    }
    // A stderr layer without an error estimate (+inf where a pixel has fewer than two samples, as a
    // 1-spp render writes; or 0 everywhere, as older files and other renderers may write) carries no
    // error bar: the projections take σ from the residuals instead (crate::projection::stderr_estimate).
    for (path, image) in paths.iter().zip(&images) {
        let unknown = ["stderr.R", "stderr.G", "stderr.B"]
            .iter()
            .any(|c| image.channel(c).is_some_and(|v| v.iter().any(|x| x.is_infinite())));
        let zero = image.stderr_layer().is_ok_and(|s| s.is_some())
            && crate::projection::stderr_estimate(image).is_ok_and(|s| s.is_none());
        if unknown || zero {
            warnings.push(format!(
                "{}: the stderr layer holds no error estimate ({}; one sample per pixel, e.g. a 1-spp render, has no \
                 spread to estimate an error from): σ is estimated from the residuals of the fits instead",
                path.display(),
                if unknown { "+inf: fewer than 2 samples" } else { "0 at every pixel" }
            ));
        }
    }
    let first = &paths[0];
    let brdf = observed.transfer(&params.brdf, 0.0).map_err(|e| e.in_file(first))?.map(|r| Brdf {
        model: r.transfer.map(|t| t.model),
        scale: r.transfer.map_or([1.0; 3], |t| t.scale),
        kind: r.kind,
        horizon: r.transfer.map_or(Horizon::Clamp, |t| t.horizon),
        table: r.table,
    });
    let sphere = observed.sphere;
    let param = match params.param {
        Some(p) => p,
        None => brdf.as_ref().map_or(Param::Normal, |b| parameterization(b.kind)),
    };
    let in_first = |e: Error| if paths.len() == 1 { e.in_file(first) } else { e };

    let n_probe = cameras.iter().filter(|c| matches!(c, Camera::NormalProbe { .. })).count();
    let mut brdf = brdf;
    let (pixel_noise_report, notes) = pixel_noise_of(&mut images, cameras, &sphere, param, lmax, params.pixel_filter)
        .map_err(|e| in_first(e.into()))?;
    let (b, b_se, method, pixels, se_source, rms, carried, samples) = if n_probe > 0 {
        if images.len() != 1 {
            return Err(Error::ProbeNotAlone { what: "analysed" });
        }
        let Camera::NormalProbe { theta_o_deg, phi_o_deg } = cameras[0] else { unreachable!() };
        let theta_o_deg =
            Camera::probe_theta_o_deg(theta_o_deg, phi_o_deg, "analysed").map_err(|e| e.in_file(first))?;
        // Torrance–Sparrow and microfacet seen at θ_o: the q = 0 coefficient at that exitance angle.
        // (θ_o passed the one exitance check when the header was read; validated again as a model.)
        if let Some(Brdf { model: Some(m), .. }) = brdf.as_mut()
            && m.depends_on_exitance()
        {
            *m = m.at_exitance(theta_o_deg.to_radians());
            m.validate().map_err(|e| e.in_file(first))?;
        }
        let (c, se) = project_normal_probe(&images[0], lmax).map_err(|e| e.in_file(first))?;
        let src = if se.is_some() { "stderr-layer" } else { "none" };
        let samples = probe_samples(&images[0]).map_err(|e| e.in_file(first))?;
        (
            c,
            se,
            format!("normal-probe quadrature (theta_o {theta_o_deg}°)"),
            images[0].width * images[0].height,
            src,
            None,
            crate::projection::latlong_max_order(images[0].width, images[0].height).unwrap_or(0),
            samples,
        )
    } else {
        let views: Vec<OrthoView> = images
            .iter()
            .zip(cameras)
            .map(|(image, c)| match c {
                Camera::Ortho(camera) => OrthoView { image, camera: *camera },
                Camera::NormalProbe { .. } => unreachable!(),
            })
            .collect();
        let mut fit = fit_orthographic(&views, &sphere, param, lmax).map_err(|e| in_first(e.into()))?;
        if views.len() == 1 && param == Param::Normal {
            warnings.push(
                "one orthographic view sees one hemisphere of normals: the B_lm fit there is not a projection, energy of \
                 B above l_max aliases into it (the filter A_l is fitted in pixel space and does not divide B_lm; add \
                 the opposite view or render a normal-probe for B_lm)"
                    .to_string(),
            );
        }
        let samples = ortho_samples(&views, &sphere, param).map_err(|e| in_first(e.into()))?;
        if let Some(noise) = &pixel_noise_report {
            fit.stderr.iter_mut().flatten().for_each(|s| *s *= noise.stderr_scale);
            warnings.extend(noise.warning());
        }
        (
            fit.coefficients,
            Some(fit.stderr),
            format!(
                "weighted least squares over {} orthographic view(s), {} parameterization",
                images.len(),
                param.name()
            ),
            fit.pixels_used,
            fit.stderr_source,
            Some(fit.rms_residual),
            fit.lmax_carried,
            samples,
        )
    };

    let lighting = lighting_given(params.lighting.as_ref(), params.mapping, observed)
        .map_err(|e| if params.lighting.is_none() { e.in_file(first) } else { e })?;
    // Two orders beyond l_max estimate the truncation bias of the filter fit.
    let l_hi = match &lighting {
        Some((l, _)) => Some(l.coefficients(l_hi_order(lmax))?),
        None => None,
    };
    let l_coeffs: Option<Vec<[f64; 3]>> = l_hi.as_ref().map(|l| l[..num_coefficients(lmax)].to_vec());
    let inflation = pixel_noise_report.as_ref().map_or(1.0, |n| n.inflation);
    let filter = match &l_hi {
        Some(l) => {
            let (samples, have_sigma) = &samples;
            Some(fit_filter_pixels(samples, *have_sigma, inflation, l, lmax).map_err(|e| in_first(e.into()))?)
        }
        None => None,
    };
    if let Some((l, _)) = &lighting
        && let Some(note) = l.mapping_note()
    {
        warnings.push(note);
    }
    // SH coefficients are the whole lighting (orders not given are 0): coefficients of a map cut at
    // l_max describe a smoother lighting than the image was rendered under, and the verdict, which
    // reads the lighting to l_max + 2, would call the difference a contradiction without this.
    if let Some((crate::lighting::Lighting::Sh { coefficients }, _)) = &lighting
        && coefficients.len() < num_coefficients(l_hi_order(lmax))
    {
        let given = crate::sh::reconstruct::lmax_of(coefficients.len())
            .map_or_else(|| format!("{} coefficients", coefficients.len()), |l| format!("coefficients to l = {l}"));
        // The order is named, not "a few more than the highest order asked": at a small l_max the fit
        // reads to l = 16 (`l_hi_order`). No parameter is named, so the report's text is the same in
        // every front-end (Python's `to_dict()` is the CLI's `--json`).
        let read = l_hi_order(lmax);
        warnings.push(format!(
            "the lighting is SH {given}, orders above taken as 0; the fit and verdict read it to l = {read} (for \
             l_max {lmax}): if the lighting has energy there (coefficients projected from a map), the image will \
             contradict it — give coefficients to at least l = {read}, or the map"
        ));
    }
    let analytic: Option<Vec<[f64; 3]>> = brdf.as_ref().and_then(|br| {
        br.model.map(|m| {
            m.lambda_rho(lmax).into_iter().map(|f| [f * br.scale[0], f * br.scale[1], f * br.scale[2]]).collect()
        })
    });
    let predicted = match (&l_coeffs, &brdf) {
        (Some(l), Some(Brdf { model: Some(m), scale, .. })) => {
            Some(crate::predict::predict(l, &m.lambda_rho(lmax), *scale))
        }
        _ => None,
    };
    if let Some(br) = &brdf {
        let horizon = br.horizon;
        if matches!(br.kind, BrdfKind::Phong | BrdfKind::TorranceSparrow) && horizon != Horizon::Ignore {
            warnings.push(format!(
                "horizon = \"{horizon}\": the analytic Λ_l ρ̂_l (eq. 43/50) ignores the horizon, so expect differences"
            ));
        }
    }
    let verdict = match (&filter, &analytic, &l_hi, &lighting) {
        (Some(f), Some(an), Some(l), Some((lighting, _))) => {
            let other_lightings = lighting
                .other_mappings()
                .into_iter()
                .filter_map(|(name, alt)| Some((name, alt.coefficients(l_hi_order(lmax)).ok()?)))
                .collect();
            let refit = crate::verdict::Refit {
                samples: &samples.0,
                have_sigma: samples.1,
                inflation,
                light: l,
                lmax,
                other_lightings,
            };
            Some(crate::verdict::verdict(
                &f.orders,
                &f.channels,
                an,
                crate::verdict::DEFAULT_ALPHA,
                samples.1,
                (!params.no_diagnosis).then_some(&refit),
            )?)
        }
        _ => None,
    };
    let (filter, filter_fit) = match filter {
        Some(f) => {
            warnings.extend(zero_orders(f.warnings, analytic.as_deref()));
            (Some(f.orders), Some(f.channels))
        }
        None => (None, None),
    };
    Ok(AnalyzeReport {
        lmax,
        lmax_carried: carried,
        images: paths.iter().map(|p| p.display().to_string()).collect(),
        method,
        param: if n_probe > 0 { "normal".into() } else { param.name().into() },
        sphere: SphereReport { center: sphere.center, radius: sphere.radius },
        pixels_used: pixels,
        stderr_source: se_source.into(),
        rms_residual: rms,
        lm: (0..b.len()).map(lm).collect(),
        coefficients: b,
        stderr: b_se,
        lighting: lighting.map(|(_, source)| LightingReport { source, coefficients: l_coeffs.unwrap_or_default() }),
        filter,
        filter_fit,
        brdf: brdf.map(|b| b.table),
        lambda_rho_analytic: analytic,
        predicted,
        pixel_noise: pixel_noise_report,
        verdict,
        warnings,
        notes,
    })
}

/// The lighting order the filter fit is given: two orders beyond l_max estimate its truncation bias.
fn l_hi_order(lmax: usize) -> usize {
    crate::inverse::views::truncation_lmax(lmax)
}

/// The filter fit's warnings, where an order the fit "cannot determine" is one the BRDF makes
/// exactly zero (Lambert's odd orders above 1, eq. 38) said as such instead.
fn zero_orders(warnings: Vec<String>, analytic: Option<&[[f64; 3]]>) -> Vec<String> {
    let Some(an) = analytic else { return warnings };
    let zero: Vec<usize> = (0..an.len()).filter(|&l| an[l].iter().all(|v| *v == 0.0)).collect();
    if zero.is_empty() {
        return warnings;
    }
    let mut out: Vec<String> = warnings.into_iter().filter(|w| !crate::filter::is_order_note(w, &zero)).collect();
    let list: Vec<String> = zero.iter().map(|l| l.to_string()).collect();
    out.push(format!(
        "the BRDF makes A_l exactly 0 at l = {} (eq. 38 for Lambert's odd orders above 1): those orders are known, \
         not measured; the fit's value there only shows noise and truncation",
        list.join(", ")
    ));
    out
}
