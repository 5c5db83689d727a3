//! `reflect invert separate DIFFUSE.exr SPECULAR.exr… [--kd X --ks Y] [--lmax L] [--channel r|g|b]
//! [--scan] [--output ENV.exr --width W] [--json]`: diffuse + specular separation (sec. 3.5, the
//! algorithm of reference \[17\]; library `analysis::inverse::separation`).
//!
//! The surface is ρ̂ = k_d · lambert (unit albedo) + k_s · mirror (unit k_r). The inputs are
//! `normal-probe` renders of it (docs/src/conventions.md §6; with the `reflect:camera` header, or another
//! renderer's described by `--theta-o/--phi-o` per image or a `--scene` sidecar, as in every analysis
//! command, [`super::header::load`]): the *diffuse
//! view* first, at normal exitance θ_o = 0 (R = n), which gives the 9 low-order lighting
//! coefficients L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2; then one or more *specular views* at
//! θ_o > 0 and φ_o ∈ {0°, 180°} (R ≠ n; the two azimuths together cover the sphere of R), from
//! which the 9-term diffuse part (eq. 38–39) is subtracted and the rest fitted as a gazing sphere:
//! the lighting L_lm, l ≤ `lmax`, by least squares weighted by the pixels' exact solid angles about
//! R (`probe_samples`). The consistency d_lm = L̂_lm − c_lm (l ≤ 2) with its χ² (9 dof) tests the
//! split and the 9-term approximation; `--scan` scans the diffuse fraction k_d / (k_d + k_s) at
//! fixed k_d + k_s for the χ² minimum (how \[17\] fixes the split).
//!
//! Parameters: `--kd`, `--ks` (one number or r,g,b; default: the header's BRDF when it is a `mix`
//! of one `lambert` and one `mirror` layer, k_d = weight × albedo, k_s = weight × k_r; else the
//! `--scene` sidecar's), `--lmax`
//! (default 8, at most [`MAX_LMAX`] and 2(lmax + 1) ≤ H), `--channel` (default all three; JSON
//! coefficients are then `[r, g, b]` triples, else numbers of the one channel), `--scan`,
//! `--output` (the recovered lighting as a W × W/2 lat-long EXR, reconstructed from its SH, one
//! channel replicated to R, G, B) and `--width`, `--json`.
//! Standard errors come from the renders' `stderr.R/G/B` layers; without them (another renderer's
//! images) the noise is estimated from the residuals, as `analyze` and `invert` do: the residual
//! variance σ̂² = Σ_p r_p²/ν of the diffuse view's fit (SH up to `lmax` at n) for its pixels and of
//! the specular views' fit (SH up to `lmax` at R plus the harmonics 1 ≤ l ≤ 2 at n, so whatever the
//! split) for theirs (stated in the output). Both fits are reported with their χ²/ν and p-value
//! when the layers give σ (`fits`); their views cover the whole sphere of the fitted directions, so
//! orders above `lmax` bias no coefficient (up to the grid's aliasing) and no truncation term is
//! added: their power is in the residuals. The output also predicts the 9-term residual's share of d from the recovered
//! lighting's orders 3…lmax (fitted at R as in the algorithm) and gives the χ² with it removed,
//! so that a large χ² at the right split can be told apart from a wrong split.

use super::Error;
use super::args::{Channel, ImageArgs};
use super::outputs::{Files, Format};
use analysis::image::{Image, RgbImage, write_exr};
use analysis::inverse::separation::{
    LOW, ResidualFit, Samples, Separated, Separation, best_split, fit_residuals, nine_term_residual, probe_samples,
};
use analysis::observation::Camera;
use analysis::projection::resolution::{
    LATLONG_REFLECTION_RULE, check_latlong, check_order, latlong_max_order_reflection,
};
use analysis::sh::{ShBasis, lm, num_coefficients, reconstruct_latlong};
use renderer::sampling::chi2::chi2_survival;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Highest order of the recovered lighting: the least squares costs O(pixels · (lmax+1)⁴).
pub const MAX_LMAX: usize = 32;
/// P(χ²_9 ≥ χ²) below which the two sides are called inconsistent: the one mismatch threshold of
/// every fit, `analysis::fit::MISMATCH_P` (between it and `analysis::fit::MARGINAL_P`: "marginal").
pub const P_CONSISTENT: f64 = analysis::fit::MISMATCH_P;
const CHANNELS: [&str; 3] = ["R", "G", "B"];

