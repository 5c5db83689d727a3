//! The inverse BRDF of `reflect invert brdf` ([`brdf()`]): Λ_l ρ̂_l per order (eq. 16) and the
//! fitted Phong s, Torrance–Sparrow σ or microfacet α ([`FitModel`]) with its Δχ² = 1 interval
//! (unbounded sides reported as null). The lighting is the explicit one where given (a scene's
//! `[lighting]`, an environment map, a lighting in memory), else the observation's.

use super::{CHANNELS, Error, fmt_opt, fmt_se, project};
use crate::filter::{ChannelFit, OrderStatus, PixelFilterFit, PixelOrder, fit_filter_pixels};
use crate::image::Image;
use crate::inverse::brdf::{BrdfFit, Model, estimate_transfer, fit_model, fit_model_gls, transfer_covariance_probe};
use crate::observation::pixels::PixelNoise;
use crate::observation::{LightingInput, Observation, lighting_given};
use crate::projection::{Mapping, Param};
use std::path::PathBuf;

/// The parametric BRDF model an inverse BRDF fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitModel {
    /// Phong's exponent s (eq. 43).
    Phong,
    /// Torrance–Sparrow's roughness σ in radians (eq. 50 / 59).
    TorranceSparrow,
    /// The microfacet BRDF's roughness α (Beckmann or GGX, Smith G, F = 1).
    Microfacet { distribution: vocab::Distribution },
}

/// What an inverse BRDF is asked for (the CLI's flags as values).
#[derive(Clone, Debug)]
pub struct BrdfParams {
    /// Highest SH order (at most [`crate::sh::MAX_LMAX`] and what the images carry).
    pub lmax: usize,
    /// The lighting; `None`: the observed one.
    pub lighting: Option<LightingInput>,
    /// The mapping of an environment-map file in `lighting` (default: from its aspect ratio).
    pub mapping: Option<Mapping>,
    /// The model fitted.
    pub model: FitModel,
    /// The search range of the model's parameter (default: s [0.5, 1e4], σ [0.005, 1], α likewise
    /// [`Model::default_range`]).
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// The reconstruction filter of the renderer that made orthographic views.
    pub pixel_filter: Option<crate::noise::PixelFilter>,
}

/// One channel's generalised least-squares fit of `invert brdf`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BrdfChannelFit {
    pub channel: String,
    pub estimate: f64,
    /// Δχ² = 1 interval (null: unbounded within the search range).
    pub interval: [Option<f64>; 2],
    pub chi2_min: f64,
    pub dof: i64,
}

/// One order of the measured Λ_l ρ̂_l of `invert brdf`, per channel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BrdfOrder {
    pub l: usize,
    pub estimate: [Option<f64>; 3],
    pub stderr: [Option<f64>; 3],
    pub observable: bool,
}

/// Everything `reflect invert brdf` computes; `--json` prints it, the text is its `Display`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct InvertBrdfReport {
    /// How the model was fitted, in words.
    pub fit: String,
    /// Per-channel fits (normal-probe input with a stderr layer; empty otherwise).
    pub channels: Vec<BrdfChannelFit>,
    /// `invert brdf`.
    pub command: String,
    pub lmax: usize,
    pub lmax_carried: usize,
    pub images: Vec<String>,
    pub method: String,
    pub lighting: String,
    pub model: String,
    /// `s` or `sigma`.
    pub parameter: String,
    pub estimate: f64,
    pub interval: [Option<f64>; 2],
    pub relative_width: Option<f64>,
    pub range: [f64; 2],
    pub scale: [Option<f64>; 3],
    pub chi2_min: f64,
    pub dof: i64,
    pub weighted_by_stderr: bool,
    pub points: usize,
    pub filter: Vec<BrdfOrder>,
    /// (parameter, Δχ²) along the profile.
    pub profile: Vec<[f64; 2]>,
    /// Orthographic views: the pixel-space filter fit (error budget, conditioning, χ² per channel).
    pub filter_fit: Option<FilterFitReport>,
    /// Orthographic views: the correlation of neighbouring pixels' noise and the variance inflation
    /// applied to the noise part of every error bar.
    pub pixel_noise: Option<PixelNoise>,
    /// The image against the re-prediction of the recovered model (`crate::verdict::of_model_fit`):
    /// χ² of the measured filter against the model at the fitted parameter, per channel with its ν
    /// and p, Šidák over the channels at α = 1 %; null when the fit has no weights (no error estimate)
    /// or no degrees of freedom.
    pub verdict: Option<crate::verdict::Verdict>,
    pub warnings: Vec<String>,
    /// The `note: …` lines of the pixel-noise decision, for stderr; not in the `--json` document.
    #[serde(skip)]
    pub notes: Vec<String>,
}

