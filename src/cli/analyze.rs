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
//! Output: B_lm ± standard error, L_lm, the measured filter (per-order least-squares estimate of
//! albedo · Λ_l ρ̂_l with its standard error; orders where L has no energy are unobservable) and,
//! with a known BRDF, its analytic Λ_l ρ̂_l (eq. 38/43/33/50) scaled by the albedo.
use super::Error;
use super::args::{CameraFlags, ParamArg, ViewArgs};
use super::header::{first_sphere, json_vec3, lighting_of};
use super::sh::check_lmax;
use analysis::filter::{OrderEstimate, measured_filter};
use analysis::image::{Image, read_image};
use analysis::projection::{OrthoCamera, OrthoView, Param, Sphere, fit_orthographic, project_normal_probe};
use analysis::sh::lm;
use analysis::transfer::{TransferModel, parameterization};
use serde_json::{Value, json};
use std::path::PathBuf;
use std::process::ExitCode;
use vocab::scene::BrdfSection;
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
    #[arg(long)]
    pub lmax: usize,
    /// The direction the radiance is a function of (default: from the BRDF).
    #[arg(long, value_enum)]
    pub param: Option<ParamArg>,
    /// The camera and sphere of images whose header does not say them.
    #[command(flatten)]
    pub view: ViewArgs,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

/// The camera of one image.
enum Camera {
    Ortho(OrthoCamera),
    NormalProbe { theta_o_deg: f64 },
}

fn camera_of(img: &Image, f: CameraFlags) -> Result<Camera, Error> {
    if let Some(text) = img.attributes.get("reflect:camera") {
        let v: Value =
            serde_json::from_str(text).map_err(|e| Error::new(format!("header reflect:camera is not JSON: {e}")))?;
        let ty = v.get("type").and_then(|t| t.as_str()).unwrap_or("");
        return match ty {
            "orthographic" => Ok(Camera::Ortho(OrthoCamera {
                from: json_vec3(&v, "from")?,
                to: json_vec3(&v, "to")?,
                up: json_vec3(&v, "up")?,
                extent: v
                    .get("extent")
                    .and_then(|e| e.as_f64())
                    .ok_or_else(|| Error::new("header camera has no 'extent'"))?,
            })),
            "normal-probe" => {
                Ok(Camera::NormalProbe { theta_o_deg: super::header::probe_theta_o_deg(&v, "analysed")? })
            }
            other => Err(Error::new(format!(
                "camera type '{other}' cannot be analysed (use an orthographic or normal-probe render)"
            ))),
        };
    }
    f.camera().map(Camera::Ortho).ok_or_else(|| {
        Error::new("no reflect:camera in the header: pass --from x,y,z and --extent (orthographic camera)")
    })
}

/// The BRDF of the analysed sphere, from the header: transfer model, RGB scale, kind, table (as
/// the header wrote it, for the report).
struct Brdf {
    model: Option<TransferModel>,
    scale: [f64; 3],
    kind: BrdfKind,
    horizon: Horizon,
    table: Value,
}

fn sphere_and_brdf(img: &Image) -> Result<(Option<Sphere>, Option<Brdf>), Error> {
    let (sphere, brdf, count) = first_sphere(img)?;
    if sphere.is_none() {
        return Ok((None, None));
    }
    if count > 1 {
        eprintln!("note: the scene has {count} objects; analysing the first sphere");
    }
    let brdf = brdf.as_ref().map(|b| {
        // The one BRDF → transfer-model mapping (a malformed table is an error naming the key).
        let section: BrdfSection = serde_json::from_value(b.clone())
            .map_err(|e| Error::new(format!("header reflect:objects: BRDF table: {e}")))?;
        let t = TransferModel::of_brdf(&section, 0.0)
            .map_err(|e| Error::new(format!("header reflect:objects {}", e.message)))?;
        Ok::<_, Error>(Brdf {
            model: t.map(|t| t.model),
            scale: t.map_or([1.0; 3], |t| t.scale),
            kind: section.kind(),
            horizon: t.map_or(Horizon::Clamp, |t| t.horizon),
            table: b.clone(),
        })
    });
    Ok((sphere, brdf.transpose()?))
}

