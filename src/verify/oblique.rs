//! Predictions for Torrance–Sparrow at non-normal exitance (eq. 58–59), by direct numerical
//! integration of eq. 48 — no small-angle approximation:
//!
//! - [`predict_probe`]: the full image B(n) = ∫ L(ω_i) ρ̂(ω_i; n, ω_o) dω_i of a `normal-probe`
//!   render at θ_o (ω_o = cosθ_o n + sinθ_o t), integrated over the half vector h
//!   (dω_i = 4 (ω_o·h) dω_h; θ_h ≤ 5σ, where the lobe has fallen to e^{−25}), with the horizon
//!   clamped (ω_i·n > 0). The lighting is looked up in a fine lat-long table with bilinear
//!   interpolation ([`LightTable`]).
//! - [`q0_term`]: the q = 0 coefficient about R of the lobe, Λ_l ρ̂_l0(θ_o) = ∫ ρ̂ P_l(R·ω_i) dω_i.
//! - [`eq59`]: the paper's first-order formula eq. 59,
//!   Λ_l ρ̂_l = (1/cosθ_o) ∫_0^∞ 2u e^{−u²} P_l(cos 2σu) (1 − u² tan²θ_o / 2) du.

use super::fit::{dot, normalize};
use super::transfer::{gauss_legendre, integrate, legendre_all};
use analysis::sh::{ShBasis, num_coefficients};
use rayon::prelude::*;
use std::f64::consts::PI;

/// A lat-long table of a scalar SH lighting (W = 2H), bilinear lookup.
pub struct LightTable {
    w: usize,
    h: usize,
    v: Vec<f64>,
}

impl LightTable {
    pub fn new(light: &[f64], lmax: usize, h: usize) -> LightTable {
        let w = 2 * h;
        let basis = ShBasis::new(lmax);
        let n = num_coefficients(lmax).min(light.len());
        let v = (0..w * h)
            .into_par_iter()
            .map_init(
                || vec![0.0; num_coefficients(lmax)],
                |y, i| {
                    let (r, c) = (i / w, i % w);
                    // Nodes at θ = π r/(h−1) (poles included) and φ = 2π c/w, so lookups never extrapolate.
                    let t = PI * r as f64 / (h - 1) as f64;
                    let p = 2.0 * PI * c as f64 / w as f64;
                    basis.eval_into([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()], y);
                    (0..n).map(|k| light[k] * y[k]).sum()
                },
            )
            .collect();
        LightTable { w, h, v }
    }

    #[inline]
    pub fn lookup(&self, d: [f64; 3]) -> f64 {
        let t = d[2].clamp(-1.0, 1.0).acos() / PI * (self.h - 1) as f64;
        let mut p = d[1].atan2(d[0]) / (2.0 * PI);
        if p < 0.0 {
            p += 1.0;
        }
        let p = p * self.w as f64;
        let (r0, c0) = ((t.floor() as usize).min(self.h - 2), (p.floor() as usize) % self.w);
        let (ft, fp) = (t - r0 as f64, p - p.floor());
        let c1 = (c0 + 1) % self.w;
        let a = self.v[r0 * self.w + c0] * (1.0 - fp) + self.v[r0 * self.w + c1] * fp;
        let b = self.v[(r0 + 1) * self.w + c0] * (1.0 - fp) + self.v[(r0 + 1) * self.w + c1] * fp;
        a * (1.0 - ft) + b * ft
    }
}

/// Quadrature resolution: Gauss–Legendre points in θ_h and midpoint points in φ_h.
#[derive(Clone, Copy, Debug)]
pub struct Resolution {
    pub n_theta: usize,
    pub n_phi: usize,
}

/// The nodes of [`integrate_lobe`] for one σ and resolution, which do not depend on the pixel:
/// per θ_h node (sin θ_h, cos θ_h, ½ θ_max w_i sin θ_h e^{−θ_h²/σ²}) and per φ_h node (sin φ_h,
/// cos φ_h). Computed once per image instead of once per pixel (the Gauss–Legendre nodes and the
/// φ sines were most of the prediction's time); the sums are the same numbers in the same order.
pub struct LobeNodes {
    sigma: f64,
    n_phi: usize,
    theta: Vec<(f64, f64, f64)>,
    phi: Vec<(f64, f64)>,
}

