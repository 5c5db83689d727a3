//! **The oracle**: the one independent source of the transfer coefficients Λ_l ρ̂_l
//! (docs/src/conventions.md §4) in `verify` (issue 11), computed apart from the `analysis` crate so the verifier
//! does not check a formula against itself: closed forms (eq. 38, 43), the approximations (eq. 46,
//! 57) and numerical quadrature of eq. 41/50 for any radial lobe ([`super::oblique`] extends its
//! quadrature to non-normal exitance, eq. 48). Every predicted Λ_l ρ̂_l that a check compares a
//! render against comes from here; everything else in `verify` (projections, fits, covariances,
//! inversions, the transfer model an inversion assumes) calls the `analysis` functions that
//! `reflect analyze` and `reflect invert` run, and the unit test
//! `oblique::tests::closed_forms_and_quadratures_agree_with_the_analysis_crate` pins the library's
//! closed forms to this oracle.
//!
//! For a radially symmetric transfer function ρ̂(θ) about the reflection vector,
//! Λ_l ρ̂_l = Λ_l · 2π ∫ ρ̂(θ) Y_l0(θ) sinθ dθ = 2π ∫_{-1}^{1} ρ̂(u) P_l(u) du (since Λ_l Y_l0 = P_l).

use std::f64::consts::PI;

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n; accurate to ~1e-15 for n ≤ 200).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, z);
            dp = d;
            let dz = p / d;
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, z);
        dp = if d != 0.0 { d } else { dp };
        x[i] = -z;
        x[n - 1 - i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        w[n - 1 - i] = w[i];
    }
    (x, w)
}

fn legendre_and_derivative(n: usize, z: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, z);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, n as f64 * (z * p1 - p0) / (z * z - 1.0))
}

/// P_0(u) … P_lmax(u) into `out` (Bonnet's recurrence).
pub fn legendre_all(u: f64, out: &mut [f64]) {
    out[0] = 1.0;
    if out.len() > 1 {
        out[1] = u;
    }
    for l in 2..out.len() {
        out[l] = ((2 * l - 1) as f64 * u * out[l - 1] - (l - 1) as f64 * out[l - 2]) / l as f64;
    }
}

/// ∫_a^b f by composite Gauss–Legendre (`panels` × 24 points).
pub fn integrate(a: f64, b: f64, panels: usize, mut f: impl FnMut(f64) -> f64) -> f64 {
    let (x, w) = gauss_legendre(24);
    let h = (b - a) / panels as f64;
    let mut s = 0.0;
    for p in 0..panels {
        let c = a + (p as f64 + 0.5) * h;
        for i in 0..x.len() {
            s += w[i] * 0.5 * h * f(c + 0.5 * h * x[i]);
        }
    }
    s
}

/// Λ_l ρ̂_l for l ≤ lmax of a radial lobe ρ̂(θ) supported on θ ∈ [0, θ_max], by quadrature in θ
/// (`panels` × 24 points): Λ_l ρ̂_l = 2π ∫ ρ̂(θ) P_l(cosθ) sinθ dθ.
pub fn radial(rho_hat: impl Fn(f64) -> f64, theta_max: f64, lmax: usize, panels: usize) -> Vec<f64> {
    let mut out = vec![0.0; lmax + 1];
    let mut p = vec![0.0; lmax + 1];
    let (x, w) = gauss_legendre(24);
    let h = theta_max / panels as f64;
    for q in 0..panels {
        let c = (q as f64 + 0.5) * h;
        for i in 0..x.len() {
            let t = c + 0.5 * h * x[i];
            let f = 2.0 * PI * w[i] * 0.5 * h * rho_hat(t) * t.sin();
            legendre_all(t.cos(), &mut p);
            for l in 0..=lmax {
                out[l] += f * p[l];
            }
        }
    }
    out
}

/// Lambert, unit albedo (eq. 38 / π): 1, 2/3, 1/4, 0, −1/24, 0, 1/64, …
pub fn lambert(lmax: usize) -> Vec<f64> {
    (0..=lmax)
        .map(|l| match l {
            0 => 1.0,
            1 => 2.0 / 3.0,
            l if l % 2 == 1 => 0.0,
            l => {
                // A_l/π = 2 (−1)^{l/2−1} / ((l+2)(l−1)) · l! / (2^l ((l/2)!)²), the central binomial
                // coefficient C(l, l/2)/2^l built by a ratio recurrence (no factorials).
                let mut c = 1.0;
                for j in 1..=(l / 2) {
                    c *= (l / 2 + j) as f64 / (4.0 * j as f64);
                }
                let sign = if (l / 2 - 1) % 2 == 0 { 1.0 } else { -1.0 };
                2.0 * sign / (((l + 2) * (l - 1)) as f64) * c
            }
        })
        .collect()
}