/// Checks the parameters before any image is read (`lmax`).
pub fn validate(params: &BrdfParams) -> Result<(), Error> {
    super::check_lmax(params.lmax)
}

/// The BRDF fitted to `images` (named `paths`; as [`crate::observation::observe`] left them)
/// described by `observed`: the report, or an error naming the file and problem.
pub fn brdf(
    params: &BrdfParams,
    images: Vec<Image>,
    paths: &[PathBuf],
    observed: &Observation,
) -> Result<InvertBrdfReport, Error> {
    let lmax = params.lmax;
    let mut p = project(images, paths, observed, lmax, Param::Reflection, params.pixel_filter)?;
    let notes = std::mem::take(&mut p.notes);
    let model = match params.model {
        FitModel::Phong => Model::Phong,
        FitModel::TorranceSparrow => Model::TorranceSparrow { theta_o: p.theta_o },
        FitModel::Microfacet { distribution } => Model::Microfacet { distribution, theta_o: p.theta_o },
    };
    let (dlo, dhi) = model.default_range();
    let range = (params.min.unwrap_or(dlo), params.max.unwrap_or(dhi));
    let (lighting, source) = lighting_given(params.lighting.as_ref(), params.mapping, observed)?
        .ok_or_else(|| Error::NoLighting.in_file(&paths[0]))?;
    // Two orders beyond l_max estimate the truncation bias of the pixel-space filter fit.
    let l_hi = lighting.coefficients(crate::inverse::views::truncation_lmax(lmax))?;
    let l = l_hi[..crate::sh::num_coefficients(lmax)].to_vec();
    let in_first = |e: Error| if paths.len() == 1 { e.in_file(&paths[0]) } else { e };
    // Orthographic views: the filter is fitted in pixel space (the one fit `analyze` prints:
    // conditioning from the design, truncation, χ²), not B_lm / L_lm, which is wrong on part of
    // the sphere; the model is then fitted by GLS to it with its covariance ⊕ truncation².
    if let Some((samples, have_sigma)) = &p.samples {
        let pf = fit_filter_pixels(samples, *have_sigma, p.noise.as_ref().map_or(1.0, |n| n.inflation), &l_hi, lmax)
            .map_err(|e| in_first(e.into()))?;
        let mut r = brdf_report_from_pixel_fit(lmax, paths, p.lmax_carried, p.method, source, model, range, pf)?;
        r.warnings.splice(0..0, observed.stderr_notes.iter().chain(&observed.warnings).cloned());
        r.warnings.extend(p.noise.as_ref().and_then(|n| n.warning()));
        r.pixel_noise = p.noise;
        r.notes = notes;
        return Ok(r);
    }
    let est = estimate_transfer(&p.b, p.stderr.as_deref(), &l, lmax)?;
    // A normal-probe image with a stderr layer gives the full covariance of the per-order
    // estimates: they are correlated (≈ 0.85 between adjacent orders under a directional source),
    // and so are the channels (the same paths), so each channel is fitted by generalised least
    // squares on its own and the channel with the narrowest interval is reported.
    let cov =
        if p.probe { transfer_covariance_probe(&p.first, &l, lmax).map_err(|e| e.in_file(&paths[0]))? } else { None };
    let (fit, how, per_channel) = match cov {
        Some(cov) => {
            let mut fits = Vec::new();
            for (ch, cv) in cov.iter().enumerate() {
                let orders: Vec<usize> = est.iter().filter(|o| o.estimate[ch].is_some()).map(|o| o.l).collect();
                if orders.len() < 2 {
                    continue;
                }
                let f: Vec<f64> = orders.iter().map(|&l| est[l].estimate[ch].unwrap_or(0.0)).collect();
                let n = lmax + 1;
                let sub: Vec<f64> = orders.iter().flat_map(|&i| orders.iter().map(move |&j| cv[i * n + j])).collect();
                fits.push((ch, fit_model_gls(&orders, &f, &sub, model, Some(range))?));
            }
            let (ch, fit) = narrowest(&fits).ok_or(Error::NoObservableChannel)?;
            let how = format!(
                "generalised least squares with the full covariance of the per-order estimates, per channel (channels share their paths, so they are not combined); reported: channel {}",
                CHANNELS[ch]
            );
            (fit, how, channel_fits(&fits))
        }
        None => (
            fit_model(&est, model, Some(range))?,
            "weighted least squares over orders and channels, errors treated as independent (no per-pixel stderr layer, or orthographic views)".to_string(),
            Vec::new(),
        ),
    };
    let filter =
        est.iter().map(|o| BrdfOrder { l: o.l, estimate: o.estimate, stderr: o.stderr, observable: o.observable() });
    let warnings = observed.stderr_notes.clone();
    let mut r = brdf_report(
        lmax,
        paths,
        (p.lmax_carried, p.method, source),
        &fit,
        how,
        per_channel,
        filter.collect(),
        None,
        warnings,
    );
    r.notes = notes;
    Ok(r)
}