impl LobeNodes {
    pub fn new(sigma: f64, res: Resolution) -> LobeNodes {
        let tmax = (5.0 * sigma).min(0.5 * PI);
        let (x, w) = gauss_legendre(res.n_theta);
        let theta = (0..res.n_theta)
            .map(|i| {
                let th = 0.5 * tmax * (x[i] + 1.0);
                let (st, ct) = th.sin_cos();
                (st, ct, 0.5 * tmax * w[i] * st * (-(th * th) / (sigma * sigma)).exp())
            })
            .collect();
        let phi = (0..res.n_phi).map(|j| (2.0 * PI * (j as f64 + 0.5) / res.n_phi as f64).sin_cos()).collect();
        LobeNodes { sigma, n_phi: res.n_phi, theta, phi }
    }
}

/// ∫ f(ω_i) ρ̂(ω_i; n, ω_o) dω_i for the clamped Torrance–Sparrow lobe (unit k_s).
pub fn integrate_lobe(sigma: f64, n: [f64; 3], wo: [f64; 3], res: Resolution, f: impl FnMut([f64; 3]) -> f64) -> f64 {
    integrate_lobe_with(&LobeNodes::new(sigma, res), n, wo, f)
}

/// [`integrate_lobe`] with its nodes computed beforehand.
pub fn integrate_lobe_with(nodes: &LobeNodes, n: [f64; 3], wo: [f64; 3], mut f: impl FnMut([f64; 3]) -> f64) -> f64 {
    // A frame (t1, t2, n).
    let a = if n[2].abs() < 0.9 { [0.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0] };
    let t1 = normalize([a[1] * n[2] - a[2] * n[1], a[2] * n[0] - a[0] * n[2], a[0] * n[1] - a[1] * n[0]]);
    let t2 = [n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0]];
    let cos_o = dot(n, wo);
    let sigma = nodes.sigma;
    let norm = 1.0 / (4.0 * PI * sigma * sigma * cos_o);
    let mut sum = 0.0;
    for &(st, ct, w_theta) in &nodes.theta {
        let wt = w_theta * norm * (2.0 * PI / nodes.n_phi as f64);
        for &(sp, cp) in &nodes.phi {
            let h = [0, 1, 2].map(|k| st * cp * t1[k] + st * sp * t2[k] + ct * n[k]);
            let oh = dot(wo, h);
            if oh <= 0.0 {
                continue;
            }
            let wi = [0, 1, 2].map(|k| 2.0 * oh * h[k] - wo[k]);
            if dot(wi, n) <= 0.0 {
                continue;
            }
            sum += wt * 4.0 * oh * f(wi);
        }
    }
    sum
}

/// (n, ω_o, R) of normal-probe pixel (r, c) at exitance θ_o (docs/src/conventions.md §6).
pub fn probe_geometry(r: usize, c: usize, w: usize, h: usize, theta_o: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let t = PI * (r as f64 + 0.5) / h as f64;
    let p = 2.0 * PI * (c as f64 + 0.5) / w as f64;
    let n = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
    let tan = [t.cos() * p.cos(), t.cos() * p.sin(), -t.sin()];
    let (so, co) = theta_o.sin_cos();
    let wo = normalize([0, 1, 2].map(|k| co * n[k] + so * tan[k]));
    let no = dot(n, wo);
    let r_ = [0, 1, 2].map(|k| 2.0 * no * n[k] - wo[k]);
    (n, wo, r_)
}

/// The predicted normal-probe image at θ_o under a lighting table.
pub fn predict_probe(sigma: f64, theta_o: f64, w: usize, h: usize, table: &LightTable, res: Resolution) -> Vec<f64> {
    let nodes = LobeNodes::new(sigma, res);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (n, wo, _) = probe_geometry(i / w, i % w, w, h, theta_o);
            integrate_lobe_with(&nodes, n, wo, |wi| table.lookup(wi))
        })
        .collect()
}

/// Λ_l ρ̂_l0(θ_o), l ≤ lmax: the q = 0 coefficient of the lobe about R.
pub fn q0_term(sigma: f64, theta_o: f64, lmax: usize) -> Vec<f64> {
    let n = [0.0, 0.0, 1.0];
    let wo = [theta_o.sin(), 0.0, theta_o.cos()];
    let r = [-wo[0], 0.0, wo[2]];
    let res = Resolution { n_theta: 96, n_phi: 1024 };
    let nodes = LobeNodes::new(sigma, res);
    (0..=lmax)
        .into_par_iter()
        .map_init(
            || vec![0.0; lmax + 1],
            |p, l| {
                integrate_lobe_with(&nodes, n, wo, |wi| {
                    legendre_all(dot(r, wi).clamp(-1.0, 1.0), p);
                    p[l]
                })
            },
        )
        .collect()
}