#[derive(clap::Args, Debug)]
pub struct SeparateArgs {
    /// normal-probe renders (OpenEXR): the diffuse view at θ_o = 0 first, then specular views at
    /// θ_o > 0 and φ_o = 0 or 180 (both azimuths together cover the sphere).
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Weight k_d of the unit-albedo lambert part (one number, or r,g,b; default: the header's mix).
    #[arg(long, value_parser = super::flags::parse_rgb)]
    pub kd: Option<[f64; 3]>,
    /// Weight k_s of the unit mirror part (one number, or r,g,b; default: the header's mix).
    #[arg(long, value_parser = super::flags::parse_rgb)]
    pub ks: Option<[f64; 3]>,
    /// Highest SH order of the recovered lighting.
    #[arg(long, default_value_t = 8, value_parser = super::flags::parse_lmax, allow_hyphen_values = true)]
    pub lmax: usize,
    /// Analyse only this channel (default: all three).
    #[arg(long, value_enum)]
    pub channel: Option<Channel>,
    /// Scan the diffuse fraction k_d/(k_d+k_s) at fixed k_d + k_s for the consistency χ² minimum.
    #[arg(long)]
    pub scan: bool,
    /// Write the recovered lighting as a lat-long EXR.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Width of the --output map (height = width / 2).
    #[arg(long, default_value_t = 256, value_parser = super::flags::parse_width, allow_hyphen_values = true)]
    pub width: usize,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
    /// How images without a reflect:camera header are described: --theta-o/--phi-o per image, or a
    /// sidecar --scene whose normal-probe camera and mix BRDF they are renders of; --layer.
    #[command(flatten)]
    pub view: ImageArgs,
}

pub fn run(a: &SeparateArgs) -> Result<ExitCode, Error> {
    let r = separate_report(a)?;
    if a.json {
        println!("{}", serde_json::to_string(&r).map_err(|e| Error::new(format!("JSON output: {e}")))?);
    } else {
        print!("{r}");
    }
    Ok(ExitCode::SUCCESS)
}

/// One normal-probe render.
struct View {
    path: PathBuf,
    theta_o_deg: f64,
    phi_o_deg: f64,
    rgb: RgbImage,
    stderr: Option<RgbImage>,
}

/// One normal-probe view from an image and its described camera ([`super::header::load`]).
fn read_view(p: &Path, img: &Image, cam: &Camera) -> Result<View, Error> {
    let (theta_o_deg, phi_o_deg) = match *cam {
        Camera::NormalProbe { theta_o_deg, phi_o_deg } => (theta_o_deg, phi_o_deg),
        Camera::Ortho(_) => {
            return Err(Error::file(
                p,
                "not a normal-probe render (an orthographic camera): separation needs normal-probe views",
            ));
        }
    };
    let rgb = img.rgb().ok_or_else(|| Error::file(p, "no R, G, B channels"))?;
    if rgb.width != 2 * rgb.height || rgb.height < 4 {
        return Err(Error::file(
            p,
            format!("a normal-probe image is a lat-long map with W = 2H ≥ 8, this one is {}×{}", rgb.width, rgb.height),
        ));
    }
    let stderr = img.stderr_layer().map_err(|e| e.in_file(p))?;
    Ok(View { path: p.to_path_buf(), theta_o_deg, phi_o_deg, rgb, stderr })
}

/// Where the BRDF table came from, in the words of `split_source`: "the first image's header" or
/// "the [[objects]] of S.toml" (`--scene`).
fn table_source(brdf: &Option<(Value, &String)>) -> String {
    match brdf {
        Some((_, src)) if src.starts_with("the header") => "the first image's header".to_string(),
        Some((_, src)) => src.to_string(),
        None => "the header".to_string(),
    }
}

/// (k_d, k_s) of a header BRDF that is a `mix` of exactly one lambert and one mirror layer.
fn header_split(brdf: &Value) -> Option<([f64; 3], [f64; 3])> {
    if brdf.get("type")?.as_str()? != "mix" {
        return None;
    }
    let layers = brdf.get("layers")?.as_array()?;
    if layers.len() != 2 {
        return None;
    }
    let (mut kd, mut ks) = (None, None);
    for layer in layers {
        let w = layer.get("weight")?.as_f64()?;
        let b = layer.get("brdf")?;
        match b.get("type")?.as_str()? {
            "lambert" if kd.is_none() => kd = Some(json_rgb(b.get("albedo"))?.map(|a| w * a)),
            // k_r defaults to 1 (docs/src/conventions.md §4).
            "mirror" if ks.is_none() => ks = Some(json_rgb(b.get("kr")).unwrap_or([1.0; 3]).map(|k| w * k)),
            _ => return None,
        }
    }
    Some((kd?, ks?))
}

/// A colour as the scene format writes it: one number (grey) or `[r, g, b]`.
fn json_rgb(v: Option<&Value>) -> Option<[f64; 3]> {
    match v {
        Some(Value::Number(n)) => n.as_f64().map(|x| [x; 3]),
        Some(Value::Array(a)) if a.len() == 3 => {
            let o = [0, 1, 2].map(|i| a[i].as_f64());
            o.iter().all(|x| x.is_some()).then(|| o.map(|x| x.unwrap_or(0.0)))
        }
        _ => None,
    }
}

/// A flag `--kd` / `--ks` and a header's or scene's mix (`source` says which) that give different
/// weights contradict each other: an error naming both, as for every described quantity
/// ([`super::header::describe`]).
fn check_weight(arg: Option<[f64; 3]>, header: Option<[f64; 3]>, flag: &str, source: &str) -> Result<(), Error> {
    if let (Some(v), Some(h)) = (arg, header)
        && !(0..3).all(|i| analysis::observation::close(v[i], h[i], 1.0))
    {
        let sym = if flag == "kd" { "k_d" } else { "k_s" };
        return Err(Error::new(format!(
            "--{flag} {} but {source} gives {sym} = {} (its mix of lambert and mirror): they contradict each other",
            analysis::observation::v3(v),
            analysis::observation::v3(h)
        )));
    }
    Ok(())
}

/// A per-channel weight from `--kd` / `--ks` (one number or r,g,b), else the header's.
fn weight_arg(arg: Option<[f64; 3]>, header: Option<[f64; 3]>, flag: &str) -> Result<([f64; 3], bool), Error> {
    match arg {
        Some(v) => Ok((v, true)),
        None => header.map(|h| (h, false)).ok_or_else(|| {
            Error::new(format!(
                "--{flag} is required: the first image's header (or --scene) BRDF is not a mix of one lambert and one mirror layer (pass --kd and --ks)"
            ))
        }),
    }
}

/// The split scan of one channel: (fraction, χ²) on the coarse grid, and the refined minimum.
type Scan = (Vec<(f64, f64)>, Option<(f64, f64)>);

/// Separation of one channel.
struct ChannelResult {
    sep: Separated,
    scan: Option<Scan>,
    /// The 9-term residual's predicted share of d (eq. 38–39), estimated from the recovered
    /// lighting's orders 3…lmax, and the χ² of d minus it.
    residual_d: Vec<f64>,
    chi2_residual_removed: Option<f64>,
    /// The diffuse view's and the specular views' residual fits ([`fit_residuals`]).
    fits: [ResidualFit; 2],
}

fn validate(a: &SeparateArgs) -> Result<Vec<usize>, Error> {
    if let Some(out) = &a.output {
        let files = Files::new().inputs("the image", &a.images).inputs("the scene", &a.view.scene);
        files.output("--output", out, Format::Exr).check()?;
    }
    if a.images.len() < 2 {
        return Err(Error::new("separation needs the diffuse view (θ_o = 0) and at least one specular view (θ_o > 0)"));
    }
    if a.lmax > MAX_LMAX {
        return Err(Error::new(format!("--lmax {} is above the supported maximum {MAX_LMAX} for separation", a.lmax)));
    }
    if a.output.is_some() && !(a.width >= 4 && a.width.is_multiple_of(2) && a.width <= 16384) {
        return Err(Error::new(format!("--width must be even and in [4, 16384], got {}", a.width)));
    }
    if let Some(out) = &a.output {
        // The written map must carry every order it is reconstructed from.
        check_latlong(a.lmax, a.width, a.width / 2, "--output map (--width)").map_err(|e| e.in_file(out))?;
    }
    Ok(match a.channel {
        None => vec![0, 1, 2],
        Some(c) => vec![c.index()],
    })
}

/// The separation of `a.images` (see the module docs): the report `--json` prints. Errors: bad
/// input (named file and problem), or a separation the views cannot solve.
pub fn separate_report(a: &SeparateArgs) -> Result<InvertSeparateReport, Error> {
    let channels = validate(a)?;
    let (images, described) = super::header::load(&a.images, &a.view.view(), "separated")?;
    let mut views = Vec::with_capacity(a.images.len());
    let header_brdf = described.brdf.as_ref().map(|(b, src)| (serde_json::to_value(b).unwrap_or_default(), src));
    for (i, ((p, img), cam)) in a.images.iter().zip(&images).zip(&described.cameras).enumerate() {
        let v = read_view(p, img, cam)?;
        if i == 0 {
            if v.theta_o_deg != 0.0 {
                return Err(Error::file(
                    p,
                    format!(
                        "the diffuse view (the first image) must be at normal exitance θ_o = 0, this render is at θ_o = {}° (give the θ_o = 0 render first)",
                        v.theta_o_deg
                    ),
                ));
            }
        } else {
            if v.theta_o_deg == 0.0 {
                return Err(Error::file(
                    p,
                    "a specular view must be at θ_o > 0 (at θ_o = 0 R = n and the consistency holds for any split)",
                ));
            }
            let phi = v.phi_o_deg.rem_euclid(360.0);
            if phi != 0.0 && phi != 180.0 {
                return Err(Error::file(
                    p,
                    format!(
                        "a specular view must be at φ_o = 0° or 180° (R on the normal's meridian), this render is at φ_o = {}°",
                        v.phi_o_deg
                    ),
                ));
            }
            let first: &View = &views[0];
            if (v.rgb.width, v.rgb.height) != (first.rgb.width, first.rgb.height) {
                return Err(Error::file(
                    p,
                    format!(
                        "image size {}×{} differs from the diffuse view's {}×{}",
                        v.rgb.width, v.rgb.height, first.rgb.width, first.rgb.height
                    ),
                ));
            }
        }
        views.push(v);
    }
    let (w, h) = (views[0].rgb.width, views[0].rgb.height);
    // The specular views' pixels are attributed to R, which turns twice as fast as n.
    let carried = latlong_max_order_reflection(w, h);
    check_order(a.lmax, carried, &format!("a {w}×{h} specular view"), LATLONG_REFLECTION_RULE)
        .map_err(|e| e.in_file(&a.images[0]))?;
    let hs = header_brdf.as_ref().and_then(|(b, _)| header_split(b));
    let (kd, kd_arg) = weight_arg(a.kd, hs.map(|s| s.0), "kd")?;
    let (ks, ks_arg) = weight_arg(a.ks, hs.map(|s| s.1), "ks")?;
    for &c in &channels {
        if !(kd[c].is_finite() && kd[c] > 0.0 && ks[c].is_finite() && ks[c] > 0.0) {
            return Err(Error::new(format!(
                "k_d and k_s must be > 0, got k_d = {}, k_s = {} in channel {}",
                kd[c], ks[c], CHANNELS[c]
            )));
        }
    }
    // A value out of its domain is said first; then a flag against the header's or scene's mix.
    let first = |e: Error| e.in_file(&a.images[0]);
    check_weight(a.kd, hs.map(|s| s.0), "kd", &table_source(&header_brdf)).map_err(first)?;
    check_weight(a.ks, hs.map(|s| s.1), "ks", &table_source(&header_brdf)).map_err(first)?;
    let split_source = match (kd_arg, ks_arg) {
        (true, true) => "command line".to_string(),
        (false, false) => format!("{} (mix of lambert and mirror)", table_source(&header_brdf)),
        (true, false) => format!("k_d from the command line, k_s from {}", table_source(&header_brdf)),
        (false, true) => format!("k_s from the command line, k_d from {}", table_source(&header_brdf)),
    };
    let missing_stderr: Vec<String> =
        views.iter().filter(|v| v.stderr.is_none()).map(|v| v.path.display().to_string()).collect();
    let with_stderr = missing_stderr.is_empty();
    if with_stderr {
        // The layers weight the fits and their covariances are inverted (the χ²).
        for v in &views {
            if let Some(s) = &v.stderr {
                s.check_weights(&channels).map_err(|e| e.in_file(&v.path))?;
            }
        }
    }
    let sigma_source = if with_stderr {
        "the renders' stderr layers".to_string()
    } else {
        format!(
            "the residual variance σ̂² = Σ_p r_p²/ν of each side's fit (no stderr layer in {}): one σ̂ for the diffuse \
             view's pixels, one for the specular views' (the 'fits' below), as analyze and invert estimate a foreign \
             image's noise; lighting above l_max counts as noise there, so the bars and the consistency χ² are upper \
             and lower estimates respectively",
            missing_stderr.join(", ")
        )
    };

    // Separate each channel.
    let mut results = Vec::with_capacity(channels.len());
    for &c in &channels {
        let samples = |v: &View| {
            let value: Vec<f64> = v.rgb.pixels.iter().map(|p| p[c] as f64).collect();
            let sigma: Vec<f64> = match (&v.stderr, with_stderr) {
                (Some(s), true) => s.pixels.iter().map(|p| p[c] as f64).collect(),
                _ => vec![1.0; value.len()],
            };
            let flip = v.phi_o_deg.rem_euclid(360.0) == 180.0;
            probe_samples(&value, &sigma, w, h, v.theta_o_deg.to_radians(), flip)
        };
        let dif = samples(&views[0]);
        let mut spec = Samples::default();
        for v in &views[1..] {
            spec.append(samples(v));
        }
        let in_c = |e: analysis::Error| Error::new(format!("channel {}: {}", CHANNELS[c], e.message));
        let mut sep = Separation::new(&dif, &spec, a.lmax).map_err(in_c)?;
        // Each side's fit and its residuals: the diffuse view at n, the specular views at R with the
        // harmonics 1 ≤ l ≤ 2 at n (the diffuse part, whatever the split). With the stderr layers their χ²/ν
        // tests the fits; without, their residual variance is the noise (σ = 1 above, rescaled).
        let fits =
            [fit_residuals(&dif, a.lmax, false).map_err(in_c)?, fit_residuals(&spec, a.lmax, true).map_err(in_c)?];
        if !with_stderr {
            let var = |f: &ResidualFit, what: &str| {
                f.residual_variance().ok_or_else(|| {
                    Error::new(format!(
                        "channel {}: the {what} have no more pixels than fitted coefficients: no residual to estimate the noise from",
                        CHANNELS[c]
                    ))
                })
            };
            sep.scale_noise(var(&fits[0], "diffuse view")?, var(&fits[1], "specular views")?);
        }
        let solved = sep.solve(kd[c], ks[c])?;
        let scan = a.scan.then(|| {
            let total = kd[c] + ks[c];
            let coarse: Vec<f64> = (1..100).map(|i| i as f64 / 100.0).collect();
            let pts = sep.scan_split(total, &coarse);
            // Refine around the grid minimum (step 5e-4): the scan is cheap once the operators exist.
            let best = best_split(&pts).map(|(x0, _)| {
                let fine: Vec<f64> =
                    (-20..=20).map(|i| x0 + 5e-4 * i as f64).filter(|x| *x > 0.0 && *x < 1.0).collect();
                best_split(&sep.scan_split(total, &fine)).unwrap_or((x0, f64::NAN))
            });
            (pts, best)
        });
        // What the 9-term subtraction leaves (eq. 38–39): r(n) = (k_d/k_s) Σ_{l≥3} Λ_l ρ̂_l L_lm Y_lm(n),
        // with L_lm the recovered lighting, fitted at R by the same least squares (nothing
        // subtracted: k_d = 0, k_s = 1). By linearity it shifts d by −(its fit)_j, j < 9.
        let basis = ShBasis::new(a.lmax);
        let mut y = vec![0.0; num_coefficients(a.lmax)];
        let res = Samples {
            value: spec
                .normal
                .iter()
                .map(|&nn| nine_term_residual(&solved.specular, kd[c], ks[c], &basis, nn, &mut y))
                .collect(),
            sigma: vec![0.0; spec.len()],
            ..spec
        };
        let zero = Samples { value: vec![0.0; dif.len()], sigma: vec![0.0; dif.len()], ..dif };
        let r_fit = Separation::new(&zero, &res, a.lmax)?.solve(0.0, 1.0)?.specular;
        let residual_d: Vec<f64> = r_fit[..LOW].iter().map(|r| -r).collect();
        let removed: Vec<f64> = (0..LOW).map(|j| solved.consistency[j] - residual_d[j]).collect();
        let chi2_residual_removed = solved.chi2_of(&removed);
        results.push(ChannelResult { sep: solved, scan, residual_d, chi2_residual_removed, fits });
    }

    // Everything is computed: write the map last, so a failure leaves no partial output.
    let n = num_coefficients(a.lmax);
    if let Some(out) = &a.output {
        let coeffs: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                if results.len() == 3 {
                    [0, 1, 2].map(|c| results[c].sep.specular[k])
                } else {
                    [results[0].sep.specular[k]; 3]
                }
            })
            .collect();
        let (ow, oh) = (a.width, a.width / 2);
        let px = reconstruct_latlong(&coeffs, ow, oh);
        let mut img = Image { width: ow, height: oh, ..Default::default() };
        for (ch, name) in CHANNELS.iter().enumerate() {
            img.channels.insert(name.to_string(), px.iter().map(|p| p[ch] as f32).collect());
        }
        let what = if results.len() == 3 {
            "R, G, B".to_string()
        } else {
            format!("channel {} replicated to R, G, B", CHANNELS[channels[0]])
        };
        img.attributes
            .insert("reflect:lighting-source".into(), format!("invert separate (sec. 3.5), l <= {}, {what}", a.lmax));
        write_exr(out, &img)?;
    }

    let per = |len: usize, f: &dyn Fn(&ChannelResult, usize) -> f64| -> Vec<PerChannel<f64>> {
        (0..len).map(|k| PerChannel::of(results.iter().map(|r| f(r, k)).collect())).collect()
    };
    let one = |f: &dyn Fn(&ChannelResult) -> Option<f64>| -> PerChannel<Option<f64>> {
        PerChannel::of(results.iter().map(f).collect())
    };
    let pick = |v: [f64; 3]| PerChannel::of(channels.iter().map(|&c| v[c]).collect());
    let p_of = |c: Option<f64>| c.map(|c| chi2_survival(c, LOW as f64));
    let fit_report = |side: usize, description: &str| SideFit {
        description: description.into(),
        chi2: one(&|r| Some(r.fits[side].chi2)),
        dof: one(&|r| Some(r.fits[side].dof as f64)),
        chi2_per_dof: one(&|r| r.fits[side].chi2_per_dof().filter(|_| with_stderr)),
        p_value: one(&|r| r.fits[side].p_value().filter(|_| with_stderr)),
        residual_variance: one(&|r| r.fits[side].residual_variance()),
        pixels: one(&|r| Some(r.fits[side].samples as f64)),
    };
    let scan = a.scan.then(|| {
        channels
            .iter()
            .zip(&results)
            .map(|(&c, r)| {
                let (pts, best) = r.scan.as_ref().map(|(p, b)| (p.clone(), *b)).unwrap_or_default();
                SplitScan {
                    channel: CHANNELS[c].to_string(),
                    total: kd[c] + ks[c],
                    points: pts.iter().map(|(x, c)| [*x, *c]).collect(),
                    best_fraction: best.map(|b| b.0),
                    best_chi2: best.map(|b| b.1),
                    assumed_fraction: kd[c] / (kd[c] + ks[c]),
                }
            })
            .collect()
    });
    Ok(InvertSeparateReport {
        command: "invert separate".into(),
        lmax: a.lmax,
        lmax_carried: carried,
        lmax_carried_rule: LATLONG_REFLECTION_RULE.into(),
        channels: channels.iter().map(|&c| CHANNELS[c].to_string()).collect(),
        layout: if channels.len() == 3 {
            "per coefficient an [r, g, b] triple, index order k = l(l+1)+m".to_string()
        } else {
            format!("per coefficient a number of channel {}, index order k = l(l+1)+m", CHANNELS[channels[0]])
        },
        diffuse_view: DiffuseView { file: views[0].path.display().to_string(), theta_o_deg: 0.0 },
        specular_views: views[1..]
            .iter()
            .map(|v| SpecularView {
                file: v.path.display().to_string(),
                theta_o_deg: v.theta_o_deg,
                phi_o_deg: v.phi_o_deg,
            })
            .collect(),
        width: w,
        height: h,
        kd: pick(kd),
        ks: pick(ks),
        split_source,
        sigma_source,
        weighted_by_stderr: with_stderr,
        diffuse: DiffuseSide {
            description: "L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2, from the diffuse view".into(),
            coefficients: per(LOW, &|r, k| r.sep.diffuse[k]),
            stderr: per(LOW, &|r, k| r.sep.diffuse_se[k]),
        },
        coefficients: per(n, &|r, k| r.sep.specular[k]),
        stderr: per(n, &|r, k| r.sep.specular_se[k]),
        consistency: Consistency {
            description: "d_lm = L̂_lm − c_lm, l ≤ 2 (diffuse side minus recovered lighting)".into(),
            d: per(LOW, &|r, k| r.sep.consistency[k]),
            stderr: per(LOW, &|r, k| r.sep.consistency_se[k]),
            chi2: one(&|r| r.sep.chi2),
            dof: LOW,
            p_value: one(&|r| p_of(r.sep.chi2)),
            consistent: PerChannel::of(results.iter().map(|r| p_of(r.sep.chi2).map(|p| p >= P_CONSISTENT)).collect()),
            threshold_p: P_CONSISTENT,
            meaning: PerChannel::of(results.iter().map(|r| meaning(r.sep.chi2, with_stderr, a.lmax)).collect()),
            nine_term_residual: NineTermShare {
                description: "the share of d predicted from the 9-term subtraction's residual (eq. 38–39), \
                              estimated from the recovered lighting's orders 3..lmax, and the χ² of d minus it"
                    .into(),
                d: per(LOW, &|r, k| r.residual_d[k]),
                chi2_removed: one(&|r| r.chi2_residual_removed),
                p_value_removed: one(&|r| p_of(r.chi2_residual_removed)),
            },
        },
        fits: Fits {
            truncation: format!(
                "none added: each side's views cover the whole sphere of the fitted directions (n; R at φ_o = 0° and \
                 180°) with solid-angle weights, so the orders above l_max = {} are orthogonal to the fitted ones up to \
                 the grid's aliasing ({}): they bias no coefficient, and their power is in the residuals (the χ² with \
                 stderr layers, the noise estimate without)",
                a.lmax, LATLONG_REFLECTION_RULE
            ),
            diffuse: fit_report(0, "the diffuse view's pixels fitted by the SH up to l_max at n"),
            specular: fit_report(
                1,
                "the specular views' pixels fitted by the SH up to l_max at R plus the harmonics 1 ≤ l ≤ 2 at n (the \
                 diffuse part, any split)",
            ),
        },
        scan,
        output: a.output.as_ref().map(|p| p.display().to_string()),
    })
}

