//! Flag values that are more than one number, parsed whole per occurrence, and flags that mean one
//! value per image.
//!
//! A comma-separated flag is parsed by its own value parser (`--from 3,0,1` is one `[f64; 3]`), so
//! repeating it never concatenates the numbers of two occurrences into one wrong-length list:
//! a flag with one value per command is refused by clap when repeated ("cannot be used multiple
//! times"), and a flag with one value per image collects one value per occurrence, matched to the
//! images in order by [`per_image`].

use super::Error;

/// Parses `x,y,z`: three finite numbers.
pub fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let v = numbers(s)?;
    match v[..] {
        [x, y, z] => Ok([x, y, z]),
        _ => Err(format!("'{s}' is not three numbers x,y,z")),
    }
}

/// Parses one number (grey) or `r,g,b`, all finite.
pub fn parse_rgb(s: &str) -> Result<[f64; 3], String> {
    let v = numbers(s)?;
    match v[..] {
        [x] => Ok([x; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => Err(format!("'{s}' is not one number or r,g,b")),
    }
}

fn numbers(s: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|t| match t.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!("'{}' is not a finite number", t.trim())),
        })
        .collect()
}

/// Matches the occurrences of a per-image flag to `n` images: none (every image `None`), or
/// exactly one per image in the order of the images. Any other count is refused naming the flag,
/// so a second image never silently takes the first one's value.
pub fn per_image<T: Copy>(values: &[T], flag: &str, n: usize) -> Result<Vec<Option<T>>, Error> {
    match values.len() {
        0 => Ok(vec![None; n]),
        k if k == n => Ok(values.iter().map(|&v| Some(v)).collect()),
        k => Err(Error::new(format!(
            "--{flag} is given {k} time{} for {n} image{}: give it once per image, in the order of the images, or not at all",
            if k == 1 { "" } else { "s" },
            if n == 1 { "" } else { "s" }
        ))),
    }
}

/// Parses `--lmax`: an integer order in 0 ..= [`super::sh::MAX_LMAX`] (a command may allow fewer and
/// says so). Negative values reach this parser (`allow_hyphen_values`), so `--lmax -1` is named
/// with its range rather than taken for a flag.
pub fn parse_lmax(s: &str) -> Result<usize, String> {
    let max = super::sh::MAX_LMAX;
    match s.trim().parse::<i64>() {
        Ok(l) if (0..=max as i64).contains(&l) => Ok(l as usize),
        _ => Err(format!("must be an integer order in 0..={max}")),
    }
}

/// Parses a length or scale that must be a finite number > 0 (`--extent`, `--radius`,
/// `--max-amplification`, the bounds of a search range).
pub fn parse_positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err("must be a finite number > 0".to_string()),
    }
}

/// Parses `--theta-o`: an exitance angle in degrees, 0 ≤ θ_o < 90 (docs/src/conventions.md §6, as
/// [`analysis::transfer::validate_exitance`]).
pub fn parse_theta_o(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if (0.0..90.0).contains(&x) => Ok(x),
        _ => Err("must be an angle in degrees with 0 ≤ θ_o < 90".to_string()),
    }
}

/// Parses `--phi-o`: a finite azimuth in degrees.
pub fn parse_degrees(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err("must be a finite number of degrees".to_string()),
    }
}

/// Parses the `--width` of a written lat-long map: an even integer in 4 ..= 16384.
pub fn parse_width(s: &str) -> Result<usize, String> {
    match s.trim().parse::<i64>() {
        Ok(w) if (4..=16384).contains(&w) && w % 2 == 0 => Ok(w as usize),
        _ => Err("must be an even integer in 4..=16384".to_string()),
    }
}

/// Parses `--max-amplification`: the noise amplification 1/gain above which an order is
/// ill-conditioned, a finite number ≥ 1 (an order is never better conditioned than unamplified).
pub fn parse_amplification(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 1.0 => Ok(x),
        _ => Err("must be a finite number ≥ 1".to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parsers_and_per_image_counts() {
        assert_eq!(parse_vec3("3,-1,0.5"), Ok([3.0, -1.0, 0.5]));
        assert!(parse_vec3("1,2").unwrap_err().contains("three numbers"));
        assert!(parse_vec3("1,nan,2").unwrap_err().contains("nan"));
        assert_eq!(parse_rgb("0.5"), Ok([0.5; 3]));
        assert_eq!(parse_rgb("0.1,0.2,0.3"), Ok([0.1, 0.2, 0.3]));
        assert!(parse_rgb("0.1,0.2").unwrap_err().contains("r,g,b"));
        assert_eq!(per_image::<f64>(&[], "extent", 2).unwrap(), vec![None, None]);
        assert_eq!(per_image(&[1.0, 2.0], "extent", 2).unwrap(), vec![Some(1.0), Some(2.0)]);
        let e = per_image(&[1.0], "extent", 2).unwrap_err().to_string();
        assert!(e.contains("--extent is given 1 time for 2 images"), "{e}");
    }
}