/// eq. 59 (the paper's first-order correction for θ_o ≠ 0).
pub fn eq59(sigma: f64, theta_o: f64, lmax: usize) -> Vec<f64> {
    let t2 = theta_o.tan().powi(2);
    let mut p = vec![0.0; lmax + 1];
    (0..=lmax)
        .map(|l| {
            integrate(0.0, 6.0, 64, |u| {
                legendre_all((2.0 * sigma * u).cos(), &mut p);
                2.0 * u * (-u * u).exp() * p[l] * (1.0 - u * u * t2 / 2.0)
            }) / theta_o.cos()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verify::transfer;

    #[test]
    fn at_normal_exitance_q0_is_eq50_and_eq59_is_eq55_like() {
        let a = q0_term(0.1, 0.0, 8);
        let b = transfer::torrance_sparrow(0.1, 8);
        for l in 0..=8 {
            assert!((a[l] - b[l]).abs() < 2e-4, "l={l}: {} vs {}", a[l], b[l]);
        }
        let e = eq59(0.1, 0.0, 8);
        let g = transfer::torrance_sparrow_gaussian(0.1, 8);
        for l in 0..=8 {
            // eq. 59 at θ_o = 0 is eq. 53 (sinθ ≈ θ, upper limit ∞), which keeps Y_l0's l(l+1)
            // where eq. 55/57 have l²: departure ≤ (σl)⁴/2 + (l+1)σ² (as in transfer's test).
            let sl = 0.1 * l as f64;
            assert!((e[l] - g[l]).abs() < 0.5 * sl.powi(4) + (l + 1) as f64 * 0.01, "l={l}: {} vs {}", e[l], g[l]);
        }
        // l = 0 at θ_o ≠ 0 is the albedo.
        let q = q0_term(0.2, 60f64.to_radians(), 0)[0];
        let alb = transfer::ts_albedo(0.2, 60f64.to_radians(), true);
        assert!((q - alb).abs() < 1e-3, "{q} vs {alb}");
    }

    #[test]
    fn table_lookup_matches_the_series() {
        let light = crate::verify::scenes::sh_lighting(8, 0.5, 3);
        let t = LightTable::new(&light, 8, 256);
        let basis = ShBasis::new(8);
        for d in [[0.3, -0.5, 0.81], [0.0, 0.0, 1.0], [-0.7, 0.1, -0.2]] {
            let d = normalize(d);
            let y = basis.eval(d);
            let exact: f64 = (0..81).map(|k| light[k] * y[k]).sum();
            assert!((t.lookup(d) - exact).abs() < 2e-3 * light[0], "{d:?}");
        }
    }
}

/// Cross-checks against the `analysis` crate, an independent implementation (it integrates about
/// R; [`integrate_lobe`] about the half vector), so an error in either shows up here.
#[cfg(test)]
mod cross_checks {
    use super::*;
    use crate::verify::transfer;
    use analysis::transfer::{Horizon, lambert, phong, torrance_sparrow as ts};

    #[test]
    fn closed_forms_and_quadratures_agree_with_the_analysis_crate() {
        let (a, b) = (transfer::lambert(12), lambert::lambert(12));
        for l in 0..=12 {
            assert!((a[l] - b[l]).abs() < 1e-12, "lambert l={l}");
        }
        for s in [1.0, 8.0, 32.0, 128.0] {
            let (a, b) = (transfer::phong(s, 12), phong::phong(s, 12));
            for l in 0..=12 {
                assert!((a[l] - b[l]).abs() < 1e-10, "phong s={s} l={l}");
            }
        }
        for sigma in [0.05, 0.1, 0.2] {
            let (a, b) = (transfer::torrance_sparrow(sigma, 12), ts::normal_exitance(sigma, 12));
            for l in 0..=12 {
                assert!((a[l] - b[l]).abs() < 1e-6, "ts σ={sigma} l={l}: {} vs {}", a[l], b[l]);
            }
            for t in [30f64, 60.0] {
                let th = t.to_radians();
                let (a, b) = (q0_term(sigma, th, 8), ts::exitance(sigma, th, 8, Horizon::Clamp));
                // Both are 2-D quadratures with a horizon cut (midpoint rule in φ): agree to 1e-3.
                for l in 0..=8 {
                    assert!((a[l] - b[l]).abs() < 1e-3, "q0 σ={sigma} θo={t} l={l}: {} vs {}", a[l], b[l]);
                }
                let (a, b) = (eq59(sigma, th, 8), ts::eq59(sigma, th, 8));
                for l in 0..=8 {
                    assert!((a[l] - b[l]).abs() < 1e-6, "eq59 σ={sigma} θo={t} l={l}: {} vs {}", a[l], b[l]);
                }
            }
        }
    }
}
