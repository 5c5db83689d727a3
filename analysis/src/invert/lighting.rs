//! The inverse lighting of `reflect invert lighting` ([`lighting()`]): L_lm = B_lm / (albedo
//! Λ_l ρ̂_l) (eq. 17) per order with standard errors, noise amplification and status (recovered /
//! ill-conditioned / unobservable), and the Tikhonov-regularised lighting (λ by GCV unless
//! [`Rule::Discrepancy`]). The BRDF (and albedo / k_s / k_r) is the explicit one where given, else
//! the observation's ([`Observation::transfer`]).

use super::{CHANNELS, Error, fmt_opt, fmt_se, project};
use crate::filter::ChannelFit;
use crate::image::Image;
use crate::inverse::lighting::{DEFAULT_MAX_AMPLIFICATION, Rule, Status, invert_lighting};
use crate::inverse::views::invert_lighting_views;
use crate::observation::pixels::PixelNoise;
use crate::observation::{BrdfValues, Observation};
use crate::projection::{Param, check_latlong, project_normal_probe};
use crate::sh::{lm, reconstruct_latlong};
use crate::transfer::{TransferModel, parameterization};
use std::path::PathBuf;

/// What an inverse lighting is asked for (the CLI's flags as values).
#[derive(Clone, Debug)]
pub struct LightingParams {
    /// Highest SH order (at most [`crate::sh::MAX_LMAX`] and what the images carry).
    pub lmax: usize,
    /// The BRDF of the sphere where the observation does not say it.
    pub brdf: BrdfValues,
    /// Noise amplification above which an order is ill-conditioned.
    pub max_amplification: f64,
    /// The rule choosing the Tikhonov λ.
    pub rule: Rule,
    /// The lat-long map of the regularised lighting a front-end writes
    /// ([`InvertLightingReport::lighting_map`]): its file (named in the report and errors) and width
    /// W (height W/2; even, in [4, 16384], carrying every order ≤ `lmax`).
    pub map: Option<(PathBuf, usize)>,
    /// The reconstruction filter of the renderer that made orthographic views.
    pub pixel_filter: Option<crate::noise::PixelFilter>,
}

impl Default for LightingParams {
    fn default() -> LightingParams {
        LightingParams {
            lmax: 0,
            brdf: BrdfValues::default(),
            max_amplification: DEFAULT_MAX_AMPLIFICATION,
            rule: Rule::Gcv,
            map: None,
            pixel_filter: None,
        }
    }
}

/// Checks the parameters before any image is read: the map's width and the orders its grid
/// carries, then `lmax`.
pub fn validate(params: &LightingParams) -> Result<(), Error> {
    if let Some((out, width)) = &params.map {
        if !(*width >= 4 && width.is_multiple_of(2) && *width <= 16384) {
            return Err(Error::MapWidth(*width));
        }
        // The written map must carry every order it is reconstructed from.
        check_latlong(params.lmax, *width, width / 2, "--output map (--width)").map_err(|e| e.in_file(out))?;
    }
    super::check_lmax(params.lmax)
}

/// BRDF model and albedo from the explicit values, else from the observed BRDF table, both through
/// the one BRDF → transfer-model mapping ([`Observation::transfer`]).
fn brdf_of(given: &BrdfValues, d: &Observation, theta_o: f64) -> Result<(TransferModel, [f64; 3], String), Error> {
    let r = d.transfer(given, theta_o)?.ok_or(Error::NoBrdf)?;
    let t = r.transfer.ok_or_else(|| Error::NoTransfer { kind: r.kind.to_string(), src: r.source.clone() })?;
    let albedo = t.scale;
    if albedo.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return Err(Error::AlbedoNotPositive(albedo));
    }
    Ok((t.model, albedo, r.kind.name().to_string()))
}

/// One order of `invert lighting`: the filter, its noise amplification and status.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LightingOrder {
    pub l: usize,
    /// Λ_l ρ̂_l (unit albedo).
    pub lambda_rho: f64,
    pub amplification: Option<f64>,
    /// `recovered`, `ill-conditioned` or `unobservable`.
    pub status: String,
}

/// The Tikhonov-regularised lighting of `invert lighting`.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RegularisedReport {
    pub rule: String,
    /// λ per channel (null when all of B is noise).
    pub lambda: [f64; 3],
    pub residual: [f64; 3],
    /// Per channel whether λ changes any coefficient by more than 10⁻⁶ of itself
    /// (`crate::inverse::lighting::Regularised::needed`); all `false`: "no regularization
    /// needed", the regularised lighting is the plain inverse.
    pub needed: [bool; 3],
    pub coefficients: Vec<[f64; 3]>,
}

