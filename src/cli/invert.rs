//! `reflect invert lighting|brdf IMAGE.exr… …`: inverse rendering from renders (or photographs) of
//! a sphere (paper sec. 2.2, sec. 3; library `analysis::inverse`).
//!
//! - `invert lighting IMAGE.exr… [--brdf B --s S --sigma X] [--albedo A] --lmax L
//!   [--max-amplification 10] [--lambda-rule gcv|discrepancy] [--output ENV.exr --width W] [--json]`:
//!   L_lm = B_lm / (albedo Λ_l ρ̂_l) (eq. 17) per order with standard errors, noise amplification
//!   and status (recovered / ill-conditioned / unobservable), and the Tikhonov-regularised lighting
//!   (λ by GCV unless `--lambda-rule discrepancy`), written as a W × W/2 lat-long EXR with `--output`.
//!   Without `--brdf`, the BRDF (and albedo / k_s / k_r) comes from the image's `reflect:objects`.
//! - `invert brdf IMAGE.exr… [--lighting SCENE_OR_ENV] --model phong|torrance-sparrow|microfacet
//!   [--distribution beckmann|ggx] --lmax L
//!   [--min P --max P] [--json]`: Λ_l ρ̂_l per order (eq. 16) and the fitted s or σ with its
//!   Δχ² = 1 interval (unbounded sides reported as null). Lighting as in `analyze`: a scene's
//!   `[lighting]`, an environment map, or the image's `reflect:lighting` header.
//!
//! `--lmax` above the highest order the images carry is refused as in `analyze` (`lmax_carried` in
//! the output), and so is an `--output` map whose W × W/2 grid cannot carry it (W/2 − 1).
//!
//! Images are projected as in `analyze`: one `normal-probe` render (lat-long quadrature; at
//! θ_o = 0 the normal is the reflection vector, so every BRDF's B is in its own parameterization),
//! or orthographic views whose camera and sphere are in the header (weighted least squares, in the
//! normal parameterization for lambert and the reflection one otherwise).
use super::Error;
use super::args::{BrdfFlags, FitModel, LambdaRule, ViewArgs};
use super::header::load;
use super::outputs::{Files, Format};
use super::sh::check_lmax;
use analysis::filter::{ChannelFit, OrderStatus, PixelFilterFit, PixelOrder, fit_filter_pixels};
use analysis::image::{Image, write_exr};
use analysis::inverse::brdf::{BrdfFit, Model, estimate_transfer, fit_model, fit_model_gls, transfer_covariance_probe};
use analysis::inverse::lighting::{DEFAULT_MAX_AMPLIFICATION, Rule, Status, invert_lighting};
use analysis::inverse::views::invert_lighting_views;
use analysis::lighting::Lighting;
use analysis::observation::pixels::PixelNoise;
use analysis::observation::{Camera, Observation, lighting_of};
use analysis::projection::{
    OrthoView, Param, Sample, check_latlong, fit_orthographic, latlong_max_order, ortho_samples, project_normal_probe,
};
use analysis::sh::{lm, reconstruct_latlong};
use analysis::transfer::{TransferModel, parameterization};
use std::path::PathBuf;
use std::process::ExitCode;
use vocab::Mapping;

#[derive(clap::Subcommand, Debug)]
pub enum InvertCommand {
    /// Recover the lighting L_lm from renders of a sphere of known BRDF (eq. 17).
    Lighting(LightingArgs),
    /// Estimate Λ_l ρ̂_l and fit Phong s or Torrance–Sparrow σ from renders under known lighting (eq. 16).
    Brdf(BrdfArgs),
    /// Diffuse + specular separation (sec. 3.5, the paper's reference 17): lighting from a lambert + mirror sphere.
    Separate(super::separate::SeparateArgs),
    /// Factor a sphere's 4D reflected light field into lighting and BRDF up to global scale (eq. 18, 23).
    Factor(super::factor::FactorArgs),
}

#[derive(clap::Args, Debug)]
pub struct LightingArgs {
    /// Rendered images (OpenEXR): one normal-probe image, or orthographic views.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// The BRDF of the sphere (default: the header's or --scene's).
    #[command(flatten)]
    pub brdf: BrdfFlags,
    /// The camera and sphere of images whose header does not say them.
    #[command(flatten)]
    pub view: ViewArgs,
    /// Highest SH order.
    #[arg(long, value_parser = super::flags::parse_lmax, allow_hyphen_values = true)]
    pub lmax: usize,
    /// Noise amplification above which an order is ill-conditioned.
    #[arg(long, default_value_t = DEFAULT_MAX_AMPLIFICATION, value_parser = super::flags::parse_amplification, allow_hyphen_values = true)]
    pub max_amplification: f64,
    /// The rule choosing the Tikhonov λ.
    #[arg(long, value_enum, default_value_t = LambdaRule::Gcv)]
    pub lambda_rule: LambdaRule,
    /// Write the regularised lighting as a lat-long EXR.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Width of the --output map (height = width / 2).
    #[arg(long, default_value_t = 256, value_parser = super::flags::parse_width, allow_hyphen_values = true)]
    pub width: usize,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args, Debug)]