/// Phong, exact eq. 43 (any real s > 0, unit k_s).
pub fn phong(s: f64, lmax: usize) -> Vec<f64> {
    (0..=lmax)
        .map(|l| {
            if l % 2 == 1 {
                let mut num = s + 1.0;
                for j in 1..=(l - 1) / 2 {
                    num *= s - (2 * j) as f64 + 1.0;
                }
                let mut den = 1.0;
                for j in 0..=(l - 1) / 2 {
                    den *= s + (l + 1 - 2 * j) as f64;
                }
                num / den
            } else {
                let mut v = 1.0;
                for j in 0..l / 2 {
                    v *= (s - (2 * j) as f64) / (s + (l + 1 - 2 * j) as f64);
                }
                v
            }
        })
        .collect()
}

/// Phong, the Gaussian approximation eq. 46: exp(−l²/2s).
pub fn phong_gaussian(s: f64, lmax: usize) -> Vec<f64> {
    (0..=lmax).map(|l| (-((l * l) as f64) / (2.0 * s)).exp()).collect()
}

/// Torrance–Sparrow at normal exitance, eq. 50 by quadrature (θ_i ∈ [0, π/2]; unit k_s).
pub fn torrance_sparrow(sigma: f64, lmax: usize) -> Vec<f64> {
    let rho = |t: f64| (-(t * t) / (4.0 * sigma * sigma)).exp() / (4.0 * PI * sigma * sigma);
    radial(rho, 0.5 * PI, lmax, 400)
}

/// Torrance–Sparrow, the approximation eq. 57: exp(−(σl)²).
pub fn torrance_sparrow_gaussian(sigma: f64, lmax: usize) -> Vec<f64> {
    (0..=lmax).map(|l| (-(sigma * l as f64).powi(2)).exp()).collect()
}

/// Value of the Phong lobe ρ̂ (unit k_s) at angle α from R (eq. 40).
pub fn phong_lobe(s: f64, alpha: f64) -> f64 {
    (s + 1.0) / (2.0 * PI) * alpha.cos().max(0.0).powf(s)
}

/// Value of the Torrance–Sparrow ρ̂ at normal exitance, angle θ_i from n = R (θ_h = θ_i/2).
pub fn ts_lobe_normal(sigma: f64, theta_i: f64) -> f64 {
    if theta_i >= 0.5 * PI {
        return 0.0;
    }
    (-(theta_i * theta_i) / (4.0 * sigma * sigma)).exp() / (4.0 * PI * sigma * sigma)
}

/// Lambert ρ̂ (unit albedo) at angle θ_i from n.
pub fn lambert_lobe(theta_i: f64) -> f64 {
    theta_i.cos().max(0.0) / PI
}

/// Fraction of the normalized Phong lobe about R that lies above the horizon of n when
/// angle(R, n) = α: (s+1) ∫_0^{π/2} cos^s θ sinθ · φ-fraction(θ) dθ, where at lobe angle θ the
/// directions with n·ω > 0 are those with cosφ > −cotα cotθ (φ measured from the n side).
/// This is B / (k_s L) for a Phong sphere with `horizon = "clamp"` under uniform lighting L.
pub fn phong_horizon_fraction(s: f64, alpha: f64) -> f64 {
    if alpha <= 1e-12 {
        return 1.0;
    }
    let (ca, sa) = (alpha.cos(), alpha.sin());
    // Split at the angle where the horizon starts to cut the cone (θ = π/2 − α).
    let edge = (0.5 * PI - alpha).max(0.0);
    let g = |t: f64| {
        let (ct, st) = (t.cos(), t.sin());
        let frac = if st < 1e-15 {
            if ca > 0.0 { 1.0 } else { 0.0 }
        } else {
            let c = -ca * ct / (sa * st);
            if c <= -1.0 {
                1.0
            } else if c >= 1.0 {
                0.0
            } else {
                c.acos() / PI
            }
        };
        (s + 1.0) * ct.max(0.0).powf(s) * st * frac
    };
    integrate(0.0, edge, 64, g) + integrate(edge, 0.5 * PI, 256, g)
}

