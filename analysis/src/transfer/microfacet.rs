//! The microfacet BRDF of the renderer (docs/src/conventions.md §4: `microfacet`, distribution
//! `beckmann` or `ggx`, Smith's height-correlated masking–shadowing, Fresnel `none` or `schlick`)
//! and its transfer coefficients.
//!
//! ρ̂(ω_i; ω_o) = BRDF · cos θ_i = D(h) G(ω_o, ω_i) F(ω_i·h) / (4 cos θ_o), with
//! - D(h): Beckmann exp(−tan²θ_h/α²) / (π α² cos⁴θ_h), or GGX 1 / (π α² cos⁴θ_h (1 + tan²θ_h/α²)²);
//! - G = 1 / (1 + Λ(ω_o) + Λ(ω_i)), Λ Beckmann's (e^{−a²}/(a√π) − erfc(a))/2 with a = cot θ/α, or
//!   GGX's (√(1 + α² tan²θ) − 1)/2;
//! - F = 1 or Schlick's f0 + (1 − f0)(1 − ω_i·h)⁵ with a grey f0;
//! - ρ̂ = 0 for ω_i below the horizon (the model is physical).
//!
//! Transfer coefficients (reparameterized by the reflection vector R, as Torrance–Sparrow's):
//! the q = 0 coefficient Λ_l ρ̂_l0(θ_o) = ∫_{S²} ρ̂(ω_i; ω_o) P_l(R·ω_i) dω_i, by 2D quadrature in
//! polar coordinates (t, φ) about R: composite Gauss–Legendre in t on panels whose edges grow
//! geometrically from α/2 (so a narrow lobe and GGX's long tail are both resolved), trapezoid in φ.
//! At θ_o = 0 the integrand does not depend on φ (eq. 13–15's radially symmetric case).
//! [`beckmann_normal_exitance`] is the θ_o = 0, Beckmann, F = 1 case by 1D quadrature.

use crate::quadrature::{integrate, legendre_all};
use crate::special::erfc;
use std::f64::consts::PI;
pub use vocab::Distribution;

/// The Fresnel term of a microfacet lobe that has a transfer model (docs/src/conventions.md §4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MicrofacetFresnel {
    /// F = 1.
    None,
    /// Schlick's approximation, one (grey) normal-incidence reflectance f0 ∈ [0, 1].
    Schlick { f0: f64 },
}

/// A microfacet lobe: distribution D, roughness α (> 0) and Fresnel term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetLobe {
    pub distribution: Distribution,
    pub alpha: f64,
    pub fresnel: MicrofacetFresnel,
}

/// Beckmann's Smith Λ at polar angle θ (radians) for roughness α:
/// (e^{−a²}/(a√π) − erfc(a)) / 2 with a = cot θ / α; 0 at θ = 0.
pub fn beckmann_lambda(theta: f64, alpha: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    if s <= 0.0 {
        return 0.0;
    }
    beckmann_lambda_a(c / (alpha * s))
}

/// Beckmann's Λ as a function of a = cot θ / α (a > 0); below 1e-17 (returned as 0) for a ≥ 6,
/// where the two terms cancel to rounding.
fn beckmann_lambda_a(a: f64) -> f64 {
    if a >= 6.0 {
        return 0.0;
    }
    (0.5 * ((-a * a).exp() / (a * PI.sqrt()) - erfc(a))).max(0.0)
}

impl MicrofacetLobe {
    /// D(θ_h) from cos θ_h > 0 and tan²θ_h (per steradian of h, ∫ D cos θ_h dω_h = 1).
    pub fn d(&self, cos_h: f64, tan2_h: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        let c4 = cos_h.powi(4);
        match self.distribution {
            Distribution::Beckmann => (-tan2_h / a2).exp() / (PI * a2 * c4),
            Distribution::Ggx => 1.0 / (PI * a2 * c4 * (1.0 + tan2_h / a2).powi(2)),
        }
    }

    /// Smith's Λ for a direction at cos θ > 0, sin θ ≥ 0.
    pub fn lambda(&self, cos: f64, sin: f64) -> f64 {
        if sin <= 0.0 {
            return 0.0;
        }
        match self.distribution {
            Distribution::Beckmann => beckmann_lambda_a(cos / (self.alpha * sin)),
            Distribution::Ggx => 0.5 * ((1.0 + (self.alpha * sin / cos).powi(2)).sqrt() - 1.0),
        }
    }

    /// F at the cosine between ω_i and h.
    pub fn fresnel(&self, cos_d: f64) -> f64 {
        match self.fresnel {
            MicrofacetFresnel::None => 1.0,
            MicrofacetFresnel::Schlick { f0 } => f0 + (1.0 - f0) * (1.0 - cos_d).clamp(0.0, 1.0).powi(5),
        }
    }