pub struct BrdfArgs {
    /// Rendered images (OpenEXR): one normal-probe image, or orthographic views.
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Scene file (.toml, its `[lighting]` table) or environment map (default: the header's lighting).
    #[arg(long)]
    pub lighting: Option<PathBuf>,
    /// Mapping of an environment map given with --lighting (default: from the aspect ratio).
    #[arg(long, value_enum)]
    pub mapping: Option<Mapping>,
    /// The parametric model fitted.
    #[arg(long, value_enum)]
    pub model: FitModel,
    /// The normal distribution of --model microfacet.
    #[arg(long, value_enum, default_value_t)]
    pub distribution: vocab::Distribution,
    /// The camera and sphere of images whose header does not say them.
    #[command(flatten)]
    pub view: ViewArgs,
    /// Highest SH order.
    #[arg(long, value_parser = super::flags::parse_lmax, allow_hyphen_values = true)]
    pub lmax: usize,
    /// Lower end of the parameter search range (default: s 0.5, σ 0.005).
    #[arg(long, value_parser = super::flags::parse_positive, allow_hyphen_values = true)]
    pub min: Option<f64>,
    /// Upper end of the parameter search range (default: s 1e4, σ 1).
    #[arg(long, value_parser = super::flags::parse_positive, allow_hyphen_values = true)]
    pub max: Option<f64>,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(c: InvertCommand) -> Result<ExitCode, Error> {
    fn emit<R: serde::Serialize + std::fmt::Display>(r: &R, json_out: bool) -> Result<ExitCode, Error> {
        if json_out {
            println!("{}", serde_json::to_string(r).map_err(|e| Error::new(format!("JSON output: {e}")))?);
        } else {
            print!("{r}");
        }
        Ok(ExitCode::SUCCESS)
    }
    match c {
        InvertCommand::Lighting(a) => {
            let r = invert_lighting_report(&a)?;
            super::print_warnings(&r.warnings);
            emit(&r, a.json)
        }
        InvertCommand::Brdf(a) => {
            let r = invert_brdf_report(&a)?;
            super::print_warnings(&r.warnings);
            emit(&r, a.json)
        }
        InvertCommand::Separate(a) => super::separate::run(&a),
        InvertCommand::Factor(a) => super::factor::run(&a),
    }
}

/// Projected B_lm with standard errors, θ_o of a normal-probe image, and the header objects.
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
    /// Cameras, sphere, BRDF and lighting of the images (header, --scene, flags).
    described: Observation,
    /// Orthographic views: the correlation of neighbouring pixels' noise and the variance
    /// inflation every pixel fit applies ([`analysis::observation::pixels::noise`]).
    noise: Option<PixelNoise>,
}

/// Projects the images described by their headers, `view` (flags, `--scene`); `param` gives the
/// parameterization of orthographic views from what is known of the BRDF.
fn project(
    paths: &[PathBuf],
    view: &ViewArgs,
    lmax: usize,
    param: impl Fn(&Observation) -> Param,
) -> Result<Projected, Error> {
    check_lmax(lmax)?;
    let (mut images, described) = load(paths, view, "inverted")?;
    let param = param(&described);
    let in_first = |e: Error| if paths.len() == 1 { e.in_file(&paths[0]) } else { e };
    let (noise, notes) = analysis::observation::pixels::prepare(
        &mut images,
        &described.cameras,
        &described.sphere,
        param,
        lmax,
        view.pixel_filter,
    )
    .map_err(|e| in_first(e.into()))?;
    notes.iter().for_each(|n| eprintln!("{n}"));
    let mut ortho = Vec::new();
    let mut probe = None;
    for (c, p) in described.cameras.iter().zip(paths) {
        match *c {
            Camera::NormalProbe { theta_o_deg, phi_o_deg } => {
                probe = Some(Camera::probe_theta_o_deg(theta_o_deg, phi_o_deg, "inverted").map_err(|e| e.in_file(p))?)
            }
            Camera::Ortho(o) => ortho.push(o),
        }
    }
    if let Some(theta_o_deg) = probe {
        if images.len() != 1 {
            return Err(Error::new("a normal-probe render must be inverted on its own (one image)"));
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
            described,
            noise: None,
        });
    }
    let sphere = described.sphere;
    let views: Vec<OrthoView> =
        images.iter().zip(&ortho).map(|(image, camera)| OrthoView { image, camera: *camera }).collect();
    let mut fit = fit_orthographic(&views, &sphere, param, lmax)
        .map_err(|e| if paths.len() == 1 { e.in_file(&paths[0]) } else { e })?;
    let method =
        format!("weighted least squares over {} orthographic view(s), {} parameterization", views.len(), param.name());
    let samples =
        ortho_samples(&views, &sphere, param).map_err(|e| if paths.len() == 1 { e.in_file(&paths[0]) } else { e })?;
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
        described,
        noise,
    })
}