/// Everything `reflect invert lighting` computes; `--json` prints it, the text is its `Display`.
/// Coefficient lists are in index order k = l(l + 1) + m, labelled by `lm`; every channel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct InvertLightingReport {
    /// `invert lighting`.
    pub command: String,
    pub lmax: usize,
    pub lmax_carried: usize,
    pub images: Vec<String>,
    pub method: String,
    pub brdf: String,
    /// Λ_l ρ̂_l per order (unit albedo).
    pub lambda_rho: Vec<f64>,
    pub albedo: [f64; 3],
    pub max_amplification: f64,
    pub orders: Vec<LightingOrder>,
    pub lm: Vec<(usize, i64)>,
    /// L_lm (eq. 17); null where unobservable. A normal-probe render: B_lm / (albedo Λ_l ρ̂_l);
    /// orthographic views: fitted in pixel space (`crate::inverse::views`).
    pub coefficients: Vec<Option<[f64; 3]>>,
    /// Total standard error (noise ⊕ truncation for orthographic views).
    pub stderr: Vec<Option<[f64; 3]>>,
    /// Orthographic views: the noise part (the per-pixel σ propagated; the residual σ without them).
    pub stderr_noise: Option<Vec<Option<[f64; 3]>>>,
    /// Orthographic views: the estimated truncation bias, a standard deviation (`crate::inverse::views`).
    pub truncation: Option<Vec<Option<[f64; 3]>>>,
    /// Orthographic views: the truncation bias with the first band above l_max aligned worst
    /// (`crate::inverse::views`); an order whose bound reaches 35 % of its size is
    /// `undetermined` ("cannot be determined from these views").
    pub truncation_bound: Option<Vec<Option<[f64; 3]>>>,
    /// Orthographic views: amplification per coefficient (filter × design).
    pub coefficient_amplification: Option<Vec<Option<f64>>>,
    /// Orthographic views: χ², ν, χ²/ν, p-value, error scale, covariance per channel.
    pub channel_fits: Option<Vec<ChannelFit>>,
    pub regularised: RegularisedReport,
    /// The lat-long EXR written with `--output`.
    pub output: Option<String>,
    /// Orthographic views: the correlation of neighbouring pixels' noise (a reconstruction filter
    /// wider than a pixel) and the variance inflation applied to the noise part of every error bar.
    pub pixel_noise: Option<PixelNoise>,
    /// A normal-probe image against the BRDF it was told: the orders the BRDF does not pass must be
    /// 0 (`crate::verdict::of_unpassed_orders`); null when every order is passed (the lighting
    /// absorbs any B_lm), for views that see part of the sphere (their B_lm alias the orders above
    /// l_max), or without a stderr layer.
    pub verdict: Option<crate::verdict::Verdict>,
    pub warnings: Vec<String>,
    /// The `note: …` lines of the pixel-noise decision, for stderr; not in the `--json` document.
    #[serde(skip)]
    pub notes: Vec<String>,
}