/// A plain statement of what the consistency χ² says.
fn meaning(chi2: Option<f64>, with_stderr: bool, lmax: usize) -> String {
    let Some(c) = chi2 else {
        return "χ² undefined (the consistency covariance is singular: noise-free data?)".into();
    };
    let p = chi2_survival(c, LOW as f64);
    // Without stderr layers σ̂ holds the lighting above l_max as well: a small χ² is weaker evidence.
    let noise = if with_stderr { "" } else { " (σ from the residual variance, an upper estimate of the noise)" };
    if (P_CONSISTENT..analysis::fit::MARGINAL_P).contains(&p) {
        format!(
            "marginal: the diffuse side's 9 low-order coefficients and the recovered lighting's agree within the noise{noise} at the {P_CONSISTENT:.0e} level but not at {:.2} (χ² = {c:.1}, P(χ²_9 ≥ χ²) = {p:.3}); worth a --scan of the split",
            analysis::fit::MARGINAL_P
        )
    } else if p >= P_CONSISTENT {
        format!(
            "consistent: the diffuse side's 9 low-order coefficients and the recovered lighting's agree within the noise{noise} at this split (χ² = {c:.1}, P(χ²_9 ≥ χ²) = {p:.2})"
        )
    } else {
        format!(
            "inconsistent: the two sides differ beyond the noise (χ² = {c:.1}, P(χ²_9 ≥ χ²) = {p:.1e}); the split k_d : k_s is wrong, or the 9-term diffuse subtraction's residual (eq. 38–39) or the aliasing of lighting above l = {lmax} exceeds the noise (--scan shows which split fits best)"
        )
    }
}

