//! Albedo textures: a spatially varying RGB reflectance factor T(n) of an object, given as a function
//! of its world-space surface normal n by spherical-harmonic coefficients (docs/src/conventions.md §3):
//! T(n) = Σ_k T_k Y_k(n), k = l(l+1) + m, l ≤ [`MAX_LMAX`]. On a sphere this is an ordinary texture
//! (n is the point on the sphere); on a convex mesh it paints by orientation.
//!
//! The factor multiplies the BRDF at the surface point (f → T(n) f), so it scales every sample's
//! contribution at that vertex and leaves every sampling density unchanged: the BRDF samplers' χ²
//! tests hold as they are, and an estimate stays unbiased for any T ≥ 0. Scene key (on any object):
//! `texture = { type = "sh", coefficients = [[r, g, b], …] }`.
//!
//! Errors: a count that is not (l_max + 1)², l_max > [`MAX_LMAX`], a non-finite coefficient, or a
//! texture that is negative somewhere on a 1° grid of normals (a reflectance cannot be negative).

use crate::math::{Rgb, Vec3};
use analysis::sh::ShBasis;

/// Largest supported order (289 coefficients): the stack buffer of [`ShTexture::eval`] is sized for it.
pub const MAX_LMAX: usize = 16;
const MAX_COEFFICIENTS: usize = (MAX_LMAX + 1) * (MAX_LMAX + 1);

/// T(n) = Σ_k T_k Y_k(n), RGB.
#[derive(Clone, Debug)]
pub struct ShTexture {
    coefficients: Vec<[f64; 3]>,
    basis: ShBasis,
}

impl ShTexture {
    pub fn new(coefficients: &[[f32; 3]]) -> crate::Result<ShTexture> {
        let n = coefficients.len();
        let side = (n as f64).sqrt().round() as usize;
        if n == 0 || side * side != n {
            return Err(crate::Error::new(format!(
                "sh texture: {n} coefficients given; the count must be (lmax+1)² (1, 4, 9, 16, …)"
            )));
        }
        let lmax = side - 1;
        if lmax > MAX_LMAX {
            return Err(crate::Error::new(format!(
                "sh texture: lmax = {lmax} ({n} coefficients) exceeds the supported maximum {MAX_LMAX}"
            )));
        }
        if let Some(k) = coefficients.iter().position(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(crate::Error::new(format!("sh texture: coefficient {k} is not finite")));
        }
        let t = ShTexture {
            coefficients: coefficients.iter().map(|c| c.map(|v| v as f64)).collect(),
            basis: ShBasis::new(lmax),
        };
        // A 1° grid: a band-limited T (l ≤ 16) cannot dip far below zero between its nodes unless
        // it is negative at one of them to within rounding.
        let (gh, gw) = (180, 360);
        for r in 0..gh {
            for c in 0..gw {
                let theta = std::f64::consts::PI * (r as f64 + 0.5) / gh as f64;
                let phi = 2.0 * std::f64::consts::PI * (c as f64 + 0.5) / gw as f64;
                let d = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
                let v = t.eval_f64(d);
                if let Some(ch) = v.iter().position(|x| *x < -1e-6) {
                    return Err(crate::Error::new(format!(
                        "sh texture: negative reflectance {:.4} in channel {ch} at θ = {:.1}°, φ = {:.1}°",
                        v[ch],
                        theta.to_degrees(),
                        phi.to_degrees()
                    )));
                }
            }
        }
        Ok(t)
    }

    /// T(d) for a unit direction d (f64).
    pub fn eval_f64(&self, d: [f64; 3]) -> [f64; 3] {
        let n = self.coefficients.len();
        let mut y = [0.0f64; MAX_COEFFICIENTS];
        self.basis.eval_into(d, &mut y[..n]);
        let mut s = [0.0f64; 3];
        for (yk, c) in y[..n].iter().zip(&self.coefficients) {
            for i in 0..3 {
                s[i] += yk * c[i];
            }
        }
        s
    }

    /// T(n) at a world-space normal (need not be normalised), clamped at 0 against rounding.
    #[inline]
    pub fn eval(&self, n: Vec3) -> Rgb {
        let (x, y, z) = (n.x as f64, n.y as f64, n.z as f64);
        let len = (x * x + y * y + z * z).sqrt();
        if len.is_nan() || len <= 0.0 {
            return Rgb::ZERO;
        }
        let v = self.eval_f64([x / len, y / len, z / len]);
        Rgb::new(v[0].max(0.0) as f32, v[1].max(0.0) as f32, v[2].max(0.0) as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_and_linear_textures_evaluate_exactly() {
        let y00 = 0.282_094_8_f32;
        let t = ShTexture::new(&[[0.5 / y00, 1.0 / y00, 0.25 / y00]]).unwrap();
        let v = t.eval(Vec3::new(0.3, -0.2, 0.9));
        assert!((v.x - 0.5).abs() < 1e-6 && (v.y - 1.0).abs() < 1e-6 && (v.z - 0.25).abs() < 1e-6, "{v:?}");
        // 1 + 0.5 z: Y_10 = 0.488603 z.
        let c = [[1.0 / y00; 3], [0.0; 3], [0.5 / 0.488_602_5; 3], [0.0; 3]];
        let t = ShTexture::new(&c).unwrap();
        let v = t.eval(Vec3::new(0.0, 0.6, 0.8));
        assert!((v.y - 1.4).abs() < 1e-5, "{v:?}");
    }

    #[test]
    fn bad_textures_are_refused() {
        assert!(ShTexture::new(&[[1.0; 3]; 3]).is_err(), "not a square count");
        assert!(ShTexture::new(&[[f32::NAN; 3]]).is_err());
        assert!(ShTexture::new(&vec![[0.0; 3]; 18 * 18]).is_err(), "lmax 17 > 16");
        // 0.5 + z is negative near the south pole.
        let y00 = 0.282_094_8_f32;
        let e = ShTexture::new(&[[0.5 / y00; 3], [0.0; 3], [1.0 / 0.488_602_5; 3], [0.0; 3]]).unwrap_err();
        assert!(e.to_string().contains("negative"), "{e}");
    }
}
