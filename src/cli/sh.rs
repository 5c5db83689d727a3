//! `reflect sh …`: spherical-harmonic tools.
//!
//! - `reflect sh project ENV [--mapping latlong|angular] [--layer NAME] --lmax L [--json]`: L_lm of an environment
//!   map (`.exr` or `.hdr`). Without `--mapping` the mapping is inferred from the aspect ratio
//!   (W = H → angular, W = 2H → lat-long; anything else is an error). Each Y_lm is integrated
//!   exactly over each pixel's footprint, for the piecewise-constant map the renderer lights with
//!   (analysis::projection::envmap), so every order is the exact expansion of that map.
//! - `reflect sh transfer --brdf lambert|phong|mirror|torrance-sparrow|microfacet [--s S] [--sigma X]
//!   [--brdf-param KEY=VALUE] [--theta-o DEG] --lmax L [--json]`: Λ_l ρ̂_l for unit albedo / k_s (docs/src/conventions.md §4), with the
//!   paper's approximation alongside where it has one (eq. 46, 57, 59).
//!
//! `--json` prints one JSON document (docs/src/conventions.md §7) to stdout; otherwise a table.
use super::Error;
use super::args::BrdfFlags;
use analysis::image::read_rgb_layer;
use analysis::projection::{Mapping, project_envmap};
use analysis::sh::lm;
use serde::Serialize;
use std::fmt;
use std::path::PathBuf;
use std::process::ExitCode;

/// Largest l_max accepted on the command line: the analysis's.
pub use analysis::sh::MAX_LMAX;

#[derive(clap::Subcommand, Debug)]
pub enum ShCommand {
    /// Project an environment map into SH (L_lm, RGB).
    Project(ProjectArgs),
    /// Transfer coefficients Λ_l ρ̂_l of a BRDF (unit albedo / k_s).
    Transfer(TransferArgs),
}

#[derive(clap::Args, Debug)]
pub struct ProjectArgs {
    /// Environment map (.exr or .hdr).
    pub env: PathBuf,
    /// Mapping of the map (default: inferred from the aspect ratio, W = H angular, W = 2H lat-long).
    #[arg(long, value_enum)]
    pub mapping: Option<Mapping>,
    /// Highest SH order.
    #[arg(long)]
    pub lmax: usize,
    /// The layer of the map to project: a channel prefix (e.g. ViewLayer.Combined) or a part of a
    /// multi-part EXR (e.g. diffuse); default: the beauty (plain R, G, B), else the only radiance layer.
    #[arg(long)]
    pub layer: Option<String>,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

/// `--albedo` of the shared [`BrdfFlags`] is hidden here (and refused): the coefficients are for unit
/// albedo / k_s.
#[derive(clap::Args, Debug)]
#[command(mut_arg("albedo", |a| a.hide(true)))]
pub struct TransferArgs {
    /// The BRDF (`--brdf` is required here).
    #[command(flatten)]
    pub brdf: BrdfFlags,
    /// Torrance–Sparrow exitance angle θ_o in degrees (default 0, normal exitance).
    #[arg(long = "theta-o")]
    pub theta_o: Option<f64>,
    /// Highest SH order.
    #[arg(long)]
    pub lmax: usize,
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(c: ShCommand) -> Result<ExitCode, Error> {
    match c {
        ShCommand::Project(a) => project(a),
        ShCommand::Transfer(a) => transfer(a),
    }
}

pub fn check_lmax(lmax: usize) -> Result<(), Error> {
    if lmax > MAX_LMAX {
        return Err(Error::new(format!("--lmax {lmax} is above the supported maximum {MAX_LMAX}")));
    }
    Ok(())
}

fn project(a: ProjectArgs) -> Result<ExitCode, Error> {
    check_lmax(a.lmax)?;
    // Flags are checked before the file is read: a bad flag is named whatever the file holds.
    let given = a.mapping;
    refuse_render(&a.env)?;
    let img = read_rgb_layer(&a.env, a.layer.as_deref())?;
    let mapping = match given {
        Some(m) => m,
        None => Mapping::infer(img.width, img.height).map_err(|e| e.in_file(&a.env))?,
    };
    let c = project_envmap(&img, mapping, a.lmax).map_err(|e| e.in_file(&a.env))?;
    let report = ProjectReport {
        file: a.env.display().to_string(),
        mapping: mapping.name().to_string(),
        width: img.width,
        height: img.height,
        lmax: a.lmax,
        integration: PROJECT_INTEGRATION.to_string(),
        coefficients: c,
    };
    if a.json {
        println!("{}", serde_json::to_string(&report).map_err(|e| Error::new(format!("JSON: {e}")))?);
    } else {
        print!("{report}");
    }
    Ok(ExitCode::SUCCESS)
}

/// Camera types whose image is an environment (radiance by direction), which `sh project` may
/// take; any other `reflect:camera` is a render of an object.
const ENVIRONMENT_CAMERAS: [&str; 4] = ["environment", "envmap", "latlong", "angular"];

/// `sh project` reads its input as lighting by direction. A reflect render (its EXR header has a
/// `reflect:camera` whose type is not an environment) is an object seen by a camera: projecting
/// it as an environment map gives numbers with no meaning, so it is refused, naming the camera
/// and the command that does take it. An unreadable header is left to the image reader.
fn refuse_render(path: &std::path::Path) -> Result<(), Error> {
    let Ok(attrs) = analysis::image::header_attributes(path) else { return Ok(()) };
    let Some(camera) = attrs.get("reflect:camera") else { return Ok(()) };
    let ty = serde_json::from_str::<serde_json::Value>(camera)
        .ok()
        .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(str::to_string));
    match ty {
        Some(t) if ENVIRONMENT_CAMERAS.contains(&t.as_str()) => Ok(()),
        Some(t) => Err(Error::file(
            path,
            format!(
                "this is a render (header reflect:camera type \"{t}\"), not an environment map: `sh project` takes lighting \
                 by direction; project a render with `reflect analyze`"
            ),
        )),
        None => Err(Error::file(
            path,
            "the header has a reflect:camera attribute without a camera type, so this may be a render, not an environment \
             map; `sh project` refuses it",
        )),
    }
}

fn transfer(a: TransferArgs) -> Result<ExitCode, Error> {
    check_lmax(a.lmax)?;
    let kind = a.brdf.brdf.ok_or_else(|| Error::new("sh transfer needs --brdf"))?;
    if a.brdf.albedo.is_some() {
        return Err(Error::new("--albedo does not apply to sh transfer (it prints Λ_l ρ̂_l for unit albedo / k_s)"));
    }
    let model = a.brdf.model(a.theta_o)?.expect("--brdf is given");
    let f = model.lambda_rho(a.lmax);
    let approx = model.approximation(a.lmax);
    let method = model.method();
    let report = TransferReport {
        brdf: kind.name().to_string(),
        lmax: a.lmax,
        s: a.brdf.s,
        sigma: a.brdf.sigma,
        theta_o_deg: a.theta_o,
        method: method.to_string(),
        lambda_rho: f,
        approximation: approx
            .map(|(equation, lambda_rho)| Approximation { equation: equation.to_string(), lambda_rho }),
    };
    if a.json {
        println!("{}", serde_json::to_string(&report).map_err(|e| Error::new(format!("JSON: {e}")))?);
    } else {
        print!("{report}");
    }
    Ok(ExitCode::SUCCESS)
}

/// How `sh project` integrates (printed with its output).
pub const PROJECT_INTEGRATION: &str = "exact: each Y_lm integrated over each pixel of the piecewise-constant map the \
                                       renderer lights with, so every order is the exact expansion of that map";

/// The output of `reflect sh project` (`--json` prints it; docs/src/conventions.md §7). `Display` is the table.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ProjectReport {
    /// The environment map, as given.
    pub file: String,
    /// `latlong` or `angular` (docs/src/conventions.md §2).
    pub mapping: String,
    /// Map size in pixels.
    pub width: usize,
    pub height: usize,
    pub lmax: usize,
    /// How the coefficients were integrated.
    pub integration: String,
    /// L_lm as `[r, g, b]`, (lmax + 1)² triples in index order k = l² + l + m (docs/src/conventions.md §3).
    pub coefficients: Vec<[f64; 3]>,
}

