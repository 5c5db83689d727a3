//! Lighting descriptions (the `[lighting]` table of a scene, CONVENTIONS §6, or the
//! `reflect:lighting` JSON of a render's header) and their SH coefficients L_lm.
//!
//! Supported: `uniform` (L_00 = L √(4π)), `directional` (a delta of irradiance E toward `direction`:
//! L_lm = E Y_lm(direction)), `sh` (given coefficients), `envmap` (projected, then scaled and rotated
//! by `rotate_deg`, world = R_z R_y R_x · map). `axial` is not supported here (its profile format is
//! the renderer's). Only the `[lighting]` table of a scene file is read, so this crate does not
//! depend on the renderer.

use crate::error::{Error, Result};
use crate::image::read_rgb;
use crate::projection::{Mapping, project_envmap};
use crate::sh::{Rotation, ShBasis, num_coefficients, rotate_coefficients};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A distant lighting environment.
#[derive(Clone, Debug, PartialEq)]
pub enum Lighting {
    Uniform { radiance: [f64; 3] },
    Directional { direction: [f64; 3], irradiance: [f64; 3] },
    Sh { coefficients: Vec<[f64; 3]> },
    Envmap { file: PathBuf, mapping: Option<Mapping>, scale: f64, rotate_deg: [f64; 3] },
}

fn rgb(v: &Value, key: &str) -> Result<[f64; 3]> {
    match v {
        Value::Number(n) => {
            let x = n.as_f64().unwrap_or(f64::NAN);
            Ok([x, x, x])
        }
        Value::Array(a) if a.len() == 3 => {
            let mut o = [0.0; 3];
            for (i, x) in a.iter().enumerate() {
                o[i] = x.as_f64().ok_or_else(|| Error::new(format!("lighting.{key}: expected numbers")))?;
            }
            Ok(o)
        }
        _ => Err(Error::new(format!("lighting.{key}: expected a number or an [r, g, b] array"))),
    }
}

fn field<'a>(t: &'a serde_json::Map<String, Value>, key: &str) -> Result<&'a Value> {
    t.get(key).ok_or_else(|| Error::new(format!("lighting: missing key '{key}'")))
}

impl Lighting {
    /// From the JSON form of a `[lighting]` table; relative `file` paths are resolved against `base`.
    /// Unknown keys are an error (CONVENTIONS §6).
    pub fn from_json(v: &Value, base: Option<&Path>) -> Result<Lighting> {
        Lighting::from_json_with(v, base, true)
    }

