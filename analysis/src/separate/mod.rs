//! Diffuse + specular separation (sec. 3.5, the algorithm of reference \[17\]; its linear algebra in
//! [`crate::inverse::separation`]), the analysis of `reflect invert separate`: [`SeparateParams`] and
//! observed images in, an [`InvertSeparateReport`] out.
//!
//! The surface is ρ̂ = k_d · lambert (unit albedo) + k_s · mirror (unit k_r). The inputs are
//! `normal-probe` renders of it (docs/src/conventions.md §6; with the `reflect:camera` header, or another
//! renderer's described by `--theta-o/--phi-o` per image or a `--scene` sidecar, as in every analysis
//! command, [`crate::observation`]): the *diffuse
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

//!
//! The parameters are the CLI's flags as values: `--kd`, `--ks` are [`SeparateParams::kd`] and
//! [`SeparateParams::ks`], `--output`/`--width` the [`SeparateParams::map`] (the front-end writes
//! [`InvertSeparateReport::lighting_map`]).

mod error;
mod report;

pub use error::Error;
pub use report::*;

use crate::image::{Image, RgbImage};
use crate::inverse::separation::{
    LOW, ResidualFit, Samples, Separated, Separation, best_split, fit_residuals, nine_term_residual, probe_samples,
};
use crate::observation::{Camera, Observation, Spelling};
use crate::projection::resolution::{
    LATLONG_REFLECTION_RULE, check_latlong, check_order, latlong_max_order_reflection,
};
use crate::sh::{ShBasis, num_coefficients};
use crate::special::chi2_survival;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Highest order of the recovered lighting: the least squares costs O(pixels · (lmax+1)⁴).
pub const MAX_LMAX: usize = 32;
/// P(χ²_9 ≥ χ²) below which the two sides are called inconsistent: the one mismatch threshold of
/// every fit, [`crate::fit::MISMATCH_P`] (between it and [`crate::fit::MARGINAL_P`]: "marginal").
pub const P_CONSISTENT: f64 = crate::fit::MISMATCH_P;
const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// What a separation is asked for.
#[derive(Clone, Debug)]
pub struct SeparateParams {
    /// Weight k_d of the unit-albedo lambert part per channel; `None`: the observed BRDF's mix.
    pub kd: Option<[f64; 3]>,
    /// Weight k_s of the unit mirror part per channel; `None`: the observed BRDF's mix.
    pub ks: Option<[f64; 3]>,
    /// Highest SH order of the recovered lighting (at most [`MAX_LMAX`]).
    pub lmax: usize,
    /// The one channel analysed (0, 1, 2 for R, G, B); `None`: all three.
    pub channel: Option<usize>,
    /// Scan the diffuse fraction k_d/(k_d+k_s) at fixed k_d + k_s for the consistency χ² minimum.
    pub scan: bool,
    /// The lat-long map of the recovered lighting a front-end writes: its file (named in errors and
    /// the report) and width W (height W/2; even, in [4, 16384], carrying every order ≤ `lmax`).
    pub map: Option<(PathBuf, usize)>,
    /// How the front-end names `kd`, `ks` and `scene` in messages (`--kd`, `kd=`).
    pub spelling: Spelling,
}

/// One normal-probe render.
struct View {
    path: PathBuf,
    theta_o_deg: f64,
    phi_o_deg: f64,
    rgb: RgbImage,
    stderr: Option<RgbImage>,
}