/// The channel whose model fit has the narrowest interval, its `scale` kept for that channel only.
fn narrowest(fits: &[(usize, BrdfFit)]) -> Option<(usize, BrdfFit)> {
    let (ch, mut fit) = fits.iter().min_by(|x, y| x.1.relative_width().total_cmp(&y.1.relative_width())).cloned()?;
    let k = fit.scale[0];
    fit.scale = [None; 3];
    fit.scale[ch] = k;
    Some((ch, fit))
}

/// Each channel's model fit, as reported.
fn channel_fits(fits: &[(usize, BrdfFit)]) -> Vec<BrdfChannelFit> {
    fits.iter()
        .map(|(ch, f)| BrdfChannelFit {
            channel: CHANNELS[*ch].into(),
            estimate: f.parameter,
            interval: [f.interval.0, f.interval.1],
            chi2_min: f.chi2_min,
            dof: f.dof,
        })
        .collect()
}

/// The report of `invert brdf` from the reported model fit (`how` it was fitted) and the per-order
/// filter it was fitted to; `(lmax_carried, method, lighting source)` come from the projection.
#[allow(clippy::too_many_arguments)]
fn brdf_report(
    lmax: usize,
    paths: &[PathBuf],
    (lmax_carried, method, source): (usize, String, String),
    fit: &BrdfFit,
    how: String,
    channels: Vec<BrdfChannelFit>,
    filter: Vec<BrdfOrder>,
    filter_fit: Option<FilterFitReport>,
    mut warnings: Vec<String>,
) -> InvertBrdfReport {
    let model = fit.model;
    let described = format!("the {} model at {} = {:.4}", model.name(), model.parameter_name(), fit.parameter);
    let verdict = if channels.is_empty() {
        fit.p_value().and(crate::verdict::of_model_fit(
            &[("all", fit.chi2_min, fit.dof)],
            &described,
            crate::verdict::DEFAULT_ALPHA,
            fit.weighted_by_stderr,
        ))
    } else {
        let per: Vec<(&str, f64, i64)> = channels.iter().map(|c| (c.channel.as_str(), c.chi2_min, c.dof)).collect();
        let have_sigma = filter_fit.as_ref().is_none_or(|f| f.channels.iter().any(|c| c.p_value.is_some()));
        crate::verdict::of_model_fit(
            &per,
            &format!("the {} model fitted per channel", model.name()),
            crate::verdict::DEFAULT_ALPHA,
            have_sigma,
        )
    };
    // A minimum of χ² on the search range's bound is no estimate: χ² still falls beyond it (a
    // mismatched model runs s to the bottom of the range: a 90°-rotated lighting gave s = 0.5 of
    // [0.5, 10000], printed as the interval [unbounded, 0.5]).
    let (lo, hi) = fit.range;
    let near = |b: f64| (fit.parameter.ln() - b.ln()).abs() < 1e-6;
    if near(lo) || near(hi) {
        warnings.push(format!(
            "{} = {} is at the edge of the search range [{lo}, {hi}]: χ² still falls beyond it, so it is no estimate \
             — a model that does not fit these images (see the warnings above) or a value outside the range \
             (--min / --max)",
            model.parameter_name(),
            fit.parameter
        ));
    }
    InvertBrdfReport {
        fit: how,
        channels,
        command: "invert brdf".into(),
        lmax,
        lmax_carried,
        images: paths.iter().map(|p| p.display().to_string()).collect(),
        method,
        lighting: source,
        model: model.name().into(),
        parameter: model.parameter_name().into(),
        estimate: fit.parameter,
        interval: [fit.interval.0, fit.interval.1],
        relative_width: fit.relative_width().is_finite().then(|| fit.relative_width()),
        range: [fit.range.0, fit.range.1],
        scale: fit.scale,
        chi2_min: fit.chi2_min,
        dof: fit.dof,
        weighted_by_stderr: fit.weighted_by_stderr,
        points: fit.points,
        filter,
        profile: fit.profile.iter().map(|(p, d)| [*p, *d]).collect(),
        filter_fit,
        pixel_noise: None,
        verdict,
        warnings,
        notes: Vec::new(),
    }
}

