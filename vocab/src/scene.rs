//! The scene-file vocabulary of docs/src/conventions.md §6, as serde types. Unknown keys are errors
//! (`deny_unknown_fields` everywhere), so a typo never silently changes a render, and every closed
//! set (`sampler`, `horizon`, `distribution`, `fresnel`, `mapping`, and the `type`/`shape` tags) is
//! an enum, so a bad value is refused by the parser with the line and the accepted names.
//!
//! The renderer builds its scene from these types, the analysis reads its lighting from them, the
//! EXR header (`reflect:*` attributes, [`crate::header`]) is written from and read back into them,
//! and `reflect verify` builds its scenes as values of them.
//!
//! The vocabulary is defined by docs/src/conventions.md §6 and, key by key with defaults, by
//! docs/src/reference/scene-files.md (rotations: §2 "Rotations").

use crate::closed::{Distribution, FresnelKind, Horizon, Mapping, Sampler};
use serde::{Deserialize, Serialize};

/// A colour given either as one number (grey) or as `[r, g, b]`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Color {
    Grey(f32),
    Rgb([f32; 3]),
}

impl Color {
    pub fn rgb(self) -> [f32; 3] {
        match self {
            Color::Grey(v) => [v; 3],
            Color::Rgb(c) => c,
        }
    }
}

