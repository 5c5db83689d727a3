//! Transfer coefficients Λ_l ρ̂_l of radially symmetric (or reparameterized) BRDFs, unit albedo /
//! k_s, l = 0 … l_max (docs/src/conventions.md §4). With them B_lm = Λ_l ρ̂_l L_lm (eq. 15).
//!
//! - [`lambert`]: eq. 38 in closed form (÷ π for BRDF = albedo/π); [`lambert::irradiance_kernel`]
//!   is the BRDF = 1 kernel A_l of eq. 39.
//! - [`phong`]: eq. 43 by a ratio recurrence (no overflow, no cancellation) and eq. 46.
//! - [`mirror`]: eq. 33, Λ_l ρ̂_l = 1.
//! - [`torrance_sparrow`]: eq. 50 by quadrature and eq. 57 at normal exitance; at exitance θ_o the
//!   q = 0 coefficient by 2D quadrature over the reparameterized lobe (eq. 49) and eq. 59.
//! - [`microfacet`]: the renderer's microfacet BRDF (Beckmann or GGX, Smith G, Fresnel none or
//!   Schlick) and its q = 0 coefficient at exitance θ_o by 2D quadrature.
//! - [`radial`]: any radially symmetric ρ̂(θ) by quadrature of eq. 13.

pub mod lambert;
pub mod microfacet;
pub mod mirror;
pub mod phong;
pub mod radial;
pub mod torrance_sparrow;

use crate::error::{Error, Result};
use crate::projection::Param;
use vocab::BrdfKind;
use vocab::scene::{BrdfSection, decimal, decimal3};

/// Horizon handling of `phong` and `torrance-sparrow` (docs/src/conventions.md §4), defined in `vocab`.
pub use vocab::Horizon;

/// A BRDF model whose transfer coefficients we can compute.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TransferModel {
    Lambert,
    Phong {
        s: f64,
    },
    Mirror,
    TorranceSparrow {
        sigma: f64,
        theta_o: f64,
    },
    /// The renderer's `microfacet` (docs/src/conventions.md §4) at exitance θ_o (radians).
    Microfacet {
        lobe: microfacet::MicrofacetLobe,
        theta_o: f64,
    },
}

/// The value of a BRDF parameter given by name (`--brdf-param KEY=VALUE`): a number, or a word of
/// a closed set (`distribution=ggx`, `fresnel=schlick`). Parsed as a number when it is one.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum ParamValue {
    Number(f64),
    Word(String),
}

impl std::str::FromStr for ParamValue {
    type Err = Error;
    fn from_str(s: &str) -> Result<ParamValue> {
        let s = s.trim();
        if s.is_empty() {
            return Err(Error::new("empty value"));
        }
        Ok(s.parse::<f64>().map_or_else(|_| ParamValue::Word(s.to_string()), ParamValue::Number))
    }
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Number(x) => write!(f, "{x}"),
            ParamValue::Word(w) => f.write_str(w),
        }
    }
}

impl From<f64> for ParamValue {
    fn from(x: f64) -> ParamValue {
        ParamValue::Number(x)
    }
}

/// The exitance angle θ_o (radians) of every command and header: 0 ≤ θ_o < π/2 (at 90° the
/// Torrance–Sparrow lobe's 1/cos θ_o diverges and a `normal-probe` camera looks along the
/// surface). The one check, used by [`TransferModel::validate`], by the EXR-header readers of the
/// CLI and by the inverse fits.
pub fn validate_exitance(theta_o: f64) -> Result<()> {
    if (0.0..std::f64::consts::FRAC_PI_2).contains(&theta_o) {
        Ok(())
    } else {
        Err(Error::new(format!("theta_o must be in [0°, 90°), got {}°", theta_o.to_degrees())))
    }
}