/// A value per analysed channel: with one `--channel` the value itself, with all three an
/// [r, g, b] triple (the JSON keeps that shape: numbers for one channel, triples for three).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum PerChannel<T> {
    One(T),
    Rgb(Vec<T>),
}

impl<T> PerChannel<T> {
    /// One value per analysed channel (in [`InvertSeparateReport::channels`] order).
    fn of(mut v: Vec<T>) -> PerChannel<T> {
        if v.len() == 1 { PerChannel::One(v.remove(0)) } else { PerChannel::Rgb(v) }
    }

    /// The values in channel order.
    pub fn cells(&self) -> &[T] {
        match self {
            PerChannel::One(x) => std::slice::from_ref(x),
            PerChannel::Rgb(v) => v,
        }
    }
}

impl std::fmt::Display for PerChannel<f64> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PerChannel::One(x) => write!(f, "{x}"),
            PerChannel::Rgb(v) => write!(f, "[{}]", v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", ")),
        }
    }
}

/// The diffuse view (the first image, θ_o = 0).
#[derive(Clone, Debug, serde::Serialize)]
pub struct DiffuseView {
    pub file: String,
    pub theta_o_deg: f64,
}

/// A specular view (θ_o > 0, φ_o ∈ {0°, 180°}).
#[derive(Clone, Debug, serde::Serialize)]
pub struct SpecularView {
    pub file: String,
    pub theta_o_deg: f64,
    pub phi_o_deg: f64,
}

/// The diffuse side's low-order lighting L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2 (index order).
#[derive(Clone, Debug, serde::Serialize)]
pub struct DiffuseSide {
    pub description: String,
    pub coefficients: Vec<PerChannel<f64>>,
    pub stderr: Vec<PerChannel<f64>>,
}

/// The share of d predicted from the 9-term subtraction's residual (eq. 38–39) and the χ² of d
/// minus it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NineTermShare {
    pub description: String,
    pub d: Vec<PerChannel<f64>>,
    pub chi2_removed: PerChannel<Option<f64>>,
    /// P(χ²_9 ≥ χ²) of `chi2_removed`; `None` without χ².
    pub p_value_removed: PerChannel<Option<f64>>,
}

/// The consistency d_lm = L̂_lm − c_lm, l ≤ 2, of the two sides and its χ² (9 dof).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Consistency {
    pub description: String,
    pub d: Vec<PerChannel<f64>>,
    pub stderr: Vec<PerChannel<f64>>,
    /// `None` when d's covariance is singular (noise-free data).
    pub chi2: PerChannel<Option<f64>>,
    pub dof: usize,
    /// P(χ²_9 ≥ χ²) (σ from the stderr layers, else the residual variance); `None` without χ².
    pub p_value: PerChannel<Option<f64>>,
    /// p ≥ `threshold_p`; `None` where there is no p-value.
    pub consistent: PerChannel<Option<bool>>,
    pub threshold_p: f64,
    /// A plain statement of what the χ² says, per channel.
    pub meaning: PerChannel<String>,
    pub nine_term_residual: NineTermShare,
}

