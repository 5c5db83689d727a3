//! The colour meaning of stored RGB: images may declare their primaries and white point (OpenEXR's
//! standard `chromaticities` attribute, a Radiance file's `PRIMARIES=` line). Everything in reflect
//! works in one **working colour space**: linear RGB with the Rec. ITU-R BT.709 / sRGB primaries and
//! the D65 white point. Pixels declared in other primaries are converted to it by the 3 × 3 matrix
//! RGB → XYZ → RGB built from the chromaticities (SMPTE RP 177), with a Bradford chromatic
//! adaptation (Lam 1985, as in ICC v4 and the ACES reference transforms) from the file's white to
//! D65 when the whites differ.

use glam::{DMat3, DVec3};

/// CIE xy chromaticities of the red, green and blue primaries and of the white point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chromaticities {
    pub red: [f64; 2],
    pub green: [f64; 2],
    pub blue: [f64; 2],
    pub white: [f64; 2],
}

/// The working colour space: Rec. 709 / sRGB primaries, D65 white (OpenEXR's default too).
pub const REC709: Chromaticities =
    Chromaticities { red: [0.64, 0.33], green: [0.30, 0.60], blue: [0.15, 0.06], white: [0.3127, 0.3290] };

/// Declared chromaticities within this distance in x and y of [`REC709`] mean Rec. 709: files
/// store the coordinates as 32-bit floats, rounded to 4 or 5 digits (D65 is written 0.3127 0.329
/// or 0.31271 0.32902).
pub const REC709_TOLERANCE: f64 = 1e-3;

/// The Bradford cone-response matrix (XYZ → sharpened RGB).
const BRADFORD: DMat3 = DMat3::from_cols_array(&[
    0.8951, -0.7502, 0.0389, // first column
    0.2664, 1.7135, -0.0685, //
    -0.1614, 0.0367, 1.0296, //
]);

impl Chromaticities {
    /// The numbers as `red x y, green x y, blue x y, white x y`, for messages.
    pub fn describe(&self) -> String {
        let p = |v: [f64; 2]| format!("{} {}", v[0] as f32, v[1] as f32);
        format!("red {}, green {}, blue {}, white {}", p(self.red), p(self.green), p(self.blue), p(self.white))
    }

    /// Whether these are [`REC709`] within [`REC709_TOLERANCE`].
    pub fn is_rec709(&self) -> bool {
        let pairs =
            [(self.red, REC709.red), (self.green, REC709.green), (self.blue, REC709.blue), (self.white, REC709.white)];
        pairs.iter().all(|(a, b)| (a[0] - b[0]).abs() <= REC709_TOLERANCE && (a[1] - b[1]).abs() <= REC709_TOLERANCE)
    }

    /// The matrix taking linear RGB in these primaries to CIE XYZ (Y of the white = 1). Errors say
    /// why the chromaticities define no RGB space: a non-finite number, a white point with y ≤ 0,
    /// primaries on one line (no gamut), or a white point that is not a positive mix of the primaries.
    pub fn rgb_to_xyz(&self) -> Result<DMat3, String> {
        let all = [self.red, self.green, self.blue, self.white];
        if all.iter().flatten().any(|v| !v.is_finite()) {
            return Err("a coordinate is not a finite number".into());
        }
        let [wx, wy] = self.white;
        if !(wy > 1e-6) {
            return Err(format!("the white point has y = {wy}, which must be > 0"));
        }
        // Columns (x, y, z) of each primary, unnormalized, so a primary with y ≤ 0 (ACES AP0's blue
        // has y = −0.077) needs no division.
        let col = |p: [f64; 2]| DVec3::new(p[0], p[1], 1.0 - p[0] - p[1]);
        let p = DMat3::from_cols(col(self.red), col(self.green), col(self.blue));
        if p.determinant().abs() < 1e-6 {
            return Err("the three primaries lie on one line (no gamut)".into());
        }
        let white = DVec3::new(wx / wy, 1.0, (1.0 - wx - wy) / wy);
        let s = p.inverse() * white;
        if !(s.min_element() > 0.0) {
            return Err("the white point lies outside the triangle of the primaries".into());
        }
        Ok(p * DMat3::from_diagonal(s))
    }