/// Below this σ (l_max + 1), Torrance–Sparrow's Λ_l ρ̂_l equals the mirror's 1 to within
/// (σ (l+1))² < 1e-18 (eq. 55: 1 − l(l+1)σ² − 2σ²/3 + O(σ⁴ l⁴)), so the mirror limit is returned.
pub const MIRROR_LIMIT_SIGMA_L: f64 = 1e-9;

impl TransferModel {
    /// Checks the parameters, the one validation of BRDF parameters for every command and header:
    /// Phong `s` finite and > 0, Torrance–Sparrow `σ` finite and > 0, 0 ≤ θ_o < π/2
    /// ([`validate_exitance`]). Every such value gives finite Λ_l ρ̂_l (σ → 0 and s → ∞ tend to
    /// the mirror's 1).
    pub fn validate(&self) -> Result<()> {
        match *self {
            TransferModel::Phong { s } if !(s > 0.0 && s.is_finite()) => {
                Err(Error::new(format!("phong exponent s must be finite and > 0, got {s}")))
            }
            TransferModel::TorranceSparrow { sigma, theta_o } => {
                if !(sigma > 0.0 && sigma.is_finite()) {
                    Err(Error::new(format!("torrance-sparrow sigma must be finite and > 0, got {sigma}")))
                } else {
                    validate_exitance(theta_o)
                }
            }
            TransferModel::Microfacet { lobe, theta_o } => {
                if !(lobe.alpha > 0.0 && lobe.alpha.is_finite()) {
                    return Err(Error::new(format!("microfacet alpha must be finite and > 0, got {}", lobe.alpha)));
                }
                if let microfacet::MicrofacetFresnel::Schlick { f0 } = lobe.fresnel
                    && !(0.0..=1.0).contains(&f0)
                {
                    return Err(Error::new(format!("microfacet f0 must be in [0, 1], got {f0}")));
                }
                validate_exitance(theta_o)
            }
            _ => Ok(()),
        }
    }

    /// Λ_l ρ̂_l, l = 0 … lmax, by the exact (or numerically exact) formula. Torrance–Sparrow uses the
    /// paper's horizon (`ignore` beyond π/2 at normal exitance, eq. 50; `clamp` off normal); when
    /// σ (l_max + 1) < [`MIRROR_LIMIT_SIGMA_L`] it is the mirror limit 1 (to rounding).
    pub fn lambda_rho(&self, lmax: usize) -> Vec<f64> {
        match *self {
            TransferModel::Lambert => lambert::lambert(lmax),
            TransferModel::Phong { s } => phong::phong(s, lmax),
            TransferModel::Mirror => mirror::mirror(lmax),
            TransferModel::TorranceSparrow { sigma, .. } if sigma * (lmax as f64 + 1.0) < MIRROR_LIMIT_SIGMA_L => {
                mirror::mirror(lmax)
            }
            TransferModel::TorranceSparrow { sigma, theta_o } => {
                if theta_o == 0.0 {
                    torrance_sparrow::normal_exitance(sigma, lmax)
                } else {
                    torrance_sparrow::exitance(sigma, theta_o, lmax, Horizon::Clamp)
                }
            }
            TransferModel::Microfacet { lobe, theta_o } => microfacet::exitance(&lobe, theta_o, lmax),
        }
    }

    /// [`TransferModel::from_named`] with the parameters of the built-in models as arguments:
    /// `s` (Phong's exponent), `sigma` (Torrance–Sparrow's roughness, radians), each `None` when
    /// not given.
    pub fn from_params(
        kind: BrdfKind,
        s: Option<f64>,
        sigma: Option<f64>,
        theta_o_deg: Option<f64>,
    ) -> Result<TransferModel> {
        let named: Vec<(String, ParamValue)> =
            [("s", s), ("sigma", sigma)].into_iter().filter_map(|(n, v)| Some((n.to_string(), v?.into()))).collect();
        TransferModel::from_named(kind, &named, theta_o_deg)
    }

