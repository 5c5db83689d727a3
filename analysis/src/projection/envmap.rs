//! Projection of environment maps into SH: L_lm = Σ_pixels L(ω_p) Y_lm(ω_p) ΔΩ_p with the exact
//! per-pixel solid angles of CONVENTIONS §2, RGB.
//!
//! - Lat-long (W × H): every row has one θ, so the sum separates: a φ-Fourier sum per row and order m,
//!   then the associated Legendre functions once per row. O(W H l_max) instead of O(W H l_max²), which
//!   makes a 2048 × 1024 map at l_max = 20 a fraction of a second. An optional per-pixel variance
//!   image propagates to per-coefficient variances Σ ΔΩ² Y² σ² (used for `normal-probe` renders).
//! - Angular map (W × W, Debevec probe): pixels with ρ > 1 skipped; the four pixels mirrored about
//!   the image axes share θ, so one evaluation of all Y_lm serves four pixels (even W).
//!
//! Rows are processed in parallel and reduced in a fixed order (results do not depend on threads).

use crate::error::{Error, Result};
use crate::image::RgbImage;
use crate::sh::{RgbCoeffs, ShBasis, index, num_coefficients};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Environment-map parameterization (CONVENTIONS §2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mapping {
    LatLong,
    Angular,
}

impl Mapping {
    pub fn parse(s: &str) -> Result<Mapping> {
        match s {
            "latlong" => Ok(Mapping::LatLong),
            "angular" => Ok(Mapping::Angular),
            _ => Err(Error::new(format!("unknown mapping '{s}' (expected latlong or angular)"))),
        }
    }

    /// Infers the mapping from the aspect ratio: W = H → angular, W = 2H → lat-long.
    pub fn infer(width: usize, height: usize) -> Result<Mapping> {
        if width == height {
            Ok(Mapping::Angular)
        } else if width == 2 * height {
            Ok(Mapping::LatLong)
        } else {
            Err(Error::new(format!(
                "cannot infer the mapping of a {width}×{height} map (W = H is angular, W = 2H lat-long): pass --mapping"
            )))
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Mapping::LatLong => "latlong",
            Mapping::Angular => "angular",
        }
    }
}

/// Direction of the angular-map pixel (row, col) and its solid angle, or `None` outside the disc.
#[inline]
pub fn angular_pixel(row: usize, col: usize, w: usize) -> Option<([f64; 3], f64)> {
    let half = w as f64 / 2.0;
    let u = (col as f64 + 0.5 - half) / half;
    let v = (half - row as f64 - 0.5) / half;
    let rho = (u * u + v * v).sqrt();
    if rho > 1.0 {
        return None;
    }
    let theta = PI * rho;
    let (cp, sp) = if rho > 0.0 { (u / rho, v / rho) } else { (1.0, 0.0) };
    let st = theta.sin();
    let sinc = if theta > 0.0 { st / theta } else { 1.0 };
    let d_omega = (2.0 * PI / w as f64).powi(2) * sinc;
    Some(([st * cp, st * sp, theta.cos()], d_omega))
}

/// Projects an environment map (lat-long or angular) into RGB coefficients up to `lmax`.
pub fn project_envmap(img: &RgbImage, mapping: Mapping, lmax: usize) -> Result<Vec<[f64; 3]>> {
    match mapping {
        Mapping::LatLong => Ok(project_latlong(img, None, lmax).0),
        Mapping::Angular => {
            if img.width != img.height {
                return Err(Error::new(format!(
                    "an angular map must be square, this one is {}×{}",
                    img.width, img.height
                )));
            }
            Ok(project_angular(img, lmax))
        }
    }
}

fn project_angular(img: &RgbImage, lmax: usize) -> Vec<[f64; 3]> {
    let n = num_coefficients(lmax);
    let w = img.width;
    if w % 2 == 1 {
        return project_angular_generic(img, lmax);
    }
    let basis = ShBasis::new(lmax);
    let half = w / 2;
    // Symmetry: the pixels (r, c), (r, W−1−c), (W−1−r, c), (W−1−r, W−1−c) have the same θ and solid
    // angle and azimuths φ, π − φ, −φ, π + φ. With A, B, C, D their radiances,
    //   Σ L cos(mφ) = cos(mφ) [(A + C) + (−1)^m (B + D)],
    //   Σ L sin(mφ) = sin(mφ) [(A − C) + (−1)^m (D − B)],
    // so one evaluation of Y serves four pixels. One partial sum per quadrant row (fixed order).
    let parts: Vec<Vec<[f64; 3]>> = (0..half)
        .into_par_iter()
        .map(|r| {
            let mut y = vec![0.0; n];
            let mut ys = vec![0.0; n];
            let mut acc = vec![0.0; 3 * n];
            let r2 = w - 1 - r;
            for c in 0..half {
                let Some((d, dw)) = angular_pixel(r, c, w) else { continue };
                let c2 = w - 1 - c;
                let px = |rr: usize, cc: usize| {
                    let p = img.get(rr, cc);
                    [p[0] as f64 * dw, p[1] as f64 * dw, p[2] as f64 * dw]
                };
                let (a, b, cq, dq) = (px(r, c), px(r, c2), px(r2, c), px(r2, c2));
                if a == [0.0; 3] && b == [0.0; 3] && cq == [0.0; 3] && dq == [0.0; 3] {
                    continue;
                }
                let u_pos = [a[0] + cq[0], a[1] + cq[1], a[2] + cq[2]];
                let v_pos = [b[0] + dq[0], b[1] + dq[1], b[2] + dq[2]];
                let u_neg = [a[0] - cq[0], a[1] - cq[1], a[2] - cq[2]];
                let v_neg = [dq[0] - b[0], dq[1] - b[1], dq[2] - b[2]];
                basis.eval_into(d, &mut y);
                for l in 0..=lmax {
                    let k0 = l * l;
                    for (i, m) in (-(l as i64)..=(l as i64)).enumerate() {
                        let k = k0 + i;
                        ys[k] = if m % 2 == 0 { y[k] } else { -y[k] };
                    }
                    let mid = k0 + l; // m = 0
                    let end = (l + 1) * (l + 1);
                    for ch in 0..3 {
                        let accc = &mut acc[ch * n..(ch + 1) * n];
                        let (un, vn, up, vp) = (u_neg[ch], v_neg[ch], u_pos[ch], v_pos[ch]);
                        for k in k0..mid {
                            accc[k] += y[k] * un + ys[k] * vn;
                        }
                        for k in mid..end {
                            accc[k] += y[k] * up + ys[k] * vp;
                        }
                    }
                }
            }
            (0..n).map(|k| [acc[k], acc[n + k], acc[2 * n + k]]).collect()
        })
        .collect();
    sum_parts(parts, n)
}

/// Per-pixel angular projection (any W, used for odd widths).
fn project_angular_generic(img: &RgbImage, lmax: usize) -> Vec<[f64; 3]> {
    let n = num_coefficients(lmax);
    let w = img.width;
    let basis = ShBasis::new(lmax);
    let parts: Vec<Vec<[f64; 3]>> = (0..img.height)
        .into_par_iter()
        .map(|r| {
            let mut y = vec![0.0; n];
            let mut acc = vec![0.0; 3 * n];
            for c in 0..w {
                let Some((d, dw)) = angular_pixel(r, c, w) else { continue };
                let px = img.get(r, c);
                if px == [0.0; 3] {
                    continue;
                }
                basis.eval_into(d, &mut y);
                for ch in 0..3 {
                    let v = px[ch] as f64 * dw;
                    for (a, yk) in acc[ch * n..(ch + 1) * n].iter_mut().zip(&y) {
                        *a += v * yk;
                    }
                }
            }
            (0..n).map(|k| [acc[k], acc[n + k], acc[2 * n + k]]).collect()
        })
        .collect();
    sum_parts(parts, n)
}

/// Sums per-thread partial coefficient vectors (in a fixed order, so results are deterministic).
pub(crate) fn sum_parts(parts: Vec<Vec<[f64; 3]>>, n: usize) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; n];
    for p in parts {
        for k in 0..n {
            for ch in 0..3 {
                out[k][ch] += p[k][ch];
            }
        }
    }
    out
}