/// The lighting recovered from `images` (named `paths`; as [`crate::observation::observe`] left
/// them) described by `observed`: the report, or an error naming the file and problem.
pub fn lighting(
    params: &LightingParams,
    images: Vec<Image>,
    paths: &[PathBuf],
    observed: &Observation,
) -> Result<InvertLightingReport, Error> {
    validate(params)?;
    let (lmax, max_amplification, rule) = (params.lmax, params.max_amplification, params.rule);
    // The parameterization only matters for orthographic views; lambert is a function of the normal.
    let kind = params.brdf.kind.or_else(|| observed.brdf.as_ref().map(|(b, _)| b.kind()));
    let param = kind.map_or(Param::Reflection, parameterization);
    let p = project(images, paths, observed, lmax, param, params.pixel_filter)?;
    let (model, albedo, name) = brdf_of(&params.brdf, observed, p.theta_o)
        .map_err(|e| if params.brdf.kind.is_none() { e.in_file(&paths[0]) } else { e })?;
    let filter = model.lambda_rho(lmax);
    let inv = invert_lighting(&p.b, p.stderr.as_deref(), &filter, albedo, lmax, max_amplification, Some(rule))?;
    let mut warnings = observed.stderr_notes.clone();
    warnings.extend(observed.warnings.iter().cloned());
    warnings.extend(p.noise.as_ref().and_then(|n| n.warning()));
    let mut orders: Vec<LightingOrder> = inv
        .orders
        .iter()
        .map(|o| LightingOrder {
            l: o.l,
            lambda_rho: o.filter,
            amplification: o.amplification,
            status: o.status.name().into(),
        })
        .collect();
    let unpassed: Vec<usize> = inv.orders.iter().filter(|o| o.status == Status::Unobservable).map(|o| o.l).collect();
    let verdict = match (&p.stderr, p.probe) {
        (Some(se), true) if !unpassed.is_empty() => {
            // The pixel grid puts O(pixel²) of the passed orders into the unpassed ones: measured at
            // many samples per pixel that is far beyond the noise, so the image's unpassed B_lm are
            // compared with what the grid puts there from its own passed orders (to twice l_max
            // and more, as far as the grid carries).
            let lsyn = p.lmax_carried.min(2 * lmax + 8).max(lmax);
            let (mut passed, _) = project_normal_probe(&p.first, lsyn).map_err(|e| e.in_file(&paths[0]))?;
            let syn_filter = model.lambda_rho(lsyn);
            for o in crate::inverse::lighting::classify(&syn_filter, max_amplification) {
                if o.status == Status::Unobservable {
                    passed[o.l * o.l..(o.l + 1) * (o.l + 1)].iter_mut().for_each(|v| *v = [0.0; 3]);
                }
            }
            let leak =
                crate::projection::normal_probe::probe_pixelization(&passed, p.first.width, p.first.height, lmax)
                    .map_err(|e| e.in_file(&paths[0]))?;
            let b: Vec<[f64; 3]> =
                p.b.iter().zip(&leak).map(|(b, l)| [b[0] - l[0], b[1] - l[1], b[2] - l[2]]).collect();
            crate::verdict::of_unpassed_orders(&b, se, &unpassed, &name, crate::verdict::DEFAULT_ALPHA)
        }
        _ => None,
    };
    let (mut coefficients, mut stderr) = (inv.coefficients, inv.stderr);
    let (mut stderr_noise, mut truncation, mut coefficient_amplification, mut channel_fits) = (None, None, None, None);
    let mut truncation_bound = None;
    if let Some((samples, have_sigma)) = &p.samples {
        // Views that see part of the sphere: L_lm fitted in pixel space, with the conditioning of
        // the actual design and the truncation bias (issue 16).
        let v = invert_lighting_views(
            samples,
            *have_sigma,
            p.noise.as_ref().map_or(1.0, |n| n.inflation),
            &model.lambda_rho(crate::inverse::views::truncation_lmax(lmax)),
            albedo,
            lmax,
            max_amplification,
        )
        .map_err(|e| if paths.len() == 1 { e.in_file(&paths[0]) } else { e })?;
        orders = v
            .orders
            .iter()
            .map(|o| LightingOrder {
                l: o.l,
                lambda_rho: o.lambda_rho,
                amplification: o.amplification,
                status: o.status.clone(),
            })
            .collect();
        coefficients = v.coefficients;
        stderr = v.stderr;
        stderr_noise = Some(v.stderr_noise);
        truncation = Some(v.truncation);
        truncation_bound = Some(v.truncation_bound);
        coefficient_amplification = Some(v.amplification);
        channel_fits = Some(v.channels);
        warnings.extend(v.warnings);
        if inv.regularised.needed.iter().any(|&n| n) {
            warnings.push(
                "the regularised lighting is the Tikhonov solution on the B_lm fitted to these views (not the \
                 pixel-space fit): on views that see part of the sphere those B_lm alias the orders above l_max, so \
                 it carries no error bars and only the orders reported recovered are meaningful"
                    .to_string(),
            );
        }
    }
    // The mean radiance L_00 / (2√π) cannot be negative: a regularised solution with L_00 < 0 is the
    // filter's inverse of noise or aliasing, not a lighting (one Lambert view at --lmax 6 gave
    // L_00 = −7.3 for the map's 2.5 while the pixel-space fit gave 2.25).
    let negative: Vec<&str> =
        (0..3).filter(|&c| inv.regularised.coefficients[0][c] < 0.0).map(|c| CHANNELS[c]).collect();
    if !negative.is_empty() {
        warnings.push(format!(
            "the regularised lighting has L_00 < 0 in {} (a negative mean radiance): it is not a physical lighting — \
             lower --lmax, add views, or use the coefficients of the orders reported recovered",
            negative.join(" ")
        ));
    }
    Ok(InvertLightingReport {
        command: "invert lighting".into(),
        lmax,
        lmax_carried: p.lmax_carried,
        images: paths.iter().map(|p| p.display().to_string()).collect(),
        method: p.method,
        brdf: name,
        lambda_rho: filter,
        albedo,
        max_amplification,
        orders,
        lm: (0..coefficients.len()).map(lm).collect(),
        coefficients,
        stderr,
        stderr_noise,
        truncation,
        truncation_bound,
        coefficient_amplification,
        channel_fits,
        regularised: RegularisedReport {
            rule: rule.name().into(),
            lambda: inv.regularised.lambda,
            residual: inv.regularised.residual,
            needed: inv.regularised.needed,
            coefficients: inv.regularised.coefficients,
        },
        output: params.map.as_ref().map(|(p, _)| p.display().to_string()),
        pixel_noise: p.noise,
        verdict,
        warnings,
        notes: p.notes,
    })
}