    /// The one mapping from a BRDF kind and its parameters to a transfer model, for every command
    /// (`sh transfer`, `analyze` and `invert` from flags, and through [`TransferModel::of_brdf`]
    /// from a header or scene): `params` are (key, value) pairs named as the BRDF table's keys
    /// (`s` is Phong's exponent, `sigma` Torrance–Sparrow's roughness in radians; `microfacet`
    /// takes `alpha`, `distribution` = `beckmann` (default) | `ggx`, `fresnel` = `none` (default) |
    /// `schlick` with a grey `f0`); `theta_o_deg` is an exitance angle in degrees given explicitly
    /// (only a model that depends on it takes it, Torrance–Sparrow and microfacet; absent = 0). The exitance of an image's view is applied with
    /// [`TransferModel::at_exitance`] instead, which every model takes.
    ///
    /// Errors: a parameter the model needs is missing or one it does not take is given (named as
    /// the flag, `--s`, `--sigma`, `--theta-o`), a word where a number is needed or a word not in
    /// the parameter's closed set, a kind without a transfer model here (`mix`; `microfacet` with
    /// `fresnel=conductor`), or a value [`TransferModel::validate`] refuses.
    pub fn from_named(
        kind: BrdfKind,
        params: &[(String, ParamValue)],
        theta_o_deg: Option<f64>,
    ) -> Result<TransferModel> {
        let mut given: Vec<(String, ParamValue)> = params.to_vec();
        let mut take_value = |name: &str| -> Option<ParamValue> {
            let i = given.iter().position(|(n, _)| n == name)?;
            Some(given.remove(i).1)
        };
        let number = |name: &str, v: Option<ParamValue>| -> Result<f64> {
            match v {
                Some(ParamValue::Number(x)) => Ok(x),
                Some(ParamValue::Word(w)) => Err(Error::new(format!("the value of {name} is not a number: \"{w}\""))),
                None => Err(Error::new(format!("--brdf {kind} needs {}", flag(name)))),
            }
        };
        fn word<T: std::str::FromStr<Err = Error> + Default>(name: &str, v: Option<ParamValue>) -> Result<T> {
            match v {
                None => Ok(T::default()),
                Some(v) => {
                    v.to_string().parse::<T>().map_err(|e| Error::new(format!("--brdf-param {name}: {}", e.message)))
                }
            }
        }
        let m = match kind {
            BrdfKind::Lambert => TransferModel::Lambert,
            BrdfKind::Mirror => TransferModel::Mirror,
            BrdfKind::Phong => TransferModel::Phong { s: number("s", take_value("s"))? },
            BrdfKind::TorranceSparrow => TransferModel::TorranceSparrow {
                sigma: number("sigma", take_value("sigma"))?,
                theta_o: theta_o_deg.unwrap_or(0.0).to_radians(),
            },
            BrdfKind::Microfacet => {
                let alpha = number("alpha", take_value("alpha"))?;
                let distribution: microfacet::Distribution = word("distribution", take_value("distribution"))?;
                let fresnel_kind: vocab::FresnelKind = word("fresnel", take_value("fresnel"))?;
                let fresnel = match fresnel_kind {
                    vocab::FresnelKind::None => microfacet::MicrofacetFresnel::None,
                    vocab::FresnelKind::Schlick => {
                        microfacet::MicrofacetFresnel::Schlick { f0: number("f0", take_value("f0"))? }
                    }
                    vocab::FresnelKind::Conductor => {
                        return Err(Error::new(
                            "microfacet with fresnel=conductor has no transfer model here (its F differs per \
                             channel): use fresnel=none or schlick",
                        ));
                    }
                };
                TransferModel::Microfacet {
                    lobe: microfacet::MicrofacetLobe { distribution, alpha, fresnel },
                    theta_o: theta_o_deg.unwrap_or(0.0).to_radians(),
                }
            }
            BrdfKind::Mix => {
                return Err(Error::new(format!(
                    "BRDF '{kind}' has no transfer model (expected lambert, phong, mirror, torrance-sparrow or microfacet)"
                )));
            }
        };
        if let Some((name, _)) = given.first() {
            return Err(Error::new(format!("{} does not apply to --brdf {kind}", flag(name))));
        }
        if theta_o_deg.is_some() && !m.depends_on_exitance() {
            return Err(Error::new(format!("--theta-o does not apply to --brdf {kind}")));
        }
        m.validate()?;
        Ok(m)
    }

