//! `reflect analyze IMAGE.exr… [--lighting SCENE_OR_ENV] --lmax L [--json]`: project renders into
//! SH (B_lm) and compare them with the lighting (L_lm) and, when the BRDF is known, with eq. 15.
//!
//! Images:
//! - a `normal-probe` render (header `reflect:camera` type `normal-probe`): lat-long quadrature;
//!   exactly one such image per run;
//! - one or more orthographic images of a sphere: weighted least squares over the covered pixels.
//!   The camera comes from the `reflect:camera` header, else from `--from/--to/--up/--extent`;
//!   the sphere from the first sphere of `reflect:objects`, else `--center/--radius`
//!   (default (0, 0, 0), 1). Files with only R, G, B work: normals come from the sphere.
//!
//! The direction B is a function of (`--param normal|reflection`) defaults from the BRDF in the
//! header: `lambert` and `mix` → normal, reflective models → reflection; normal without a BRDF.
//!
//! Lighting: `--lighting scene.toml` (only its `[lighting]` table is read), or an environment map
//! (`--mapping latlong|angular`, default inferred from the aspect ratio: W = H angular, W = 2H
//! lat-long); without `--lighting`, the `reflect:lighting` header of the first image.
//!
//! `--lmax` above the highest order the input carries (`analysis::projection::resolution`: a W × H
//! normal probe min(W/2, H) − 1; orthographic views D − 1 or D/2 − 1, D the sphere's diameter in
//! pixels) is refused; the output states that order (`lmax_carried`).
//!
//! Output ([`AnalyzeReport`]): B_lm ± standard error, L_lm, and the measured filter A_l =
//! albedo · Λ_l ρ̂_l fitted directly in pixel space for the known lighting,
//! B(d) = Σ_l A_l Σ_m L_lm Y_lm(d) over the used pixels (`analysis::filter::fit_filter_pixels`,
//! the function `verify` checks): right on one view, where dividing fitted B_lm by L_lm is not
//! (one view sees one hemisphere of normals). Its error bars are the propagated noise (the
//! per-pixel σ; a χ²/ν well above 1 is said in a warning, not folded in) and an estimated truncation bias (from a fit to
//! l ≤ l_max + 2), with the design's noise amplification per order; orders the visible directions
//! cannot determine are marked, a design they cannot solve at all is refused (exit 2). With a
//! known BRDF: its analytic Λ_l ρ̂_l (eq. 38/43/33/50) scaled by the albedo, and eq. 15's B_lm.
//!
//! Orthographic views: noise correlated between neighbouring pixels by a reconstruction filter
//! (`--pixel-filter`, else measured from the residuals) widens the noise part of every error bar by
//! √F (`analysis::observation::pixels::prepare`, `pixel_noise` in the report); a camera not from the image's own
//! header is checked against the sphere's silhouette when the image is read (`super::header::load`).
use super::Error;
use super::args::{BrdfFlags, ParamArg, ViewArgs};
use super::header::load;
use super::sh::check_lmax;
use analysis::filter::{ChannelFit, OrderStatus, PixelOrder, fit_filter_pixels};
use analysis::observation::pixels::{PixelNoise, prepare as pixel_noise_of};
use analysis::observation::{Camera, lighting_of};
use analysis::projection::{OrthoView, Param, fit_orthographic, ortho_samples, probe_samples, project_normal_probe};
use analysis::sh::{lm, num_coefficients};
use analysis::transfer::{TransferModel, parameterization};
use serde_json::Value;
use std::path::PathBuf;
use std::process::ExitCode;
use vocab::{BrdfKind, Horizon, Mapping};

#[derive(clap::Args, Debug)]
pub struct AnalyzeArgs {
    /// Rendered images (OpenEXR): one normal-probe image, or one or more orthographic views.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Scene file (.toml, its `[lighting]` table) or environment map giving the lighting.
    #[arg(long)]
    pub lighting: Option<PathBuf>,
    /// Mapping of an environment map given with --lighting (default: inferred from aspect ratio).
    #[arg(long, value_enum)]
    pub mapping: Option<Mapping>,
    /// Highest SH order.
    #[arg(long, value_parser = super::flags::parse_lmax, allow_hyphen_values = true)]
    pub lmax: usize,
    /// The direction the radiance is a function of (default: from the BRDF).
    #[arg(long, value_enum)]
    pub param: Option<ParamArg>,
    /// The camera and sphere of images whose header does not say them.
    #[command(flatten)]
    pub view: ViewArgs,
    /// The BRDF of the sphere when the header and --scene do not say it (for the analytic column).
    #[command(flatten)]
    pub brdf: BrdfFlags,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
    /// When the image contradicts its description, name only the overall scale as an alternative:
    /// skip the search over rotations, mirroring and the other mapping (each a full refit; minutes
    /// on a 512² image). The verdict and its χ² are unchanged.
    #[arg(long)]
    pub no_diagnosis: bool,
}

