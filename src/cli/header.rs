//! Reading what a render's EXR header says about how it was made (`reflect:camera`,
//! `reflect:objects`, `reflect:lighting`, written by `renderer::output`), and the lighting given on
//! the command line instead. Shared by `reflect analyze` and the `reflect invert` subcommands.

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

/// (θ_o, φ_o) in degrees of a `normal-probe` camera header (`theta_o_deg`, `phi_o_deg`; absent
/// = 0, CONVENTIONS §6 and our φ_o extension); a present value that is not a finite number is an
/// error, and θ_o goes through the one exitance check of every command
/// ([`analysis::transfer::validate_exitance`]: 0 ≤ θ_o < 90°, as the renderer's camera).
pub fn probe_exitance_deg(cam: &Value) -> Result<(f64, f64), Error> {
    let num = |k: &str| match cam.get(k) {
        None => Ok(0.0),
        Some(v) => v
            .as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| Error::new(format!("header camera '{k}' is not a number"))),
    };
    let theta_o_deg = num("theta_o_deg")?;
    analysis::transfer::validate_exitance(theta_o_deg.to_radians())
        .map_err(|e| Error::new(format!("header camera: {}", e.message)))?;
    Ok((theta_o_deg, num("phi_o_deg")?))
}

/// θ_o (degrees) of a `normal-probe` render for the per-order analysis of `analyze` and
/// `invert lighting | brdf`, which reads the q = 0 term at (θ_o, φ_o = 0) (eq. 10): another
/// azimuth at oblique exitance is refused (`what` names the command's verb in the message).
pub fn probe_theta_o_deg(cam: &Value, what: &str) -> Result<f64, Error> {
    let (theta_o_deg, phi_o_deg) = probe_exitance_deg(cam)?;
    if theta_o_deg != 0.0 && phi_o_deg.rem_euclid(360.0) != 0.0 {
        return Err(Error::new(format!(
            "a normal-probe render at phi_o_deg = {phi_o_deg} cannot be {what} (only phi_o_deg = 0)"
        )));
    }
    Ok(theta_o_deg)
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

/// The lighting to compare with: `--lighting` (a scene TOML's `[lighting]` table, or an environment
/// map with `--mapping` or a mapping inferred from its aspect ratio), else the `reflect:lighting`
/// header of the first image (a relative file there is taken relative to that image).
pub fn lighting_of(
    lighting: Option<&Path>,
    mapping: Option<Mapping>,
    first: &Image,
    first_path: &Path,
) -> Result<Option<(Lighting, String)>, Error> {
    if let Some(p) = lighting {
        if p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
            return Ok(Some((Lighting::from_scene_file(p)?, p.display().to_string())));
        }
        return Ok(Some((Lighting::from_envmap_file(p, mapping), p.display().to_string())));
    }
    if mapping.is_some() {
        return Err(Error::new("--mapping applies only to an environment map given with --lighting"));
    }
    match vocab::header::read_key::<vocab::LightingSection>(&first.attributes, vocab::header::LIGHTING)
        .map_err(|e| e.in_file(first_path))?
    {
        Some(s) => Ok(Some((
            Lighting::from_section(&s, first_path.parent()).map_err(|e| e.in_file(first_path))?,
            "reflect:lighting header".to_string(),
        ))),
        None => Ok(None),
    }
}