/// `invert brdf` on orthographic views: the model fitted per channel by generalised least squares
/// to the pixel-space filter `pf` ([`fit_filter_pixels`]) at its determined orders, with the fit's
/// covariance plus the estimated truncation bias² on the diagonal (a bias of unknown sign, treated
/// as an independent error per order); the channel with the narrowest interval is reported, as
/// for a normal probe. Ill-conditioned orders are left out of the model fit (said in a warning).
#[allow(clippy::too_many_arguments)]
fn brdf_report_from_pixel_fit(
    lmax: usize,
    paths: &[PathBuf],
    lmax_carried: usize,
    method: String,
    source: String,
    model: Model,
    range: (f64, f64),
    pf: PixelFilterFit,
) -> Result<InvertBrdfReport, Error> {
    let mut warnings = pf.warnings.clone();
    let mut fits = Vec::new();
    for (ch, c) in pf.channels.iter().enumerate() {
        let idx: Vec<usize> = (0..c.fitted_orders.len())
            .filter(|&i| pf.orders[c.fitted_orders[i]].status[ch] == OrderStatus::Determined)
            .collect();
        if idx.len() < 2 {
            warnings.push(format!("channel {}: fewer than two determined orders, no model fit", CHANNELS[ch]));
            continue;
        }
        let orders: Vec<usize> = idx.iter().map(|&i| c.fitted_orders[i]).collect();
        let f: Vec<f64> = orders.iter().map(|&l| pf.orders[l].estimate[ch].unwrap_or(0.0)).collect();
        let n = idx.len();
        let mut cov = vec![0.0; n * n];
        for (r, &i) in idx.iter().enumerate() {
            for (s, &j) in idx.iter().enumerate() {
                cov[r * n + s] = c.covariance[i][j];
            }
            cov[r * n + r] += pf.orders[c.fitted_orders[i]].truncation[ch].unwrap_or(0.0).powi(2);
        }
        fits.push((ch, fit_model_gls(&orders, &f, &cov, model, Some(range))?));
    }
    let (ch, fit) = narrowest(&fits).ok_or(Error::NoDeterminedChannel)?;
    for (c, f) in &fits {
        if let Some(p) = f.p_value().filter(|&p| p < crate::fit::MISMATCH_P) {
            warnings.push(format!(
                "channel {}: the {} model does not describe the measured filter (χ² = {:.1} for ν = {}, p = {p:.1e})",
                CHANNELS[*c],
                model.name(),
                f.chi2_min,
                f.dof
            ));
        }
    }
    let how = format!(
        "filter fitted in pixel space over the views' pixels (as analyze), then the model by generalised least \
         squares with the filter's covariance and truncation, per channel over its determined orders; reported: \
         channel {}",
        CHANNELS[ch]
    );
    let filter = pf.orders.iter().map(|o| BrdfOrder {
        l: o.l,
        estimate: o.estimate,
        stderr: o.stderr,
        observable: o.estimate.iter().any(|e| e.is_some()),
    });
    let filter = filter.collect();
    let filter_fit = Some(FilterFitReport { orders: pf.orders, channels: pf.channels });
    Ok(brdf_report(
        lmax,
        paths,
        (lmax_carried, method, source),
        &fit,
        how,
        channel_fits(&fits),
        filter,
        filter_fit,
        warnings,
    ))
}