/// BRDF model and albedo from the flags, else from the header's or scene's BRDF table, both through
/// the one BRDF → transfer-model mapping ([`Observation::transfer`]).
fn brdf_of(a: &LightingArgs, d: &Observation, theta_o: f64) -> Result<(TransferModel, [f64; 3], String), Error> {
    let r = d
        .transfer(&a.brdf.values(), theta_o)?
        .ok_or_else(|| Error::new("no BRDF: pass --brdf (the image header names none)"))?;
    let t = r.transfer.ok_or_else(|| {
        Error::new(format!("the BRDF '{}' of {} has no transfer model: pass --brdf", r.kind, r.source))
    })?;
    let albedo = t.scale;
    if albedo.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return Err(Error::new(format!("albedo must be > 0, got {albedo:?}")));
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
    /// (`analysis::inverse::lighting::Regularised::needed`); all `false`: "no regularization
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
    /// orthographic views: fitted in pixel space (`analysis::inverse::views`).
    pub coefficients: Vec<Option<[f64; 3]>>,
    /// Total standard error (noise ⊕ truncation for orthographic views).
    pub stderr: Vec<Option<[f64; 3]>>,
    /// Orthographic views: the noise part (the per-pixel σ propagated; the residual σ without them).
    pub stderr_noise: Option<Vec<Option<[f64; 3]>>>,
    /// Orthographic views: the estimated truncation bias, a standard deviation (`analysis::inverse::views`).
    pub truncation: Option<Vec<Option<[f64; 3]>>>,
    /// Orthographic views: the truncation bias with the first band above l_max aligned worst
    /// (`analysis::inverse::views`); an order whose bound reaches 35 % of its size is
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
    /// 0 (`analysis::verdict::of_unpassed_orders`); null when every order is passed (the lighting
    /// absorbs any B_lm), for views that see part of the sphere (their B_lm alias the orders above
    /// l_max), or without a stderr layer.
    pub verdict: Option<analysis::verdict::Verdict>,
    pub warnings: Vec<String>,
}

