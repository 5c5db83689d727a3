//! Arguments shared by several subcommands, defined once so that a flag name has one meaning
//! everywhere (`#[command(flatten)]` or the same type): the view of an image whose header does not
//! describe it ([`ViewArgs`]), the colour channel ([`Channel`]), and the closed sets of the
//! analysis as `clap::ValueEnum`s, so `--help` lists their names (those of the scene format,
//! `--brdf`, `--mapping`, `--sampler`, come from `vocab` with its `clap` feature).

use super::{Error, flags};
use analysis::noise::PixelFilter;
use analysis::observation::CameraValues;
use analysis::projection::Param;
use analysis::transfer::{ParamValue, TransferModel};
use std::path::PathBuf;

/// The orthographic camera of each image and the sphere they show, for images whose header does
/// not say them (another renderer's images, in the renderer's camera convention). The one place
/// these flags are parsed and documented: every command that takes a view flattens this struct.
///
/// `--from/--to/--up/--extent` (an orthographic view, docs/src/conventions.md §5) or `--theta-o/--phi-o` (a
/// normal-probe view, docs/src/conventions.md §6) are given once per image, in the order of the images, or not
/// at all ([`flags::per_image`]); `--center` and `--radius` describe the one sphere; `--scene S.toml` says
/// the images are renders of that scene (camera, sphere, BRDF, lighting; its `[render]` size must be
/// the images'). A header's `reflect:camera` / `reflect:objects`, the scene and the flags are
/// combined by [`analysis::observation::describe`]: each fills in what the others leave open, and two that
/// contradict each other are an error naming both values. Positions and lengths are in world units
/// of our frame (docs/src/conventions.md §1, +z up); `--extent` is the half-width of the view.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ViewArgs {
    /// Orthographic camera position x,y,z of an image without reflect:camera; once per image, in
    /// the order of the images (as --to, --up and --extent).
    #[arg(long, value_parser = flags::parse_vec3, allow_hyphen_values = true)]
    pub from: Vec<[f64; 3]>,
    /// Camera target x,y,z, once per image (default 0,0,0).
    #[arg(long, value_parser = flags::parse_vec3, allow_hyphen_values = true)]
    pub to: Vec<[f64; 3]>,
    /// Camera up x,y,z, once per image (default 0,0,1).
    #[arg(long, value_parser = flags::parse_vec3, allow_hyphen_values = true)]
    pub up: Vec<[f64; 3]>,
    /// Orthographic half-width of the view (> 0), once per image.
    #[arg(long, value_parser = flags::parse_positive, allow_hyphen_values = true)]
    pub extent: Vec<f64>,
    /// Sphere centre x,y,z when the header has no reflect:objects.
    #[arg(long, value_parser = flags::parse_vec3, allow_hyphen_values = true)]
    pub center: Option<[f64; 3]>,
    /// Sphere radius (> 0) when the header has no reflect:objects.
    #[arg(long, value_parser = flags::parse_positive, allow_hyphen_values = true)]
    pub radius: Option<f64>,
    /// The reconstruction filter of a renderer that splats each sample into the pixels its filter
    /// reaches (Mitsuba 3): box, gaussian:STDDEV or gaussian:STDDEV:RADIUS (radius 4·STDDEV by default; Mitsuba's
    /// default is gaussian:0.5), tent:RADIUS, in pixels. Its kernel gives the correlation of
    /// neighbouring pixels' noise, hence the widening of the error bars, and the margin of pixels
    /// near the silhouette left out; without it the correlation is measured from the residuals.
    #[arg(long, value_parser = parse_pixel_filter)]
    pub pixel_filter: Option<PixelFilter>,
    /// The flags of a view that every analysis command takes, normal-probe images included.
    #[command(flatten)]
    pub image: ImageArgs,
    /// The command takes only [`ImageArgs`] (`invert separate`, `invert factor`: normal-probe views),
    /// not the orthographic flags: its messages name only the flags it accepts.
    #[arg(skip)]
    pub probe_only: bool,
}