    /// ρ̂ = D G F / (4 cos θ_o) for unit directions in the frame of the normal n = z
    /// (0 where either is at or below the horizon). The renderer's `eval` times cos θ_i.
    pub fn rho_hat(&self, wo: [f64; 3], wi: [f64; 3]) -> f64 {
        if wo[2] <= 0.0 || wi[2] <= 0.0 {
            return 0.0;
        }
        let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
        self.rho_hat_h(wo, wi, h)
    }

    /// [`MicrofacetLobe::rho_hat`] with the unnormalised half vector h = ω_i + ω_o given (computed
    /// by the caller without cancellation).
    fn rho_hat_h(&self, wo: [f64; 3], wi: [f64; 3], h: [f64; 3]) -> f64 {
        let h_perp = h[0].hypot(h[1]);
        let h_len = h_perp.hypot(h[2]);
        if h[2] <= 0.0 || h_len <= 1e-300 {
            return 0.0;
        }
        let cos_h = h[2] / h_len;
        let tan2_h = (h_perp / h[2]).powi(2);
        let lo = self.lambda(wo[2], wo[0].hypot(wo[1]));
        let li = self.lambda(wi[2], wi[0].hypot(wi[1]));
        // ω_i·h = |ω_i + ω_o| / 2 for unit ω_i, ω_o.
        let f = self.fresnel(0.5 * h_len);
        self.d(cos_h, tan2_h) * f / ((1.0 + lo + li) * 4.0 * wo[2])
    }
}

/// Λ_l ρ̂_l0(θ_o), l = 0 … lmax, of `lobe` seen at exitance θ_o ∈ [0, π/2) (radians): the q = 0
/// coefficient of the reparameterized lobe (module docs), unit k_s (the Fresnel term included).
pub fn exitance(lobe: &MicrofacetLobe, theta_o: f64, lmax: usize) -> Vec<f64> {
    let (so, co) = theta_o.sin_cos();
    let wo = [so, 0.0, co];
    // Panels with geometric edges α/2, α, 2α, … up to π (ρ̂ = 0 beyond the horizon, which is at
    // most π/2 + θ_o from R).
    let mut edges = vec![0.0];
    let mut e = 0.5 * lobe.alpha;
    while e < PI {
        edges.push(e);
        e *= 2.0;
    }
    edges.push(PI);
    let nphi = if theta_o == 0.0 { 1 } else { 256 };
    let mut p = vec![0.0; lmax + 1];
    let mut out = vec![0.0; lmax + 1];
    for w in edges.windows(2) {
        let (a, b) = (w[0], w[1]);
        let panels = 2 + 2 * ((b - a) * (lmax as f64 + 1.0) / PI).ceil() as usize;
        integrate(a, b, panels, 16, |t, wt| {
            let (st, ct) = t.sin_cos();
            let omc = 2.0 * (0.5 * t).sin().powi(2);
            let mut ring = 0.0;
            for j in 0..nphi {
                let phi = 2.0 * PI * (j as f64 + 0.5) / nphi as f64;
                let (sp, cp) = phi.sin_cos();
                // ω_i = cos t R + sin t (cos φ t1 + sin φ t2), R = (−sin θ_o, 0, cos θ_o),
                // t1 = (cos θ_o, 0, sin θ_o), t2 = (0, 1, 0); h = ω_i + ω_o without cancellation.
                let wi = [-ct * so + st * cp * co, st * sp, ct * co + st * cp * so];
                if wi[2] <= 0.0 {
                    continue;
                }
                let h = [omc * so + st * cp * co, st * sp, 2.0 * co - omc * co + st * cp * so];
                ring += lobe.rho_hat_h(wo, wi, h);
            }
            let f = ring * 2.0 * PI / nphi as f64 * st * wt;
            legendre_all(ct, &mut p);
            for l in 0..=lmax {
                out[l] += f * p[l];
            }
        });
    }
    out
}

/// ρ̂(θ_i) = BRDF · cos θ_i of the Beckmann microfacet BRDF (F = 1) at normal exitance: the half
/// vector is at θ_i/2, cos θ_o = 1 and Λ(ω_o) = 0, so ρ̂ = D(θ_i/2) / (4 (1 + Λ(θ_i))) with
/// D(θ_h) = exp(−tan²θ_h/α²) / (π α² cos⁴θ_h).
pub fn beckmann_normal_lobe(theta_i: f64, alpha: f64) -> f64 {
    let c = (0.5 * theta_i).cos();
    let d = (-(0.5 * theta_i).tan().powi(2) / (alpha * alpha)).exp() / (PI * alpha * alpha * c.powi(4));
    d / (4.0 * (1.0 + beckmann_lambda(theta_i, alpha)))
}