/// `reflect invert lighting` as a library call: the report, or an error naming the file and problem.
pub fn invert_lighting_report(a: &LightingArgs) -> Result<InvertLightingReport, Error> {
    if let Some(out) = &a.output {
        let files = Files::new().inputs("the image", &a.images).inputs("the scene", &a.view.image.scene);
        files.output("--output", out, Format::Exr).check()?;
    }
    let rule = match a.lambda_rule {
        LambdaRule::Gcv => Rule::Gcv,
        LambdaRule::Discrepancy => Rule::Discrepancy,
    };
    if a.output.is_some() && !(a.width >= 4 && a.width.is_multiple_of(2) && a.width <= 16384) {
        return Err(Error::new(format!("--width must be even and in [4, 16384], got {}", a.width)));
    }
    if let Some(out) = &a.output {
        // The written map must carry every order it is reconstructed from.
        check_latlong(a.lmax, a.width, a.width / 2, "--output map (--width)").map_err(|e| e.in_file(out))?;
    }
    // The parameterization only matters for orthographic views; lambert is a function of the normal.
    let param = |d: &Observation| {
        let kind = a.brdf.brdf.or_else(|| d.brdf.as_ref().map(|(b, _)| b.kind()));
        kind.map_or(Param::Reflection, parameterization)
    };
    let p = project(&a.images, &a.view, a.lmax, param)?;
    let (model, albedo, name) = brdf_of(a, &p.described, p.theta_o)
        .map_err(|e| if a.brdf.brdf.is_none() { e.in_file(&a.images[0]) } else { e })?;
    let filter = model.lambda_rho(a.lmax);
    let inv = invert_lighting(&p.b, p.stderr.as_deref(), &filter, albedo, a.lmax, a.max_amplification, Some(rule))?;
    if let Some(out) = &a.output {
        let (w, h) = (a.width, a.width / 2);
        let px = reconstruct_latlong(&inv.regularised.coefficients, w, h);
        let mut img = Image { width: w, height: h, ..Default::default() };
        for (ch, n) in ["R", "G", "B"].iter().enumerate() {
            img.channels.insert(n.to_string(), px.iter().map(|p| p[ch] as f32).collect());
        }
        img.attributes
            .insert("reflect:lighting-source".into(), format!("invert lighting, {} regularisation", rule.name()));
        write_exr(out, &img)?;
    }
    let mut warnings = p.described.stderr_notes.clone();
    warnings.extend(p.described.warnings.iter().cloned());
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
            let lsyn = p.lmax_carried.min(2 * a.lmax + 8).max(a.lmax);
            let (mut passed, _) = project_normal_probe(&p.first, lsyn).map_err(|e| e.in_file(&a.images[0]))?;
            let syn_filter = model.lambda_rho(lsyn);
            for o in analysis::inverse::lighting::classify(&syn_filter, a.max_amplification) {
                if o.status == Status::Unobservable {
                    passed[o.l * o.l..(o.l + 1) * (o.l + 1)].iter_mut().for_each(|v| *v = [0.0; 3]);
                }
            }
            let leak =
                analysis::projection::normal_probe::probe_pixelization(&passed, p.first.width, p.first.height, a.lmax)
                    .map_err(|e| e.in_file(&a.images[0]))?;
            let b: Vec<[f64; 3]> =
                p.b.iter().zip(&leak).map(|(b, l)| [b[0] - l[0], b[1] - l[1], b[2] - l[2]]).collect();
            analysis::verdict::of_unpassed_orders(&b, se, &unpassed, &name, analysis::verdict::DEFAULT_ALPHA)
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
            &model.lambda_rho(analysis::inverse::views::truncation_lmax(a.lmax)),
            albedo,
            a.lmax,
            a.max_amplification,
        )
        .map_err(|e| if a.images.len() == 1 { e.in_file(&a.images[0]) } else { e })?;
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
        lmax: a.lmax,
        lmax_carried: p.lmax_carried,
        images: a.images.iter().map(|p| p.display().to_string()).collect(),
        method: p.method,
        brdf: name,
        lambda_rho: filter,
        albedo,
        max_amplification: a.max_amplification,
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
        output: a.output.as_ref().map(|p| p.display().to_string()),
        pixel_noise: p.noise,
        verdict,
        warnings,
    })
}

fn lighting_for_brdf(a: &BrdfArgs, d: &Observation) -> Result<(Lighting, String), Error> {
    lighting_of(a.lighting.as_deref(), a.mapping, d)?
        .ok_or_else(|| Error::file(&a.images[0], "no reflect:lighting in the header: pass --lighting or --scene"))
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
    /// The image against the re-prediction of the recovered model (`analysis::verdict::of_model_fit`):
    /// χ² of the measured filter against the model at the fitted parameter, per channel with its ν
    /// and p, Šidák over the channels at α = 1 %; null when the fit has no weights (no error estimate)
    /// or no degrees of freedom.
    pub verdict: Option<analysis::verdict::Verdict>,
    pub warnings: Vec<String>,
}