/// The BRDF of the analysed sphere: transfer model, RGB scale, kind, horizon, table (as the
/// header, scene or flags gave it, for the report).
struct Brdf {
    model: Option<TransferModel>,
    scale: [f64; 3],
    kind: BrdfKind,
    horizon: Horizon,
    table: Value,
}

/// The sphere analysed (world space).
#[derive(Clone, Debug, serde::Serialize)]
pub struct SphereReport {
    pub center: [f64; 3],
    pub radius: f64,
}

/// The lighting compared with: where it came from and its L_lm (RGB, index order, l ≤ lmax).
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightingReport {
    pub source: String,
    pub coefficients: Vec<[f64; 3]>,
}

/// Everything `reflect analyze` computes; `--json` prints this struct, the text output is its
/// [`Display`](std::fmt::Display). Coefficient lists are in index order k = l(l + 1) + m, labelled
/// by `lm`; every RGB channel is carried.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AnalyzeReport {
    pub lmax: usize,
    /// The highest order the input carries (`analysis::projection::resolution`).
    pub lmax_carried: usize,
    pub images: Vec<String>,
    pub method: String,
    /// `normal` or `reflection`: the direction B is a function of.
    pub param: String,
    pub sphere: SphereReport,
    pub pixels_used: usize,
    /// `stderr-layer`, `residuals` or `none`.
    pub stderr_source: String,
    /// Weighted RMS residual of the B_lm fit per channel (orthographic views).
    pub rms_residual: Option<[f64; 3]>,
    /// (l, m) of each entry of `coefficients`, `stderr`, `lighting.coefficients`, `predicted`.
    pub lm: Vec<(usize, i64)>,
    /// B_lm.
    pub coefficients: Vec<[f64; 3]>,
    pub stderr: Option<Vec<[f64; 3]>>,
    pub lighting: Option<LightingReport>,
    /// The measured filter A_l = albedo · Λ_l ρ̂_l per order, fitted in pixel space for the known
    /// lighting (`analysis::filter::fit_filter_pixels`), with its error budget and conditioning.
    pub filter: Option<Vec<PixelOrder>>,
    /// χ², ν, χ²/ν, p-value, error scale and covariance of the filter fit, per channel R, G, B.
    pub filter_fit: Option<Vec<ChannelFit>>,
    /// The BRDF table of the header (`reflect:objects`), as written there.
    pub brdf: Option<Value>,
    /// Analytic Λ_l ρ̂_l (eq. 38/43/33/50) scaled by the header's albedo / k_s / k_r, per l.
    pub lambda_rho_analytic: Option<Vec<[f64; 3]>>,
    /// B_lm predicted by eq. 15 from the lighting and the analytic filter.
    pub predicted: Option<Vec<[f64; 3]>>,
    /// Orthographic views: the correlation of neighbouring pixels' noise (a reconstruction filter
    /// wider than a pixel) and the variance inflation applied to every error bar's noise part.
    pub pixel_noise: Option<PixelNoise>,
    /// Whether the image contradicts what it was told (lighting, BRDF, camera): the measured
    /// filter against the analytic one, χ² with ν and p, and the most likely wrong assumption
    /// (`analysis::verdict`); `None` without a lighting or without a BRDF with a transfer model.
    pub verdict: Option<analysis::verdict::Verdict>,
    /// Notes and warnings, each one sentence (printed on stderr, not in the text report).
    pub warnings: Vec<String>,
}

