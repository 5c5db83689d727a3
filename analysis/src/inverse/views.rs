//! Inverse lighting from the pixels of views that see only part of the sphere (issue 16): the
//! lighting L_lm, l ≤ L, fitted directly in pixel space, B(d_p) = Σ_lm a Λ_l ρ̂_l L_lm Y_lm(d_p)
//! (eq. 15 and 17; a the albedo of the channel), with everything the views cannot tell said:
//!
//! - **conditioning from the actual design**: the amplification of coefficient k is
//!   a_k = (max_l |Λ_l ρ̂_l| / |Λ_l ρ̂_l|) · √((C⁻¹)_kk), the filter's amplification of eq. 17 (the
//!   module [`super::lighting`]) times the design's, C the Gram matrix of Y_lm over the used pixels
//!   (weights: their solid angles) normalized to unit diagonal — 1 on the whole sphere, large where
//!   one view's hemisphere of normals barely separates Y_lm from the others. An order is
//!   `recovered` when every m has a_k ≤ the threshold, `ill-conditioned` otherwise, `unobservable`
//!   where the filter is zero (not fitted); a design the pixels cannot solve is an error;
//! - **truncation in the error bars**: B has energy above L; on part of the sphere it is not
//!   orthogonal to the fitted orders and biases them. The same fit with orders up to L + 2 (the
//!   filter known there) estimates that bias, |L̂(L) − L̂(L + 2)| with the noise of the difference
//!   (σ²(L + 2) − σ²(L)) removed, stated apart from the noise;
//! - **consistency**: χ²/ν and its p-value per channel from the per-pixel standard errors; noise
//!   error bars scaled by √(χ²/ν) when it is above 1; without a `stderr` layer σ² comes from the
//!   residuals.

use super::lighting::{Status, ZERO_FILTER_REL};
use crate::error::{Error, Result};
use crate::filter::ChannelFit;
use crate::fit::{design_amplification, lsq};
use crate::projection::Sample;
use crate::sh::{ShBasis, lm, num_coefficients};

/// One order of [`invert_lighting_views`].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewOrder {
    pub l: usize,
    /// Λ_l ρ̂_l (unit albedo).
    pub lambda_rho: f64,
    /// Largest amplification a_k over the order's m (filter × design); `None` if unobservable.
    pub amplification: Option<f64>,
    /// `recovered`, `ill-conditioned` or `unobservable`.
    pub status: String,
}

/// Result of [`invert_lighting_views`]; per coefficient k (index order), RGB.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewsLighting {
    pub lmax: usize,
    pub orders: Vec<ViewOrder>,
    /// L̂_lm; `None` at unobservable orders.
    pub coefficients: Vec<Option<[f64; 3]>>,
    /// Total standard error √(noise² + truncation²).
    pub stderr: Vec<Option<[f64; 3]>>,
    /// Noise part (scaled by √(χ²/ν) when above 1).
    pub stderr_noise: Vec<Option<[f64; 3]>>,
    /// Estimated truncation bias; `None` where no higher orders could be fitted.
    pub truncation: Vec<Option<[f64; 3]>>,
    /// a_k per coefficient (the same for every channel).
    pub amplification: Vec<Option<f64>>,
    /// χ², ν, χ²/ν, p-value, error scale, covariance per channel (R, G, B).
    pub channels: Vec<ChannelFit>,
    pub warnings: Vec<String>,
}