impl fmt::Display for ProjectReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "# {} ({} {}×{}), l_max {}", self.file, self.mapping, self.width, self.height, self.lmax)?;
        writeln!(f, "# integration {}", self.integration)?;
        writeln!(f, "{:>4} {:>4} {:>14} {:>14} {:>14}", "l", "m", "R", "G", "B")?;
        for (k, v) in self.coefficients.iter().enumerate() {
            let (l, m) = lm(k);
            writeln!(f, "{l:>4} {m:>4} {:>14.6e} {:>14.6e} {:>14.6e}", v[0], v[1], v[2])?;
        }
        Ok(())
    }
}

/// The paper's approximation printed beside the exact transfer coefficients (eq. 46, 57, 59).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Approximation {
    /// Which equation, e.g. "eq. 57 exp(−(σl)²)".
    pub equation: String,
    /// Its Λ_l ρ̂_l, l = 0..=lmax.
    pub lambda_rho: Vec<f64>,
}

/// The output of `reflect sh transfer` (`--json` prints it; docs/src/conventions.md §7). `Display` is the table.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct TransferReport {
    /// `lambert`, `phong`, `mirror` or `torrance-sparrow`.
    pub brdf: String,
    pub lmax: usize,
    /// Phong exponent (null unless given).
    pub s: Option<f64>,
    /// Torrance–Sparrow roughness σ, radians (null unless given).
    pub sigma: Option<f64>,
    /// Exitance angle θ_o in degrees (null unless given; 0 is assumed).
    pub theta_o_deg: Option<f64>,
    /// How Λ_l ρ̂_l was computed (equation and method).
    pub method: String,
    /// Λ_l ρ̂_l for unit albedo / k_s, l = 0..=lmax.
    pub lambda_rho: Vec<f64>,
    /// The paper's approximation, where it has one.
    pub approximation: Option<Approximation>,
}

impl fmt::Display for TransferReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "# Λ_l ρ̂_l of {} ({}), unit albedo / k_s", self.brdf, self.method)?;
        match &self.approximation {
            Some(a) => writeln!(f, "{:>4} {:>22} {:>22}", "l", "Λ_l ρ̂_l", a.equation)?,
            None => writeln!(f, "{:>4} {:>22}", "l", "Λ_l ρ̂_l")?,
        }
        for (l, v) in self.lambda_rho.iter().enumerate() {
            match &self.approximation {
                Some(a) => writeln!(f, "{l:>4} {v:>22.15e} {:>22.15e}", a.lambda_rho[l])?,
                None => writeln!(f, "{l:>4} {v:>22.15e}")?,
            }
        }
        Ok(())
    }
}
