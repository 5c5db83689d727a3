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
//!
//! The inversions themselves are the library's ([`analysis::invert`]); this command turns the flags
//! into [`LightingParams`] / [`BrdfParams`], reads and describes the images, prints the reports and
//! writes the map.
use super::Error;
use super::args::{BrdfFlags, FitModel, LambdaRule, ViewArgs};
use super::header::load;
use super::outputs::{Files, Format};
use analysis::image::write_exr;
use analysis::inverse::lighting::{DEFAULT_MAX_AMPLIFICATION, Rule};
use analysis::invert::{BrdfParams, LightingParams};
pub use analysis::invert::{InvertBrdfReport, InvertLightingReport};
use analysis::observation::LightingInput;
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

impl LightingArgs {
    /// The flags as the inversion's parameters.
    pub fn params(&self) -> LightingParams {
        LightingParams {
            lmax: self.lmax,
            brdf: self.brdf.values(),
            max_amplification: self.max_amplification,
            rule: match self.lambda_rule {
                LambdaRule::Gcv => Rule::Gcv,
                LambdaRule::Discrepancy => Rule::Discrepancy,
            },
            map: self.output.clone().map(|p| (p, self.width)),
            pixel_filter: self.view.pixel_filter,
        }
    }
}

impl BrdfArgs {
    /// The flags as the inversion's parameters.
    pub fn params(&self) -> BrdfParams {
        BrdfParams {
            lmax: self.lmax,
            lighting: self.lighting.clone().map(LightingInput::File),
            mapping: self.mapping,
            model: match self.model {
                FitModel::Phong => analysis::invert::FitModel::Phong,
                FitModel::TorranceSparrow => analysis::invert::FitModel::TorranceSparrow,
                FitModel::Microfacet => analysis::invert::FitModel::Microfacet { distribution: self.distribution },
            },
            min: self.min,
            max: self.max,
            pixel_filter: self.view.pixel_filter,
        }
    }
}

/// `reflect invert lighting` ([`analysis::invert::lighting()`] on the images read and described by
/// [`load`]): the report, with the `--output` map written once everything is computed, so that a
/// failure leaves no partial output; the pixel-noise notes are printed on stderr.
pub fn invert_lighting_report(a: &LightingArgs) -> Result<InvertLightingReport, Error> {
    if let Some(out) = &a.output {
        let files = Files::new().inputs("the image", &a.images).inputs("the scene", &a.view.image.scene);
        files.output("--output", out, Format::Exr).check()?;
    }
    let params = a.params();
    analysis::invert::lighting::validate(&params)?;
    let (images, observed) = load(&a.images, &a.view, "inverted")?;
    let r = analysis::invert::lighting(&params, images, &a.images, &observed)?;
    r.notes.iter().for_each(|n| eprintln!("{n}"));
    if let Some(out) = &a.output {
        write_exr(out, &r.lighting_map(a.width))?;
    }
    Ok(r)
}

/// `reflect invert brdf` ([`analysis::invert::brdf()`] on the images read and described by
/// [`load`]); the pixel-noise notes are printed on stderr.
pub fn invert_brdf_report(a: &BrdfArgs) -> Result<InvertBrdfReport, Error> {
    let params = a.params();
    analysis::invert::brdf::validate(&params)?;
    let (images, observed) = load(&a.images, &a.view, "inverted")?;
    let r = analysis::invert::brdf(&params, images, &a.images, &observed)?;
    r.notes.iter().for_each(|n| eprintln!("{n}"));
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use analysis::image::{Image, read_image, write_exr};
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