/// Albedo ∫ ρ̂ dω_i of the Torrance–Sparrow lobe (unit k_s, eq. 48 × cosθ_i) at exitance θ_o,
/// i.e. B / L of a sphere under uniform lighting L: integrated over the half vector h
/// (dω_i = 4 (ω_o·h) dω_h), θ_h ≤ 12σ (the lobe is below e^{-144} beyond). `clamp`: only
/// ω_i above the horizon count; otherwise (`horizon = "ignore"`) every h with ω_o·h > 0.
pub fn ts_albedo(sigma: f64, theta_o: f64, clamp: bool) -> f64 {
    let wo = [theta_o.sin(), 0.0, theta_o.cos()];
    let tmax = (12.0 * sigma).min(if clamp { 0.5 * PI } else { PI });
    // φ_h by the midpoint rule (the horizon cut makes the integrand discontinuous in φ, so a
    // fine uniform rule: 1440 points, error ≈ 1e-6), θ_h by composite Gauss–Legendre.
    let nphi = 1440;
    let cos_phi: Vec<f64> = (0..nphi).map(|j| (2.0 * PI * (j as f64 + 0.5) / nphi as f64).cos()).collect();
    integrate(0.0, tmax, 16, |th| {
        let (st, ct) = th.sin_cos();
        let mut s = 0.0;
        for &cp in &cos_phi {
            // Only h_x and h_z matter: ω_o lies in the xz plane.
            let h = [st * cp, ct];
            let oh = wo[0] * h[0] + wo[2] * h[1];
            if oh <= 0.0 {
                continue;
            }
            let wiz = 2.0 * oh * h[1] - wo[2];
            if clamp && wiz <= 0.0 {
                continue;
            }
            s += 4.0 * oh;
        }
        s * (2.0 * PI / nphi as f64) * st * (-(th * th) / (sigma * sigma)).exp()
            / (4.0 * PI * sigma * sigma * theta_o.cos())
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn ts_albedo_at_normal_exitance_is_eq50_l0() {
        for sigma in [0.05, 0.1, 0.2] {
            let a = ts_albedo(sigma, 0.0, true);
            let b = torrance_sparrow(sigma, 0)[0];
            assert!((a - b).abs() < 1e-6, "σ={sigma}: {a} vs {b}");
        }
        // The brdf module measured ≈ 0.998 for σ = 0.05 and 0.94–0.97 for σ = 0.2.
        assert!((ts_albedo(0.05, 0.0, true) - 0.998).abs() < 0.003);
    }

    use super::*;

    #[test]
    fn lambert_closed_form_matches_quadrature_and_conventions() {
        let q = radial(lambert_lobe, 0.5 * PI, 10, 200);
        let c = lambert(10);
        for l in 0..=10 {
            assert!((q[l] - c[l]).abs() < 1e-10, "l={l}: {} vs {}", q[l], c[l]);
        }
        let want = [1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0, 0.0, 1.0 / 64.0, 0.0, -1.0 / 128.0];
        for l in 0..9 {
            assert!((c[l] - want[l]).abs() < 1e-14, "l={l}");
        }
    }

    #[test]
    fn phong_eq43_matches_quadrature_and_has_its_zeros() {
        for s in [1.0, 8.0, 32.0, 128.0, 7.3] {
            let q = radial(|t| phong_lobe(s, t), 0.5 * PI, 14, 400);
            let c = phong(s, 14);
            for l in 0..=14 {
                assert!((q[l] - c[l]).abs() < 1e-9, "s={s} l={l}: {} vs {}", q[l], c[l]);
            }
        }
        let c = phong(1.0, 9);
        assert!(c[3].abs() < 1e-15 && c[5].abs() < 1e-15 && c[7].abs() < 1e-15);
        let l1 = lambert(9);
        for l in 0..=9 {
            assert!((c[l] - l1[l]).abs() < 1e-14, "Phong s=1 is Lambert");
        }
        let c = phong(8.0, 14);
        assert!(c[10].abs() < 1e-15 && c[12].abs() < 1e-15 && c[14].abs() < 1e-15 && c[9].abs() > 1e-6);
    }

    #[test]
    fn torrance_sparrow_tends_to_eq57_and_eq55() {
        let sigma = 0.05;
        let c = torrance_sparrow(sigma, 10);
        let g = torrance_sparrow_gaussian(sigma, 10);
        // eq. 55: 1 − (σl)² + O((σl)⁴), after the paper's sinθ ≈ θ (an O(σ²) relative change:
        // ∫ e^{−θ²/4σ²} sinθ dθ / ∫ e^{−θ²/4σ²} θ dθ = 1 − 2σ²/3 + …) and l(l+1) ≈ l² in eq. 51
        // (an O(lσ²) change), so the departure from eq. 57 is bounded by (σl)⁴/2 + (l+1)σ².
        for l in 0..=10 {
            let sl = sigma * l as f64;
            assert!(
                (c[l] - g[l]).abs() < 0.5 * sl.powi(4) + (l + 1) as f64 * sigma * sigma,
                "l={l}: {} vs {}",
                c[l],
                g[l]
            );
        }
    }

    #[test]
    fn horizon_fraction_limits() {
        // α = 0: whole lobe above the horizon; α = 90°: half of it (by symmetry).
        assert!((phong_horizon_fraction(8.0, 1e-9) - 1.0).abs() < 1e-9);
        assert!((phong_horizon_fraction(8.0, 0.5 * PI) - 0.5).abs() < 1e-6);
        // s = 1 lobe about R, clamped: monotone decrease.
        let a = phong_horizon_fraction(1.0, 0.3);
        let b = phong_horizon_fraction(1.0, 0.8);
        assert!(a < 1.0 && b < a);
        // Brute force check at one angle: midpoint sum over the sphere.
        let (s, alpha) = (4.0, 1.0f64);
        let n = [alpha.sin(), 0.0, alpha.cos()];
        let (nt, np) = (800, 1600);
        let mut sum = 0.0;
        for i in 0..nt {
            let t = PI * (i as f64 + 0.5) / nt as f64;
            for j in 0..np {
                let p = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let w = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
                if w[0] * n[0] + w[2] * n[2] > 0.0 {
                    sum += phong_lobe(s, t) * t.sin() * (PI / nt as f64) * (2.0 * PI / np as f64);
                }
            }
        }
        assert!((sum - phong_horizon_fraction(s, alpha)).abs() < 2e-3, "{sum}");
    }
}