impl InvertLightingReport {
    /// The regularised lighting as a W × W/2 lat-long image (`width` = W), reconstructed from its
    /// SH coefficients: what `--output` writes.
    pub fn lighting_map(&self, width: usize) -> Image {
        let (w, h) = (width, width / 2);
        let px = reconstruct_latlong(&self.regularised.coefficients, w, h);
        let mut img = Image { width: w, height: h, ..Default::default() };
        for (ch, n) in CHANNELS.iter().enumerate() {
            img.channels.insert(n.to_string(), px.iter().map(|p| p[ch] as f32).collect());
        }
        img.attributes.insert(
            "reflect:lighting-source".into(),
            format!("invert lighting, {} regularisation", self.regularised.rule),
        );
        img
    }
}

impl std::fmt::Display for InvertLightingReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "# {} — {}", self.command, self.method)?;
        writeln!(f, "# l_max {}; the input carries l <= {}", self.lmax, self.lmax_carried)?;
        writeln!(
            f,
            "# brdf {:?}, albedo {}, orders with amplification > {} are ill-conditioned",
            self.brdf,
            self.albedo.map(|a| format!("{}", a as f32)).join(", "),
            self.max_amplification
        )?;
        writeln!(f, "{:>4} {:>12} {:>14} {:>16}", "l", "Λ_l ρ̂_l", "amplification", "status")?;
        for o in &self.orders {
            writeln!(
                f,
                "{:>4} {:>12} {:>14} {:>16}",
                o.l,
                fmt_opt(Some(o.lambda_rho)),
                fmt_opt(o.amplification),
                o.status
            )?;
        }
        writeln!(
            f,
            "\n{:>4} {:>4} {:>24} {:>24} {:>24}   {:>13} {:>13} {:>13}",
            "l", "m", "L_lm R ± se", "G ± se", "B ± se", "regularised R", "G", "B"
        )?;
        for (k, v) in self.coefficients.iter().enumerate() {
            let (l, m) = self.lm[k];
            write!(f, "{l:>4} {m:>4}")?;
            for ch in 0..3 {
                let cell = match v {
                    None => "unobservable".to_string(),
                    Some(v) => format!("{} ± {}", fmt_opt(Some(v[ch])), fmt_se(self.stderr[k].map(|s| s[ch]))),
                };
                write!(f, " {cell:>24}")?;
            }
            write!(f, " ")?;
            for ch in 0..3 {
                write!(f, " {:>13}", fmt_opt(self.regularised.coefficients.get(k).map(|c| c[ch])))?;
            }
            writeln!(f)?;
        }
        let l = self.regularised.lambda;
        let need = &self.regularised.needed;
        let verdict = if need.iter().any(|&n| n) {
            let chans: Vec<&str> = (0..3).filter(|&c| need[c]).map(|c| CHANNELS[c]).collect();
            format!("regularizes {}", chans.join(" "))
        } else {
            "no regularization needed (λ changes no coefficient by 1e-6 of itself: the plain inverse)".to_string()
        };
        writeln!(
            f,
            "# Tikhonov: {}, λ = R {:.2e}, G {:.2e}, B {:.2e}; {verdict}",
            self.regularised.rule, l[0], l[1], l[2]
        )?;
        if let Some(n) = &self.pixel_noise {
            writeln!(f, "{}", n.line())?;
        }
        if let Some(v) = &self.verdict {
            writeln!(f, "# {}", v.line)?;
        }
        Ok(())
    }
}
