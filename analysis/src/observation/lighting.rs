//! The lighting an image is compared with: an explicit lighting (a scene file's `[lighting]` or an
//! environment map) or the observation's (its sidecar scene's, else its header's).

use super::error::Error;
use super::{Observation, num, v3};
use crate::lighting::Lighting;
use crate::projection::Mapping;
use std::path::{Path, PathBuf};

/// A lighting given explicitly, in place of the observed one.
#[derive(Clone, Debug)]
pub enum LightingInput {
    /// A scene TOML file (its `[lighting]` table) or an environment map file (read with the
    /// mapping passed beside it, else one inferred from its aspect ratio).
    File(PathBuf),
    /// A lighting held in memory, with its name for the report and messages (`<lighting dict>`).
    Value { lighting: Lighting, name: String },
}

/// The lighting to compare with: `lighting` (a scene TOML's `[lighting]` table, or an environment
/// map with `mapping` or a mapping inferred from its aspect ratio), else the observed lighting
/// (the sidecar scene's, else the first image's `reflect:lighting` header; a relative file there is
/// taken relative to that file). Returns the lighting and a text saying where it came from.
pub fn lighting_of(
    lighting: Option<&Path>,
    mapping: Option<Mapping>,
    observed: &Observation,
) -> Result<Option<(Lighting, String)>, Error> {
    lighting_given(lighting.map(|p| LightingInput::File(p.to_path_buf())).as_ref(), mapping, observed)
}

/// [`lighting_of`] with the explicit lighting a file or a value ([`LightingInput`]); `mapping`
/// applies to a map file only.
pub fn lighting_given(
    lighting: Option<&LightingInput>,
    mapping: Option<Mapping>,
    observed: &Observation,
) -> Result<Option<(Lighting, String)>, Error> {
    if let Some(input) = lighting {
        let (given, name) = match input {
            LightingInput::File(p) => {
                let given = if p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
                    Lighting::from_scene_file(p)?
                } else {
                    Lighting::from_envmap_file(p, mapping)
                };
                (given, p.display().to_string())
            }
            LightingInput::Value { lighting, name } => (lighting.clone(), name.clone()),
        };
        // Unlike the camera, sphere and BRDF (the image's description, where a contradiction is an
        // error), the lighting is what the image is compared with: `--lighting` replaces the
        // sidecar's or header's by rule (guide "Analysing another renderer's images"), to test whether a
        // lighting describes the image. It never does so silently: a different lighting is named
        // with the one it replaces in the report's lighting source.
        // A described lighting the analysis cannot read (axial, a missing map) is replaced as well.
        if let Some((s, file, source)) = &observed.lighting {
            let d = Lighting::from_section(s, file.parent()).ok();
            if !d.as_ref().is_some_and(|d| same_lighting(&given, d).unwrap_or(false)) {
                let shown = format!(
                    "{name} ({}), in place of the {source} ({})",
                    lighting_text(&given),
                    d.as_ref().map_or_else(|| "not analysable".to_string(), lighting_text)
                );
                return Ok(Some((given, shown)));
            }
        }
        return Ok(Some((given, name)));
    }
    if mapping.is_some() {
        return Err(Error::MappingWithoutLighting);
    }
    match &observed.lighting {
        Some((s, file, source)) => Ok(Some((
            Lighting::from_section(s, file.parent()).map_err(|e| Error::from(e).in_file(file))?,
            source.clone(),
        ))),
        None => Ok(None),
    }
}

/// The order up to which [`same_lighting`] compares two lightings' L_lm.
const LIGHTING_AGREE_LMAX: usize = 4;

/// Whether two lightings are the same: equal tables (an environment map by its canonical path), or
/// equal L_lm up to l = [`LIGHTING_AGREE_LMAX`] to 1e-4 of the largest (the same map in another
/// file or with its mapping left to inference; a different or rotated map differs far more).
fn same_lighting(a: &Lighting, b: &Lighting) -> Result<bool, vocab::Error> {
    let canonical = |l: &Lighting| match l {
        Lighting::Envmap { file, mapping, scale, rotate_deg, layer } => Lighting::Envmap {
            file: std::fs::canonicalize(file).unwrap_or_else(|_| file.clone()),
            mapping: *mapping,
            scale: *scale,
            rotate_deg: *rotate_deg,
            layer: layer.clone(),
        },
        other => other.clone(),
    };
    if canonical(a) == canonical(b) {
        return Ok(true);
    }
    let (ca, cb) = (a.coefficients(LIGHTING_AGREE_LMAX)?, b.coefficients(LIGHTING_AGREE_LMAX)?);
    let big = ca.iter().chain(&cb).flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    Ok(ca.iter().zip(&cb).all(|(x, y)| (0..3).all(|i| (x[i] - y[i]).abs() <= 1e-4 * big)))
}

/// A lighting in a message: its type and what identifies it.
fn lighting_text(l: &Lighting) -> String {
    match l {
        Lighting::Uniform { radiance } => format!("uniform lighting of radiance {}", v3(*radiance)),
        Lighting::Directional { direction, irradiance } => {
            format!("directional lighting from {} of irradiance {}", v3(*direction), v3(*irradiance))
        }
        Lighting::Sh { coefficients } => format!("SH lighting with {} coefficients", coefficients.len()),
        Lighting::Envmap { file, scale, rotate_deg, layer, .. } => {
            let mut t = format!("the environment map {}", file.display());
            if let Some(l) = layer {
                t.push_str(&format!(" (layer '{l}')"));
            }
            if *scale != 1.0 {
                t.push_str(&format!(" scaled by {}", num(*scale)));
            }
            if *rotate_deg != [0.0; 3] {
                t.push_str(&format!(" rotated by {}°", v3(*rotate_deg)));
            }
            t
        }
    }
}