    /// Whether Λ_l ρ̂_l depends on the exitance θ_o (Torrance–Sparrow, eq. 49/59; microfacet).
    pub fn depends_on_exitance(&self) -> bool {
        matches!(self, TransferModel::TorranceSparrow { .. } | TransferModel::Microfacet { .. })
    }

    /// The model seen at exitance θ_o (radians, the view's): only a model whose coefficients depend
    /// on the exitance (Torrance–Sparrow, eq. 49/59) changes; the others are returned as they are.
    pub fn at_exitance(self, theta_o: f64) -> TransferModel {
        match self {
            TransferModel::TorranceSparrow { sigma, .. } => TransferModel::TorranceSparrow { sigma, theta_o },
            TransferModel::Microfacet { lobe, .. } => TransferModel::Microfacet { lobe, theta_o },
            m => m,
        }
    }

    /// The transfer model of a BRDF table (a scene file's or a `reflect:objects` header's) seen at
    /// exitance θ_o (radians, [`TransferModel::at_exitance`]), with the table's scale and
    /// horizon; `Ok(None)` for a BRDF with no transfer model here (`mix`; `microfacet` with a
    /// conductor Fresnel term or a Schlick f0 that differs between channels). The table's
    /// f32 values are taken as the decimals they were written as ([`vocab::scene::decimal`]).
    /// Errors: a parameter [`TransferModel::validate`] refuses, the message naming the BRDF type.
    pub fn of_brdf(brdf: &BrdfSection, theta_o: f64) -> Result<Option<BrdfTransfer>> {
        let one = vocab::scene::Color::Grey(1.0);
        let (model, scale, horizon) = match brdf {
            BrdfSection::Lambert { albedo } => (TransferModel::Lambert, albedo, Horizon::Clamp),
            BrdfSection::Mirror { kr } => (TransferModel::Mirror, kr, Horizon::Clamp),
            BrdfSection::Phong { ks, s, horizon } => (TransferModel::Phong { s: decimal(*s) }, ks, *horizon),
            BrdfSection::TorranceSparrow { ks, sigma, horizon } => {
                (TransferModel::TorranceSparrow { sigma: decimal(*sigma), theta_o }, ks, *horizon)
            }
            BrdfSection::Microfacet { distribution, alpha, fresnel, f0, .. } => {
                let fresnel = match fresnel {
                    vocab::FresnelKind::None => microfacet::MicrofacetFresnel::None,
                    vocab::FresnelKind::Schlick => {
                        let f = decimal3(f0.unwrap_or(vocab::scene::Color::Grey(1.0)).rgb());
                        if f[1] != f[0] || f[2] != f[0] {
                            return Ok(None);
                        }
                        microfacet::MicrofacetFresnel::Schlick { f0: f[0] }
                    }
                    vocab::FresnelKind::Conductor => return Ok(None),
                };
                let lobe = microfacet::MicrofacetLobe { distribution: *distribution, alpha: decimal(*alpha), fresnel };
                (TransferModel::Microfacet { lobe, theta_o }, &one, Horizon::Clamp)
            }
            BrdfSection::Mix { .. } => return Ok(None),
        };
        // θ_o in radians as given (no round trip through degrees).
        let model = model.at_exitance(theta_o);
        model.validate().map_err(|e| Error::new(format!("{} BRDF: {}", brdf.kind(), e.message)))?;
        Ok(Some(BrdfTransfer { model, scale: decimal3(scale.rgb()), horizon }))
    }

