//! Lighting descriptions (the `[lighting]` table of a scene, docs/src/conventions.md §6, or the
//! `reflect:lighting` JSON of a render's header, both read into `vocab`'s [`LightingSection`]) and
//! their SH coefficients L_lm.
//!
//! Supported: `uniform` (L_00 = L √(4π)), `directional` (a delta of irradiance E toward `direction`:
//! L_lm = E Y_lm(direction)), `sh` (given coefficients), `envmap` (projected, then scaled and rotated
//! by `rotate_deg`, world = R_z R_y R_x · map). `axial` is not supported here (its profile format is
//! the renderer's). Only the `[lighting]` table of a scene file is read.

use crate::error::{Error, Result};
use crate::image::read_rgb_layer;
use crate::projection::{Mapping, project_envmap};
use crate::sh::{Rotation, ShBasis, num_coefficients, rotate_coefficients};
use std::path::{Path, PathBuf};
use vocab::scene::{Color, LightingSection, decimal, decimal3};

/// What identifies a projection of an environment-map file: the file (canonical path, length and
/// modification time, so that a file rewritten in between is read again), its layer, the mapping
/// asked for and l_max.
type ProjectionKey = (PathBuf, u64, std::time::SystemTime, Option<String>, Option<Mapping>, usize);

/// L_lm of the map `file` (unscaled, unrotated), projected once per process: a 1000² probe takes
/// about a second to project to l = 16, and an analysis reads the same map several times (the filter
/// fit, the lighting check, the other mapping of the verdict), as do callers that analyse many images
/// under one lighting (a coverage test over seeds, `verify`).
fn projected_envmap(
    file: &Path,
    layer: Option<&str>,
    mapping: Option<Mapping>,
    lmax: usize,
) -> Result<std::sync::Arc<Vec<[f64; 3]>>> {
    use std::collections::HashMap;
    use std::sync::{Arc, Mutex, OnceLock};
    type Memo = Mutex<HashMap<ProjectionKey, Arc<Vec<[f64; 3]>>>>;
    static MEMO: OnceLock<Memo> = OnceLock::new();
    let key = std::fs::canonicalize(file).ok().and_then(|path| {
        let meta = std::fs::metadata(&path).ok()?;
        Some((path, meta.len(), meta.modified().ok()?, layer.map(str::to_string), mapping, lmax))
    });
    let memo = MEMO.get_or_init(Default::default);
    if let Some(c) = key.as_ref().and_then(|k| memo.lock().ok()?.get(k).cloned()) {
        return Ok(c);
    }
    let img = read_rgb_layer(file, layer)?;
    let mapping = match mapping {
        Some(m) => m,
        None => Mapping::infer(img.width, img.height).map_err(|e| e.in_file(file))?,
    };
    let c = Arc::new(project_envmap(&img, mapping, lmax).map_err(|e| e.in_file(file))?);
    if let (Some(k), Ok(mut m)) = (key, memo.lock()) {
        m.insert(k, c.clone());
    }
    Ok(c)
}

/// A distant lighting environment.
#[derive(Clone, Debug, PartialEq)]
pub enum Lighting {
    Uniform {
        radiance: [f64; 3],
    },
    Directional {
        direction: [f64; 3],
        irradiance: [f64; 3],
    },
    Sh {
        coefficients: Vec<[f64; 3]>,
    },
    /// `layer`: the map's layer or part (`vocab::image::read_rgb_layer`).
    Envmap {
        file: PathBuf,
        mapping: Option<Mapping>,
        scale: f64,
        rotate_deg: [f64; 3],
        layer: Option<String>,
    },
}

impl Lighting {
    /// From a scene's `[lighting]` table ([`LightingSection`], docs/src/conventions.md §6); a relative `file`
    /// is resolved against `base`. Values are checked here (finite colours, a non-zero direction,
    /// a non-empty coefficient list); `axial` is refused (its profile is the renderer's).
    pub fn from_section(section: &LightingSection, base: Option<&Path>) -> Result<Lighting> {
        let rgb = |c: &Color, key: &str| -> Result<[f64; 3]> {
            let v = decimal3(c.rgb());
            if v.iter().all(|x| x.is_finite()) {
                Ok(v)
            } else {
                Err(Error::new(format!("lighting.{key} must be finite, got {v:?}")))
            }
        };
        Ok(match section {
            LightingSection::Uniform { radiance } => Lighting::Uniform { radiance: rgb(radiance, "radiance")? },
            LightingSection::Directional { direction, irradiance } => {
                let d = decimal3(*direction);
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if !(n > 0.0) || !n.is_finite() {
                    return Err(Error::new("lighting.direction must be a non-zero vector"));
                }
                Lighting::Directional {
                    direction: [d[0] / n, d[1] / n, d[2] / n],
                    irradiance: rgb(irradiance, "irradiance")?,
                }
            }
            LightingSection::Sh { coefficients } => {
                if coefficients.is_empty() {
                    return Err(Error::new("lighting.coefficients is empty"));
                }
                let coefficients: Vec<[f64; 3]> = coefficients.iter().map(|c| decimal3(*c)).collect();
                if coefficients.iter().flatten().any(|x| !x.is_finite()) {
                    return Err(Error::new("lighting.coefficients must be finite"));
                }
                Lighting::Sh { coefficients }
            }
            LightingSection::Envmap { file, mapping, scale, rotate_deg, layer } => {
                let file = match base {
                    Some(b) if Path::new(file).is_relative() => b.join(file),
                    _ => PathBuf::from(file),
                };
                Lighting::Envmap {
                    file,
                    mapping: *mapping,
                    scale: decimal(*scale),
                    rotate_deg: decimal3(*rotate_deg),
                    layer: layer.clone(),
                }
            }
            LightingSection::Axial { .. } => {
                return Err(Error::new("lighting type 'axial' is not supported by the analysis"));
            }
        })
    }