    /// As [`Lighting::from_json`]; with `strict = false` unknown keys are ignored (for the
    /// `reflect:lighting` header, which a renderer may annotate with extra fields).
    pub fn from_json_with(v: &Value, base: Option<&Path>, strict: bool) -> Result<Lighting> {
        let t = v.as_object().ok_or_else(|| Error::new("lighting: expected a table"))?;
        let ty = field(t, "type")?.as_str().ok_or_else(|| Error::new("lighting.type: expected a string"))?;
        let allowed: &[&str] = match ty {
            "uniform" => &["type", "radiance"],
            "directional" => &["type", "direction", "irradiance"],
            "sh" => &["type", "coefficients"],
            "envmap" => &["type", "file", "mapping", "scale", "rotate_deg"],
            "axial" => return Err(Error::new("lighting type 'axial' is not supported by the analysis")),
            other => return Err(Error::new(format!("unknown lighting type '{other}'"))),
        };
        if let Some(k) = t.keys().find(|k| strict && !allowed.contains(&k.as_str())) {
            return Err(Error::new(format!("lighting: unknown key '{k}' for type '{ty}'")));
        }
        let l = match ty {
            "uniform" => Lighting::Uniform { radiance: rgb(field(t, "radiance")?, "radiance")? },
            "directional" => {
                let d = rgb(field(t, "direction")?, "direction")?;
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if !(n > 0.0) || !n.is_finite() {
                    return Err(Error::new("lighting.direction must be a non-zero vector"));
                }
                Lighting::Directional {
                    direction: [d[0] / n, d[1] / n, d[2] / n],
                    irradiance: rgb(field(t, "irradiance")?, "irradiance")?,
                }
            }
            "sh" => {
                let a = field(t, "coefficients")?
                    .as_array()
                    .ok_or_else(|| Error::new("lighting.coefficients: expected an array of [r, g, b]"))?;
                let coefficients = a.iter().map(|c| rgb(c, "coefficients")).collect::<Result<Vec<_>>>()?;
                if coefficients.is_empty() {
                    return Err(Error::new("lighting.coefficients is empty"));
                }
                Lighting::Sh { coefficients }
            }
            _ => {
                let file = field(t, "file")?.as_str().ok_or_else(|| Error::new("lighting.file: expected a string"))?;
                let file = match base {
                    Some(b) if Path::new(file).is_relative() => b.join(file),
                    _ => PathBuf::from(file),
                };
                let mapping = match t.get("mapping") {
                    Some(m) => Some(Mapping::parse(
                        m.as_str().ok_or_else(|| Error::new("lighting.mapping: expected a string"))?,
                    )?),
                    None => None,
                };
                let scale = match t.get("scale") {
                    Some(s) => s.as_f64().ok_or_else(|| Error::new("lighting.scale: expected a number"))?,
                    None => 1.0,
                };
                let rotate_deg = match t.get("rotate_deg") {
                    Some(r) => rgb(r, "rotate_deg")?,
                    None => [0.0; 3],
                };
                Lighting::Envmap { file, mapping, scale, rotate_deg }
            }
        };
        Ok(l)
    }

    /// The `[lighting]` table of a scene TOML file (other tables are not read).
    pub fn from_scene_file(path: &Path) -> Result<Lighting> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
        let table: toml::Table =
            text.parse().map_err(|e: toml::de::Error| Error::file(path, format!("invalid TOML: {e}")))?;
        let lt = table.get("lighting").ok_or_else(|| Error::file(path, "scene has no [lighting] table"))?;
        let v = serde_json::to_value(lt).map_err(|e| Error::file(path, format!("lighting: {e}")))?;
        Lighting::from_json(&v, path.parent()).map_err(|e| e.in_file(path))
    }

    /// An environment map file used directly as lighting.
    pub fn from_envmap_file(path: &Path, mapping: Option<Mapping>) -> Lighting {
        Lighting::Envmap { file: path.to_path_buf(), mapping, scale: 1.0, rotate_deg: [0.0; 3] }
    }

    /// L_lm, RGB, l ≤ lmax.
    pub fn coefficients(&self, lmax: usize) -> Result<Vec<[f64; 3]>> {
        let n = num_coefficients(lmax);
        Ok(match self {
            Lighting::Uniform { radiance } => {
                let s = (4.0 * std::f64::consts::PI).sqrt();
                let mut c = vec![[0.0; 3]; n];
                c[0] = [radiance[0] * s, radiance[1] * s, radiance[2] * s];
                c
            }
            Lighting::Directional { direction, irradiance } => {
                let y = ShBasis::new(lmax).eval(*direction);
                y.iter().map(|y| [irradiance[0] * y, irradiance[1] * y, irradiance[2] * y]).collect()
            }
            Lighting::Sh { coefficients } => (0..n).map(|k| coefficients.get(k).copied().unwrap_or([0.0; 3])).collect(),
            Lighting::Envmap { file, mapping, scale, rotate_deg } => {
                let img = read_rgb(file)?;
                let mapping = match mapping {
                    Some(m) => *m,
                    None => Mapping::infer(img.width, img.height).map_err(|e| e.in_file(file))?,
                };
                let mut c = project_envmap(&img, mapping, lmax).map_err(|e| e.in_file(file))?;
                if *rotate_deg != [0.0; 3] {
                    c = rotate_coefficients(&c, &Rotation::from_xyz_deg(*rotate_deg));
                }
                c.iter().map(|v| [v[0] * scale, v[1] * scale, v[2] * scale]).collect()
            }
        })
    }
}