/// The part of [`ViewArgs`] that also describes normal-probe images, the only part `invert separate`
/// and `invert factor` take: the sidecar `--scene`, the radiance `--layer`, and the normal-probe
/// camera of a headerless image (`--theta-o/--phi-o`, once per image, as the orthographic flags).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ImageArgs {
    /// Scene file (TOML, our vocabulary) the images are renders of: camera, sphere, BRDF and
    /// lighting for images whose header does not say them; its `[render]` size must be the images'.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// The radiance layer of a multi-layer EXR, by its channel prefix (e.g. ViewLayer.Combined for
    /// ViewLayer.Combined.R/G/B); needed only when the file has several radiance layers.
    #[arg(long)]
    pub layer: Option<String>,
    /// Normal-probe camera (a lat-long map over the sphere's normals, guide "Cameras") of an image
    /// without reflect:camera: its exitance θ_o in degrees, 0 ≤ θ_o < 90, once per image (default 0
    /// when only --phi-o is given); a --scene normal-probe camera takes these angles per image.
    #[arg(long = "theta-o", value_parser = flags::parse_theta_o, allow_hyphen_values = true)]
    pub theta_o: Vec<f64>,
    /// Normal-probe azimuth φ_o in degrees, once per image (default 0).
    #[arg(long = "phi-o", value_parser = flags::parse_degrees, allow_hyphen_values = true)]
    pub phi_o: Vec<f64>,
}

impl ImageArgs {
    /// These flags as a whole [`ViewArgs`] (no orthographic flag), for [`super::header::load`].
    pub fn view(&self) -> ViewArgs {
        ViewArgs { image: self.clone(), probe_only: true, ..Default::default() }
    }
}

/// `--pixel-filter`, refusing a Gaussian cut off within 2 stddev (`gaussian:0.5:0.1` keeps a sliver
/// of the kernel, surely not the renderer's filter: Mitsuba cuts at 4·stddev, pbrt-v4 at 3).
fn parse_pixel_filter(s: &str) -> Result<PixelFilter, String> {
    let f: PixelFilter = s.parse()?;
    if let PixelFilter::Gaussian { stddev, radius } = f
        && radius < 2.0 * stddev
    {
        return Err(format!(
            "a gaussian of stddev {stddev} px cut at radius {radius} px (< 2 × stddev) keeps only the kernel's core;              give RADIUS ≥ 2·STDDEV (Mitsuba's is 4·STDDEV, the default)"
        ));
    }
    Ok(f)
}

/// The BRDF of the sphere in an image, by flags: a kind plus its parameters, each named as the key
/// of a scene file's `brdf` table (`--s` for Phong, `--sigma` for Torrance–Sparrow, `--brdf-param
/// KEY=VALUE` for any other, so a new BRDF needs no new flag), and `--albedo` the albedo / k_s / k_r
/// scale. Shared by every command that takes a BRDF by flags (`sh transfer`, `analyze`, `invert
/// lighting`), all through the one mapping [`TransferModel::from_named`];
/// a header's or `--scene`'s BRDF that contradicts the flags is an error naming both
/// ([`analysis::observation::Observation::transfer`]).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct BrdfFlags {
    /// BRDF model of the sphere (default: the header's or --scene's; mix has no transfer model, microfacet
    /// only with fresnel none or schlick).
    #[arg(long, value_enum)]
    pub brdf: Option<vocab::BrdfKind>,
    /// Phong exponent s (with --brdf phong).
    #[arg(long)]
    pub s: Option<f64>,
    /// Torrance–Sparrow roughness σ in radians (with --brdf torrance-sparrow).
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Any other parameter of the --brdf model, KEY=VALUE with KEY its key in a scene file's brdf
    /// table (repeatable).
    #[arg(long = "brdf-param", value_parser = parse_param)]
    pub brdf_param: Vec<(String, ParamValue)>,
    /// Albedo / k_s / k_r (one number, or r,g,b; default: the header's or scene's, else 1).
    #[arg(long, value_parser = flags::parse_rgb)]
    pub albedo: Option<[f64; 3]>,
}

/// `KEY=VALUE` with a number or a word of a closed set (`distribution=ggx`) as the value; which
/// keys take which is the transfer model's to say ([`TransferModel::from_named`]).
fn parse_param(s: &str) -> Result<(String, ParamValue), String> {
    let (k, v) = s.split_once('=').ok_or_else(|| format!("expected KEY=VALUE, got \"{s}\""))?;
    let v: ParamValue = v.parse().map_err(|e: analysis::Error| format!("the value of {k}: {}", e.message))?;
    Ok((k.trim().to_string(), v))
}