    /// How [`TransferModel::lambda_rho`] computes the coefficients (the paper's equation).
    pub fn method(&self) -> &'static str {
        match self {
            TransferModel::Lambert => "eq. 38 closed form",
            TransferModel::Phong { .. } => "eq. 43 exact",
            TransferModel::Mirror => "eq. 33",
            TransferModel::TorranceSparrow { theta_o: 0.0, .. } => "eq. 50 numerical integration",
            TransferModel::TorranceSparrow { .. } => {
                "q = 0 coefficient of eq. 49, numerical integration (exact half angle, horizon clamped)"
            }
            TransferModel::Microfacet { .. } => "q = 0 coefficient of D G F / 4 cos θ_o about R, numerical integration",
        }
    }

    /// The paper's approximation, when it has one: eq. 46 (Phong), eq. 57 (TS, normal exitance),
    /// eq. 59 (TS at θ_o).
    pub fn approximation(&self, lmax: usize) -> Option<(&'static str, Vec<f64>)> {
        match *self {
            TransferModel::Phong { s } => Some(("eq. 46", phong::gaussian(s, lmax))),
            TransferModel::TorranceSparrow { sigma, theta_o: 0.0 } => {
                Some(("eq. 57", torrance_sparrow::gaussian(sigma, lmax)))
            }
            TransferModel::TorranceSparrow { sigma, theta_o } => {
                Some(("eq. 59", torrance_sparrow::eq59(sigma, theta_o, lmax)))
            }
            _ => None,
        }
    }
}

/// How the command line spells BRDF parameter `name`: the built-in models' `--s` and `--sigma`,
/// any other as `--brdf-param NAME=…` (docs/src/reference/cli.md, the `--brdf-param` flag).
fn flag(name: &str) -> String {
    match name {
        "s" | "sigma" => format!("--{name}"),
        _ => format!("--brdf-param {name}=…"),
    }
}

/// A BRDF table's transfer model ([`TransferModel::of_brdf`]) and what scales it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrdfTransfer {
    pub model: TransferModel,
    /// RGB factor of the unit-albedo Λ_l ρ̂_l: `albedo` (lambert), `kr` (mirror), `ks` (phong,
    /// torrance-sparrow); 1 for microfacet (its Fresnel term is in the model).
    pub scale: [f64; 3],
    /// The table's horizon handling (`clamp` for lambert and mirror, where it makes no difference).
    pub horizon: Horizon,
}

