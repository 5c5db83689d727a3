//! The closed sets of the scene format and the command line, each defined once: its Rust variants,
//! its spelling in TOML, JSON, EXR headers and on the command line (the same string everywhere),
//! and its default. With the `clap` feature each is a `clap::ValueEnum`, so `--help` lists the names.

use crate::error::{Error, Result};

/// Defines a closed set: a fieldless enum with one spelling per variant, serde and (feature `clap`)
/// `clap::ValueEnum` under that spelling, [`std::fmt::Display`], [`std::str::FromStr`] and `Deserialize` (an error
/// names the set and lists the names),
/// `name()` and `ALL`.
macro_rules! closed_set {
    (
        $(#[$meta:meta])*
        $what:literal, $name:ident { $( $(#[$vmeta:meta])* $variant:ident = $text:literal ),+ $(,)? }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
        #[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
        pub enum $name {
            $(
                $(#[$vmeta])*
                #[serde(rename = $text)]
                #[cfg_attr(feature = "clap", value(name = $text))]
                $variant,
            )+
        }

        impl $name {
            /// Every member, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// The spelling in scene files, headers and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text,)+
                }
            }
        }

        /// By name; an unknown name is an error naming the set and listing its names (so a scene
        /// file's message says which key holds the bad value).
        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
                let s = <String as serde::Deserialize>::deserialize(d)?;
                s.parse().map_err(|e: $crate::error::Error| serde::de::Error::custom(e.message))
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $name {
            type Err = $crate::error::Error;
            fn from_str(s: &str) -> $crate::error::Result<Self> {
                $name::ALL.iter().copied().find(|v| v.name() == s).ok_or_else(|| {
                    let names: Vec<String> = $name::ALL.iter().map(|v| format!("\"{}\"", v.name())).collect();
                    $crate::error::Error::new(format!("unknown {} \"{s}\" (expected {})", $what, names.join(" | ")))
                })
            }
        }
    };
}

// `scene` derives `BrdfKind` from the list of `BrdfSection` variants with this macro.
pub(crate) use closed_set;

closed_set! {
    /// The sample generator of a render (`render.sampler`).
    #[derive(Default)]
    "sampler", Sampler {
        /// Owen-scrambled Sobol points (the default): stratified in every pair of dimensions.
        #[default]
        Sobol = "sobol",
        /// Independent uniform numbers: the per-pixel standard error is the estimator's own.
        Independent = "independent",
        /// One Owen-scrambled Sobol sequence per pixel, no replicates: the lowest error at a given
        /// spp, but its error bar (the samples' own standard error) is conservative, 1.5–10× too
        /// wide (docs/src/how-to/error-bars.md).
        SobolSingle = "sobol-single",
    }
}

/// The number of independent replicates (independent scrambles) of the Sobol sampler; the renderer's
/// `sampling::sampler::REPLICATES` (why 16 is argued there). Here because a reader of a render's
/// header needs it to know its error bars' degrees of freedom ([`Sampler::stderr_dof`]).
pub const SOBOL_REPLICATES: u32 = 16;

impl Sampler {
    /// The degrees of freedom of a render's per-pixel standard error (`stderr` layer) at `spp`
    /// samples: the independent sampler's is the sample standard error of the mean, spp − 1; the
    /// Sobol sampler's is the spread of its [`SOBOL_REPLICATES`] replicate means, R − 1 from one
    /// full round on (below one round every sample is its own replicate: spp − 1); one Sobol
    /// sequence's (`sobol-single`) is the samples' own, spp − 1, as the independent sampler's
    /// (there it is conservative: the points are not independent). At least 1.
    pub fn stderr_dof(self, spp: u32) -> u32 {
        let samples = match self {
            Sampler::Independent | Sampler::SobolSingle => spp,
            Sampler::Sobol => spp.min(SOBOL_REPLICATES),
        };
        samples.saturating_sub(1).max(1)
    }
}

closed_set! {
    /// Horizon handling of `phong` and `torrance-sparrow` (docs/src/conventions.md §4, paper sec. 3.6).
    #[derive(Default)]
    "horizon", Horizon {
        /// Physical (the default): nothing arrives from n·ω_i ≤ 0 (the convex object occludes itself).
        #[default]
        Clamp = "clamp",
        /// The paper's simplification: the lobe gathers distant light in every direction it covers.
        Ignore = "ignore",
    }
}

closed_set! {
    /// The microfacet normal distribution D of a `microfacet` BRDF.
    #[derive(Default)]
    "distribution", Distribution {
        /// Beckmann–Spizzichino (the default).
        #[default]
        Beckmann = "beckmann",
        /// Trowbridge–Reitz (GGX).
        Ggx = "ggx",
    }
}

closed_set! {
    /// The Fresnel term F of a `microfacet` BRDF (its parameters `f0`, `eta`, `k` are sibling keys).
    #[derive(Default)]
    "fresnel", FresnelKind {
        /// F = 1 (the default).
        #[default]
        None = "none",
        /// Schlick's approximation with normal-incidence reflectance `f0`.
        Schlick = "schlick",
        /// Exact conductor Fresnel with complex index `eta` + i `k`.
        Conductor = "conductor",
    }
}

closed_set! {
    /// Environment-map parameterization (docs/src/conventions.md §2).
    "mapping", Mapping {
        /// Equirectangular: W = 2H, row 0 at θ = 0 (+z).
        LatLong = "latlong",
        /// Debevec's angular (light-probe) map: W = H.
        Angular = "angular",
    }
}

impl Mapping {
    /// Infers the mapping from the aspect ratio: W = H → angular, W = 2H → lat-long; any other
    /// shape is an error asking for the mapping.
    pub fn infer(width: usize, height: usize) -> Result<Mapping> {
        if width == height {
            Ok(Mapping::Angular)
        } else if width == 2 * height {
            Ok(Mapping::LatLong)
        } else {
            Err(Error::new(format!(
                "cannot infer the mapping of a {width}×{height} map (W = H is angular, W = 2H lat-long): pass --mapping"
            )))
        }
    }

    /// Parses a mapping name (as [`std::str::FromStr`]).
    pub fn parse(s: &str) -> Result<Mapping> {
        s.parse()
    }
}

closed_set! {
    /// The lighting types of docs/src/conventions.md §6 (the `type` of the `[lighting]` table).
    "lighting type", LightingKind {
        /// Constant radiance.
        Uniform = "uniform",
        /// A delta light of given irradiance.
        Directional = "directional",
        /// Axially symmetric about `axis`, profile given in the file.
        Axial = "axial",
        /// Given SH coefficients.
        Sh = "sh",
        /// An environment map file.
        Envmap = "envmap",
    }
}

closed_set! {
    /// The camera types of docs/src/conventions.md §6 (the `type` of the `[camera]` table).
    "camera type", CameraKind {
        /// Parallel rays along `to − from`, half-width `extent`.
        Orthographic = "orthographic",
        /// A pinhole with vertical field of view `fov_deg`.
        Perspective = "perspective",
        /// B on a lat-long grid of normals of a sphere.
        NormalProbe = "normal-probe",
    }
}

closed_set! {
    /// The object shapes of a scene (the `shape` of an `[[objects]]` table).
    "shape", ShapeKind {
        /// An analytic sphere.
        Sphere = "sphere",
        /// A triangle mesh from an OBJ or glTF file.
        Mesh = "mesh",
        /// A subdivided icosahedron built in memory.
        Icosphere = "icosphere",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_through_serde_and_from_str() {
        for m in Mapping::ALL {
            assert_eq!(serde_json::to_string(m).unwrap(), format!("\"{m}\""));
            assert_eq!(m.name().parse::<Mapping>().unwrap(), *m);
        }
        assert_eq!(crate::BrdfKind::TorranceSparrow.name(), "torrance-sparrow");
        assert_eq!(serde_json::from_str::<CameraKind>("\"normal-probe\"").unwrap(), CameraKind::NormalProbe);
        let e = "mercator".parse::<Mapping>().unwrap_err().to_string();
        assert!(e.contains("mercator") && e.contains("\"latlong\" | \"angular\""), "{e}");
        assert_eq!(Sampler::default(), Sampler::Sobol);
        // The error bar's degrees of freedom: Sobol's from its 16 replicates whatever the spp.
        assert_eq!([1, 8, 16, 64, 16384].map(|n| Sampler::Sobol.stderr_dof(n)), [1, 7, 15, 15, 15]);
        assert_eq!([1, 8, 16, 64, 16384].map(|n| Sampler::Independent.stderr_dof(n)), [1, 7, 15, 63, 16383]);
        assert_eq!([1, 8, 16, 64, 16384].map(|n| Sampler::SobolSingle.stderr_dof(n)), [1, 7, 15, 63, 16383]);
        // A bad value in a file names the key's set, not just "unknown variant".
        let e = serde_json::from_str::<Sampler>("\"halton\"").unwrap_err().to_string();
        assert!(e.contains("sampler") && e.contains("halton") && e.contains("\"sobol\""), "{e}");
        assert_eq!(Horizon::default(), Horizon::Clamp);
    }
}