impl BrdfFlags {
    /// The parameters given (`--s`, `--sigma`, each `--brdf-param`), as (key, value) pairs.
    pub fn params(&self) -> Vec<(String, ParamValue)> {
        let named = [("s", self.s), ("sigma", self.sigma)]
            .into_iter()
            .filter_map(|(n, v)| Some((n.to_string(), ParamValue::Number(v?))));
        named.chain(self.brdf_param.iter().cloned()).collect()
    }

    /// The transfer model of `--brdf` and its parameters, with `theta_o_deg` an exitance given on
    /// the command line (`sh transfer --theta-o`); `None` without `--brdf`, a parameter given
    /// without `--brdf` being an error.
    pub fn model(&self, theta_o_deg: Option<f64>) -> Result<Option<TransferModel>, Error> {
        match self.brdf {
            Some(kind) => Ok(Some(TransferModel::from_named(kind, &self.params(), theta_o_deg)?)),
            None => match self.params().first() {
                Some((name, _)) => Err(Error::new(format!("--{name} needs --brdf"))),
                None => Ok(None),
            },
        }
    }
}

impl ViewArgs {
    /// The camera flags of each of `n` images: each flag given not at all or once per image
    /// (anything else is refused naming the flag).
    pub fn per_image(&self, n: usize) -> Result<Vec<CameraValues>, Error> {
        let (from, to) = (flags::per_image(&self.from, "from", n)?, flags::per_image(&self.to, "to", n)?);
        let (up, extent) = (flags::per_image(&self.up, "up", n)?, flags::per_image(&self.extent, "extent", n)?);
        let theta_o = flags::per_image(&self.image.theta_o, "theta-o", n)?;
        let phi_o = flags::per_image(&self.image.phi_o, "phi-o", n)?;
        Ok((0..n)
            .map(|i| CameraValues {
                from: from[i],
                to: to[i],
                up: up[i],
                extent: extent[i],
                theta_o: theta_o[i],
                phi_o: phi_o[i],
            })
            .collect())
    }
}

/// One colour channel. `--channel C` means the same in every command: analyse channel C only;
/// without it a command analyses every channel it can in one run (`separate`: all three; `invert
/// factor`, which factors one channel per run: R).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Channel {
    #[default]
    #[value(name = "r", alias = "R")]
    R,
    #[value(name = "g", alias = "G")]
    G,
    #[value(name = "b", alias = "B")]
    B,
}

impl Channel {
    /// 0, 1, 2 for R, G, B (the index into an RGB triple).
    pub fn index(self) -> usize {
        self as usize
    }

    /// The EXR layer name: "R", "G" or "B".
    pub fn layer(self) -> &'static str {
        ["R", "G", "B"][self.index()]
    }
}

/// The direction the reflected radiance is a function of, in the orthographic fit (`--param`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ParamArg {
    /// The surface normal n (Lambert).
    Normal,
    /// The reflection vector R (lobes centred on R).
    Reflection,
}

impl From<ParamArg> for Param {
    fn from(p: ParamArg) -> Param {
        match p {
            ParamArg::Normal => Param::Normal,
            ParamArg::Reflection => Param::Reflection,
        }
    }
}

/// The rule choosing the Tikhonov λ of `invert lighting` (`--lambda-rule`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LambdaRule {
    /// Generalised cross-validation (needs no standard errors).
    Gcv,
    /// Morozov's discrepancy principle (needs standard errors).
    Discrepancy,
}

/// The parametric BRDF model `invert brdf` fits (`--model`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FitModel {
    /// Phong's exponent s (eq. 43).
    Phong,
    /// Torrance–Sparrow's roughness σ (eq. 50 / 59).
    TorranceSparrow,
    /// The microfacet BRDF's roughness α (Beckmann or GGX by --distribution, Smith G, F = 1).
    Microfacet,
}

/// The quadrature over the normals of `invert factor` (`--quadrature`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Quadrature {
    /// Fejér's first rule (the default).
    #[default]
    Fejer,
    /// The exact solid angles of the lat-long pixels.
    Pixel,
}