/// Analyses the images of `a` (see the module docs): the report, or an error naming the file and
/// the problem (bad input, or views that cannot determine what was asked).
pub fn analyze(a: &AnalyzeArgs) -> Result<AnalyzeReport, Error> {
    check_lmax(a.lmax)?;
    let (mut images, described) = load(&a.images, &a.view, "analysed")?;
    let cameras = &described.cameras;
    let mut warnings = described.stderr_notes.clone();
    warnings.extend(described.warnings.iter().cloned());
    if described.object_count > 1 {
        warnings.push(format!("the scene has {} objects; analysing the first sphere", described.object_count));
    }
    // A stderr layer without an error estimate (+inf where a pixel has fewer than two samples, as a
    // 1-spp render writes; or 0 everywhere, as older files and other renderers may write) carries no
    // error bar: the projections take σ from the residuals instead (analysis::projection::stderr_estimate).
    for (path, image) in a.images.iter().zip(&images) {
        let unknown = ["stderr.R", "stderr.G", "stderr.B"]
            .iter()
            .any(|c| image.channel(c).is_some_and(|v| v.iter().any(|x| x.is_infinite())));
        let zero = image.stderr_layer().is_ok_and(|s| s.is_some())
            && analysis::projection::stderr_estimate(image).is_ok_and(|s| s.is_none());
        if unknown || zero {
            warnings.push(format!(
                "{}: the stderr layer holds no error estimate ({}; one sample per pixel, e.g. a 1-spp render, has no \
                 spread to estimate an error from): σ is estimated from the residuals of the fits instead",
                path.display(),
                if unknown { "+inf: fewer than 2 samples" } else { "0 at every pixel" }
            ));
        }
    }
    let brdf_at = |theta_o: f64| -> Result<Option<Brdf>, Error> {
        Ok(described.transfer(&a.brdf.values(), theta_o).map_err(|e| e.in_file(&a.images[0]))?.map(|r| Brdf {
            model: r.transfer.map(|t| t.model),
            scale: r.transfer.map_or([1.0; 3], |t| t.scale),
            kind: r.kind,
            horizon: r.transfer.map_or(Horizon::Clamp, |t| t.horizon),
            table: r.table,
        }))
    };
    let brdf = brdf_at(0.0)?;
    let sphere = described.sphere;
    let param = match a.param {
        Some(p) => Param::from(p),
        None => brdf.as_ref().map_or(Param::Normal, |b| parameterization(b.kind)),
    };
    let in_first = |e: Error| if a.images.len() == 1 { e.in_file(&a.images[0]) } else { e };

    let n_probe = cameras.iter().filter(|c| matches!(c, Camera::NormalProbe { .. })).count();
    let mut brdf = brdf;
    let (pixel_noise_report, notes) = pixel_noise_of(&mut images, cameras, &sphere, param, a.lmax, a.view.pixel_filter)
        .map_err(|e| in_first(e.into()))?;
    notes.iter().for_each(|n| eprintln!("{n}"));
    let (b, b_se, method, pixels, se_source, rms, carried, samples) = if n_probe > 0 {
        if images.len() != 1 {
            return Err(Error::new("a normal-probe render must be analysed on its own (one image)"));
        }
        let Camera::NormalProbe { theta_o_deg, phi_o_deg } = cameras[0] else { unreachable!() };
        let theta_o_deg =
            Camera::probe_theta_o_deg(theta_o_deg, phi_o_deg, "analysed").map_err(|e| e.in_file(&a.images[0]))?;
        // Torrance–Sparrow and microfacet seen at θ_o: the q = 0 coefficient at that exitance angle.
        // (θ_o passed the one exitance check when the header was read; validated again as a model.)
        if let Some(Brdf { model: Some(m), .. }) = brdf.as_mut()
            && m.depends_on_exitance()
        {
            *m = m.at_exitance(theta_o_deg.to_radians());
            m.validate().map_err(|e| e.in_file(&a.images[0]))?;
        }
        let (c, se) = project_normal_probe(&images[0], a.lmax).map_err(|e| e.in_file(&a.images[0]))?;
        let src = if se.is_some() { "stderr-layer" } else { "none" };
        let samples = probe_samples(&images[0]).map_err(|e| e.in_file(&a.images[0]))?;
        (
            c,
            se,
            format!("normal-probe quadrature (theta_o {theta_o_deg}°)"),
            images[0].width * images[0].height,
            src,
            None,
            analysis::projection::latlong_max_order(images[0].width, images[0].height).unwrap_or(0),
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
        let mut fit = fit_orthographic(&views, &sphere, param, a.lmax).map_err(in_first)?;
        if views.len() == 1 && param == Param::Normal {
            warnings.push(
                "one orthographic view sees one hemisphere of normals: the B_lm fit there is not a projection, energy of \
                 B above l_max aliases into it (the filter A_l is fitted in pixel space and does not divide B_lm; add \
                 the opposite view or render a normal-probe for B_lm)"
                    .to_string(),
            );
        }
        let samples = ortho_samples(&views, &sphere, param).map_err(in_first)?;
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

    let lighting = lighting_of(a.lighting.as_deref(), a.mapping, &described)
        .map_err(|e| if a.lighting.is_none() { e.in_file(&a.images[0]) } else { e })?;
    // Two orders beyond l_max estimate the truncation bias of the filter fit.
    let l_hi = match &lighting {
        Some((l, _)) => Some(l.coefficients(l_hi_order(a.lmax))?),
        None => None,
    };
    let l_coeffs: Option<Vec<[f64; 3]>> = l_hi.as_ref().map(|l| l[..num_coefficients(a.lmax)].to_vec());
    let inflation = pixel_noise_report.as_ref().map_or(1.0, |n| n.inflation);
    let filter = match &l_hi {
        Some(l) => {
            let (samples, have_sigma) = &samples;
            Some(fit_filter_pixels(samples, *have_sigma, inflation, l, a.lmax).map_err(in_first)?)
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
    if let Some((analysis::lighting::Lighting::Sh { coefficients }, _)) = &lighting
        && coefficients.len() < num_coefficients(l_hi_order(a.lmax))
    {
        let given = analysis::sh::reconstruct::lmax_of(coefficients.len())
            .map_or_else(|| format!("{} coefficients", coefficients.len()), |l| format!("coefficients to l = {l}"));
        warnings.push(format!(
            "the lighting is SH {given}, orders above taken as 0; the fit and verdict read it to l = {}: if the \
             lighting has energy there (coefficients projected from a map), the image will contradict it — give \
             coefficients to a few orders more than --lmax, or the map",
            l_hi_order(a.lmax)
        ));
    }
    let analytic: Option<Vec<[f64; 3]>> = brdf.as_ref().and_then(|br| {
        br.model.map(|m| {
            m.lambda_rho(a.lmax).into_iter().map(|f| [f * br.scale[0], f * br.scale[1], f * br.scale[2]]).collect()
        })
    });
    let predicted = match (&l_coeffs, &brdf) {
        (Some(l), Some(Brdf { model: Some(m), scale, .. })) => {
            Some(analysis::predict::predict(l, &m.lambda_rho(a.lmax), *scale))
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
                .filter_map(|(name, alt)| Some((name, alt.coefficients(l_hi_order(a.lmax)).ok()?)))
                .collect();
            let refit = analysis::verdict::Refit {
                samples: &samples.0,
                have_sigma: samples.1,
                inflation,
                light: l,
                lmax: a.lmax,
                other_lightings,
            };
            Some(analysis::verdict::verdict(
                &f.orders,
                &f.channels,
                an,
                analysis::verdict::DEFAULT_ALPHA,
                samples.1,
                (!a.no_diagnosis).then_some(&refit),
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
        lmax: a.lmax,
        lmax_carried: carried,
        images: a.images.iter().map(|p| p.display().to_string()).collect(),
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
    })
}

/// The lighting order the filter fit is given: two orders beyond l_max estimate its truncation bias.
fn l_hi_order(lmax: usize) -> usize {
    analysis::inverse::views::truncation_lmax(lmax)
}

/// The filter fit's warnings, where an order the fit "cannot determine" is one the BRDF makes
/// exactly zero (Lambert's odd orders above 1, eq. 38) said as such instead.
fn zero_orders(warnings: Vec<String>, analytic: Option<&[[f64; 3]]>) -> Vec<String> {
    let Some(an) = analytic else { return warnings };
    let zero: Vec<usize> = (0..an.len()).filter(|&l| an[l].iter().all(|v| *v == 0.0)).collect();
    if zero.is_empty() {
        return warnings;
    }
    let mut out: Vec<String> = warnings.into_iter().filter(|w| !analysis::filter::is_order_note(w, &zero)).collect();
    let list: Vec<String> = zero.iter().map(|l| l.to_string()).collect();
    out.push(format!(
        "the BRDF makes A_l exactly 0 at l = {} (eq. 38 for Lambert's odd orders above 1): those orders are known, \
         not measured; the fit's value there only shows noise and truncation",
        list.join(", ")
    ));
    out
}

impl std::fmt::Display for AnalyzeReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "# {} — {}", self.images.join(", "), self.method)?;
        writeln!(
            f,
            "# pixels used {}, standard errors from {}; the input carries l <= {}",
            self.pixels_used, self.stderr_source, self.lmax_carried
        )?;
        if let Some(r) = self.rms_residual {
            writeln!(f, "# weighted RMS residual of the fit: {:.3e} {:.3e} {:.3e}", r[0], r[1], r[2])?;
        }
        if let Some(n) = &self.pixel_noise {
            writeln!(f, "{}", n.line())?;
        }
        if let Some(l) = &self.lighting {
            writeln!(f, "# lighting: {}", l.source)?;
        }
        if let Some(b) = &self.brdf {
            writeln!(f, "# brdf: {}", super::shown_json(b))?;
        }
        writeln!(f, "{:>4} {:>4} {:>26} {:>26} {:>26}", "l", "m", "B_lm R ± se", "G ± se", "B ± se")?;
        for (k, v) in self.coefficients.iter().enumerate() {
            let (l, m) = self.lm[k];
            let se = self.stderr.as_ref().map(|s| s[k]);
            let cell = |ch: usize| match se {
                Some(s) => format!("{:.5e} ± {:.1e}", v[ch], s[ch]),
                None => format!("{:.5e}", v[ch]),
            };
            writeln!(f, "{l:>4} {m:>4} {:>26} {:>26} {:>26}", cell(0), cell(1), cell(2))?;
        }
        if let (Some(orders), Some(fits)) = (&self.filter, &self.filter_fit) {
            writeln!(
                f,
                "\n# measured filter A_l = albedo · Λ_l ρ̂_l, fitted in pixel space: B(d) = Σ_l A_l Σ_m L_lm Y_lm(d) \
                 over the used pixels; ± total (noise ⊕ truncation)"
            )?;
            writeln!(
                f,
                "{:>4} {:>26} {:>26} {:>26} {:>14}",
                "l",
                "R ± se",
                "G ± se",
                "B ± se",
                if self.lambda_rho_analytic.is_some() { "analytic (R)" } else { "" }
            )?;
            for o in orders {
                let cell = |ch: usize| match (o.estimate[ch], o.stderr[ch]) {
                    (Some(e), Some(s)) => {
                        // Ill-conditioned or undetermined (truncation): the warnings say which.
                        let flag = if matches!(o.status[ch], OrderStatus::IllConditioned | OrderStatus::Undetermined) {
                            " !"
                        } else {
                            ""
                        };
                        format!("{e:.5e} ± {s:.1e}{flag}")
                    }
                    (Some(e), None) => format!("{e:.5e}"),
                    _ => "unobservable".to_string(),
                };
                let an = self.lambda_rho_analytic.as_ref().map(|a| format!("{:.5e}", a[o.l][0])).unwrap_or_default();
                writeln!(f, "{:>4} {:>26} {:>26} {:>26} {:>14}", o.l, cell(0), cell(1), cell(2), an)?;
            }
            writeln!(f, "# error budget (R): noise, truncation, amplification of the design")?;
            for o in orders {
                let g = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.1e}"));
                writeln!(
                    f,
                    "{:>4} {:>10} {:>10} {:>8}",
                    o.l,
                    g(o.stderr_noise[0]),
                    g(o.truncation[0]),
                    o.amplification[0].map_or("-".to_string(), |v| format!("{v:.2}"))
                )?;
            }
            let chi = |c: &ChannelFit| match (c.chi2_per_dof, c.p_value) {
                (Some(x), Some(p)) => {
                    format!(
                        "{x:.3} (ν {}, p {p:.1e}, robust {:.3}, misfit {:.1} %)",
                        c.dof,
                        c.robust_chi2_per_dof.unwrap_or(f64::NAN),
                        100.0 * c.relative_misfit
                    )
                }
                (Some(x), None) => format!("{x:.3e} (ν {})", c.dof),
                _ => "-".to_string(),
            };
            if fits.iter().all(|c| c.p_value.is_none()) {
                // Without per-pixel standard errors Σ r²/ν is not a χ² (there is no σ to divide by):
                // it is the residual variance the noise is estimated from.
                writeln!(
                    f,
                    "# filter fit residual variance σ̂² = Σ_p r_p²/ν (no stderr layer: the noise estimate, not a χ² test): \
                     R {}, G {}, B {}",
                    chi(&fits[0]),
                    chi(&fits[1]),
                    chi(&fits[2])
                )?;
            } else {
                writeln!(
                    f,
                    "# filter fit χ²/ν at l <= {} (the orders above it are signal this fit leaves in the residual, so \
                     it exceeds 1 by the truncation; not the verdict's test): R {}, G {}, B {}",
                    self.lmax,
                    chi(&fits[0]),
                    chi(&fits[1]),
                    chi(&fits[2])
                )?;
            }
            if let Some(top) = fits.iter().filter_map(|c| c.truncation_lmax).max() {
                let x = |c: &ChannelFit| c.truncation_chi2_per_dof.map_or("-".to_string(), |x| format!("{x:.3}"));
                let what = if fits.iter().all(|c| c.p_value.is_none()) {
                    "residual variance (the noise σ̂² of the error bars)"
                } else {
                    "χ²/ν (truncation_chi2_per_dof: above 2 is scatter beyond the σ, said in a warning)"
                };
                writeln!(
                    f,
                    "# with the orders up to l = {top}, {what}: R {}, G {}, B {}",
                    x(&fits[0]),
                    x(&fits[1]),
                    x(&fits[2])
                )?;
            }
        }
        if let Some(v) = &self.verdict {
            writeln!(f, "# {}", v.line)?;
        }
        Ok(())
    }
}

/// `reflect analyze`: the report as JSON (`--json`) or text on stdout; warnings on stderr, one
/// `warning: …` line each (and in the JSON's `warnings`).
pub fn run(a: AnalyzeArgs) -> Result<ExitCode, Error> {
    let report = analyze(&a)?;
    super::print_warnings(&report.warnings);
    if a.json {
        println!("{}", serde_json::to_string(&report).map_err(|e| Error::new(format!("JSON output: {e}")))?);
    } else {
        print!("{report}");
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::image::{Image, write_exr};
    use analysis::sh::{Reconstructor, latlong_direction};
    use serde_json::json;

    fn args(images: Vec<PathBuf>, lmax: usize) -> AnalyzeArgs {
        AnalyzeArgs {
            images,
            lighting: None,
            mapping: None,
            lmax,
            param: None,
            view: ViewArgs::default(),
            brdf: BrdfFlags::default(),
            json: true,
            no_diagnosis: false,
        }
    }

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("reflect-cli-analyze-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d.join(name)
    }

    #[test]
    fn normal_probe_render_is_analysed_and_bad_inputs_are_errors() {
        // A Lambertian normal-probe image under SH lighting, exactly B = Λ_l ρ̂_l L_lm.
        let l: Vec<[f64; 3]> = (0..9).map(|k| if k == 0 { [2.0, 2.0, 2.0] } else { [0.2, -0.1, 0.05] }).collect();
        let b = analysis::predict::predict(&l, &analysis::transfer::lambert::lambert(2), [0.5, 0.5, 0.5]);
        let (w, h) = (64, 32);
        let mut rec = Reconstructor::new(2);
        let mut img = Image { width: w, height: h, ..Default::default() };
        let px: Vec<[f64; 3]> = (0..w * h).map(|i| rec.eval(&b, latlong_direction(i / w, i % w, w, h))).collect();
        for (ch, n) in ["R", "G", "B"].iter().enumerate() {
            img.channels.insert(n.to_string(), px.iter().map(|p| p[ch] as f32).collect());
        }
        img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
        img.attributes.insert("reflect:lighting".into(), json!({"type": "sh", "coefficients": l}).to_string());
        img.attributes.insert(
            "reflect:objects".into(),
            r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"lambert","albedo":[0.5,0.5,0.5]}}]"#
                .into(),
        );
        let good = tmp("probe.exr");
        write_exr(&good, &img).unwrap();
        assert!(run(args(vec![good.clone()], 2)).is_ok());

        // Perspective renders cannot be analysed: an error naming the file.
        img.attributes.insert(
            "reflect:camera".into(),
            r#"{"type":"perspective","from":[0,0,3],"to":[0,0,0],"fov_deg":40}"#.into(),
        );
        let persp = tmp("persp.exr");
        write_exr(&persp, &img).unwrap();
        let e = run(args(vec![persp], 2)).unwrap_err().to_string();
        assert!(e.contains("persp.exr") && e.contains("perspective"), "{e}");

        // No camera in the header and none on the command line.
        img.attributes.remove("reflect:camera");
        let nocam = tmp("nocam.exr");
        write_exr(&nocam, &img).unwrap();
        let e = run(args(vec![nocam], 2)).unwrap_err().to_string();
        assert!(e.contains("nocam.exr") && e.contains("--from"), "{e}");

        // Absurd l_max, missing file (a bad --param is refused by clap: tests/cli_errors.rs).
        assert!(run(args(vec![good.clone()], 100_000)).is_err());
        assert!(run(args(vec![tmp("missing.exr")], 2)).unwrap_err().to_string().contains("missing.exr"));
    }
}
