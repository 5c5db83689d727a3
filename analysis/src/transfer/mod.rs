//! Transfer coefficients Λ_l ρ̂_l of radially symmetric (or reparameterized) BRDFs, unit albedo /
//! k_s, l = 0 … l_max (docs/src/conventions.md §4). With them B_lm = Λ_l ρ̂_l L_lm (eq. 15).
//!
//! - [`lambert`]: eq. 38 in closed form (÷ π for BRDF = albedo/π); [`lambert::irradiance_kernel`]
//!   is the BRDF = 1 kernel A_l of eq. 39.
//! - [`phong`]: eq. 43 by a ratio recurrence (no overflow, no cancellation) and eq. 46.
//! - [`mirror`]: eq. 33, Λ_l ρ̂_l = 1.
//! - [`torrance_sparrow`]: eq. 50 by quadrature and eq. 57 at normal exitance; at exitance θ_o the
//!   q = 0 coefficient by 2D quadrature over the reparameterized lobe (eq. 49) and eq. 59.
//! - [`microfacet`]: the Beckmann microfacet lobe and its Λ_l ρ̂_l at normal exitance.
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
    Phong { s: f64 },
    Mirror,
    TorranceSparrow { sigma: f64, theta_o: f64 },
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
        let named: Vec<(String, f64)> =
            [("s", s), ("sigma", sigma)].into_iter().filter_map(|(n, v)| Some((n.to_string(), v?))).collect();
        TransferModel::from_named(kind, &named, theta_o_deg)
    }

    /// The one mapping from a BRDF kind and its parameters to a transfer model, for every command
    /// (`sh transfer`, `analyze` and `invert` from flags, and through [`TransferModel::of_brdf`]
    /// from a header or scene): `params` are (key, value) pairs named as the BRDF table's keys
    /// (`s` is Phong's exponent, `sigma` Torrance–Sparrow's roughness in radians); `theta_o_deg`
    /// is an exitance angle in degrees given explicitly (only a model that depends on it takes it,
    /// Torrance–Sparrow, eq. 49/59; absent = 0). The exitance of an image's view is applied with
    /// [`TransferModel::at_exitance`] instead, which every model takes.
    ///
    /// Errors: a parameter the model needs is missing or one it does not take is given (named as
    /// the flag, `--s`, `--sigma`, `--theta-o`), a kind without a transfer model here
    /// (`microfacet`, `mix`), or a value [`TransferModel::validate`] refuses.
    pub fn from_named(kind: BrdfKind, params: &[(String, f64)], theta_o_deg: Option<f64>) -> Result<TransferModel> {
        let mut given: Vec<(String, f64)> = params.to_vec();
        let mut take = |name: &str| -> Result<f64> {
            let i = given
                .iter()
                .position(|(n, _)| n == name)
                .ok_or_else(|| Error::new(format!("--brdf {kind} needs {}", flag(name))))?;
            Ok(given.remove(i).1)
        };
        let m = match kind {
            BrdfKind::Lambert => TransferModel::Lambert,
            BrdfKind::Mirror => TransferModel::Mirror,
            BrdfKind::Phong => TransferModel::Phong { s: take("s")? },
            BrdfKind::TorranceSparrow => TransferModel::TorranceSparrow {
                sigma: take("sigma")?,
                theta_o: theta_o_deg.unwrap_or(0.0).to_radians(),
            },
            BrdfKind::Microfacet | BrdfKind::Mix => {
                return Err(Error::new(format!(
                    "BRDF '{kind}' has no transfer model (expected lambert, phong, mirror or torrance-sparrow)"
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

    /// Whether Λ_l ρ̂_l depends on the exitance θ_o (Torrance–Sparrow, eq. 49/59).
    pub fn depends_on_exitance(&self) -> bool {
        matches!(self, TransferModel::TorranceSparrow { .. })
    }

    /// The model seen at exitance θ_o (radians, the view's): only a model whose coefficients depend
    /// on the exitance (Torrance–Sparrow, eq. 49/59) changes; the others are returned as they are.
    pub fn at_exitance(self, theta_o: f64) -> TransferModel {
        match self {
            TransferModel::TorranceSparrow { sigma, .. } => TransferModel::TorranceSparrow { sigma, theta_o },
            m => m,
        }
    }

    /// The transfer model of a BRDF table (a scene file's or a `reflect:objects` header's) seen at
    /// exitance θ_o (radians, [`TransferModel::at_exitance`]), with the table's scale and
    /// horizon; `Ok(None)` for a BRDF with no transfer model here (`microfacet`, `mix`). The table's
    /// f32 values are taken as the decimals they were written as ([`vocab::scene::decimal`]).
    /// Errors: a parameter [`TransferModel::validate`] refuses, the message naming the BRDF type.
    pub fn of_brdf(brdf: &BrdfSection, theta_o: f64) -> Result<Option<BrdfTransfer>> {
        let (model, scale, horizon) = match brdf {
            BrdfSection::Lambert { albedo } => (TransferModel::Lambert, albedo, Horizon::Clamp),
            BrdfSection::Mirror { kr } => (TransferModel::Mirror, kr, Horizon::Clamp),
            BrdfSection::Phong { ks, s, horizon } => (TransferModel::Phong { s: decimal(*s) }, ks, *horizon),
            BrdfSection::TorranceSparrow { ks, sigma, horizon } => {
                (TransferModel::TorranceSparrow { sigma: decimal(*sigma), theta_o }, ks, *horizon)
            }
            BrdfSection::Microfacet { .. } | BrdfSection::Mix { .. } => return Ok(None),
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
/// any other as `--brdf-param NAME=…` (guide "Adding a BRDF").
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
    /// torrance-sparrow).
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
        assert!(m(Microfacet, None, None, None).unwrap_err().message.contains("no transfer model"));
        let k = TransferModel::from_named(Lambert, &[("k".to_string(), 1.0)], None).unwrap_err().message;
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
        assert_eq!(TransferModel::of_brdf(&mf, 0.0).unwrap(), None);
        assert_eq!(parameterization(BrdfKind::Lambert), Param::Normal);
        assert_eq!(parameterization(BrdfKind::Phong), Param::Reflection);
    }
}