pub fn run(a: AnalyzeArgs) -> Result<ExitCode, Error> {
    check_lmax(a.lmax)?;
    let images: Vec<Image> = a.images.iter().map(read_image).collect::<Result<_, _>>()?;
    let cameras: Vec<Camera> = images
        .iter()
        .zip(&a.images)
        .zip(a.view.per_image(a.images.len())?)
        .map(|((img, p), f)| camera_of(img, f).map_err(|e| e.in_file(p)))
        .collect::<Result<_, _>>()?;
    let (header_sphere, brdf) = sphere_and_brdf(&images[0]).map_err(|e| e.in_file(&a.images[0]))?;
    let sphere = a.view.sphere(header_sphere);
    let param = match a.param {
        Some(p) => Param::from(p),
        None => brdf.as_ref().map_or(Param::Normal, |b| parameterization(b.kind)),
    };

    let n_probe = cameras.iter().filter(|c| matches!(c, Camera::NormalProbe { .. })).count();
    let mut brdf = brdf;
    let (b, b_se, method, pixels, se_source, rms, carried) = if n_probe > 0 {
        if images.len() != 1 {
            return Err(Error::new("a normal-probe render must be analysed on its own (one image)"));
        }
        let Camera::NormalProbe { theta_o_deg } = cameras[0] else { unreachable!() };
        // Torrance–Sparrow seen at θ_o: the q = 0 coefficient at that exitance angle.
        // (θ_o passed the one exitance check when the header was read; validated again as a model.)
        if let Some(Brdf { model: Some(m), .. }) = brdf.as_mut()
            && let TransferModel::TorranceSparrow { theta_o, .. } = m
        {
            *theta_o = theta_o_deg.to_radians();
            m.validate().map_err(|e| e.in_file(&a.images[0]))?;
        }
        let (c, se) = project_normal_probe(&images[0], a.lmax).map_err(|e| e.in_file(&a.images[0]))?;
        let src = if se.is_some() { "stderr-layer" } else { "none" };
        (
            c,
            se,
            format!("normal-probe quadrature (theta_o {theta_o_deg}°)"),
            images[0].width * images[0].height,
            src,
            None,
            analysis::projection::latlong_max_order(images[0].width, images[0].height).unwrap_or(0),
        )
    } else {
        let views: Vec<OrthoView> = images
            .iter()
            .zip(&cameras)
            .map(|(image, c)| match c {
                Camera::Ortho(camera) => OrthoView { image, camera: *camera },
                Camera::NormalProbe { .. } => unreachable!(),
            })
            .collect();
        let fit = fit_orthographic(&views, &sphere, param, a.lmax)
            .map_err(|e| if a.images.len() == 1 { e.in_file(&a.images[0]) } else { e })?;
        // (After the fit, so that a refusal stays the one line on stderr.)
        if views.len() == 1 && param == Param::Normal {
            eprintln!(
                "note: one orthographic view sees one hemisphere of normals; energy of B above l_max aliases into the fit \
                 (raise --lmax, add the opposite view, or render a normal-probe)"
            );
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
        )
    };

    let lighting = lighting_of(a.lighting.as_deref(), a.mapping, &images[0], &a.images[0])
        .map_err(|e| if a.lighting.is_none() { e.in_file(&a.images[0]) } else { e })?;
    let l_coeffs = match &lighting {
        Some((l, _)) => Some(l.coefficients(a.lmax)?),
        None => None,
    };
    let filter: Option<Vec<OrderEstimate>> =
        l_coeffs.as_ref().map(|l| measured_filter(&b, b_se.as_deref(), l, a.lmax, 1e-8));
    let analytic: Option<Vec<[f64; 3]>> = brdf.as_ref().and_then(|br| {
        br.model.map(|m| {
            m.lambda_rho(a.lmax).into_iter().map(|f| [f * br.scale[0], f * br.scale[1], f * br.scale[2]]).collect()
        })
    });

    if a.json {
        let filt = filter.as_ref().map(|f| {
            f.iter()
                .map(|o| {
                    json!({"l": o.l, "energy": o.energy, "estimate": o.estimate, "stderr": o.stderr, "observable": o.observable()})
                })
                .collect::<Vec<_>>()
        });
        let predicted = match (&l_coeffs, &brdf) {
            (Some(l), Some(Brdf { model: Some(m), scale, .. })) => {
                Some(analysis::predict::predict(l, &m.lambda_rho(a.lmax), *scale))
            }
            _ => None,
        };
        let doc = json!({
            "lmax": a.lmax,
            "lmax_carried": carried,
            "images": a.images.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "method": method,
            "param": if n_probe > 0 { "normal" } else { param.name() },
            "sphere": {"center": sphere.center, "radius": sphere.radius},
            "pixels_used": pixels,
            "stderr_source": se_source,
            "rms_residual": rms,
            "coefficients": b,
            "stderr": b_se,
            "lighting": lighting.as_ref().map(|(_, src)| json!({"source": src, "coefficients": l_coeffs})),
            "filter": filt,
            "brdf": brdf.as_ref().map(|b| b.table.clone()),
            "lambda_rho_analytic": analytic,
            "predicted": predicted,
        });
        println!("{doc}");
        return Ok(ExitCode::SUCCESS);
    }

    println!("# {} — {method}", a.images.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "));
    println!("# pixels used {pixels}, standard errors from {se_source}; the input carries l <= {carried}");
    if let Some(r) = rms {
        println!("# weighted RMS residual of the fit: {:.3e} {:.3e} {:.3e}", r[0], r[1], r[2]);
    }
    if let Some((_, src)) = &lighting {
        println!("# lighting: {src}");
    }
    if let Some(br) = &brdf {
        println!("# brdf: {}", br.table);
        let horizon = br.horizon;
        if matches!(br.kind, BrdfKind::Phong | BrdfKind::TorranceSparrow) && horizon != Horizon::Ignore {
            println!(
                "# note: horizon = \"{horizon}\": the analytic Λ_l ρ̂_l (eq. 43/50) ignores the horizon, so expect differences"
            );
        }
    }
    println!("{:>4} {:>4} {:>26} {:>26} {:>26}", "l", "m", "B_lm R ± se", "G ± se", "B ± se");
    for (k, v) in b.iter().enumerate() {
        let (l, m) = lm(k);
        let se = b_se.as_ref().map(|s| s[k]);
        let cell = |ch: usize| match se {
            Some(s) => format!("{:.5e} ± {:.1e}", v[ch], s[ch]),
            None => format!("{:.5e}", v[ch]),
        };
        println!("{l:>4} {m:>4} {:>26} {:>26} {:>26}", cell(0), cell(1), cell(2));
    }
    if let Some(f) = &filter {
        println!(
            "\n# measured filter (albedo · Λ_l ρ̂_l per order, least squares over m weighted by the lighting's energy)"
        );
        println!(
            "{:>4} {:>26} {:>26} {:>26} {:>14}",
            "l",
            "R ± se",
            "G ± se",
            "B ± se",
            if analytic.is_some() { "analytic (R)" } else { "" }
        );
        for o in f {
            let cell = |ch: usize| match (o.estimate[ch], o.stderr[ch]) {
                (Some(e), Some(s)) => format!("{e:.5e} ± {s:.1e}"),
                (Some(e), None) => format!("{e:.5e}"),
                _ => "unobservable".to_string(),
            };
            let an = analytic.as_ref().map(|a| format!("{:.5e}", a[o.l][0])).unwrap_or_default();
            println!("{:>4} {:>26} {:>26} {:>26} {:>14}", o.l, cell(0), cell(1), cell(2), an);
        }
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::image::write_exr;
    use analysis::sh::{Reconstructor, latlong_direction};

    fn args(images: Vec<PathBuf>, lmax: usize) -> AnalyzeArgs {
        AnalyzeArgs { images, lighting: None, mapping: None, lmax, param: None, view: ViewArgs::default(), json: true }
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
        img.attributes.insert("reflect:camera".into(), r#"{"type":"perspective","fov_deg":40}"#.into());
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