/// Lat-long projection by separable quadrature. With `variance` (per-pixel variance of the
/// radiance, same size), also returns the variance of each coefficient, Σ ΔΩ² Y_k² σ².
pub fn project_latlong(img: &RgbImage, variance: Option<&RgbImage>, lmax: usize) -> (RgbCoeffs, Option<RgbCoeffs>) {
    let n = num_coefficients(lmax);
    let (w, h) = (img.width, img.height);
    let nm = lmax + 1;
    // cos(mφ_c), sin(mφ_c) for every column, laid out [c][m] for a contiguous inner loop.
    let mut cos_t = vec![0.0f64; w * nm];
    let mut sin_t = vec![0.0f64; w * nm];
    for c in 0..w {
        let phi = 2.0 * PI * (c as f64 + 0.5) / w as f64;
        for m in 0..nm {
            let (s, co) = (m as f64 * phi).sin_cos();
            cos_t[c * nm + m] = co;
            sin_t[c * nm + m] = s;
        }
    }
    let basis = ShBasis::new(lmax);
    let with_var = variance.is_some();
    let parts: Vec<(RgbCoeffs, RgbCoeffs)> = (0..h)
        .into_par_iter()
        .map(|r| {
            let th_top = PI * r as f64 / h as f64;
            let th_bot = PI * (r + 1) as f64 / h as f64;
            let theta = PI * (r as f64 + 0.5) / h as f64;
            let d_omega = 2.0 * PI / w as f64 * (th_top.cos() - th_bot.cos());
            // Fourier sums of the row: C_m = Σ_c L_c cos(mφ_c), S_m = Σ_c L_c sin(mφ_c).
            let mut cs = vec![[0.0f64; 3]; nm];
            let mut ss = vec![[0.0f64; 3]; nm];
            let mut cv = vec![[0.0f64; 3]; if with_var { nm } else { 0 }];
            let mut sv = vec![[0.0f64; 3]; if with_var { nm } else { 0 }];
            let row = &img.pixels[r * w..(r + 1) * w];
            for (c, px) in row.iter().enumerate() {
                let v = [px[0] as f64, px[1] as f64, px[2] as f64];
                let ct = &cos_t[c * nm..(c + 1) * nm];
                let st = &sin_t[c * nm..(c + 1) * nm];
                for m in 0..nm {
                    for ch in 0..3 {
                        cs[m][ch] += v[ch] * ct[m];
                        ss[m][ch] += v[ch] * st[m];
                    }
                }
                if let Some(var) = variance {
                    let q = var.pixels[r * w + c];
                    for m in 0..nm {
                        for ch in 0..3 {
                            cv[m][ch] += q[ch] as f64 * ct[m] * ct[m];
                            sv[m][ch] += q[ch] as f64 * st[m] * st[m];
                        }
                    }
                }
            }
            // Y at φ = 0: Y_l,m>0 = √2 P̄_l^m(θ), Y_l,m<0 = 0; the φ dependence is in C_m, S_m.
            let y = basis.eval([theta.sin(), 0.0, theta.cos()]);
            let mut acc = vec![[0.0; 3]; n];
            let mut accv = vec![[0.0; 3]; if with_var { n } else { 0 }];
            for l in 0..=lmax {
                for m in 0..=l {
                    let p = y[index(l, m as i64)] * d_omega;
                    for ch in 0..3 {
                        acc[index(l, m as i64)][ch] += p * cs[m][ch];
                        if m > 0 {
                            acc[index(l, -(m as i64))][ch] += p * ss[m][ch];
                        }
                        if with_var {
                            accv[index(l, m as i64)][ch] += p * p * cv[m][ch];
                            if m > 0 {
                                accv[index(l, -(m as i64))][ch] += p * p * sv[m][ch];
                            }
                        }
                    }
                }
            }
            (acc, accv)
        })
        .collect();
    let mut out = vec![[0.0; 3]; n];
    let mut outv = vec![[0.0; 3]; n];
    for (a, v) in parts {
        for k in 0..n {
            for ch in 0..3 {
                out[k][ch] += a[k][ch];
                if with_var {
                    outv[k][ch] += v[k][ch];
                }
            }
        }
    }
    (out, with_var.then_some(outv))
}