    /// From the JSON form of a `[lighting]` table (as in a `reflect:lighting` header); relative
    /// `file` paths are resolved against `base`. Unknown keys and bad values are errors (docs/src/conventions.md §6).
    pub fn from_json(v: &serde_json::Value, base: Option<&Path>) -> Result<Lighting> {
        let section: LightingSection =
            serde_json::from_value(v.clone()).map_err(|e| Error::new(format!("lighting: {e}")))?;
        Lighting::from_section(&section, base)
    }

    /// The `[lighting]` table of a scene TOML file (other tables are not read).
    pub fn from_scene_file(path: &Path) -> Result<Lighting> {
        #[derive(serde::Deserialize)]
        struct OnlyLighting {
            lighting: Option<LightingSection>,
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read file: {e}")))?;
        let t: OnlyLighting = toml::from_str(&text)
            .map_err(|e| Error::file(path, format!("invalid TOML: {}", e.message().trim().replace('\n', " "))))?;
        let section = t.lighting.ok_or_else(|| Error::file(path, "scene has no [lighting] table"))?;
        Lighting::from_section(&section, path.parent()).map_err(|e| e.in_file(path))
    }

    /// An environment map file used directly as lighting.
    pub fn from_envmap_file(path: &Path, mapping: Option<Mapping>) -> Lighting {
        Lighting::Envmap { file: path.to_path_buf(), mapping, scale: 1.0, rotate_deg: [0.0; 3], layer: None }
    }

    /// An environment map read with a mapping its aspect ratio contradicts (a square map as
    /// lat-long, a 2:1 map as angular): a warning naming the file, the shape and both mappings;
    /// `None` otherwise (including a map that cannot be read, whose error comes from
    /// [`Lighting::coefficients`]).
    pub fn mapping_note(&self) -> Option<String> {
        let Lighting::Envmap { file, mapping: Some(m), layer, .. } = self else { return None };
        let img = read_rgb_layer(file, layer.as_deref()).ok()?;
        let inferred = Mapping::infer(img.width, img.height).ok()?;
        (inferred != *m).then(|| {
            format!(
                "{}: a {}×{} map is {inferred} by its aspect ratio but is read as {m} (--mapping or the scene's \
                 `mapping`): check it",
                file.display(),
                img.width,
                img.height
            )
        })
    }

    /// The same environment map read with the other mapping (lat-long ↔ angular), named, for a
    /// verdict's alternatives; empty for other lightings.
    pub fn other_mappings(&self) -> Vec<(String, Lighting)> {
        let Lighting::Envmap { file, mapping, scale, rotate_deg, layer } = self else { return Vec::new() };
        let current = match mapping {
            Some(m) => *m,
            None => {
                match read_rgb_layer(file, layer.as_deref()).ok().and_then(|i| Mapping::infer(i.width, i.height).ok()) {
                    Some(m) => m,
                    None => return Vec::new(),
                }
            }
        };
        let other = match current {
            Mapping::LatLong => Mapping::Angular,
            Mapping::Angular => Mapping::LatLong,
        };
        vec![(
            format!("the map read as {other} instead of {current}"),
            Lighting::Envmap {
                file: file.clone(),
                mapping: Some(other),
                scale: *scale,
                rotate_deg: *rotate_deg,
                layer: layer.clone(),
            },
        )]
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
            Lighting::Envmap { file, mapping, scale, rotate_deg, layer } => {
                let mut c = projected_envmap(file, layer.as_deref(), *mapping, lmax)?.as_ref().clone();
                if *rotate_deg != [0.0; 3] {
                    c = rotate_coefficients(&c, &Rotation::from_xyz_deg(*rotate_deg));
                }
                c.iter().map(|v| [v[0] * scale, v[1] * scale, v[2] * scale]).collect()
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vocab::image::{Image, write_exr};

    fn write_map(path: &Path, (w, h): (usize, usize), value: f32) {
        let mut img = Image { width: w, height: h, ..Default::default() };
        for c in ["R", "G", "B"] {
            img.channels.insert(c.to_string(), vec![value; w * h]);
        }
        write_exr(path, &img).unwrap();
    }

    #[test]
    fn a_map_file_is_projected_once_until_it_changes() {
        let dir = std::env::temp_dir().join(format!("reflect-lighting-memo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("map.exr");
        write_map(&path, (16, 8), 1.0);
        let a = projected_envmap(&path, None, None, 2).unwrap();
        let b = projected_envmap(&path, None, None, 2).unwrap();
        assert!(std::sync::Arc::ptr_eq(&a, &b), "the second projection was not the first one's");
        assert!(!std::sync::Arc::ptr_eq(&a, &projected_envmap(&path, None, None, 3).unwrap()));
        // Rewritten (another size, so another length): projected again, with the new values.
        write_map(&path, (32, 16), 2.0);
        let c = projected_envmap(&path, None, None, 2).unwrap();
        assert!((c[0][0] / a[0][0] - 2.0).abs() < 1e-3, "{} then {}: a stale projection", a[0][0], c[0][0]);
        // Lighting::coefficients goes through it, scaled afterwards.
        let l = Lighting::Envmap { file: path, mapping: None, scale: 0.5, rotate_deg: [0.0; 3], layer: None };
        assert_eq!(l.coefficients(2).unwrap()[0][0], 0.5 * c[0][0]);
        let _ = std::fs::remove_dir_all(dir);
    }
}