/// `reflect invert brdf` as a library call: the report, or an error naming the file and problem.
pub fn invert_brdf_report(a: &BrdfArgs) -> Result<InvertBrdfReport, Error> {
    let p = project(&a.images, &a.view, a.lmax, |_| Param::Reflection)?;
    let model = match a.model {
        FitModel::Phong => Model::Phong,
        FitModel::TorranceSparrow => Model::TorranceSparrow { theta_o: p.theta_o },
        FitModel::Microfacet => Model::Microfacet { distribution: a.distribution, theta_o: p.theta_o },
    };
    let (dlo, dhi) = model.default_range();
    let range = (a.min.unwrap_or(dlo), a.max.unwrap_or(dhi));
    let (lighting, source) = lighting_for_brdf(a, &p.described)?;
    // Two orders beyond l_max estimate the truncation bias of the pixel-space filter fit.
    let l_hi = lighting.coefficients(analysis::inverse::views::truncation_lmax(a.lmax))?;
    let l = l_hi[..analysis::sh::num_coefficients(a.lmax)].to_vec();
    let in_first = |e: Error| if a.images.len() == 1 { e.in_file(&a.images[0]) } else { e };
    // Orthographic views: the filter is fitted in pixel space (the one fit `analyze` prints:
    // conditioning from the design, truncation, χ²), not B_lm / L_lm, which is wrong on part of
    // the sphere; the model is then fitted by GLS to it with its covariance ⊕ truncation².
    if let Some((samples, have_sigma)) = &p.samples {
        let pf = fit_filter_pixels(samples, *have_sigma, p.noise.as_ref().map_or(1.0, |n| n.inflation), &l_hi, a.lmax)
            .map_err(in_first)?;
        let mut r = brdf_report_from_pixel_fit(a, p.lmax_carried, p.method, source, model, range, pf)?;
        r.warnings.splice(0..0, p.described.stderr_notes.iter().chain(&p.described.warnings).cloned());
        r.warnings.extend(p.noise.as_ref().and_then(|n| n.warning()));
        r.pixel_noise = p.noise;
        return Ok(r);
    }
    let est = estimate_transfer(&p.b, p.stderr.as_deref(), &l, a.lmax)?;
    // A normal-probe image with a stderr layer gives the full covariance of the per-order
    // estimates: they are correlated (≈ 0.85 between adjacent orders under a directional source),
    // and so are the channels (the same paths), so each channel is fitted by generalised least
    // squares on its own and the channel with the narrowest interval is reported.
    let cov = if p.probe {
        transfer_covariance_probe(&p.first, &l, a.lmax).map_err(|e| e.in_file(&a.images[0]))?
    } else {
        None
    };
    let (fit, how, per_channel) = match cov {
        Some(cov) => {
            let mut fits = Vec::new();
            for (ch, cv) in cov.iter().enumerate() {
                let orders: Vec<usize> = est.iter().filter(|o| o.estimate[ch].is_some()).map(|o| o.l).collect();
                if orders.len() < 2 {
                    continue;
                }
                let f: Vec<f64> = orders.iter().map(|&l| est[l].estimate[ch].unwrap_or(0.0)).collect();
                let n = a.lmax + 1;
                let sub: Vec<f64> = orders.iter().flat_map(|&i| orders.iter().map(move |&j| cv[i * n + j])).collect();
                fits.push((ch, fit_model_gls(&orders, &f, &sub, model, Some(range))?));
            }
            let (ch, fit) =
                narrowest(&fits).ok_or_else(|| Error::new("no channel has two observable orders to fit"))?;
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
    let notes = p.described.stderr_notes.clone();
    Ok(brdf_report(a, (p.lmax_carried, p.method, source), &fit, how, per_channel, filter.collect(), None, notes))
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
    a: &BrdfArgs,
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
        fit.p_value().and(analysis::verdict::of_model_fit(
            &[("all", fit.chi2_min, fit.dof)],
            &described,
            analysis::verdict::DEFAULT_ALPHA,
            fit.weighted_by_stderr,
        ))
    } else {
        let per: Vec<(&str, f64, i64)> = channels.iter().map(|c| (c.channel.as_str(), c.chi2_min, c.dof)).collect();
        let have_sigma = filter_fit.as_ref().is_none_or(|f| f.channels.iter().any(|c| c.p_value.is_some()));
        analysis::verdict::of_model_fit(
            &per,
            &format!("the {} model fitted per channel", model.name()),
            analysis::verdict::DEFAULT_ALPHA,
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
        lmax: a.lmax,
        lmax_carried,
        images: a.images.iter().map(|p| p.display().to_string()).collect(),
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
    }
}

/// `invert brdf` on orthographic views: the model fitted per channel by generalised least squares
/// to the pixel-space filter `pf` ([`fit_filter_pixels`]) at its determined orders, with the fit's
/// covariance plus the estimated truncation bias² on the diagonal (a bias of unknown sign, treated
/// as an independent error per order); the channel with the narrowest interval is reported, as
/// for a normal probe. Ill-conditioned orders are left out of the model fit (said in a warning).
fn brdf_report_from_pixel_fit(
    a: &BrdfArgs,
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
    let (ch, fit) = narrowest(&fits)
        .ok_or_else(|| Error::new("no channel has two determined filter orders to fit the model to"))?;
    for (c, f) in &fits {
        if let Some(p) = f.p_value().filter(|&p| p < analysis::fit::MISMATCH_P) {
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
    Ok(brdf_report(a, (lmax_carried, method, source), &fit, how, channel_fits(&fits), filter, filter_fit, warnings))
}

/// The pixel-space filter fit behind `invert brdf` on orthographic views (the one `analyze`
/// prints): per order its noise, truncation, amplification and status; per channel χ², ν, p-value
/// and covariance.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FilterFitReport {
    pub orders: Vec<PixelOrder>,
    pub channels: Vec<ChannelFit>,
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

fn fmt_opt(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite()).map_or("—".to_string(), |x| format!("{x:.4e}"))
}

/// A standard error with the two digits it has.
fn fmt_se(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite()).map_or("—".to_string(), |x| format!("{x:.1e}"))
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

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::image::read_image;
    use serde_json::{Value, json};
    use vocab::BrdfKind;

    /// The reports as JSON values, as `--json` prints them.
    fn lighting_doc(a: &LightingArgs) -> Result<Value, Error> {
        invert_lighting_report(a).map(|r| serde_json::to_value(r).unwrap())
    }
    fn brdf_doc(a: &BrdfArgs) -> Result<Value, Error> {
        invert_brdf_report(a).map(|r| serde_json::to_value(r).unwrap())
    }
    use analysis::sh::{Reconstructor, index, latlong_direction, num_coefficients};
    use std::path::Path;

    /// `invert brdf IMAGE --model phong --lmax L --json`.
    fn phong_args(image: PathBuf, lmax: usize) -> BrdfArgs {
        BrdfArgs {
            images: vec![image],
            lighting: None,
            mapping: None,
            model: FitModel::Phong,
            distribution: vocab::Distribution::Beckmann,
            view: ViewArgs::default(),
            lmax,
            min: None,
            max: None,
            json: true,
        }
    }

    fn tmp(name: &str) -> PathBuf {
        crate::cli::test_path("invert", name)
    }

    /// A normal-probe image (θ_o = 0) of B = k Λ_l ρ̂_l L_lm, exactly band-limited.
    fn probe(path: &Path, l: &[[f64; 3]], f: &[f64], k: [f64; 3], brdf: &str) {
        let lmax = analysis::sh::lmax_of(l.len()).unwrap();
        let b = analysis::predict::predict(l, f, k);
        let (w, h) = (256, 128);
        let mut rec = Reconstructor::new(lmax);
        let mut img = Image { width: w, height: h, ..Default::default() };
        let px: Vec<[f64; 3]> = (0..w * h).map(|i| rec.eval(&b, latlong_direction(i / w, i % w, w, h))).collect();
        for (ch, n) in ["R", "G", "B"].iter().enumerate() {
            img.channels.insert(n.to_string(), px.iter().map(|p| p[ch] as f32).collect());
        }
        img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
        img.attributes.insert("reflect:lighting".into(), json!({"type": "sh", "coefficients": l}).to_string());
        img.attributes.insert(
            "reflect:objects".into(),
            format!(r#"[{{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{brdf}}}]"#),
        );
        write_exr(path, &img).unwrap();
    }

    fn lighting_args(images: Vec<PathBuf>, lmax: usize) -> LightingArgs {
        LightingArgs {
            images,
            brdf: BrdfFlags::default(),
            view: ViewArgs::default(),
            lmax,
            max_amplification: DEFAULT_MAX_AMPLIFICATION,
            lambda_rule: LambdaRule::Gcv,
            output: None,
            width: 64,
            json: true,
        }
    }

    #[test]
    fn lambert_probe_recovers_low_orders_and_flags_the_rest() {
        let lmax = 6;
        let l: Vec<[f64; 3]> = (0..num_coefficients(lmax)).map(|k| [1.0 / (1.0 + k as f64), 0.5, 0.2]).collect();
        let path = tmp("lambert.exr");
        probe(&path, &l, &analysis::transfer::lambert::lambert(lmax), [0.5; 3], r#"{"type":"lambert","albedo":0.5}"#);
        let mut a = lighting_args(vec![path.clone()], lmax);
        a.output = Some(tmp("env.exr"));
        let doc = lighting_doc(&a).unwrap();
        let status: Vec<&str> =
            doc["orders"].as_array().unwrap().iter().map(|o| o["status"].as_str().unwrap()).collect();
        assert_eq!(
            status,
            [
                "recovered",
                "recovered",
                "recovered",
                "unobservable",
                "ill-conditioned",
                "unobservable",
                "ill-conditioned"
            ]
        );
        // Midpoint lat-long quadrature (256×128) errs (and aliases higher orders) by
        // O((π l_max/H)²/24) ≈ 3e-5 l_max² ≈ 1e-3 of B_00 (l_max = 6); inversion amplifies that by
        // 1/(albedo Λ_l ρ̂_l). Measured: worst 2.4e-4 at (2, 0). Able to fail: a wrong albedo
        // (--albedo 1) halves them.
        let f = analysis::transfer::lambert::lambert(lmax);
        for k in 0..9 {
            let got = doc["coefficients"][k][0].as_f64().unwrap();
            let tol = 1e-3 * 0.5 * l[0][0] / (0.5 * f[analysis::sh::lm(k).0]);
            assert!((got - l[k][0]).abs() < tol, "k={k}: {got} vs {} (tol {tol})", l[k][0]);
        }
        assert!(doc["coefficients"][index(3, 1)].is_null());
        let env = read_image(tmp("env.exr")).unwrap();
        assert_eq!((env.width, env.height), (64, 32));
        // The written map is the regularised lighting: projected back into SH it returns the
        // regularised coefficients. At 256 × 128 the midpoint rule's error is
        // O((π l_max / H)² / 24) ≈ 9e-4 of the largest coefficient (l_max = 6); 2e-3 allows for
        // the f32 pixels and aliasing of nothing (the map is band-limited to l_max).
        a.width = 256;
        lighting_doc(&a).unwrap();
        let back = analysis::projection::project_envmap(
            &analysis::image::read_rgb(tmp("env.exr")).unwrap(),
            analysis::projection::Mapping::LatLong,
            lmax,
        )
        .unwrap();
        let reg = &doc["regularised"]["coefficients"];
        let scale = reg[0][0].as_f64().unwrap().abs();
        for (k, b) in back.iter().enumerate() {
            for ch in 0..3 {
                let r = reg[k][ch].as_f64().unwrap();
                assert!((b[ch] - r).abs() < 2e-3 * scale, "k={k} ch={ch}: map {} vs regularised {r}", b[ch]);
            }
        }
        a.width = 64;
        a.brdf.albedo = Some([1.0; 3]);
        a.output = None;
        // The header says albedo 0.5: --albedo 1 contradicts it, an error naming both values ...
        let e = lighting_doc(&a).unwrap_err().to_string();
        assert!(e.contains("--albedo 1,1,1") && e.contains("0.5,0.5,0.5"), "{e}");
        // ... and on the same image without reflect:objects the flags are taken: albedo 1 halves L_lm.
        let mut bare = read_image(&path).unwrap();
        bare.attributes.remove("reflect:objects");
        write_exr(tmp("lambert-bare.exr"), &bare).unwrap();
        a.images = vec![tmp("lambert-bare.exr")];
        a.brdf.brdf = Some(BrdfKind::Lambert);
        let wrong = lighting_doc(&a).unwrap();
        assert!((wrong["coefficients"][0][0].as_f64().unwrap() - 0.5 * l[0][0]).abs() < 1e-3);
        // Bad input: absurd width, a BRDF without a transfer model (unknown names and rules are
        // refused by clap, tests/cli_errors.rs).
        a.output = Some(tmp("x.exr"));
        a.width = 3;
        assert!(lighting_doc(&a).is_err());
        a.output = None;
        a.brdf.brdf = Some(BrdfKind::Microfacet);
        assert!(lighting_doc(&a).is_err());
    }

    #[test]
    fn phong_probe_under_a_directional_source_fits_s() {
        let lmax = 12;
        let mut l = vec![[0.0; 3]; num_coefficients(lmax)];
        for o in 0..=lmax {
            l[index(o, 0)] = [1.0 / analysis::sh::lambda(o); 3];
        }
        let s = 24.0;
        let path = tmp("phong.exr");
        probe(&path, &l, &analysis::transfer::phong::phong(s, lmax), [0.8; 3], r#"{"type":"phong","s":24,"ks":0.8}"#);
        let a = phong_args(path.clone(), lmax);
        let doc = brdf_doc(&a).unwrap();
        // No stderr layer: unit weights rescaled by the residual scatter. The only error is the
        // quadrature's, ≈ 3e-5 l² relative (1/2 % at l = 12); d ln Λρ̂_l / d ln s ≈ l²/2s ≈ 3 there,
        // so ŝ within 1 % and k̂_s within 1 %.
        let est = doc["estimate"].as_f64().unwrap();
        assert!((est - s).abs() < 1e-2 * s, "{est}");
        assert!((doc["scale"][0].as_f64().unwrap() - 0.8).abs() < 0.008);
    }

    #[test]
    fn correlated_order_estimates_give_honest_intervals() {
        // A Phong probe under a directional source at the pole with noise proportional to the
        // signal (as a render's: it concentrates near the pole), the same in R, G, B (grey paths,
        // fully correlated channels). The GLS interval of one channel must match the spread of ŝ
        // over 40 seeds (summing the three channels' χ² as if independent would make it √3 too
        // narrow).
        let lmax = 12;
        let mut l = vec![[0.0; 3]; num_coefficients(lmax)];
        for o in 0..=lmax {
            l[index(o, 0)] = [1.0 / analysis::sh::lambda(o); 3];
        }
        let s_true = 32.0;
        let b = analysis::predict::predict(&l, &analysis::transfer::phong::phong(s_true, lmax), [1.0; 3]);
        let (w, h) = (128, 64);
        let mut rec = Reconstructor::new(lmax);
        let clean: Vec<f64> = (0..w * h).map(|i| rec.eval(&b, latlong_direction(i / w, i % w, w, h))[0]).collect();
        let bmax = clean.iter().fold(0.0f64, |a, v| a.max(*v));
        let mut rng = renderer::sampling::chi2::TestRng::new(11);
        let mut gauss = || {
            let u1 = ((rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64).max(1e-300);
            let u2 = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        };
        let (mut est, mut half) = (vec![], vec![]);
        for trial in 0..40 {
            let sigma: Vec<f64> = clean.iter().map(|v| 0.05 * v.max(0.0) / bmax + 1e-3).collect();
            let noisy: Vec<f64> = clean.iter().zip(&sigma).map(|(v, s)| v + s * gauss()).collect();
            let mut img = Image { width: w, height: h, ..Default::default() };
            for n in ["R", "G", "B"] {
                img.channels.insert(n.to_string(), noisy.iter().map(|v| *v as f32).collect());
                img.channels.insert(format!("stderr.{n}"), sigma.iter().map(|v| *v as f32).collect());
            }
            img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
            img.attributes.insert("reflect:lighting".into(), json!({"type": "sh", "coefficients": l}).to_string());
            img.attributes.insert(
                "reflect:objects".into(),
                r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"phong","s":32,"ks":1}}]"#.into(),
            );
            let path = tmp(&format!("noisy{trial}.exr"));
            write_exr(&path, &img).unwrap();
            let a = phong_args(path.clone(), lmax);
            let doc = brdf_doc(&a).unwrap();
            assert!(doc["fit"].as_str().unwrap().starts_with("generalised"), "{}", doc["fit"]);
            assert_eq!(doc["channels"].as_array().unwrap().len(), 3);
            est.push(doc["estimate"].as_f64().unwrap());
            half.push(0.5 * (doc["interval"][1].as_f64().unwrap() - doc["interval"][0].as_f64().unwrap()));
            let _ = std::fs::remove_file(&path);
        }
        let n = est.len() as f64;
        let mean = est.iter().sum::<f64>() / n;
        let sd = (est.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let hw = half.iter().sum::<f64>() / n;
        // 40 trials: the sample sd is within ±11 % (1σ) of the true one; 35 % is ≈ 3σ.
        assert!((sd / hw - 1.0).abs() < 0.35, "spread {sd} vs GLS half-width {hw}");
        // The mean is ŝ of the noise-free image (same weights) up to 4 standard errors; that one
        // differs from s by the 128 × 64 quadrature's bias (≈ 1e-4 l² relative in Λ_l ρ̂_l at
        // l ≤ 12, which moves ŝ by a few 0.1 %; bounded here at 1 %).
        let clean_fit = {
            let mut img = Image { width: w, height: h, ..Default::default() };
            let sigma: Vec<f32> = clean.iter().map(|v| (0.05 * v.max(0.0) / bmax + 1e-3) as f32).collect();
            for n in ["R", "G", "B"] {
                img.channels.insert(n.to_string(), clean.iter().map(|v| *v as f32).collect());
                img.channels.insert(format!("stderr.{n}"), sigma.clone());
            }
            img.attributes.insert("reflect:camera".into(), r#"{"type":"normal-probe","theta_o_deg":0}"#.into());
            img.attributes.insert("reflect:lighting".into(), json!({"type": "sh", "coefficients": l}).to_string());
            img.attributes.insert(
                "reflect:objects".into(),
                r#"[{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{"type":"phong","s":32,"ks":1}}]"#.into(),
            );
            let path = tmp("clean.exr");
            write_exr(&path, &img).unwrap();
            let a = phong_args(path, lmax);
            brdf_doc(&a).unwrap()["estimate"].as_f64().unwrap()
        };
        assert!((clean_fit / s_true - 1.0).abs() < 1e-2, "quadrature bias {clean_fit}");
        assert!((mean - clean_fit).abs() < 4.0 * sd / n.sqrt(), "mean {mean} vs noise-free {clean_fit} (sd {sd})");
    }
}
