//! Reading what a render's EXR header says about how it was made (`reflect:camera`,
//! `reflect:objects`, `reflect:lighting`, written by `renderer::output`), and the lighting given on
//! the command line instead. Shared by `reflect analyze` and `reflect invert`.

use super::Error;
use analysis::image::Image;
use analysis::lighting::Lighting;
use analysis::projection::{Mapping, Sphere};
use serde_json::Value;
use std::path::Path;

/// The JSON value of header attribute `key`, if present.
pub fn header_json(img: &Image, key: &str) -> Result<Option<Value>, Error> {
    img.attributes
        .get(key)
        .map(|t| serde_json::from_str(t).map_err(|e| Error::new(format!("header {key} is not JSON: {e}"))))
        .transpose()
}

/// `v[key]` as three numbers.
pub fn json_vec3(v: &Value, key: &str) -> Result<[f64; 3], Error> {
    let a = v.get(key).and_then(|a| a.as_array()).filter(|a| a.len() == 3);
    let a = a.ok_or_else(|| Error::new(format!("header: '{key}' must be an array of 3 numbers")))?;
    let mut o = [0.0; 3];
    for (i, x) in a.iter().enumerate() {
        o[i] = x.as_f64().ok_or_else(|| Error::new(format!("header: '{key}' must hold numbers")))?;
    }
    Ok(o)
}

/// A colour as the scene format writes it: one number (grey) or `[r, g, b]`.
pub fn json_rgb(v: Option<&Value>) -> Option<[f64; 3]> {
    match v {
        Some(Value::Number(n)) => n.as_f64().map(|x| [x; 3]),
        Some(Value::Array(a)) if a.len() == 3 => {
            let o = [0, 1, 2].map(|i| a[i].as_f64());
            o.iter().all(|x| x.is_some()).then(|| o.map(|x| x.unwrap_or(0.0)))
        }
        _ => None,
    }
}

/// The first sphere of `reflect:objects`, its BRDF table, and the number of objects.
pub fn first_sphere(img: &Image) -> Result<(Option<Sphere>, Option<Value>, usize), Error> {
    let Some(v) = header_json(img, "reflect:objects")? else { return Ok((None, None, 0)) };
    let objs = v.as_array().ok_or_else(|| Error::new("header reflect:objects is not an array"))?;
    let Some(o) = objs.iter().find(|o| o.get("shape").and_then(|s| s.as_str()) == Some("sphere")) else {
        return Ok((None, None, objs.len()));
    };
    let sphere = Sphere {
        center: json_vec3(o, "center").unwrap_or([0.0; 3]),
        radius: o.get("radius").and_then(|r| r.as_f64()).unwrap_or(1.0),
    };
    Ok((Some(sphere), o.get("brdf").cloned(), objs.len()))
}

/// The lighting to compare with: `--lighting` (a scene TOML's [lighting] table, or an environment
/// map with `--mapping` or a mapping inferred from its aspect ratio), else the `reflect:lighting`
/// header of the first image (a relative file there is taken relative to that image).
pub fn lighting_of(
    lighting: Option<&Path>,
    mapping: Option<&str>,
    first: &Image,
    first_path: &Path,
) -> Result<Option<(Lighting, String)>, Error> {
    if let Some(p) = lighting {
        if p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
            return Ok(Some((Lighting::from_scene_file(p)?, p.display().to_string())));
        }
        let mapping = mapping.map(Mapping::parse).transpose()?;
        return Ok(Some((Lighting::from_envmap_file(p, mapping), p.display().to_string())));
    }
    if mapping.is_some() {
        return Err(Error::new("--mapping applies only to an environment map given with --lighting"));
    }
    match header_json(first, "reflect:lighting").map_err(|e| e.in_file(first_path))? {
        Some(v) => Ok(Some((Lighting::from_json_with(&v, first_path.parent(), false)?, "reflect:lighting header".to_string()))),
        None => Ok(None),
    }
}
