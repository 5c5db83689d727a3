//! The BRDF of the sphere an image shows: its header's or scene's table, explicit values, or both
//! when they agree, as a transfer model ([`TransferModel`]).

use super::error::Error;
use super::{Observation, close, v3};
use crate::transfer::{BrdfTransfer, ParamValue, TransferModel};
use vocab::BrdfKind;

/// The explicit BRDF of the sphere: a kind plus its parameters, each named as the key of a scene
/// file's `brdf` table (`s` for Phong, `sigma` for Torrance–Sparrow, …), and the albedo / k_s / k_r
/// scale. The CLI's `--brdf`, `--s`, `--sigma`, `--brdf-param`, `--albedo`; Python's `brdf=`,
/// `s=`, `sigma=`, `brdf_params=`, `albedo=` (`spelling` says which, for messages).
#[derive(Clone, Debug, Default)]
pub struct BrdfValues {
    pub kind: Option<BrdfKind>,
    pub params: Vec<(String, ParamValue)>,
    pub albedo: Option<[f64; 3]>,
    /// How the front-end that gave these values names them in messages.
    pub spelling: Spelling,
}

/// How a front-end names its parameters in messages: the CLI's flags (`--albedo 0.5,0.5,0.5`) or
/// Python's keywords (`albedo=0.5,0.5,0.5`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Spelling {
    #[default]
    Flags,
    Keywords,
}

impl Spelling {
    /// The parameter `key` (a flag's name without `--`, e.g. `brdf-param`) given `value`.
    pub fn given(self, key: &str, value: impl std::fmt::Display) -> String {
        match self {
            Spelling::Flags => format!("--{key} {value}"),
            Spelling::Keywords => format!("{}={value}", key.replace('-', "_")),
        }
    }

    /// The parameter `key` alone (`--albedo`, `albedo=`).
    pub fn name(self, key: &str) -> String {
        match self {
            Spelling::Flags => format!("--{key}"),
            Spelling::Keywords => format!("{}=", key.replace('-', "_")),
        }
    }
}

/// A BRDF's transfer model, scale and kind, and the table it came from (for the report).
#[derive(Clone, Debug)]
pub struct Resolved {
    pub transfer: Option<BrdfTransfer>,
    pub kind: BrdfKind,
    /// The BRDF as JSON: the scene's or header's table, or the explicit values as a table.
    pub table: serde_json::Value,
    /// Where it came from: "the header's reflect:objects", "the `[[objects]]` of S", "--brdf".
    pub source: String,
}

impl Observation {
    /// The BRDF of the sphere seen at exitance θ_o (radians): the explicit values where given,
    /// else the scene's or header's table, through the one BRDF → transfer-model mapping
    /// ([`TransferModel::from_named`], [`TransferModel::of_brdf`]). Values and a table that
    /// contradict each other (another kind, exponent, roughness or albedo) are an error naming both.
    /// `Ok(None)` when no source names a BRDF.
    pub fn transfer(&self, given: &BrdfValues, theta_o: f64) -> Result<Option<Resolved>, Error> {
        let table = match &self.brdf {
            Some((b, src)) => {
                let t = TransferModel::of_brdf(b, theta_o)
                    .map_err(|e| Error::BrdfTable { src: src.clone(), message: e.message })?;
                Some((b, src, t))
            }
            None => None,
        };
        let params = !given.params.is_empty();
        if table.is_none() && given.kind.is_none() && (params || given.albedo.is_some()) {
            return Err(Error::BrdfParamsWithoutKind { spelling: given.spelling });
        }
        // Parameters without a kind are parameters of the table's kind, checked against it below.
        let kind = match (given.kind, &table) {
            (Some(k), _) => k,
            (None, Some((b, _, _))) if params => b.kind(),
            (None, _) => {
                return Ok(table.map(|(b, src, t)| {
                    let mut t = t;
                    if let Some(a) = given.albedo
                        && let Some(t) = t.as_mut()
                    {
                        t.scale = a;
                    }
                    Resolved {
                        transfer: t,
                        kind: b.kind(),
                        table: serde_json::to_value(b).unwrap_or_default(),
                        source: src.clone(),
                    }
                }))
                .and_then(|r| self.check_albedo(r, given));
            }
        };
        let model = TransferModel::from_named(kind, &given.params, None)?.at_exitance(theta_o);
        model.validate()?;
        let scale = given.albedo.or(table.as_ref().and_then(|(_, _, t)| t.map(|t| t.scale))).unwrap_or([1.0; 3]);
        if let Some((b, src, t)) = &table {
            let agrees = b.kind() == kind && t.is_none_or(|t| same_model(&t.model, &model));
            if !agrees {
                return Err(Error::Contradiction {
                    one: format!("{}{}", given.spelling.given("brdf", kind), param_text(given)),
                    other: format!("{src} gives the BRDF {}", serde_json::to_string(b).unwrap_or_default()),
                });
            }
        }
        let horizon = table.as_ref().and_then(|(_, _, t)| t.map(|t| t.horizon)).unwrap_or_default();
        let mut values_table = serde_json::json!({ "type": kind.name() });
        for (key, v) in &given.params {
            values_table[key] = serde_json::to_value(v).unwrap_or_default();
        }
        values_table["albedo"] = serde_json::json!(scale);
        let r = Resolved {
            transfer: Some(BrdfTransfer { model, scale, horizon }),
            kind,
            table: values_table,
            source: "--brdf".into(),
        };
        self.check_albedo(Some(r), given)
    }

    /// An explicit albedo that contradicts the table's albedo / k_s / k_r is an error naming both.
    fn check_albedo(&self, r: Option<Resolved>, given: &BrdfValues) -> Result<Option<Resolved>, Error> {
        if let (Some(a), Some((b, src))) = (given.albedo, &self.brdf)
            && let Ok(Some(t)) = TransferModel::of_brdf(b, 0.0)
            && !(0..3).all(|i| close(a[i], t.scale[i], 1.0))
        {
            return Err(Error::Contradiction {
                one: given.spelling.given("albedo", v3(a)),
                other: format!("{src} gives {}", v3(t.scale)),
            });
        }
        Ok(r)
    }
}

fn same_model(a: &TransferModel, b: &TransferModel) -> bool {
    match (a, b) {
        (TransferModel::Phong { s: x }, TransferModel::Phong { s: y }) => close(*x, *y, 1.0),
        (TransferModel::TorranceSparrow { sigma: x, .. }, TransferModel::TorranceSparrow { sigma: y, .. }) => {
            close(*x, *y, 1.0)
        }
        (TransferModel::Microfacet { lobe: x, .. }, TransferModel::Microfacet { lobe: y, .. }) => {
            x.distribution == y.distribution && close(x.alpha, y.alpha, 1.0) && x.fresnel == y.fresnel
        }
        (a, b) => std::mem::discriminant(a) == std::mem::discriminant(b),
    }
}

/// The explicit parameters as the front-end's parameters that give them, for a message.
fn param_text(given: &BrdfValues) -> String {
    let sp = given.spelling;
    let sep = if sp == Spelling::Flags { " " } else { ", " };
    let flag = |k: &str, x: &ParamValue| match (k, sp) {
        ("s" | "sigma", _) => format!("{sep}{}", sp.given(k, x)),
        (_, Spelling::Flags) => format!(" --brdf-param {k}={x}"),
        (_, Spelling::Keywords) => format!(", brdf_params['{k}']={x}"),
    };
    given.params.iter().map(|(k, x)| flag(k, x)).collect()
}