/// One side's least-squares fit of its pixels ([`fit_residuals`]), per channel.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SideFit {
    pub description: String,
    /// χ² = Σ_p (r_p/σ_p)² against the stderr layers (against σ = 1 without them).
    pub chi2: PerChannel<Option<f64>>,
    /// ν = pixels − fitted coefficients.
    pub dof: PerChannel<Option<f64>>,
    /// χ²/ν with stderr layers; `None` without (σ̂² is then the noise estimate, χ²/ν = 1 by construction).
    pub chi2_per_dof: PerChannel<Option<f64>>,
    /// P(χ²_ν ≥ χ²) with stderr layers; `None` without.
    pub p_value: PerChannel<Option<f64>>,
    /// σ̂² = Σ_p r_p²/ν (radiance²): the noise estimate without stderr layers.
    pub residual_variance: PerChannel<Option<f64>>,
    pub pixels: PerChannel<Option<f64>>,
}

/// The two sides' fits and what is said of their truncation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Fits {
    /// Why no truncation term is added to the bars.
    pub truncation: String,
    pub diffuse: SideFit,
    pub specular: SideFit,
}

/// `--scan`: consistency χ² against the diffuse fraction k_d/(k_d+k_s) at fixed k_d + k_s.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SplitScan {
    pub channel: String,
    pub total: f64,
    /// (fraction, χ²) on the grid 0.01 … 0.99.
    pub points: Vec<[f64; 2]>,
    /// The minimum refined on a 5e-4 grid.
    pub best_fraction: Option<f64>,
    pub best_chi2: Option<f64>,
    pub assumed_fraction: f64,
}

/// The report of `reflect invert separate` (`--json` prints this struct; coefficient lists are in
/// index order k = l(l+1)+m, each entry a [`PerChannel`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct InvertSeparateReport {
    pub command: String,
    pub lmax: usize,
    /// Highest order the specular views' grid carries at R ([`LATLONG_REFLECTION_RULE`]).
    pub lmax_carried: Option<usize>,
    pub lmax_carried_rule: String,
    pub channels: Vec<String>,
    pub layout: String,
    pub diffuse_view: DiffuseView,
    pub specular_views: Vec<SpecularView>,
    pub width: usize,
    pub height: usize,
    pub kd: PerChannel<f64>,
    pub ks: PerChannel<f64>,
    pub split_source: String,
    pub sigma_source: String,
    pub weighted_by_stderr: bool,
    pub diffuse: DiffuseSide,
    /// The recovered lighting L_lm, l ≤ `lmax` (the specular side).
    pub coefficients: Vec<PerChannel<f64>>,
    pub stderr: Vec<PerChannel<f64>>,
    pub consistency: Consistency,
    /// Each side's fit quality (χ²/ν and p with stderr layers) and noise estimate.
    pub fits: Fits,
    pub scan: Option<Vec<SplitScan>>,
    /// The lat-long map written by `--output`.
    pub output: Option<String>,
}

fn table(
    f: &mut std::fmt::Formatter<'_>,
    title: &str,
    channels: &[String],
    val: &[PerChannel<f64>],
    se: &[PerChannel<f64>],
) -> std::fmt::Result {
    writeln!(f, "\n## {title}")?;
    write!(f, "{:>4} {:>3} {:>3}", "k", "l", "m")?;
    for c in channels {
        write!(f, " {:>26}", format!("{c} ± σ"))?;
    }
    writeln!(f)?;
    for (k, (v, s)) in val.iter().zip(se).enumerate() {
        let (l, m) = lm(k);
        write!(f, "{k:>4} {l:>3} {m:>3}")?;
        for (v, s) in v.cells().iter().zip(s.cells()) {
            write!(f, " {:>26}", format!("{v:+.4e} ± {s:.4e}"))?;
        }
        writeln!(f)?;
    }
    Ok(())
}