fn one() -> Color {
    Color::Grey(1.0)
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    #[serde(default)]
    pub render: RenderSection,
    pub camera: CameraSection,
    pub lighting: LightingSection,
    #[serde(default)]
    pub objects: Vec<ObjectSection>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSection {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    /// Path vertices; a convex object under distant light needs 1.
    pub max_depth: u32,
    /// Sample generator (default Sobol).
    pub sampler: Sampler,
}

impl Default for RenderSection {
    fn default() -> Self {
        RenderSection { width: 512, height: 512, spp: 64, seed: 0, max_depth: 8, sampler: Sampler::Sobol }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum CameraSection {
    Orthographic {
        from: [f32; 3],
        /// The point looked at; default the origin (where a scene's sphere usually is).
        #[serde(default)]
        to: [f32; 3],
        #[serde(default = "z_up")]
        up: [f32; 3],
        extent: f32,
    },
    Perspective {
        from: [f32; 3],
        /// The point looked at; default the origin.
        #[serde(default)]
        to: [f32; 3],
        #[serde(default = "z_up")]
        up: [f32; 3],
        fov_deg: f32,
    },
    NormalProbe {
        #[serde(default)]
        theta_o_deg: f32,
        /// Azimuth of ω_o about the normal, from the θ tangent (an extension of docs/src/conventions.md §6).
        #[serde(default)]
        phi_o_deg: f32,
        /// Average each pixel over its solid angle instead of sampling the pixel centre.
        #[serde(default)]
        jitter: bool,
    },
}

fn z_up() -> [f32; 3] {
    [0.0, 0.0, 1.0]
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum LightingSection {
    Uniform {
        radiance: Color,
    },
    Directional {
        /// Direction toward the source.
        direction: [f32; 3],
        irradiance: Color,
    },
    Axial {
        #[serde(default = "z_up")]
        axis: [f32; 3],
        /// `[theta_deg, r, g, b]` rows, θ increasing from 0 to 180; linear in between.
        profile: Vec<[f32; 4]>,
    },
    Sh {
        /// RGB triples in index order k = l(l+1) + m.
        coefficients: Vec<[f32; 3]>,
    },
    Envmap {
        file: String,
        /// Absent: inferred from the map's aspect ratio ([`Mapping::infer`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        mapping: Option<Mapping>,
        #[serde(default = "one_f")]
        scale: f32,
        #[serde(default)]
        rotate_deg: [f32; 3],
        /// The layer of the map to light with: a channel prefix (`ViewLayer.Combined`) or the name of
        /// a part of a multi-part OpenEXR file (guide "Bad input"). Absent: the beauty (plain `R, G, B`),
        /// else the only radiance layer.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        layer: Option<String>,
    },
}

fn one_f() -> f32 {
    1.0
}

fn yes() -> bool {
    true
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "shape", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ObjectSection {
    Sphere {
        #[serde(default)]
        center: [f32; 3],
        #[serde(default = "one_f")]
        radius: f32,
        /// Albedo texture T(n) multiplying the BRDF (`renderer::texture`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        texture: Option<TextureSection>,
        brdf: BrdfSection,
    },
    Mesh {
        file: String,
        #[serde(default = "yes")]
        smooth: bool,
        #[serde(default)]
        translate: [f32; 3],
        #[serde(default = "one_f")]
        scale: f32,
        #[serde(default)]
        rotate_deg: [f32; 3],
        /// Albedo texture T(n) multiplying the BRDF (`renderer::texture`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        texture: Option<TextureSection>,
        brdf: BrdfSection,
    },
    /// A tessellated sphere built in memory (`geometry::icosphere`: 20·4ⁿ triangles, vertex
    /// normals = positions when `smooth`), placed like a sphere: for meshes of known size without
    /// a file (the 1.31M-triangle benchmark scene of issue 10 is `subdivisions = 8`).
    Icosphere {
        /// n = 0..=9 (9: 5.2M triangles).
        subdivisions: u32,
        #[serde(default)]
        center: [f32; 3],
        #[serde(default = "one_f")]
        radius: f32,
        #[serde(default = "yes")]
        smooth: bool,
        /// Albedo texture T(n) multiplying the BRDF (`renderer::texture`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        texture: Option<TextureSection>,
        brdf: BrdfSection,
    },
}

/// An albedo texture (docs/src/conventions.md §6 extension, guide "Scene files").
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TextureSection {
    /// T(n) = Σ_k T_k Y_k(n): RGB triples in index order k, l ≤ 16.
    Sh { coefficients: Vec<[f32; 3]> },
}

impl ObjectSection {
    pub fn texture(&self) -> Option<&TextureSection> {
        match self {
            ObjectSection::Sphere { texture, .. }
            | ObjectSection::Mesh { texture, .. }
            | ObjectSection::Icosphere { texture, .. } => texture.as_ref(),
        }
    }

    pub fn brdf(&self) -> &BrdfSection {
        match self {
            ObjectSection::Sphere { brdf, .. }
            | ObjectSection::Mesh { brdf, .. }
            | ObjectSection::Icosphere { brdf, .. } => brdf,
        }
    }
}

/// Defines the BRDF tables once: [`BrdfSection`] (the `brdf` table of an object, its variants
/// tagged by `type`) and, from the same list, the closed set [`BrdfKind`] of their names and
/// [`BrdfSection::kind`]. Adding a BRDF to the scene format is one entry here (guide "Adding a
/// BRDF").
macro_rules! brdf_tables {
    ($( $(#[$vmeta:meta])* $variant:ident = $text:literal { $($fields:tt)* } ),+ $(,)?) => {
        /// A `brdf` table (docs/src/conventions.md §4 and §6), tagged by `type`.
        #[derive(Clone, Debug, Deserialize, Serialize)]
        #[serde(tag = "type", deny_unknown_fields)]
        pub enum BrdfSection {
            $( $(#[$vmeta])* #[serde(rename = $text)] $variant { $($fields)* }, )+
        }

        crate::closed::closed_set! {
            /// The BRDF models of docs/src/conventions.md §4 (the `type` of a `brdf` table), one per
            /// [`BrdfSection`] variant.
            "BRDF type", BrdfKind { $( $(#[$vmeta])* $variant = $text ),+ }
        }

        impl BrdfSection {
            /// The BRDF's `type`.
            pub fn kind(&self) -> BrdfKind {
                match self {
                    $( BrdfSection::$variant { .. } => BrdfKind::$variant, )+
                }
            }
        }
    };
}

brdf_tables! {
    /// ρ̂ = k_r δ(ω_i = R).
    Mirror = "mirror" {
        #[serde(default = "one")]
        kr: Color,
    },
    /// BRDF = albedo / π.
    Lambert = "lambert" {
        albedo: Color,
    },
    /// The normalized Phong lobe of eq. 40.
    Phong = "phong" {
        #[serde(default = "one")]
        ks: Color,
        s: f32,
        #[serde(default)]
        horizon: Horizon,
    },
    /// The Torrance–Sparrow lobe of eq. 48.
    TorranceSparrow = "torrance-sparrow" {
        #[serde(default = "one")]
        ks: Color,
        sigma: f32,
        #[serde(default)]
        horizon: Horizon,
    },
    /// Beckmann or GGX D, Smith G, Fresnel F.
    Microfacet = "microfacet" {
        #[serde(default)]
        distribution: Distribution,
        alpha: f32,
        #[serde(default)]
        fresnel: FresnelKind,
        /// Schlick: reflectance at normal incidence.
        #[serde(default)]
        f0: Option<Color>,
        /// Conductor: complex index of refraction η + i k.
        #[serde(default)]
        eta: Option<Color>,
        #[serde(default)]
        k: Option<Color>,
    },
    /// A weighted sum of the others.
    Mix = "mix" {
        layers: Vec<MixLayer>,
    },
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MixLayer {
    pub weight: f32,
    pub brdf: BrdfSection,
}

impl SceneFile {
    /// Parses TOML text; errors carry the line number and serde's one-line message.
    ///
    /// An error inside an `[[objects]]` entry names the entry (`objects[i]`) and the line of its
    /// table: the `shape`-tagged entries are read whole, so the parser's own span covers the whole
    /// array and cannot say which entry (or line) is at fault.
    pub fn parse(text: &str) -> Result<Self, String> {
        toml::from_str::<SceneFile>(text).map_err(|e| {
            if let Some(located) = locate_object_error(text) {
                return located;
            }
            let msg = e.message().trim().replace('\n', " ");
            match e.span() {
                Some(s) => format!("line {}: {msg}", line_of(text, s.start)),
                None => msg,
            }
        })
    }
}

/// The 1-based line holding byte `offset` of `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The first `[[objects]]` entry that does not parse on its own, as "line L: objects[i]: message"
/// (L the first line of its table); `None` when every entry parses (the fault is elsewhere).
fn locate_object_error(text: &str) -> Option<String> {
    #[derive(Deserialize)]
    struct Objects {
        #[serde(default)]
        objects: Vec<toml::Spanned<toml::Table>>,
    }
    let all: Objects = toml::from_str(text).ok()?;
    all.objects.into_iter().enumerate().find_map(|(i, o)| {
        let start = o.span().start;
        let err = toml::Value::Table(o.into_inner()).try_into::<ObjectSection>().err()?;
        let msg = err.message().trim().replace('\n', " ");
        Some(format!("line {}: objects[{i}]: {msg}", line_of(text, start)))
    })
}

impl CameraSection {
    /// The camera's `type`.
    pub fn kind(&self) -> crate::CameraKind {
        match self {
            CameraSection::Orthographic { .. } => crate::CameraKind::Orthographic,
            CameraSection::Perspective { .. } => crate::CameraKind::Perspective,
            CameraSection::NormalProbe { .. } => crate::CameraKind::NormalProbe,
        }
    }
}

impl LightingSection {
    /// The lighting's `type`.
    pub fn kind(&self) -> crate::LightingKind {
        match self {
            LightingSection::Uniform { .. } => crate::LightingKind::Uniform,
            LightingSection::Directional { .. } => crate::LightingKind::Directional,
            LightingSection::Axial { .. } => crate::LightingKind::Axial,
            LightingSection::Sh { .. } => crate::LightingKind::Sh,
            LightingSection::Envmap { .. } => crate::LightingKind::Envmap,
        }
    }
}

impl ObjectSection {
    /// The object's `shape`.
    pub fn kind(&self) -> crate::ShapeKind {
        match self {
            ObjectSection::Sphere { .. } => crate::ShapeKind::Sphere,
            ObjectSection::Mesh { .. } => crate::ShapeKind::Mesh,
            ObjectSection::Icosphere { .. } => crate::ShapeKind::Icosphere,
        }
    }
}

/// An f32 scene value as the decimal it was written as (its shortest round-trip form, as TOML,
/// JSON and the `reflect:*` headers spell it), so an analysis takes `s = 0.1` as 0.1, not as the
/// f32 nearest to it (0.10000000149…): the renderer needs f32, the analysis the stated number.
pub fn decimal(x: f32) -> f64 {
    if x.is_finite() { x.to_string().parse().unwrap_or(f64::from(x)) } else { f64::from(x) }
}

/// [`decimal`] of each component.
pub fn decimal3(v: [f32; 3]) -> [f64; 3] {
    v.map(decimal)
}
