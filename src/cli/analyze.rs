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
//! The analysis itself is the library's ([`analysis::analyze`]); this command turns its flags into
//! [`AnalyzeParams`], reads and describes the images, and prints the report.
//!
//! Orthographic views: noise correlated between neighbouring pixels by a reconstruction filter
//! (`--pixel-filter`, else measured from the residuals) widens the noise part of every error bar by
//! √F (`analysis::observation::pixels::prepare`, `pixel_noise` in the report); a camera not from the image's own
//! header is checked against the sphere's silhouette when the image is read (`super::header::load`).
use super::Error;
use super::args::{BrdfFlags, ParamArg, ViewArgs};
use super::header::load;
use analysis::analyze::AnalyzeParams;
pub use analysis::analyze::AnalyzeReport;
use analysis::observation::LightingInput;
use std::path::PathBuf;
use std::process::ExitCode;
use vocab::Mapping;

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

impl AnalyzeArgs {
    /// The flags as the analysis's parameters.
    pub fn params(&self) -> AnalyzeParams {
        AnalyzeParams {
            lmax: self.lmax,
            lighting: self.lighting.clone().map(LightingInput::File),
            mapping: self.mapping,
            param: self.param.map(Into::into),
            brdf: self.brdf.values(),
            pixel_filter: self.view.pixel_filter,
            no_diagnosis: self.no_diagnosis,
        }
    }
}

/// Analyses the images of `a` ([`analysis::analyze::analyze`] on the images read and described by
/// [`load`]); the pixel-noise notes are printed on stderr.
pub fn analyze(a: &AnalyzeArgs) -> Result<AnalyzeReport, Error> {
    let params = a.params();
    params.validate()?;
    let (images, observed) = load(&a.images, &a.view, "analysed")?;
    let report = analysis::analyze::analyze(&params, images, &a.images, &observed)?;
    report.notes.iter().for_each(|n| eprintln!("{n}"));
    Ok(report)
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