impl std::fmt::Display for InvertSeparateReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let lmax = self.lmax;
        writeln!(f, "# invert separate — diffuse + specular separation (sec. 3.5, ref. [17]), {}", self.layout)?;
        let carried = self.lmax_carried.map_or("—".to_string(), |l| l.to_string());
        writeln!(f, "# l_max {lmax}; the views carry l <= {carried} ({})", self.lmax_carried_rule)?;
        writeln!(f, "# diffuse view: {} (θ_o = 0)", self.diffuse_view.file)?;
        for v in &self.specular_views {
            writeln!(f, "# specular view: {} (θ_o = {}°, φ_o = {}°)", v.file, v.theta_o_deg, v.phi_o_deg)?;
        }
        writeln!(
            f,
            "# {}×{} pixels; k_d = {}, k_s = {} ({}); σ from {}",
            self.width, self.height, self.kd, self.ks, self.split_source, self.sigma_source
        )?;
        for (name, fit) in [("diffuse view", &self.fits.diffuse), ("specular views", &self.fits.specular)] {
            let cells = |v: &PerChannel<Option<f64>>, fmt: &dyn Fn(f64) -> String| {
                v.cells().iter().map(|x| x.map_or("—".to_string(), fmt)).collect::<Vec<_>>().join(" ")
            };
            if self.weighted_by_stderr {
                writeln!(
                    f,
                    "# {name} fit: χ²/ν = {} (ν = {}), P(χ²_ν ≥ χ²) = {}",
                    cells(&fit.chi2_per_dof, &|x| format!("{x:.3}")),
                    cells(&fit.dof, &|x| format!("{x}")),
                    cells(&fit.p_value, &|x| format!("{x:.2e}"))
                )?;
            } else {
                writeln!(
                    f,
                    "# {name} fit: residual variance σ̂² = {} (ν = {}; the noise estimate, not a χ² test)",
                    cells(&fit.residual_variance, &|x| format!("{x:.3e}")),
                    cells(&fit.dof, &|x| format!("{x}"))
                )?;
            }
        }
        writeln!(f, "# truncation: {}", self.fits.truncation)?;
        let ch = &self.channels;
        table(
            f,
            "diffuse side L̂_lm = B_lm / (k_d Λ_l ρ̂_l + k_s), l ≤ 2",
            ch,
            &self.diffuse.coefficients,
            &self.diffuse.stderr,
        )?;
        table(
            f,
            &format!("recovered lighting L_lm (specular side), l ≤ {lmax}"),
            ch,
            &self.coefficients,
            &self.stderr,
        )?;
        let cons = &self.consistency;
        table(f, "consistency d_lm = L̂_lm − c_lm, l ≤ 2", ch, &cons.d, &cons.stderr)?;
        let nr = &cons.nine_term_residual;
        table(
            f,
            "9-term residual's predicted share of d (eq. 38–39, from the recovered orders 3…lmax; σ is d's)",
            ch,
            &nr.d,
            &cons.stderr,
        )?;
        writeln!(f)?;
        for (((c, m), x), p) in
            ch.iter().zip(cons.meaning.cells()).zip(nr.chi2_removed.cells()).zip(nr.p_value_removed.cells())
        {
            writeln!(f, "# consistency, {c}: {m}")?;
            let x = x.map_or("—".into(), |x| format!("{x:.1}"));
            let p = p.map_or("—".into(), |p| format!(", P(χ²_9 ≥ χ²) = {p:.2e}"));
            writeln!(f, "#   with the predicted 9-term residual removed from d: χ² = {x}{p}")?;
        }
        for s in self.scan.iter().flatten() {
            writeln!(
                f,
                "\n## split scan, channel {}: consistency χ² vs k_d/(k_d+k_s) at k_d + k_s = {}",
                s.channel, s.total
            )?;
            // Every 0.05, and the grid points next to the minimum.
            let bx = s.best_fraction.unwrap_or(f64::NAN);
            for [x, c] in &s.points {
                let i = (x * 100.0).round() as i64;
                if i % 5 == 0 || (x - bx).abs() <= 0.0151 {
                    writeln!(f, "{x:>8.2} {c:>14.4}")?;
                }
            }
            writeln!(
                f,
                "# minimum χ² = {} at k_d/(k_d+k_s) = {} (refined on a 5e-4 grid); assumed {:.4}",
                s.best_chi2.map_or("—".into(), |c| format!("{c:.2}")),
                s.best_fraction.map_or("—".into(), |x| format!("{x:.4}")),
                s.assumed_fraction
            )?;
        }
        if let Some(o) = &self.output {
            writeln!(f, "# wrote the recovered lighting (l ≤ {lmax}) to {o}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::image::read_image;
    use analysis::sh::ShBasis;
    use renderer::sampling::chi2::TestRng;
    use serde_json::json;

    fn tmp(name: &str) -> PathBuf {
        crate::cli::test_path("separate", name)
    }

    /// The report as the JSON document `--json` prints.
    fn separate_doc(a: &SeparateArgs) -> Result<Value, Error> {
        separate_report(a).map(|r| serde_json::to_value(r).unwrap())
    }

    /// The three verdicts of the 9-coefficient consistency χ² (ν = 9): P(χ²_9 ≥ 8.34) = 0.50,
    /// P(≥ 21.67) = 0.010 (between MISMATCH_P and MARGINAL_P), P(≥ 30) = 4.4e-4.
    #[test]
    fn consistency_verdicts_follow_the_shared_thresholds() {
        assert!(meaning(Some(8.34), true, 2).starts_with("consistent:"), "{}", meaning(Some(8.34), true, 2));
        assert!(meaning(Some(21.67), true, 2).starts_with("marginal:"), "{}", meaning(Some(21.67), true, 2));
        assert!(meaning(Some(30.0), true, 2).starts_with("inconsistent:"), "{}", meaning(Some(30.0), true, 2));
        assert!(meaning(None, true, 2).starts_with("χ² undefined"));
    }

    const MIX: &str = r#"{"type":"mix","layers":[{"weight":0.5,"brdf":{"type":"lambert","albedo":1.0}},{"weight":0.5,"brdf":{"type":"mirror"}}]}"#;
    /// Per-channel scale of the synthetic lighting (so R, G, B differ).
    const TINT: [f64; 3] = [1.0, 0.8, 0.5];

    /// A lighting with orders 0–3 and 5 only: Lambert's Λ_l ρ̂_l vanishes at odd l ≥ 3 (eq. 38),
    /// so the 9-term diffuse part is the whole diffuse part and the separation has no 9-term bias.
    /// Orders 1–2 get a lighting-like strength (up to ≈ 0.5 L_00) so that the split shows.
    fn light() -> Vec<f64> {
        (0..num_coefficients(5))
            .map(|k| {
                let (l, m) = lm(k);
                let v = (((7 * k + 3 * (m + 8) as usize) % 13) as f64 / 13.0 - 0.4) / (1.0 + l as f64);
                match l {
                    0 => 2.0,
                    1 | 2 => 4.0 * v,
                    3 | 5 => 0.4 * v,
                    _ => 0.0,
                }
            })
            .collect()
    }

    /// A synthetic normal-probe render (W × H, pixel centres) of k_d·lambert + k_s·mirror under
    /// `light` × TINT at exitance (θ_o, φ_o ∈ {0°, 180°}), Gaussian noise σ per pixel (seeded) and
    /// a stderr layer σ unless `stderr` is false.
    #[allow(clippy::too_many_arguments)]
    fn render(
        path: &Path,
        light: &[f64],
        kd: f64,
        ks: f64,
        theta_o_deg: f64,
        phi_o_deg: f64,
        (w, h): (usize, usize),
        sigma: f64,
        seed: u64,
        stderr: bool,
        brdf: &str,
    ) {
        let lmax = analysis::sh::lmax_of(light.len()).unwrap();
        let basis = ShBasis::new(lmax);
        let f = analysis::transfer::lambert::lambert(lmax);
        let geo =
            probe_samples(&vec![0.0; w * h], &vec![0.0; w * h], w, h, theta_o_deg.to_radians(), phi_o_deg == 180.0);
        let mut y = vec![0.0; light.len()];
        let mut rng = TestRng::new(seed);
        let mut gauss = || {
            // Box–Muller.
            let mut u = || (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
            let (u1, u2) = (u().max(1e-300), u());
            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        };
        let mut img = Image { width: w, height: h, ..Default::default() };
        let mut px = vec![[0f32; 3]; w * h];
        for (i, p) in px.iter_mut().enumerate() {
            basis.eval_into(geo.normal[i], &mut y);
            let d: f64 = (0..light.len()).map(|k| f[lm(k).0] * light[k] * y[k]).sum();
            basis.eval_into(geo.reflected[i], &mut y);
            let g: f64 = (0..light.len()).map(|k| light[k] * y[k]).sum();
            for ch in 0..3 {
                p[ch] = (TINT[ch] * (kd * d + ks * g) + sigma * gauss()) as f32;
            }
        }
        for (ch, n) in CHANNELS.iter().enumerate() {
            img.channels.insert(n.to_string(), px.iter().map(|p| p[ch]).collect());
            if stderr {
                img.channels.insert(format!("stderr.{n}"), vec![sigma as f32; w * h]);
            }
        }
        img.attributes.insert(
            "reflect:camera".into(),
            json!({"type": "normal-probe", "theta_o_deg": theta_o_deg, "phi_o_deg": phi_o_deg}).to_string(),
        );
        img.attributes.insert(
            "reflect:objects".into(),
            format!(r#"[{{"shape":"sphere","center":[0,0,0],"radius":1,"brdf":{brdf}}}]"#),
        );
        write_exr(path, &img).unwrap();
    }

    const SIZE: (usize, usize) = (256, 128);
    const SIGMA: f64 = 0.05;

    /// The three views of the example scenes (0°; 50° at φ_o 0° and 180°), true split 0.5 : 0.5.
    fn views(tag: &str) -> Vec<PathBuf> {
        let lt = light();
        [(0.0, 0.0), (50.0, 0.0), (50.0, 180.0)]
            .iter()
            .enumerate()
            .map(|(i, &(t, p))| {
                let path = tmp(&format!("{tag}-{i}.exr"));
                render(&path, &lt, 0.5, 0.5, t, p, SIZE, SIGMA, 11 + i as u64, true, MIX);
                path
            })
            .collect()
    }

    fn args(images: Vec<PathBuf>) -> SeparateArgs {
        SeparateArgs {
            images,
            kd: None,
            ks: None,
            lmax: 5,
            channel: None,
            scan: false,
            output: None,
            width: 64,
            json: true,
            view: ImageArgs::default(),
        }
    }

    fn f(v: &Value) -> f64 {
        v.as_f64().unwrap_or(f64::NAN)
    }

    #[test]
    fn recovers_band_limited_lighting_and_flags_a_wrong_split() {
        let lt = light();
        let mut a = args(views("known"));
        a.scan = true;
        a.output = Some(tmp("known-env.exr"));
        let doc = separate_doc(&a).unwrap();
        assert_eq!(doc["split_source"], "the first image's header (mix of lambert and mirror)");
        assert_eq!(doc["weighted_by_stderr"], true);
        // Tolerance: 4σ (σ propagated from the stderr layers, validated against the spread of
        // repeated draws in analysis::inverse::separation's tests) + the bias of the diffuse view's
        // lat-long midpoint quadrature. The lighting has no 9-term residual (no even order ≥ 4) and
        // the least squares at R is exact for a lighting inside its span (l ≤ 5), so that
        // quadrature is the only bias: O((π (L+2)/H)²/24) ≈ 1.2e-4 (L + 2 = 7: the degree of
        // Y_lm × B, l ≤ 2; H = 128) of the largest coefficient (≈ 2 × tint), amplified by at most
        // 1 + k_d/k_s · |H F| ≈ 2 in c: bias allowance 2.5e-4 × |L_00|. Measured on noise-free
        // images: worst 2.1e-5 (at (1, 0), R); with noise the worst error is 0.7σ.
        // Able to fail: the wrong split below moves c_lm by ≫ this.
        for ch in 0..3 {
            let bias = 2.5e-4 * TINT[ch] * lt[0];
            for k in 0..lt.len() {
                let (got, se) = (f(&doc["coefficients"][k][ch]), f(&doc["stderr"][k][ch]));
                let want = TINT[ch] * lt[k];
                assert!((got - want).abs() <= 4.0 * se + bias, "ch {ch} k {k}: {got} vs {want} (σ {se})");
                assert!(se > 0.0 && se < 0.01, "σ {se}");
            }
            for k in 0..LOW {
                let (got, se) = (f(&doc["diffuse"]["coefficients"][k][ch]), f(&doc["diffuse"]["stderr"][k][ch]));
                assert!((got - TINT[ch] * lt[k]).abs() <= 4.0 * se + bias, "diffuse ch {ch} k {k}");
            }
            // At the true split the consistency χ² follows χ²_9: P(χ²_9 > 33.7) = 1e-4.
            let chi2 = f(&doc["consistency"]["chi2"][ch]);
            assert!(chi2 < 33.7, "ch {ch}: χ² {chi2}");
            assert_eq!(doc["consistency"]["consistent"][ch], true);
            // No even order ≥ 4 in the lighting: the predicted 9-term share of d is only what the
            // noise in the recovered l = 4 coefficients (σ ≈ 1e-3, × |Λ_4 ρ̂_4| = 1/24) makes of it.
            for k in 0..LOW {
                let r = f(&doc["consistency"]["nine_term_residual"]["d"][k][ch]);
                assert!(r.abs() < 0.25 * f(&doc["consistency"]["stderr"][k][ch]), "ch {ch} k {k}: {r}");
            }
            // The scan's minimum is at the true fraction (one coarse step).
            let best = f(&doc["scan"][ch]["best_fraction"]);
            assert!((best - 0.5).abs() <= 0.01, "ch {ch}: scan minimum {best}");
        }
        // The map is the recovered lighting reconstructed from SH: check a few pixels (f32 rounding).
        let env = read_image(tmp("known-env.exr")).unwrap();
        assert_eq!((env.width, env.height), (64, 32));
        let mut rec = analysis::sh::Reconstructor::new(5);
        let c: Vec<[f64; 3]> = (0..lt.len()).map(|k| [0, 1, 2].map(|ch| f(&doc["coefficients"][k][ch]))).collect();
        for (r, col) in [(0, 0), (7, 40), (31, 63)] {
            let want = rec.eval(&c, analysis::sh::latlong_direction(r, col, 64, 32));
            for (ch, n) in CHANNELS.iter().enumerate() {
                let got = env.channel(n).unwrap()[r * 64 + col] as f64;
                assert!((got - want[ch]).abs() < 1e-5 * (1.0 + want[ch].abs()), "{n} ({r},{col})");
            }
        }
        // A wrong split (0.6 : 0.4 instead of 0.5 : 0.5): χ²_9 > 100 has probability ≈ 1e-16 for a
        // consistent split. One channel: the coefficients are then numbers. The split by flags
        // contradicts the header's mix (an error naming both), so it is given for the same pixels
        // without a header (another renderer's files: angles by flags).
        let mut wrong = args(a.images.clone());
        wrong.kd = Some([0.6; 3]);
        wrong.ks = Some([0.4; 3]);
        wrong.channel = Some(Channel::G);
        let e = separate_doc(&wrong).unwrap_err().to_string();
        assert!(e.contains("--kd 0.6,0.6,0.6") && e.contains("k_d = 0.5,0.5,0.5") && e.contains("contradict"), "{e}");
        wrong.images =
            a.images.iter().enumerate().map(|(i, p)| foreign_copy(p, &format!("known-foreign-{i}.exr"))).collect();
        wrong.view.theta_o = vec![0.0, 50.0, 50.0];
        wrong.view.phi_o = vec![0.0, 0.0, 180.0];
        wrong.view.layer = Some("ViewLayer.Combined".into());
        let w = separate_doc(&wrong).unwrap();
        assert_eq!(w["split_source"], "command line");
        assert!(w["coefficients"][0].is_number() && w["channels"] == json!(["G"]));
        let chi2 = f(&w["consistency"]["chi2"]);
        assert!(chi2 > 100.0, "wrong split: χ² {chi2}");
        assert_eq!(w["consistency"]["consistent"], false);
        assert!(w["consistency"]["meaning"].as_str().unwrap().starts_with("inconsistent"));
    }

    /// `path` rewritten as another renderer writes it: no `reflect:` attribute, RGB(+stderr) under
    /// a Blender-style layer prefix, beside a depth AOV.
    fn foreign_copy(path: &Path, name: &str) -> PathBuf {
        let img = read_image(path).unwrap();
        let mut out = Image { width: img.width, height: img.height, ..Default::default() };
        for (n, data) in &img.channels {
            let n = if n.starts_with("stderr") { n.clone() } else { format!("ViewLayer.Combined.{n}") };
            out.channels.insert(n, data.clone());
        }
        out.channels.insert("ViewLayer.Depth.Z".into(), vec![1.0; img.width * img.height]);
        let p = tmp(name);
        write_exr(&p, &out).unwrap();
        p
    }

    #[test]
    fn headerless_views_described_by_flags_or_sidecar_separate_as_the_originals() {
        let ours = views("ours");
        let want = separate_doc(&args(ours.clone())).unwrap();
        let foreign: Vec<PathBuf> =
            ours.iter().enumerate().map(|(i, p)| foreign_copy(p, &format!("foreign-{i}.exr"))).collect();
        // By flags: the angles per image, the split by --kd/--ks, the layer by --layer.
        let mut a = args(foreign.clone());
        a.view.theta_o = vec![0.0, 50.0, 50.0];
        a.view.phi_o = vec![0.0, 0.0, 180.0];
        a.view.layer = Some("ViewLayer.Combined".into());
        a.kd = Some([0.5; 3]);
        a.ks = Some([0.5; 3]);
        let by_flags = separate_doc(&a).unwrap();
        // By a sidecar: its mix BRDF gives the split, its normal-probe camera the angles' default.
        let scene = tmp("sidecar.toml");
        std::fs::write(
            &scene,
            format!(
                "[render]\nwidth = {}\nheight = {}\n[camera]\ntype = \"normal-probe\"\n[lighting]\ntype = \"uniform\"\nradiance = 1.0\n\
                 [[objects]]\nshape = \"sphere\"\nbrdf = {}\n",
                SIZE.0,
                SIZE.1,
                r#"{ type = "mix", layers = [{ weight = 0.5, brdf = { type = "lambert", albedo = 1.0 } }, { weight = 0.5, brdf = { type = "mirror" } }] }"#
            ),
        )
        .unwrap();
        let mut b = args(foreign.clone());
        b.view.theta_o = vec![0.0, 50.0, 50.0];
        b.view.phi_o = vec![0.0, 0.0, 180.0];
        b.view.layer = Some("ViewLayer.Combined".into());
        b.view.scene = Some(scene.clone());
        let by_scene = separate_doc(&b).unwrap();
        assert!(by_scene["split_source"].as_str().unwrap().contains("sidecar.toml"), "{}", by_scene["split_source"]);
        for doc in [&by_flags, &by_scene] {
            for key in ["coefficients", "stderr", "diffuse", "consistency", "kd", "ks"] {
                assert_eq!(doc[key], want[key], "{key}");
            }
        }
        // Contradictions name both sides; orthographic-only flags are refused by name.
        let mut c = args(ours.clone());
        c.view.theta_o = vec![0.0, 40.0, 50.0];
        let e = separate_doc(&c).unwrap_err().to_string();
        assert!(
            e.contains("--theta-o/--phi-o give") && e.contains("reflect:camera") && e.contains("contradict"),
            "{e}"
        );
        let mut d = args(foreign.clone());
        d.view.layer = Some("ViewLayer.Combined".into());
        let e = separate_doc(&d).unwrap_err().to_string();
        assert!(e.contains("no reflect:camera") && e.contains("--theta-o"), "{e}");
    }

    /// Without stderr layers the noise is the residual variance of each side's fit (issue 14): on
    /// band-limited views (no truncation at lmax 5) with noise σ = 0.05, the bars are those the
    /// stderr layers give within 7 % (σ̂/σ has standard error 1/√(2ν) ≤ 1.6 % here, ν ≥ 2012:
    /// 4.4 se), said in the output. With the layers each fit's χ²/ν is within 4·√(2/ν) of 1. The
    /// planted error is the old σ = 1 per pixel: bars 20× too wide.
    #[test]
    fn without_stderr_layers_sigma_is_the_residual_variance_and_said_so() {
        let lt = light();
        let mut docs = vec![];
        for stderr in [true, false] {
            let mut images = vec![];
            for (i, (t, p)) in [(0.0, 0.0), (40.0, 0.0), (40.0, 180.0)].into_iter().enumerate() {
                let path = tmp(&format!("nostderr-{stderr}-{i}.exr"));
                render(&path, &lt, 0.5, 0.5, t, p, (64, 32), SIGMA, 1 + i as u64, stderr, MIX);
                images.push(path);
            }
            let mut a = args(images.clone());
            a.channel = Some(Channel::R);
            let doc = separate_doc(&a).unwrap();
            assert_eq!(doc["weighted_by_stderr"], stderr);
            if !stderr {
                let src = doc["sigma_source"].as_str().unwrap();
                assert!(src.contains("residual variance") && src.contains(&images[1].display().to_string()), "{src}");
                assert!(doc["fits"]["specular"]["chi2_per_dof"].is_null());
                assert!(doc["consistency"]["p_value"].is_number(), "{}", doc["consistency"]);
            }
            for side in ["diffuse", "specular"] {
                let fit = &doc["fits"][side];
                let nu = f(&fit["dof"]);
                let var = f(&fit["residual_variance"]);
                assert!((var.sqrt() / SIGMA - 1.0).abs() < 4.0 / (2.0 * nu).sqrt(), "{side}: σ̂ {}", var.sqrt());
                if stderr {
                    let x = f(&fit["chi2_per_dof"]);
                    assert!((x - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(), "{side}: χ²/ν {x} (ν {nu})");
                    assert!(f(&fit["p_value"]) > 1e-4);
                }
            }
            docs.push(doc);
        }
        for key in ["stderr", "/diffuse/stderr", "/consistency/stderr"] {
            let ptr = if key.starts_with('/') { key.to_string() } else { format!("/{key}") };
            let (with, without) = (docs[0].pointer(&ptr).unwrap(), docs[1].pointer(&ptr).unwrap());
            for (x, y) in with.as_array().unwrap().iter().zip(without.as_array().unwrap()) {
                let r = f(y) / f(x);
                assert!((r - 1.0).abs() < 0.07, "{key}: residual-σ bar / stderr-layer bar = {r}");
            }
        }
        // The same pixels, so the same estimates.
        assert_eq!(docs[0]["coefficients"], docs[1]["coefficients"]);
    }

    #[test]
    fn bad_input_is_a_one_line_error_naming_the_file() {
        let lt = light();
        let small = (32, 16);
        let mk = |name: &str, t: f64, p: f64, size: (usize, usize), brdf: &str| {
            let path = tmp(name);
            render(&path, &lt, 0.5, 0.5, t, p, size, 0.01, 3, true, brdf);
            path
        };
        let d0 = mk("bad-d0.exr", 0.0, 0.0, small, MIX);
        let d0_copy = d0.with_file_name("bad-d0-copy.exr");
        std::fs::copy(&d0, &d0_copy).unwrap();
        let s1 = mk("bad-s1.exr", 40.0, 0.0, small, MIX);
        let s2 = mk("bad-s2.exr", 40.0, 180.0, small, MIX);
        let s90 = mk("bad-s90.exr", 40.0, 90.0, small, MIX);
        let big = mk("bad-big.exr", 40.0, 180.0, (64, 32), MIX);
        let lam = mk("bad-lambert.exr", 0.0, 0.0, small, r#"{"type":"lambert","albedo":0.5}"#);
        let mut ortho = read_image(&d0).unwrap();
        ortho.attributes.insert(
            "reflect:camera".into(),
            r#"{"type":"orthographic","from":[3,0,1],"to":[0,0,0],"up":[0,0,1],"extent":1.05}"#.into(),
        );
        let ortho_path = tmp("bad-ortho.exr");
        write_exr(&ortho_path, &ortho).unwrap();
        let missing = tmp("bad-missing.exr");
        let out = tmp("bad-out.exr");
        let ok = args(vec![d0.clone(), s1.clone(), s2.clone()]);
        assert!(separate_doc(&SeparateArgs { lmax: 3, ..args(ok.images.clone()) }).is_ok());
        let cases: Vec<(SeparateArgs, Option<&PathBuf>, &str)> = vec![
            (args(vec![d0.clone(), missing.clone()]), Some(&missing), "cannot read"),
            (args(vec![ortho_path.clone(), s1.clone()]), Some(&ortho_path), "not a normal-probe render"),
            (args(vec![s1.clone(), s2.clone()]), Some(&s1), "θ_o = 0"),
            (args(vec![d0.clone(), d0_copy.clone()]), Some(&d0_copy), "θ_o > 0"),
            (args(vec![d0.clone(), d0.clone()]), Some(&d0), "given more than once"),
            (args(vec![d0.clone(), s1.clone(), big.clone()]), Some(&big), "differs"),
            (args(vec![d0.clone(), s90.clone()]), Some(&s90), "φ_o"),
            (args(vec![d0.clone()]), None, "at least one specular view"),
            (args(vec![lam.clone(), s1.clone(), s2.clone()]), None, "--kd is required"),
            (
                SeparateArgs { kd: Some([0.5; 3]), ..args(vec![lam.clone(), s1.clone(), s2.clone()]) },
                None,
                "--ks is required",
            ),
            (SeparateArgs { kd: Some([0.0; 3]), ..args(ok.images.clone()) }, None, "must be > 0"),
            (
                SeparateArgs { ks: Some([0.5, -1.0, 0.5]), channel: Some(Channel::G), ..args(ok.images.clone()) },
                None,
                "must be > 0",
            ),
            (SeparateArgs { lmax: 1000, ..args(ok.images.clone()) }, None, "maximum"),
            // 16 rows cannot carry l = 8.
            (SeparateArgs { lmax: 8, ..args(ok.images.clone()) }, Some(&d0), "highest order"),
            (SeparateArgs { output: Some(out.clone()), width: 3, ..args(ok.images.clone()) }, None, "--width"),
        ];
        for (a, file, what) in cases {
            let e = separate_doc(&a).expect_err(what);
            let line = e.to_string();
            assert!(!line.contains('\n') && line.contains(what), "{line} (expected '{what}')");
            if let Some(fp) = file {
                assert_eq!(e.path.as_ref(), Some(fp), "{line}");
            }
        }
        assert!(!out.exists(), "no partial output");
    }

    #[test]
    fn header_split_reads_a_lambert_mirror_mix_only() {
        let v: Value = serde_json::from_str(r#"{"type":"mix","layers":[{"weight":0.25,"brdf":{"type":"mirror","kr":[1,0.5,1]}},{"weight":0.75,"brdf":{"type":"lambert","albedo":[0.8,0.4,0.2]}}]}"#).unwrap();
        let (kd, ks) = header_split(&v).unwrap();
        assert_eq!(kd, [0.75 * 0.8, 0.75 * 0.4, 0.75 * 0.2]);
        assert_eq!(ks, [0.25, 0.125, 0.25]);
        for bad in [
            r#"{"type":"lambert","albedo":1}"#,
            r#"{"type":"mix","layers":[{"weight":0.5,"brdf":{"type":"lambert","albedo":1}},{"weight":0.5,"brdf":{"type":"phong","s":10}}]}"#,
            r#"{"type":"mix","layers":[{"weight":0.5,"brdf":{"type":"lambert","albedo":1}},{"weight":0.5,"brdf":{"type":"lambert","albedo":1}}]}"#,
        ] {
            assert!(header_split(&serde_json::from_str(bad).unwrap()).is_none(), "{bad}");
        }
    }
}