/// The pixel-space filter fit behind `invert brdf` on orthographic views (the one `analyze`
/// prints): per order its noise, truncation, amplification and status; per channel χ², ν, p-value
/// and covariance.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FilterFitReport {
    pub orders: Vec<PixelOrder>,
    pub channels: Vec<ChannelFit>,
}

impl std::fmt::Display for InvertBrdfReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "# {} — {}", self.command, self.method)?;
        writeln!(f, "# l_max {}; the input carries l <= {}", self.lmax, self.lmax_carried)?;
        writeln!(f, "# lighting: {}", self.lighting)?;
        writeln!(f, "{:>4} {:>24} {:>24} {:>24}", "l", "Λ_l ρ̂_l R ± se", "G ± se", "B ± se")?;
        for o in &self.filter {
            write!(f, "{:>4}", o.l)?;
            for ch in 0..3 {
                let cell = if o.observable {
                    format!("{} ± {}", fmt_opt(o.estimate[ch]), fmt_se(o.stderr[ch]))
                } else {
                    "unobservable".into()
                };
                write!(f, " {cell:>24}")?;
            }
            writeln!(f)?;
        }
        let iv = |v: Option<f64>| v.map_or("unbounded".to_string(), |x| format!("{x:.4}"));
        // Per-channel fits: the one reported is the narrowest interval's; say which, and the others.
        let reported = self.channels.iter().find(|c| c.estimate == self.estimate).map(|c| c.channel.as_str());
        writeln!(
            f,
            "# {} {} = {:.4}{}, Δχ² = 1 interval [{}, {}] within the search range {:?}",
            self.model,
            self.parameter,
            self.estimate,
            reported.map_or(String::new(), |c| format!(" (channel {c}, the narrowest interval)")),
            iv(self.interval[0]),
            iv(self.interval[1]),
            self.range
        )?;
        if self.channels.len() > 1 {
            let each: Vec<String> = self
                .channels
                .iter()
                .map(|c| format!("{} {:.4} [{}, {}]", c.channel, c.estimate, iv(c.interval[0]), iv(c.interval[1])))
                .collect();
            writeln!(f, "# per channel: {}", each.join(", "))?;
        }
        if let Some(n) = &self.pixel_noise {
            writeln!(f, "{}", n.line())?;
        }
        if let Some(v) = &self.verdict {
            writeln!(f, "# {}", v.line)?;
        }
        Ok(())
    }
}