/// One normal-probe view from an image and its observed camera ([`crate::observation`]).
fn read_view(p: &Path, img: &Image, cam: &Camera) -> Result<View, Error> {
    let (theta_o_deg, phi_o_deg) = match *cam {
        Camera::NormalProbe { theta_o_deg, phi_o_deg } => (theta_o_deg, phi_o_deg),
        Camera::Ortho(_) => {
            return Err(Error::NotProbe.in_file(p));
        }
    };
    let rgb = img.rgb().ok_or_else(|| Error::NoRgb.in_file(p))?;
    if rgb.width != 2 * rgb.height || rgb.height < 4 {
        return Err(Error::ProbeShape { width: rgb.width, height: rgb.height }.in_file(p));
    }
    let stderr = img.stderr_layer().map_err(|e| Error::from(e).in_file(p))?;
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
/// weights contradict each other: an error naming both, as for every observed quantity
/// ([`crate::observation::describe`]).
fn check_weight(
    arg: Option<[f64; 3]>,
    header: Option<[f64; 3]>,
    flag: &'static str,
    spelling: Spelling,
    source: &str,
) -> Result<(), Error> {
    if let (Some(v), Some(h)) = (arg, header)
        && !(0..3).all(|i| crate::observation::close(v[i], h[i], 1.0))
    {
        return Err(Error::WeightContradicts {
            flag,
            spelling,
            given: crate::observation::v3(v),
            src: source.to_string(),
            table: crate::observation::v3(h),
        });
    }
    Ok(())
}

/// A per-channel weight from `--kd` / `--ks` (one number or r,g,b), else the header's.
fn weight_arg(
    arg: Option<[f64; 3]>,
    header: Option<[f64; 3]>,
    flag: &'static str,
    spelling: Spelling,
) -> Result<([f64; 3], bool), Error> {
    match arg {
        Some(v) => Ok((v, true)),
        None => header.map(|h| (h, false)).ok_or(Error::WeightRequired { flag, spelling }),
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

/// Checks `params` for `n_images` views before any image is read.
pub fn validate(params: &SeparateParams, n_images: usize) -> Result<(), Error> {
    if n_images < 2 {
        return Err(Error::TooFewViews);
    }
    if params.lmax > MAX_LMAX {
        return Err(Error::LmaxAbove { lmax: params.lmax });
    }
    if let Some((out, width)) = &params.map {
        let width = *width;
        if !(width >= 4 && width.is_multiple_of(2) && width <= 16384) {
            return Err(Error::MapWidth(width));
        }
        // The written map must carry every order it is reconstructed from.
        check_latlong(params.lmax, width, width / 2, "--output map (--width)")
            .map_err(|e| Error::from(e).in_file(out))?;
    }
    Ok(())
}

/// The separation of `images` (read from `paths`, observed as `observed`; see the module docs):
/// the report `--json` prints. Errors: bad input (named file and problem), or a separation the views
/// cannot solve. [`validate`] is called first.
pub fn separate(
    params: &SeparateParams,
    images: &[Image],
    paths: &[PathBuf],
    observed: &Observation,
) -> Result<InvertSeparateReport, Error> {
    validate(params, images.len())?;
    let channels = match params.channel {
        None => vec![0, 1, 2],
        Some(c) => vec![c],
    };
    let a = params;
    let mut views = Vec::with_capacity(paths.len());
    let header_brdf = observed.brdf.as_ref().map(|(b, src)| (serde_json::to_value(b).unwrap_or_default(), src));
    for (i, ((p, img), cam)) in paths.iter().zip(images).zip(&observed.cameras).enumerate() {
        let v = read_view(p, img, cam)?;
        if i == 0 {
            if v.theta_o_deg != 0.0 {
                return Err(Error::DiffuseExitance(v.theta_o_deg).in_file(p));
            }
        } else {
            if v.theta_o_deg == 0.0 {
                return Err(Error::SpecularAtNormal.in_file(p));
            }
            let phi = v.phi_o_deg.rem_euclid(360.0);
            if phi != 0.0 && phi != 180.0 {
                return Err(Error::SpecularAzimuth(v.phi_o_deg).in_file(p));
            }
            let first: &View = &views[0];
            if (v.rgb.width, v.rgb.height) != (first.rgb.width, first.rgb.height) {
                let e = Error::SizeDiffers {
                    width: v.rgb.width,
                    height: v.rgb.height,
                    first_width: first.rgb.width,
                    first_height: first.rgb.height,
                };
                return Err(e.in_file(p));
            }
        }
        views.push(v);
    }
    let (w, h) = (views[0].rgb.width, views[0].rgb.height);
    // The specular views' pixels are attributed to R, which turns twice as fast as n.
    let carried = latlong_max_order_reflection(w, h);
    check_order(a.lmax, carried, &format!("a {w}×{h} specular view"), LATLONG_REFLECTION_RULE)
        .map_err(|e| Error::from(e).in_file(&paths[0]))?;
    let hs = header_brdf.as_ref().and_then(|(b, _)| header_split(b));
    let (kd, kd_arg) = weight_arg(a.kd, hs.map(|s| s.0), "kd", a.spelling)?;
    let (ks, ks_arg) = weight_arg(a.ks, hs.map(|s| s.1), "ks", a.spelling)?;
    for &c in &channels {
        if !(kd[c].is_finite() && kd[c] > 0.0 && ks[c].is_finite() && ks[c] > 0.0) {
            return Err(Error::WeightsNotPositive { kd: kd[c], ks: ks[c], channel: CHANNELS[c] });
        }
    }
    // A value out of its domain is said first; then a flag against the header's or scene's mix.
    let first = |e: Error| e.in_file(&paths[0]);
    check_weight(a.kd, hs.map(|s| s.0), "kd", a.spelling, &table_source(&header_brdf)).map_err(first)?;
    check_weight(a.ks, hs.map(|s| s.1), "ks", a.spelling, &table_source(&header_brdf)).map_err(first)?;
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
                s.check_weights(&channels).map_err(|e| Error::from(e).in_file(&v.path))?;
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
        let in_c = |e: vocab::Error| Error::Channel { channel: CHANNELS[c], message: e.message };
        let mut sep = Separation::new(&dif, &spec, a.lmax).map_err(in_c)?;
        // Each side's fit and its residuals: the diffuse view at n, the specular views at R with the
        // harmonics 1 ≤ l ≤ 2 at n (the diffuse part, whatever the split). With the stderr layers their χ²/ν
        // tests the fits; without, their residual variance is the noise (σ = 1 above, rescaled).
        let fits =
            [fit_residuals(&dif, a.lmax, false).map_err(in_c)?, fit_residuals(&spec, a.lmax, true).map_err(in_c)?];
        if !with_stderr {
            let var = |f: &ResidualFit, what: &'static str| {
                f.residual_variance().ok_or(Error::NoResidual { channel: CHANNELS[c], what })
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

    let n = num_coefficients(a.lmax);
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
        output: a.map.as_ref().map(|(p, _)| p.display().to_string()),
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
    if (P_CONSISTENT..crate::fit::MARGINAL_P).contains(&p) {
        format!(
            "marginal: the diffuse side's 9 low-order coefficients and the recovered lighting's agree within the noise{noise} at the {P_CONSISTENT:.0e} level but not at {:.2} (χ² = {c:.1}, P(χ²_9 ≥ χ²) = {p:.3}); worth a --scan of the split",
            crate::fit::MARGINAL_P
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The three verdicts of the 9-coefficient consistency χ² (ν = 9): P(χ²_9 ≥ 8.34) = 0.50,
    /// P(≥ 21.67) = 0.010 (between MISMATCH_P and MARGINAL_P), P(≥ 30) = 4.4e-4.
    #[test]
    fn consistency_verdicts_follow_the_shared_thresholds() {
        assert!(meaning(Some(8.34), true, 2).starts_with("consistent:"), "{}", meaning(Some(8.34), true, 2));
        assert!(meaning(Some(21.67), true, 2).starts_with("marginal:"), "{}", meaning(Some(21.67), true, 2));
        assert!(meaning(Some(30.0), true, 2).starts_with("inconsistent:"), "{}", meaning(Some(30.0), true, 2));
        assert!(meaning(None, true, 2).starts_with("χ² undefined"));
    }

    /// A missing or contradicted weight is named as the front-end names it: the CLI's flag, Python's keyword.
    #[test]
    fn weight_errors_name_the_parameter_in_the_front_ends_spelling() {
        let e = weight_arg(None, None, "kd", Spelling::Flags).unwrap_err().to_string();
        assert!(e.starts_with("--kd is required:") && e.ends_with("(pass --kd and --ks)"), "{e}");
        let e = weight_arg(None, None, "ks", Spelling::Keywords).unwrap_err().to_string();
        assert_eq!(
            e,
            "ks= is required: the first image's header (or scene=) BRDF is not a mix of one lambert and one mirror \
             layer (pass kd= and ks=)"
        );
        let e = check_weight(Some([0.6; 3]), Some([0.5; 3]), "kd", Spelling::Keywords, "the header").unwrap_err();
        assert!(e.to_string().starts_with("kd=0.6,0.6,0.6 but the header gives k_d = 0.5,0.5,0.5"), "{e}");
        let e = check_weight(Some([0.6; 3]), Some([0.5; 3]), "kd", Spelling::Flags, "the header").unwrap_err();
        assert!(e.to_string().starts_with("--kd 0.6,0.6,0.6 but the header gives"), "{e}");
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