/// Fits L_lm, l ≤ `lmax`, to `samples` (see the module docs). `filter` = Λ_l ρ̂_l (unit albedo)
/// for l ≤ at least `lmax` (orders up to `lmax` + 2 are used for the truncation estimate when
/// given), `albedo` per channel, `have_sigma` whether the sample variances are per-pixel
/// standard errors, `noise_inflation` the variance inflation F ≥ 1 of pixel noise correlated by a
/// reconstruction filter ([`crate::noise`]; 1 for independent pixels: noise error bars × √F),
/// `max_amplification` the threshold of `recovered` (the CLI's default is
/// [`super::lighting::DEFAULT_MAX_AMPLIFICATION`]).
///
/// Errors: a filter shorter than `lmax` + 1 or all zero, a non-positive albedo, a threshold < 1,
/// too few pixels, or views that cannot determine the coefficients at all (singular design).
pub fn invert_lighting_views(
    samples: &[Sample],
    have_sigma: bool,
    noise_inflation: f64,
    filter: &[f64],
    albedo: [f64; 3],
    lmax: usize,
    max_amplification: f64,
) -> Result<ViewsLighting> {
    if filter.len() < lmax + 1 || filter.iter().any(|f| !f.is_finite()) {
        return Err(Error::new(format!("inverse lighting needs finite Λ_l ρ̂_l for l = 0 … {lmax}")));
    }
    if albedo.iter().any(|a| !(a.is_finite() && *a > 0.0)) {
        return Err(Error::new(format!("albedo must be > 0 in every channel, got {albedo:?}")));
    }
    if !(max_amplification >= 1.0) {
        return Err(Error::new(format!("the amplification threshold must be ≥ 1, got {max_amplification}")));
    }
    let fmax = filter[..=lmax].iter().fold(0.0f64, |a, f| a.max(f.abs()));
    if !(fmax > 0.0) {
        return Err(Error::new("the BRDF's transfer coefficients are all zero"));
    }
    let observable = |l: usize| filter[l].abs() > ZERO_FILTER_REL * fmax;
    let l_hi = (filter.len() - 1).min(lmax + 2);
    let n = num_coefficients(lmax);
    let cols: Vec<usize> = (0..n).filter(|&k| observable(lm(k).0)).collect();
    let cols_hi: Vec<usize> = (0..num_coefficients(l_hi)).filter(|&k| observable(lm(k).0)).collect();
    if samples.len() < 2 * cols.len() {
        return Err(Error::new(format!(
            "only {} pixels for {} lighting coefficients (l_max {lmax}); check the camera and sphere or lower --lmax",
            samples.len(),
            cols.len()
        )));
    }
    let basis = ShBasis::new(l_hi);
    let weight: Vec<f64> = samples.iter().map(|s| s.w).collect();
    let full: Vec<Vec<f64>> = samples
        .iter()
        .map(|s| {
            let y = basis.eval(s.dir);
            cols_hi.iter().map(|&k| filter[lm(k).0] * y[k]).collect()
        })
        .collect();
    let p = cols.len();
    let rows: Vec<Vec<f64>> = full.iter().map(|r| r[..p].to_vec()).collect();
    // Design amplification: √((C⁻¹)_kk), C the unit-diagonal Gram of the (unscaled) Y columns.
    let amp = design_amplification(&rows, &weight, p).ok_or_else(|| {
        Error::new(format!(
            "these views cannot determine the lighting up to l_max {lmax} (the visible directions do not separate \
             its coefficients): add views (e.g. the opposite one), use a normal-probe render or lower --lmax"
        ))
    })?;
    let mut amplification = vec![None; n];
    for (i, &k) in cols.iter().enumerate() {
        amplification[k] = Some(fmax / filter[lm(k).0].abs() * amp[i]);
    }
    let mut coefficients = vec![None; n];
    let mut stderr = vec![None; n];
    let mut stderr_noise = vec![None; n];
    let mut truncation = vec![None; n];
    let mut channels = Vec::with_capacity(3);
    let mut warnings = Vec::new();
    for ch in 0..3 {
        let name = ["R", "G", "B"][ch];
        let value: Vec<f64> = samples.iter().map(|s| s.b[ch] / albedo[ch]).collect();
        let sigma: Vec<f64> = samples.iter().map(|s| s.var[ch].sqrt() / albedo[ch]).collect();
        let fit = lsq(&rows, &value, &sigma, &weight).ok_or_else(|| {
            Error::new(format!("these views cannot determine the lighting up to l_max {lmax} (channel {name})"))
        })?;
        let x = fit.chi2_per_dof();
        let chi_scale = match (have_sigma, x) {
            (true, Some(x)) if x > 1.0 => x.sqrt(),
            (false, Some(x)) => x.sqrt(),
            _ => 1.0,
        };
        let scale = chi_scale * noise_inflation.max(1.0).sqrt();
        let p_value = if have_sigma { fit.p_value() } else { None };
        let robust = if have_sigma { crate::fit::robust_chi2(&rows, &value, &sigma, &weight, &fit.coef) } else { None };
        let relative_misfit =
            crate::fit::relative_misfit(&rows, &value, have_sigma.then_some(&sigma[..]), &weight, &fit.coef);
        if have_sigma && let Some(x) = x {
            if let Some(r) = robust.filter(|&r| crate::filter::mismatch(r, relative_misfit)) {
                warnings.push(format!(
                    "channel {name}: robust χ²/ν = {r:.3} (χ²/ν = {x:.3}): the BRDF and l_max do not describe the image (a wrong BRDF or \
                     albedo, a wrong camera, extent or sphere, or lighting above l_max + 2 that the views alias); \
                     standard errors scaled by {chi_scale:.3}"
                ));
            } else if x > 1.0 {
                warnings.push(format!(
                    "channel {name}: χ²/ν = {x:.3} > 1: standard errors scaled by √(χ²/ν) = {chi_scale:.3}"
                ));
            }
        }
        let hi = (cols_hi.len() > p).then(|| lsq(&full, &value, &sigma, &weight)).flatten();
        for (i, &k) in cols.iter().enumerate() {
            let noise = fit.sigma[i] * scale;
            let t = hi.as_ref().map(|h| {
                let var_d = ((h.sigma[i] * scale).powi(2) - noise * noise).max(0.0);
                ((fit.coef[i] - h.coef[i]).powi(2) - var_d).max(0.0).sqrt()
            });
            coefficients[k].get_or_insert([0.0; 3])[ch] = fit.coef[i];
            stderr_noise[k].get_or_insert([0.0; 3])[ch] = noise;
            if let Some(t) = t {
                truncation[k].get_or_insert([0.0; 3])[ch] = t;
            }
            stderr[k].get_or_insert([0.0; 3])[ch] = (noise * noise + t.unwrap_or(0.0).powi(2)).sqrt();
        }
        let s2 = scale * scale;
        channels.push(ChannelFit {
            chi2: fit.chi2,
            dof: fit.dof,
            chi2_per_dof: x,
            robust_chi2_per_dof: robust,
            p_value,
            relative_misfit,
            stderr_scale: scale,
            fitted_orders: (0..=lmax).filter(|&l| observable(l)).collect(),
            covariance: (0..p).map(|i| (0..p).map(|j| fit.cov[i * p + j] * s2).collect()).collect(),
        });
    }
    let orders: Vec<ViewOrder> = (0..=lmax)
        .map(|l| {
            let amp = (0..2 * l + 1)
                .filter_map(|i| amplification[l * l + i])
                .fold(None, |a: Option<f64>, v| Some(a.map_or(v, |a| a.max(v))));
            let status = match amp {
                None => Status::Unobservable,
                Some(a) if a > max_amplification => Status::IllConditioned,
                Some(_) => Status::Recovered,
            };
            ViewOrder { l, lambda_rho: filter[l], amplification: amp, status: status.name().to_string() }
        })
        .collect();
    for o in &orders {
        if o.status == Status::IllConditioned.name() {
            warnings.push(format!(
                "order l = {} cannot be determined from these views: amplification {:.1} > {max_amplification} \
                 (filter × design; add views or lower --lmax)",
                o.l,
                o.amplification.unwrap_or(f64::INFINITY)
            ));
        }
    }
    Ok(ViewsLighting {
        lmax,
        orders,
        coefficients,
        stderr,
        stderr_noise,
        truncation,
        amplification,
        channels,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::latlong_direction;

    /// Pixels of a W × H lat-long grid restricted by `keep`, B = a Σ f_l L_lm Y_lm exactly.
    fn samples(light: &[f64], f: &[f64], keep: impl Fn([f64; 3]) -> bool) -> Vec<Sample> {
        let (w, h) = (64, 32);
        let lmax = f.len() - 1;
        let basis = ShBasis::new(lmax);
        (0..w * h)
            .map(|i| (i / w, i % w))
            .map(|(r, c)| (r, latlong_direction(r, c, w, h)))
            .filter(|(_, d)| keep(*d))
            .map(|(r, d)| {
                let y = basis.eval(d);
                let b: f64 = (0..y.len()).map(|k| f[lm(k).0] * light.get(k).copied().unwrap_or(0.0) * y[k]).sum();
                Sample { dir: d, w: crate::fit::latlong_omega(r, w, h), b: [b, 0.5 * b, 2.0 * b], var: [1e-6; 3] }
            })
            .collect()
    }

    #[test]
    fn exact_on_the_sphere_and_conditioning_grows_on_a_hemisphere() {
        let light: Vec<f64> =
            (0..16).map(|k| if k == 0 { 2.0 } else { 0.3 * ((k * 5 % 7) as f64 / 7.0 - 0.4) }).collect();
        // Band-limited: lighting l ≤ 3, Lambert filter (l = 3 is a zero: unobservable).
        let f = crate::transfer::lambert::lambert(3);
        let full = samples(&light, &f, |_| true);
        let r = invert_lighting_views(&full, true, 1.0, &f, [1.0, 0.5, 2.0], 2, 10.0).unwrap();
        for k in 0..9 {
            let c = r.coefficients[k].unwrap();
            for ch in 0..3 {
                assert!((c[ch] - light[k]).abs() < 1e-6, "k={k} ch{ch}: {} vs {}", c[ch], light[k]);
            }
            // The whole sphere's design is orthogonal up to quadrature: a_k ≈ the filter's.
            let want = 1.0 / f[lm(k).0];
            assert!((r.amplification[k].unwrap() / want - 1.0).abs() < 0.05, "k={k}");
        }
        assert!(r.orders.iter().all(|o| o.status == "recovered"));
        // One hemisphere (x > 0): still exact for band-limited B, but the amplification grows.
        let half = samples(&light, &f, |d| d[0] > 0.0);
        let h = invert_lighting_views(&half, true, 1.0, &f, [1.0, 0.5, 2.0], 2, 10.0).unwrap();
        for k in 0..9 {
            assert!((h.coefficients[k].unwrap()[0] - light[k]).abs() < 1e-5, "k={k}");
            // Never better than the whole sphere (yz stays orthogonal to the rest on x > 0).
            assert!(h.amplification[k].unwrap() > r.amplification[k].unwrap() * 0.99, "k={k}");
        }
        let worst = |v: &ViewsLighting| (0..9).map(|k| v.amplification[k].unwrap() * f[lm(k).0]).fold(0.0, f64::max);
        assert!(worst(&h) > 1.5 * worst(&r), "{} vs {}", worst(&h), worst(&r));
    }

    #[test]
    fn truncation_is_estimated_and_a_cap_is_refused() {
        // Lighting with energy at l = 4: a Lambert fit to l ≤ 2 on a hemisphere is biased; the
        // truncation estimate must cover the error.
        let light: Vec<f64> = (0..25)
            .map(|k| {
                if k == 0 {
                    2.0
                } else if lm(k).0 == 4 {
                    0.4
                } else {
                    0.1
                }
            })
            .collect();
        let f = crate::transfer::lambert::lambert(4);
        let half = samples(&light, &f, |d| d[0] > 0.0);
        let h = invert_lighting_views(&half, true, 1.0, &f, [1.0; 3], 2, 100.0).unwrap();
        for k in 0..9 {
            let (c, s) = (h.coefficients[k].unwrap()[0], h.stderr[k].unwrap()[0]);
            assert!((c - light[k]).abs() <= 1.5 * s + 1e-6, "k={k}: {c} ± {s} vs {}", light[k]);
        }
        assert!(h.truncation.iter().flatten().any(|t| t[0] > 1e-4), "a bias to estimate");
        // A tiny cap sees too little to separate 9 coefficients well: ill-conditioned orders said.
        let cap = samples(&light, &f, |d| d[2] > 0.95);
        match invert_lighting_views(&cap, true, 1.0, &f, [1.0; 3], 2, 10.0) {
            Ok(r) => assert!(r.orders.iter().any(|o| o.status == "ill-conditioned"), "{:?}", r.orders),
            Err(e) => assert!(e.message.contains("cannot determine"), "{e}"),
        }
    }
}