    /// The matrix taking linear RGB in these primaries to the working space ([`REC709`]): RGB → XYZ,
    /// Bradford adaptation from this white to D65, XYZ → Rec. 709. `Ok(None)` when these are Rec. 709
    /// ([`Chromaticities::is_rec709`]): the pixels are used as stored, bit for bit.
    pub fn to_working(&self) -> Result<Option<DMat3>, String> {
        if self.is_rec709() {
            return Ok(None);
        }
        let to_xyz = self.rgb_to_xyz()?;
        let from_xyz = REC709.rgb_to_xyz().expect("Rec. 709 is an RGB space").inverse();
        let xyz = |c: [f64; 2]| DVec3::new(c[0] / c[1], 1.0, (1.0 - c[0] - c[1]) / c[1]);
        let (src, dst) = (BRADFORD * xyz(self.white), BRADFORD * xyz(REC709.white));
        let adapt = BRADFORD.inverse() * DMat3::from_diagonal(dst / src) * BRADFORD;
        Ok(Some(from_xyz * adapt * to_xyz))
    }
}

/// Applies `m` to the pixels `(r[i], g[i], b[i])` in place (in f64, rounded once to f32).
pub fn convert_rgb(m: &DMat3, r: &mut [f32], g: &mut [f32], b: &mut [f32]) {
    for ((r, g), b) in r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()) {
        let v = *m * DVec3::new(*r as f64, *g as f64, *b as f64);
        (*r, *g, *b) = (v.x as f32, v.y as f32, v.z as f32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const AP0: Chromaticities =
        Chromaticities { red: [0.7347, 0.2653], green: [0.0, 1.0], blue: [0.0001, -0.0770], white: [0.32168, 0.33767] };

    /// Rec. 709's RGB → XYZ matrix is the sRGB standard's (IEC 61966-2-1, 4 decimals).
    #[test]
    fn rec709_matrix_is_the_srgb_one() {
        let m = REC709.rgb_to_xyz().unwrap();
        let want = [[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]];
        for (i, row) in want.iter().enumerate() {
            for (j, w) in row.iter().enumerate() {
                assert!((m.row(i)[j] - w).abs() < 1e-4, "({i},{j}) {} vs {w}", m.row(i)[j]);
            }
        }
        assert_eq!(REC709.to_working().unwrap(), None);
    }

    /// ACES AP0 → Rec. 709 with Bradford: the ACES reference (ACES TB-2014-004, AP0 to linear
    /// Rec. 709 D65, Bradford) rows to 4 decimals.
    #[test]
    fn ap0_to_rec709_is_the_aces_bradford_matrix() {
        let m = AP0.to_working().unwrap().unwrap();
        let want = [[2.5217, -1.1341, -0.3876], [-0.2765, 1.3727, -0.0962], [-0.0154, -0.1530, 1.1684]];
        for (i, row) in want.iter().enumerate() {
            for (j, w) in row.iter().enumerate() {
                assert!((m.row(i)[j] - w).abs() < 2e-4, "({i},{j}) {} vs {w}", m.row(i)[j]);
            }
        }
        // White maps to white: adaptation keeps the achromatic axis.
        let w = m * DVec3::ONE;
        assert!((w - DVec3::ONE).abs().max_element() < 1e-4, "{w}");
    }

    #[test]
    fn degenerate_chromaticities_are_refused() {
        let line = Chromaticities { red: [0.2, 0.2], green: [0.4, 0.4], blue: [0.6, 0.6], ..REC709 };
        assert!(line.rgb_to_xyz().unwrap_err().contains("one line"));
        let dark = Chromaticities { white: [0.3, 0.0], ..REC709 };
        assert!(dark.rgb_to_xyz().unwrap_err().contains("y = 0"));
        let nan = Chromaticities { red: [f64::NAN, 0.3], ..REC709 };
        assert!(nan.rgb_to_xyz().unwrap_err().contains("finite"));
        let outside = Chromaticities { white: [0.7, 0.29], ..REC709 };
        assert!(outside.rgb_to_xyz().unwrap_err().contains("outside"));
    }
}