/// Λ_l ρ̂_l, l ≤ `lmax`, of the Beckmann sphere seen at normal exitance (k_s = 1, F = 1), by
/// [`super::radial::radial`] quadrature of [`beckmann_normal_lobe`] over θ_i ∈ [0, π/2].
pub fn beckmann_normal_exitance(alpha: f64, lmax: usize) -> Vec<f64> {
    super::radial::radial(|t| beckmann_normal_lobe(t, alpha), PI / 2.0, lmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_and_smith_limits() {
        // Λ_0 ρ̂_0 is the albedo at normal exitance: 1 for small α (D is normalised, G ≈ 1 where
        // D lives), below 1 for a rough surface (single-scattering energy lost to G).
        let (a, b) = (beckmann_normal_exitance(0.05, 2)[0], beckmann_normal_exitance(0.4, 2)[0]);
        assert!((a - 1.0).abs() < 1e-6, "{a}");
        assert!(b < 0.99 && b > 0.8, "{b}");
        // Smith Λ vanishes towards the normal and grows towards grazing.
        assert!(beckmann_lambda(0.1, 0.3) < 1e-12);
        assert!(beckmann_lambda(1.5, 0.3) > beckmann_lambda(1.2, 0.3));
        // A narrow lobe's filter tends to the mirror's (1 at every low order).
        let f = beckmann_normal_exitance(0.01, 4);
        assert!(f.iter().all(|v| (v - 1.0).abs() < 2e-3), "{f:?}");
    }

    /// Oracle: a brute-force midpoint sum over a fine (θ_i, φ_i) grid of the upper hemisphere in
    /// the normal's frame, ∫ ρ̂(ω_i; ω_o) P_l(R·ω_i) dω_i, written independently of the polar
    /// coordinates about R that [`exitance`] uses. Its error is O(h²) of the grid (≈ 1e-4 here
    /// for α ≥ 0.2), so the tolerance is 2e-3 absolute.
    fn brute_force(lobe: &MicrofacetLobe, theta_o: f64, lmax: usize) -> Vec<f64> {
        let (nt, np) = (1200, 1200);
        let wo = [theta_o.sin(), 0.0, theta_o.cos()];
        let r = [-wo[0], 0.0, wo[2]];
        let mut out = vec![0.0; lmax + 1];
        let mut p = vec![0.0; lmax + 1];
        for i in 0..nt {
            let th = (i as f64 + 0.5) * (PI / 2.0) / nt as f64;
            for j in 0..np {
                let ph = (j as f64 + 0.5) * 2.0 * PI / np as f64;
                let wi = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
                let v = lobe.rho_hat(wo, wi);
                let dw = th.sin() * (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64);
                legendre_all(r[0] * wi[0] + r[2] * wi[2], &mut p);
                for l in 0..=lmax {
                    out[l] += v * p[l] * dw;
                }
            }
        }
        out
    }

    #[test]
    fn exitance_matches_a_brute_force_hemisphere_sum() {
        for (distribution, alpha, fresnel, theta_o) in [
            (Distribution::Beckmann, 0.3, MicrofacetFresnel::None, 0.0),
            (Distribution::Ggx, 0.3, MicrofacetFresnel::None, 0.0),
            (Distribution::Beckmann, 0.25, MicrofacetFresnel::Schlick { f0: 0.04 }, 40f64.to_radians()),
            (Distribution::Ggx, 0.4, MicrofacetFresnel::Schlick { f0: 0.5 }, 60f64.to_radians()),
        ] {
            let lobe = MicrofacetLobe { distribution, alpha, fresnel };
            let q = exitance(&lobe, theta_o, 8);
            let b = brute_force(&lobe, theta_o, 8);
            for l in 0..=8 {
                assert!((q[l] - b[l]).abs() < 2e-3, "{lobe:?} θ_o {theta_o} l={l}: {} vs {}", q[l], b[l]);
            }
        }
    }

    #[test]
    fn normal_exitance_agrees_with_the_1d_lobe_and_narrow_lobes_are_mirrors() {
        let lobe =
            MicrofacetLobe { distribution: Distribution::Beckmann, alpha: 0.2, fresnel: MicrofacetFresnel::None };
        let q = exitance(&lobe, 0.0, 20);
        let r = beckmann_normal_exitance(0.2, 20);
        for l in 0..=20 {
            assert!((q[l] - r[l]).abs() < 1e-9, "l={l}: {} vs {}", q[l], r[l]);
        }
        // Narrow lobes are resolved (the mirror limit), for both distributions.
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            let lobe = MicrofacetLobe { distribution, alpha: 1e-3, fresnel: MicrofacetFresnel::None };
            let f = exitance(&lobe, 0.3, 6);
            assert!(f.iter().all(|v| (v - 1.0).abs() < 2e-3), "{distribution:?}: {f:?}");
        }
    }
}