/// The direction reflected radiance is a function of, for the orthographic fit of a BRDF kind:
/// the normal for `lambert` (and `mix`, whose lobes need not share one), the reflection vector R
/// for the lobes centred on it (`phong`, `mirror`, `torrance-sparrow`, `microfacet`).
pub fn parameterization(kind: BrdfKind) -> Param {
    match kind {
        BrdfKind::Lambert | BrdfKind::Mix => Param::Normal,
        BrdfKind::Phong | BrdfKind::Mirror | BrdfKind::TorranceSparrow | BrdfKind::Microfacet => Param::Reflection,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_are_checked_by_the_one_mapping() {
        use BrdfKind::*;
        let m = TransferModel::from_params;
        assert!(m(Phong, None, None, None).unwrap_err().message.contains("needs --s"));
        assert!(m(Phong, Some(-1.0), None, None).is_err());
        assert!(m(Lambert, Some(3.0), None, None).unwrap_err().message.contains("--s does not apply"));
        assert!(m(TorranceSparrow, None, Some(0.1), Some(95.0)).is_err());
        assert!(m(TorranceSparrow, None, Some(f64::NAN), None).is_err());
        assert!(m(Mix, None, None, None).unwrap_err().message.contains("no transfer model"));
        assert!(m(Microfacet, None, None, None).unwrap_err().message.contains("needs --brdf-param alpha=…"));
        let p = |s: &[(&str, &str)]| -> Vec<(String, ParamValue)> {
            s.iter().map(|(k, v)| (k.to_string(), v.parse().unwrap())).collect()
        };
        let ggx = TransferModel::from_named(Microfacet, &p(&[("alpha", "0.3"), ("distribution", "ggx")]), Some(20.0));
        assert_eq!(
            ggx.unwrap(),
            TransferModel::Microfacet {
                lobe: microfacet::MicrofacetLobe {
                    distribution: vocab::Distribution::Ggx,
                    alpha: 0.3,
                    fresnel: microfacet::MicrofacetFresnel::None
                },
                theta_o: 20f64.to_radians()
            }
        );
        let bad = TransferModel::from_named(Microfacet, &p(&[("alpha", "0.3"), ("distribution", "phong")]), None);
        assert!(bad.unwrap_err().message.contains("distribution"));
        let word = TransferModel::from_named(Microfacet, &p(&[("alpha", "rough")]), None).unwrap_err().message;
        assert!(word.contains("the value of alpha is not a number"), "{word}");
        let f0 = TransferModel::from_named(Microfacet, &p(&[("alpha", "0.3"), ("fresnel", "schlick")]), None);
        assert!(f0.unwrap_err().message.contains("f0"));
        let k = TransferModel::from_named(Lambert, &[("k".to_string(), 1.0.into())], None).unwrap_err().message;
        assert!(k.contains("--brdf-param k=… does not apply"), "{k}");
        assert!(m(Lambert, None, None, Some(10.0)).unwrap_err().message.contains("--theta-o does not apply"));
        assert_eq!(m(Mirror, None, None, None).unwrap(), TransferModel::Mirror);
        assert_eq!(
            m(TorranceSparrow, None, Some(0.2), Some(30.0)).unwrap(),
            TransferModel::TorranceSparrow { sigma: 0.2, theta_o: 30f64.to_radians() }
        );
    }

    #[test]
    fn a_brdf_table_maps_to_its_model_scale_and_horizon() {
        let t: BrdfSection =
            serde_json::from_str(r#"{"type":"phong","s":0.1,"ks":[0.5,0.25,1],"horizon":"ignore"}"#).unwrap();
        let b = TransferModel::of_brdf(&t, 0.0).unwrap().unwrap();
        // s = 0.1 as written, not the f32 nearest to it.
        assert_eq!(b.model, TransferModel::Phong { s: 0.1 });
        assert_eq!((b.scale, b.horizon), ([0.5, 0.25, 1.0], Horizon::Ignore));
        let ts: BrdfSection = serde_json::from_str(r#"{"type":"torrance-sparrow","sigma":0.2}"#).unwrap();
        let b = TransferModel::of_brdf(&ts, 0.5).unwrap().unwrap();
        assert_eq!(b.model, TransferModel::TorranceSparrow { sigma: 0.2, theta_o: 0.5 });
        assert_eq!(b.scale, [1.0; 3]);
        let bad: BrdfSection = serde_json::from_str(r#"{"type":"phong","s":-2}"#).unwrap();
        assert!(TransferModel::of_brdf(&bad, 0.0).unwrap_err().message.starts_with("phong BRDF: "));
        let mf: BrdfSection = serde_json::from_str(r#"{"type":"microfacet","alpha":0.3}"#).unwrap();
        let b = TransferModel::of_brdf(&mf, 0.5).unwrap().unwrap();
        assert!(matches!(b.model, TransferModel::Microfacet { theta_o: 0.5, .. }));
        let cond: BrdfSection =
            serde_json::from_str(r#"{"type":"microfacet","alpha":0.3,"fresnel":"conductor","eta":1.5,"k":2}"#).unwrap();
        assert_eq!(TransferModel::of_brdf(&cond, 0.0).unwrap(), None);
        assert_eq!(parameterization(BrdfKind::Lambert), Param::Normal);
        assert_eq!(parameterization(BrdfKind::Phong), Param::Reflection);
    }
}
