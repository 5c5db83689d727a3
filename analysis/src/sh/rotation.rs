//! Rotation of SH coefficient vectors.
//!
//! For a rotation R and a function f with coefficients c, the rotated function f_R(ω) = f(Rᵀω)
//! (f carried along by R: f_R(Rω) = f(ω)) has coefficients c' with the same orders l mixed only
//! within each l (eq. 3). We compute c' = ∫ f(Rᵀω) Y(ω) dω by a quadrature that is *exact* for
//! band-limited integrands: Gauss–Legendre in cos θ with l_max + 1 nodes × 2 l_max + 1 uniform φ
//! (exact for degree 2 l_max, the degree of f_R · Y_lm). So the rotated coefficients equal the
//! projection of the rotated function to rounding error, at O(l_max⁴) cost, for any l_max.
//!
//! [`Rotation`] is a 3 × 3 orthonormal matrix; [`Rotation::from_xyz_deg`] builds the scene-file
//! rotation `rotate_deg` of docs/src/conventions.md §2, "Rotations" (about x, then y, then z: R = R_z R_y R_x).

use super::basis::{ShBasis, num_coefficients};
use super::reconstruct::{Reconstructor, lmax_of};
use crate::quadrature::gauss_legendre;

/// A rotation of world directions, row-major 3 × 3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotation(pub [[f64; 3]; 3]);

impl Rotation {
    pub const IDENTITY: Rotation = Rotation([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);

    /// Rotation by `angle` radians about the unit `axis` (right-handed).
    pub fn axis_angle(axis: [f64; 3], angle: f64) -> Rotation {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let [x, y, z] = [axis[0] / n, axis[1] / n, axis[2] / n];
        let (s, c) = angle.sin_cos();
        let t = 1.0 - c;
        Rotation([
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ])
    }

    /// The scene file's `rotate_deg = [ax, ay, az]`: about x, then y, then z (R = R_z R_y R_x).
    pub fn from_xyz_deg(deg: [f64; 3]) -> Rotation {
        let rx = Rotation::axis_angle([1.0, 0.0, 0.0], deg[0].to_radians());
        let ry = Rotation::axis_angle([0.0, 1.0, 0.0], deg[1].to_radians());
        let rz = Rotation::axis_angle([0.0, 0.0, 1.0], deg[2].to_radians());
        rz.mul(&ry).mul(&rx)
    }

    pub fn mul(&self, o: &Rotation) -> Rotation {
        let mut m = [[0.0; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.0[i][k] * o.0[k][j]).sum();
            }
        }
        Rotation(m)
    }

    pub fn transpose(&self) -> Rotation {
        let a = self.0;
        Rotation([[a[0][0], a[1][0], a[2][0]], [a[0][1], a[1][1], a[2][1]], [a[0][2], a[1][2], a[2][2]]])
    }

    #[inline]
    pub fn apply(&self, v: [f64; 3]) -> [f64; 3] {
        let a = self.0;
        [
            a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
            a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
            a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
        ]
    }
}

/// Coefficients of f_R(ω) = f(Rᵀ ω), the function f rotated by `r`, for RGB coefficients of any
/// l_max (the length must be a square).
pub fn rotate_coefficients(coeffs: &[[f64; 3]], r: &Rotation) -> Vec<[f64; 3]> {
    let lmax = lmax_of(coeffs.len()).expect("coefficient vector length must be (lmax+1)^2");
    let n = num_coefficients(lmax);
    let (xs, ws) = gauss_legendre(lmax + 1);
    let nphi = 2 * lmax + 1;
    let rt = r.transpose();
    let basis = ShBasis::new(lmax);
    let mut rec = Reconstructor::new(lmax);
    let mut y = vec![0.0; n];
    let mut out = vec![[0.0; 3]; n];
    for (z, wz) in xs.iter().zip(&ws) {
        let st = (1.0 - z * z).max(0.0).sqrt();
        let w = wz * 2.0 * std::f64::consts::PI / nphi as f64;
        for j in 0..nphi {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / nphi as f64;
            let d = [st * phi.cos(), st * phi.sin(), *z];
            let f = rec.eval(coeffs, rt.apply(d));
            basis.eval_into(d, &mut y);
            for k in 0..n {
                let wy = w * y[k];
                for ch in 0..3 {
                    out[k][ch] += wy * f[ch];
                }
            }
        }
    }
    out
}

/// The real rotation matrices D^l (eq. 3 in the real basis), l = 0 … lmax, each (2l+1)² row-major
/// with rows m and columns m' in −l … l: c'_lm = Σ_m' D^l_mm' c_lm' for f_R(ω) = f(Rᵀω), i.e.
/// D^l_mm' = ∫ Y_lm(ω) Y_lm'(Rᵀω) dω, by the same exact quadrature as [`rotate_coefficients`].
pub fn rotation_matrices(lmax: usize, r: &Rotation) -> Vec<Vec<f64>> {
    let n = num_coefficients(lmax);
    let (xs, ws) = gauss_legendre(lmax + 1);
    let nphi = 2 * lmax + 1;
    let rt = r.transpose();
    let basis = ShBasis::new(lmax);
    let (mut y, mut yr) = (vec![0.0; n], vec![0.0; n]);
    let mut d: Vec<Vec<f64>> = (0..=lmax).map(|l| vec![0.0; (2 * l + 1) * (2 * l + 1)]).collect();
    for (z, wz) in xs.iter().zip(&ws) {
        let st = (1.0 - z * z).max(0.0).sqrt();
        let w = wz * 2.0 * std::f64::consts::PI / nphi as f64;
        for j in 0..nphi {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / nphi as f64;
            let dir = [st * phi.cos(), st * phi.sin(), *z];
            basis.eval_into(dir, &mut y);
            basis.eval_into(rt.apply(dir), &mut yr);
            for (l, dl) in d.iter_mut().enumerate() {
                let (k0, s) = (l * l, 2 * l + 1);
                for a in 0..s {
                    let wa = w * y[k0 + a];
                    for b in 0..s {
                        dl[a * s + b] += wa * yr[k0 + b];
                    }
                }
            }
        }
    }
    d
}
