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
