//! Inverse BRDF (eq. 16): estimate the transfer coefficients Λ_l ρ̂_l = B_lm / L_lm per order from
//! the reflected light and a known lighting, then fit a BRDF model's parameter to them.
//!
//! Per-order estimates: [`crate::filter::measured_filter`] (least squares over m, weighted by the
//! lighting's energy in each m; orders where L has no energy are unobservable, sec. 3.4).
//!
//! Fit (parameters: the estimates, the [`Model`], the search range of its parameter p): the model
//! gives g_l(p) = Λ_l ρ̂_l — Phong's eq. 43 with p = s, Torrance–Sparrow's eq. 50 (normal
//! exitance) or its q = 0 coefficient at θ_o with p = σ. Each channel has its own unknown scale
//! k_c (k_s or albedo), profiled out in closed form, so
//! χ²(p) = min_k Σ_c Σ_l w_lc (f̂_lc − k_c g_l(p))², k̂_c = Σ_l w f̂ g / Σ_l w g².
//! Weights are w = 1/σ̂_lc² when every used estimate has a standard error; otherwise w = 1 and
//! χ² is rescaled by dof / χ²_min (dof = orders·channels − channels − 1), i.e. the residual
//! scatter stands in for σ. p̂ minimises χ² (log grid of 40 points per decade, then golden-section
//! in ln p); the confidence interval is where the χ² profile stays within Δχ² = 1 of its minimum
//! (68 % for one parameter). A side on which χ² never rises by 1 inside the search range is
//! reported as unbounded (`None`): the data cannot tell p from larger (or smaller) values — the
//! ill-conditioning of sec. 3.3 and 3.6 under uniform or low-frequency lighting.
//!
//! Estimates from one image are correlated (non-uniform pixel noise; and the three channels share
//! their paths), which the weighted fit above ignores. [`fit_model_gls`] fits one channel with the
//! full covariance of its per-order estimates, e.g. [`transfer_covariance_probe`] for a
//! `normal-probe` image; `reflect invert brdf` uses it whenever the image has a `stderr` layer.

use crate::error::{Error, Result};
use crate::filter::{OrderEstimate, measured_filter};
use crate::transfer::TransferModel;

/// The parametric model fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    /// Normalized Phong, parameter s (eq. 43).
    Phong,
    /// Simplified Torrance–Sparrow at exitance angle θ_o (radians), parameter σ (eq. 50 at θ_o = 0).
    TorranceSparrow { theta_o: f64 },
    /// The renderer's microfacet BRDF (F = 1) with distribution D at exitance θ_o (radians),
    /// parameter α ([`crate::transfer::microfacet`]).
    Microfacet { distribution: vocab::Distribution, theta_o: f64 },
}

impl Model {
    pub fn name(&self) -> &'static str {
        match self {
            Model::Phong => "phong",
            Model::TorranceSparrow { .. } => "torrance-sparrow",
            Model::Microfacet { .. } => "microfacet",
        }
    }
    pub fn parameter_name(&self) -> &'static str {
        match self {
            Model::Phong => "s",
            Model::TorranceSparrow { .. } => "sigma",
            Model::Microfacet { .. } => "alpha",
        }
    }
    /// The default search range of the parameter: s ∈ [0.5, 10⁴], σ ∈ [0.005, 1], α ∈ [0.005, 1].
    pub fn default_range(&self) -> (f64, f64) {
        match self {
            Model::Phong => (0.5, 1.0e4),
            Model::TorranceSparrow { .. } | Model::Microfacet { .. } => (0.005, 1.0),
        }
    }
    /// The search range (`range`, else [`Model::default_range`]) checked: 0 < min < max, both ends
    /// valid parameters of the model ([`TransferModel::validate`], which also checks θ_o).
    pub fn check_range(&self, range: Option<(f64, f64)>) -> Result<(f64, f64)> {
        let (lo, hi) = range.unwrap_or(self.default_range());
        if !(lo > 0.0 && hi > lo && hi.is_finite()) {
            return Err(Error::new(format!(
                "the {} search range must satisfy 0 < min < max, got [{lo}, {hi}]",
                self.parameter_name()
            )));
        }
        self.transfer(lo).validate()?;
        self.transfer(hi).validate()?;
        Ok((lo, hi))
    }
    pub fn transfer(&self, p: f64) -> TransferModel {
        match *self {
            Model::Phong => TransferModel::Phong { s: p },
            Model::TorranceSparrow { theta_o } => TransferModel::TorranceSparrow { sigma: p, theta_o },
            Model::Microfacet { distribution, theta_o } => TransferModel::Microfacet {
                lobe: crate::transfer::microfacet::MicrofacetLobe {
                    distribution,
                    alpha: p,
                    fresnel: crate::transfer::microfacet::MicrofacetFresnel::None,
                },
                theta_o,
            },
        }
    }
}

/// Per-order estimates of (albedo ·) Λ_l ρ̂_l from B_lm and L_lm (eq. 16); orders where the
/// lighting's energy is below 1e-8 of its largest order are unobservable.
pub fn estimate_transfer(
    b: &[[f64; 3]],
    b_stderr: Option<&[[f64; 3]]>,
    lighting: &[[f64; 3]],
    lmax: usize,
) -> Result<Vec<OrderEstimate>> {
    let n = crate::sh::num_coefficients(lmax);
    if b.len() < n || lighting.len() < n || b_stderr.is_some_and(|s| s.len() < n) {
        return Err(Error::new(format!(
            "inverse BRDF needs {n} coefficients of B, its standard errors and L for l_max {lmax}"
        )));
    }
    Ok(measured_filter(b, b_stderr, lighting, lmax, 1e-8))
}

/// Result of [`fit_model`].
#[derive(Clone, Debug)]
pub struct BrdfFit {
    pub model: Model,
    /// p̂ (s or σ).
    pub parameter: f64,
    /// Δχ² = 1 interval; `None` on a side where χ² stays within 1 of its minimum up to the range edge.
    pub interval: (Option<f64>, Option<f64>),
    pub range: (f64, f64),
    /// k̂_c at p̂ per channel (`None` for a channel with no usable order).
    pub scale: [Option<f64>; 3],
    pub chi2_min: f64,
    pub dof: i64,
    /// True when the weights are 1/σ̂² (else unit weights rescaled by the residual scatter).
    pub weighted_by_stderr: bool,
    /// Number of (order, channel) estimates used.
    pub points: usize,
    /// The χ² profile on the search grid, (p, χ²(p) − χ²_min), for plots of the error curve.
    pub profile: Vec<(f64, f64)>,
}

impl BrdfFit {
    /// Interval width relative to p̂, ∞ when a side is unbounded.
    pub fn relative_width(&self) -> f64 {
        match self.interval {
            (Some(lo), Some(hi)) => (hi - lo) / self.parameter,
            _ => f64::INFINITY,
        }
    }
    /// P(χ²_ν ≥ χ²_min) when the weights are 1/σ² (ν = `dof` > 0): small when the model does not
    /// describe the estimates; `None` otherwise (then χ² only measures the scatter).
    pub fn p_value(&self) -> Option<f64> {
        (self.weighted_by_stderr && self.dof > 0).then(|| crate::special::chi2_survival(self.chi2_min, self.dof as f64))
    }
    /// χ²(p) − χ²_min at the profile grid point nearest p (in ln p): the height of the error curve.
    pub fn delta_chi2_at(&self, p: f64) -> f64 {
        self.profile
            .iter()
            .min_by(|a, b| (a.0.ln() - p.ln()).abs().total_cmp(&(b.0.ln() - p.ln()).abs()))
            .map_or(0.0, |q| q.1)
    }
    pub fn contains(&self, p: f64) -> bool {
        self.interval.0.is_none_or(|lo| lo <= p) && self.interval.1.is_none_or(|hi| p <= hi)
    }
}

/// (l, channel, estimate, weight) of the usable estimates.
type Point = (usize, usize, f64, f64);

fn usable_points(est: &[OrderEstimate]) -> (Vec<Point>, bool) {
    let mut pts = Vec::new();
    let mut all_se = true;
    for o in est {
        for ch in 0..3 {
            if let Some(f) = o.estimate[ch] {
                match o.stderr[ch] {
                    Some(s) if s > 0.0 && s.is_finite() => pts.push((o.l, ch, f, 1.0 / (s * s))),
                    _ => {
                        all_se = false;
                        pts.push((o.l, ch, f, 1.0));
                    }
                }
            }
        }
    }
    if !all_se {
        pts.iter_mut().for_each(|p| p.3 = 1.0);
    }
    (pts, all_se)
}

/// χ²(p) with the per-channel scales profiled out; also returns k̂.
fn chi2_at(model: Model, p: f64, pts: &[Point], lmax: usize) -> (f64, [Option<f64>; 3]) {
    let g = model.transfer(p).lambda_rho(lmax);
    let mut k = [None; 3];
    for ch in 0..3 {
        let (mut num, mut den) = (0.0, 0.0);
        for &(l, c, f, w) in pts.iter().filter(|q| q.1 == ch) {
            let _ = c;
            num += w * f * g[l];
            den += w * g[l] * g[l];
        }
        if den > 0.0 {
            k[ch] = Some(num / den);
        }
    }
    let chi2 = pts.iter().map(|&(l, c, f, w)| w * (f - k[c].unwrap_or(0.0) * g[l]).powi(2)).sum();
    (chi2, k)
}

/// Weighted least-squares fit of the model parameter with its Δχ² = 1 interval (module doc).
pub fn fit_model(est: &[OrderEstimate], model: Model, range: Option<(f64, f64)>) -> Result<BrdfFit> {
    let (lo, hi) = model.check_range(range)?;
    let lmax = est.iter().map(|o| o.l).max().ok_or_else(|| Error::new("no transfer estimates to fit"))?;
    let (pts, weighted) = usable_points(est);
    let channels = (0..3).filter(|ch| pts.iter().any(|p| p.1 == *ch)).count();
    if channels == 0 {
        return Err(Error::new("no observable order: the lighting has no energy where it was measured"));
    }
    let dof = pts.len() as i64 - channels as i64 - 1;
    let chi2 = |p: f64| chi2_at(model, p, &pts, lmax).0;
    // Unit weights: rescale so that χ²_min/dof = 1 (the scatter estimates σ).
    let factor = |chi2_raw: f64| if weighted || dof <= 0 || chi2_raw <= 0.0 { 1.0 } else { dof as f64 / chi2_raw };
    let sr = profile_search(&chi2, model, lo, hi, &factor)?;
    let (_, scale) = chi2_at(model, sr.p_hat, &pts, lmax);
    Ok(BrdfFit {
        model,
        parameter: sr.p_hat,
        interval: sr.interval,
        range: (lo, hi),
        scale,
        chi2_min: sr.chi2_min,
        dof,
        weighted_by_stderr: weighted,
        points: pts.len(),
        profile: sr.profile,
    })
}

/// Result of [`profile_search`].
struct Search {
    p_hat: f64,
    /// χ²(p̂) after the rescaling factor.
    chi2_min: f64,
    interval: (Option<f64>, Option<f64>),
    profile: Vec<(f64, f64)>,
}

/// Minimises χ²(p) on [lo, hi] (log grid of 40 points per decade, then golden section in ln p
/// around the best grid point) and finds the Δχ² = 1 crossings on both sides; `factor(χ²_min)`
/// rescales χ² (1 for known standard errors).
///
/// A non-finite χ² anywhere on the way is an error naming the parameter value (never a minimum:
/// NaN compares as neither larger nor smaller, so it would steer the search silently).
fn profile_search(
    chi2: &dyn Fn(f64) -> f64,
    model: Model,
    lo: f64,
    hi: f64,
    factor: &dyn Fn(f64) -> f64,
) -> Result<Search> {
    let bad = std::cell::Cell::new(None);
    let chi2 = |p: f64| {
        let v = chi2(p);
        if !v.is_finite() && bad.get().is_none() {
            bad.set(Some((p, v)));
        }
        v
    };
    let decades = (hi / lo).log10();
    let n = ((40.0 * decades).ceil() as usize).max(20);
    let grid: Vec<f64> = (0..=n).map(|i| lo * (hi / lo).powf(i as f64 / n as f64)).collect();
    let values: Vec<f64> = grid.iter().map(|&p| chi2(p)).collect();
    let refuse = |(p, v): (f64, f64)| {
        Error::new(format!(
            "the {} fit's objective chi2 is {v} at {} = {p:e} (the model's transfer coefficients or the estimates are not finite there); narrow --min/--max",
            model.name(),
            model.parameter_name()
        ))
    };
    if let Some(b) = bad.get() {
        return Err(refuse(b));
    }
    let ibest = (0..=n).min_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap_or(0);
    let (mut a, mut b) = (grid[ibest.saturating_sub(1)].ln(), grid[(ibest + 1).min(n)].ln());
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if chi2(c.exp()) < chi2(d.exp()) { b = d } else { a = c }
    }
    let mut p_hat = (0.5 * (a + b)).exp();
    if values[ibest] < chi2(p_hat) {
        p_hat = grid[ibest];
    }
    let chi2_raw = chi2(p_hat);
    let factor = factor(chi2_raw);
    let delta = |p: f64| (chi2(p) - chi2_raw) * factor;
    let crossing = |inside: f64, outside: f64| {
        let (mut a, mut b) = (inside.ln(), outside.ln());
        for _ in 0..60 {
            let m = 0.5 * (a + b);
            if delta(m.exp()) < 1.0 { a = m } else { b = m }
        }
        (0.5 * (a + b)).exp()
    };
    let mut lower = None;
    let mut inside = p_hat;
    for &p in grid.iter().rev().filter(|&&p| p < p_hat) {
        if delta(p) >= 1.0 {
            lower = Some(crossing(inside, p));
            break;
        }
        inside = p;
    }
    let mut upper = None;
    inside = p_hat;
    for &p in grid.iter().filter(|&&p| p > p_hat) {
        if delta(p) >= 1.0 {
            upper = Some(crossing(inside, p));
            break;
        }
        inside = p;
    }
    if let Some(b) = bad.get() {
        return Err(refuse(b));
    }
    let profile = grid.iter().zip(&values).map(|(&p, &v)| (p, (v - chi2_raw) * factor)).collect();
    Ok(Search { p_hat, chi2_min: chi2_raw * factor, interval: (lower, upper), profile })
}

/// Generalised least squares for one channel whose per-order estimates f̂_l (at the orders
/// `orders`, e.g. the observable ones) are *correlated*, with covariance `cov` (n × n row-major,
/// n = orders.len()): χ²(p) = min_k (f̂ − k g(p))ᵀ C⁻¹ (f̂ − k g(p)) = f̂ᵀC⁻¹f̂ − (gᵀC⁻¹f̂)² / gᵀC⁻¹g.
/// Estimates from one image are correlated wherever its pixel noise is not uniform — for a sphere
/// under a directional source adjacent orders correlate at ≈ 0.85, because the noise concentrates
/// near the source — and ignoring that makes the Δχ² = 1 interval wrong (half as wide there).
/// Otherwise as [`fit_model`] (same search, interval and profile).
pub fn fit_model_gls(
    orders: &[usize],
    f: &[f64],
    cov: &[f64],
    model: Model,
    range: Option<(f64, f64)>,
) -> Result<BrdfFit> {
    let (lo, hi) = model.check_range(range)?;
    let n = f.len();
    if n == 0 || orders.len() != n || cov.len() != n * n || f.iter().chain(cov).any(|v| !v.is_finite()) {
        return Err(Error::new(format!(
            "GLS fit needs n orders, n finite estimates and an n × n covariance (n = {n}, {} orders, {} entries)",
            orders.len(),
            cov.len()
        )));
    }
    let cinv = crate::lsq::Cholesky::new(cov, n, 1e-14)?.inverse();
    let lmax = orders.iter().copied().max().unwrap_or(0);
    let quad =
        |x: &[f64], y: &[f64]| (0..n).map(|i| x[i] * (0..n).map(|j| cinv[i * n + j] * y[j]).sum::<f64>()).sum::<f64>();
    let ff = quad(f, f);
    let fit_at = |p: f64| {
        let all = model.transfer(p).lambda_rho(lmax);
        let g: Vec<f64> = orders.iter().map(|&l| all[l]).collect();
        let (gf, gg) = (quad(&g, f), quad(&g, &g));
        if gg > 0.0 { (ff - gf * gf / gg, Some(gf / gg)) } else { (ff, None) }
    };
    let chi2 = |p: f64| fit_at(p).0;
    let sr = profile_search(&chi2, model, lo, hi, &|_| 1.0)?;
    Ok(BrdfFit {
        model,
        parameter: sr.p_hat,
        interval: sr.interval,
        range: (lo, hi),
        scale: [fit_at(sr.p_hat).1, None, None],
        chi2_min: sr.chi2_min,
        dof: n as i64 - 2,
        weighted_by_stderr: true,
        points: n,
        profile: sr.profile,
    })
}

/// Covariance, per channel, of the per-order estimates f̂_l = Σ_m L_lm B_lm / Σ_m L_lm² of
/// [`estimate_transfer`] when B_lm is the lat-long quadrature of a `normal-probe` image with a
/// `stderr` layer (as [`crate::projection::project_normal_probe`]): f̂_l = Σ_p u_l(p) B_p with
/// u_l(p) = ΔΩ_p Σ_m L_lm Y_lm(n_p) / E_l, so Cov(f̂_l, f̂_l') = Σ_p u_l(p) u_l'(p) σ_p² (pixels
/// are independent). Returns (lmax+1)² per channel (rows/columns of orders without lighting energy
/// are 0), or None without a `stderr` layer.
pub fn transfer_covariance_probe(
    img: &crate::image::Image,
    lighting: &[[f64; 3]],
    lmax: usize,
) -> Result<Option<[Vec<f64>; 3]>> {
    let Some(se) = img.stderr_layer_for_weights()? else { return Ok(None) };
    let (w, h) = (se.width, se.height);
    let nk = crate::sh::num_coefficients(lmax);
    if lighting.len() < nk || w != 2 * h || h == 0 {
        return Err(Error::new(format!("covariance needs a W = 2H probe and {nk} lighting coefficients")));
    }
    let no = lmax + 1;
    let energy: Vec<[f64; 3]> = (0..no)
        .map(|l| {
            let mut e = [0.0; 3];
            for k in l * l..(l + 1) * (l + 1) {
                for ch in 0..3 {
                    e[ch] += lighting[k][ch] * lighting[k][ch];
                }
            }
            e
        })
        .collect();
    let basis = crate::sh::ShBasis::new(lmax);
    let mut y = vec![0.0; nk];
    let mut cov = [vec![0.0; no * no], vec![0.0; no * no], vec![0.0; no * no]];
    let mut u = vec![0.0; no];
    for r in 0..h {
        let (t0, t1) = (std::f64::consts::PI * r as f64 / h as f64, std::f64::consts::PI * (r + 1) as f64 / h as f64);
        let d_omega = 2.0 * std::f64::consts::PI / w as f64 * (t0.cos() - t1.cos());
        for c in 0..w {
            basis.eval_into(crate::sh::latlong_direction(r, c, w, h), &mut y);
            let sig = se.pixels[r * w + c];
            for ch in 0..3 {
                let v = sig[ch] as f64 * sig[ch] as f64;
                if v == 0.0 {
                    continue;
                }
                for l in 0..no {
                    let e = energy[l][ch];
                    u[l] = if e > 0.0 {
                        d_omega * (l * l..(l + 1) * (l + 1)).map(|k| lighting[k][ch] * y[k]).sum::<f64>() / e
                    } else {
                        0.0
                    };
                }
                for i in 0..no {
                    for j in 0..no {
                        cov[ch][i * no + j] += u[i] * u[j] * v;
                    }
                }
            }
        }
    }
    Ok(Some(cov))
}

/// Linearised (Cramér–Rao) standard deviation of ln ŝ from orders 0 … `lmax` with covariance `cov`
/// ((lmax+1)², row-major), the scale k_s profiled out: [(JᵀC⁻¹J)⁻¹]_{ln s, ln s} with
/// J = (g_l, ∂g_l/∂ln s), g = Λ_l ρ̂_l(s) of Phong (eq. 43, ∂ by central differences, h = 1e-4).
/// NaN when `cov` is not positive definite; ∞ when s is not identifiable (one order, a flat filter).
pub fn linearised_sd_ln_s(s: f64, cov: &[f64], lmax: usize) -> f64 {
    let n = lmax + 1;
    let Ok(ch) = crate::lsq::Cholesky::new(cov, n, 1e-14) else { return f64::NAN };
    let cinv = ch.inverse();
    let g = crate::transfer::phong::phong(s, lmax);
    let h = 1e-4;
    let (gp, gm) =
        (crate::transfer::phong::phong(s * (1.0 + h), lmax), crate::transfer::phong::phong(s * (1.0 - h), lmax));
    let d: Vec<f64> = (0..n).map(|l| (gp[l] - gm[l]) / (2.0 * h)).collect();
    let quad =
        |x: &[f64], y: &[f64]| (0..n).map(|i| x[i] * (0..n).map(|j| cinv[i * n + j] * y[j]).sum::<f64>()).sum::<f64>();
    let (a, b, c) = (quad(&g, &g), quad(&g, &d), quad(&d, &d));
    // [(JᵀC⁻¹J)⁻¹]_22 = a / (a c − b²); ∞ when s is not identifiable (one order, or a flat filter).
    let det = a * c - b * b;
    if det > 1e-300 * a * c { (a / det).sqrt() } else { f64::INFINITY }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::lighting::tests::Gauss;
    use crate::sh::{index, num_coefficients};

    /// L_lm = δ_m0 Y_l0(0) = δ_m0 √((2l+1)/4π) for l ≤ l_light, 0 above: a directional source at
    /// the pole, all orders (l_light = lmax) or its 9-term approximation (l_light = 2).
    fn directional(lmax: usize, l_light: usize) -> Vec<[f64; 3]> {
        let mut c = vec![[0.0; 3]; num_coefficients(lmax)];
        for l in 0..=l_light.min(lmax) {
            c[index(l, 0)] = [1.0 / crate::sh::lambda(l); 3];
        }
        c
    }

    /// B = k g(p) L + N(0, σ²) with σ = `sigma`.
    fn render(l: &[[f64; 3]], g: &[f64], k: [f64; 3], sigma: f64, rng: &mut Gauss) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let b = crate::predict::predict(l, g, k).into_iter().map(|v| v.map(|x| x + sigma * rng.normal())).collect();
        (b, vec![[sigma; 3]; l.len()])
    }

    fn fit(model: Model, p_true: f64, lmax: usize, l_light: usize, sigma: f64, seed: u64) -> BrdfFit {
        let light = directional(lmax, l_light);
        let g = model.transfer(p_true).lambda_rho(lmax);
        let mut rng = Gauss::new(seed);
        let (b, se) = render(&light, &g, [0.7, 0.5, 0.3], sigma, &mut rng);
        let est = estimate_transfer(&b, Some(&se), &light, lmax).unwrap();
        fit_model(&est, model, None).unwrap()
    }

    /// p lies within 4 one-sided 1σ widths of p̂ on its own side (4σ: a single 1σ interval misses 32 %
    /// of the time). The Δχ² = 1 interval is asymmetric, so the side of the interval facing p is the
    /// width that counts; that side must be bounded (an unbounded side bounds nothing, so the
    /// assertion then fails rather than passing vacuously).
    fn within_4_sigma(f: &BrdfFit, p: f64) -> bool {
        let side = if p >= f.parameter {
            f.interval.1.map(|hi| hi - f.parameter)
        } else {
            f.interval.0.map(|lo| f.parameter - lo)
        };
        side.is_some_and(|w| (p - f.parameter).abs() <= 4.0 * w)
    }

    #[test]
    fn phong_exponent_is_sharp_under_a_directional_source_and_loose_under_9_terms() {
        // s = 32, l ≤ 16, σ_B = 1e-2. Directional (all orders): accurate, narrow interval. 9-term
        // lighting (l ≤ 2): Λ_l ρ̂_l = 1, 33/34, 32/35 barely depend on s, so the interval is wide
        // (sec. 3.3). Measured (seed 1): p̂ 32.07 in [31.63, 32.52] (relative width 0.028) vs 33.8 in
        // [23.4, 59.2] (1.06); Δχ² at s = 64: 2238 vs 1.25.
        let s = 32.0;
        let dir = fit(Model::Phong, s, 16, 16, 1e-2, 1);
        let nine = fit(Model::Phong, s, 16, 2, 1e-2, 1);
        assert!(within_4_sigma(&dir, s), "{} {:?}", dir.parameter, dir.interval);
        assert!(dir.relative_width() < 0.05, "directional width {}", dir.relative_width());
        // Able to fail: a wrong exponent (s = 40) lies outside the directional interval, even at 4σ ...
        assert!(!dir.contains(40.0));
        assert!(!within_4_sigma(&dir, 40.0) && !within_4_sigma(&dir, 28.0));
        // ... but not outside the 9-term one, which is > 10× wider.
        assert!(within_4_sigma(&nine, s), "{} {:?}", nine.parameter, nine.interval);
        assert!(
            nine.relative_width() > 10.0 * dir.relative_width(),
            "9-term {} vs directional {}",
            nine.relative_width(),
            dir.relative_width()
        );
        // Flat error curve: Δχ² at s = 2·32 is > 100× smaller under 9 terms.
        assert!(
            nine.delta_chi2_at(2.0 * s) < 0.01 * dir.delta_chi2_at(2.0 * s),
            "{} vs {}",
            nine.delta_chi2_at(2.0 * s),
            dir.delta_chi2_at(2.0 * s)
        );
        // Uniform lighting (order 0 only): with a free scale the χ² profile is flat, no bound at all.
        let uni = fit(Model::Phong, s, 16, 0, 1e-2, 1);
        assert_eq!(uni.interval, (None, None));
        assert!(uni.profile.iter().all(|(_, d)| d.abs() < 1e-9));
    }

    #[test]
    fn torrance_sparrow_sigma_is_sharp_under_a_directional_source_and_loose_under_9_terms() {
        // σ = 0.1, same setting; sec. 3.6. Measured (seed 2): σ̂ 0.1011 in [0.1005, 0.1016] (relative
        // width 0.012) vs 0.037 in (unbounded, 0.085]: the 9-term χ² profile is so flat and skewed
        // that its 1σ interval even misses 0.1 on this seed; Δχ² at σ = 0.2: 11857 vs 46.
        let sigma = 0.1;
        let dir = fit(Model::TorranceSparrow { theta_o: 0.0 }, sigma, 16, 16, 1e-2, 2);
        let nine = fit(Model::TorranceSparrow { theta_o: 0.0 }, sigma, 16, 2, 1e-2, 2);
        assert!(within_4_sigma(&dir, sigma), "{} {:?}", dir.parameter, dir.interval);
        assert!(dir.relative_width() < 0.05, "{}", dir.relative_width());
        assert!(!dir.contains(0.12));
        assert!(!within_4_sigma(&dir, 0.12) && !within_4_sigma(&dir, 0.09));
        // The 9-term interval is unbounded below: only the side facing the truth (above p̂) may count.
        assert!(nine.interval.1.is_some(), "{:?}", nine.interval);
        assert!(within_4_sigma(&nine, sigma), "{} {:?}", nine.parameter, nine.interval);
        assert!(
            nine.relative_width() > 10.0 * dir.relative_width(),
            "{} vs {}",
            nine.relative_width(),
            dir.relative_width()
        );
        assert!(
            nine.delta_chi2_at(2.0 * sigma) < 0.01 * dir.delta_chi2_at(2.0 * sigma),
            "{} vs {}",
            nine.delta_chi2_at(2.0 * sigma),
            dir.delta_chi2_at(2.0 * sigma)
        );
    }

    #[test]
    fn delta_chi2_interval_covers_the_truth_68_percent_of_the_time() {
        // 300 noisy directional fits of s = 20 (l ≤ 10, σ_B = 3e-3). Coverage of a Δχ² = 1 interval
        // is 68.3 %; binomial σ = √(0.683·0.317/300) = 2.7 %: 4σ band.
        let trials = 300;
        let hits =
            (0..trials).filter(|&t| fit(Model::Phong, 20.0, 10, 10, 3e-3, 100 + t as u64).contains(20.0)).count();
        let frac = hits as f64 / trials as f64;
        let sd = (0.683f64 * 0.317 / trials as f64).sqrt();
        assert!((frac - 0.683).abs() < 4.0 * sd, "coverage {frac}");
    }

    #[test]
    fn unit_weights_use_the_residual_scatter_and_bad_inputs_are_errors() {
        let lmax = 12;
        let light = directional(lmax, lmax);
        // Lighting with energy in every m (so residuals over m exist without standard errors).
        let light: Vec<[f64; 3]> = light
            .iter()
            .enumerate()
            .map(|(k, v)| if v[0] != 0.0 { *v } else { [0.05 * ((k % 5) as f64 + 1.0); 3] })
            .collect();
        let g = crate::transfer::phong::phong(16.0, lmax);
        let mut rng = Gauss::new(9);
        let (b, _) = render(&light, &g, [1.0; 3], 1e-3, &mut rng);
        let est = estimate_transfer(&b, None, &light, lmax).unwrap();
        let f = fit_model(&est, Model::Phong, None).unwrap();
        assert!(!f.weighted_by_stderr);
        assert!(f.contains(16.0) || (f.parameter - 16.0).abs() < 0.05 * 16.0, "{} {:?}", f.parameter, f.interval);
        assert!(f.relative_width() < 0.2, "{}", f.relative_width());
        assert!(estimate_transfer(&b[..10], None, &light, lmax).is_err());
        assert!(fit_model(&est, Model::Phong, Some((5.0, 1.0))).is_err());
        assert!(fit_model(&est, Model::Phong, Some((0.0, 1.0))).is_err());
        assert!(fit_model(&[], Model::Phong, None).is_err());
    }

    /// The whole parameter range is searchable: σ down to 1e-200 (the mirror limit, where the
    /// transfer coefficients once overflowed to NaN and steered the search to σ̂ = 1e-200 with a
    /// null χ²) gives the same fit as the default range; a non-finite objective is an error naming
    /// the parameter; a range end the model refuses (σ = ∞ is not finite) is an error.
    #[test]
    fn extreme_ranges_and_non_finite_objectives() {
        let lmax = 10;
        let model = Model::TorranceSparrow { theta_o: 0.0 };
        let light = directional(lmax, lmax);
        let g = model.transfer(0.1).lambda_rho(lmax);
        let mut rng = Gauss::new(3);
        let (b, se) = render(&light, &g, [0.7, 0.5, 0.3], 1e-3, &mut rng);
        let est = estimate_transfer(&b, Some(&se), &light, lmax).unwrap();
        let d = fit_model(&est, model, None).unwrap();
        let wide = fit_model(&est, model, Some((1e-200, 1.0))).unwrap();
        assert!(wide.chi2_min.is_finite());
        assert!((wide.parameter / d.parameter - 1.0).abs() < 1e-6, "{} vs {}", wide.parameter, d.parameter);
        assert!(wide.contains(0.1) || (wide.parameter - 0.1).abs() < 4.0 * 0.1 * wide.relative_width());
        assert!(fit_model(&est, model, Some((1e-3, f64::INFINITY))).is_err());
        let mut bad = est.clone();
        bad[3].estimate[0] = Some(f64::INFINITY);
        let e = fit_model(&bad, model, None).unwrap_err().to_string();
        assert!(e.contains("sigma") && e.contains("chi2"), "{e}");
        let orders: Vec<usize> = (0..=lmax).collect();
        let f: Vec<f64> = est.iter().map(|o| o.estimate[0].unwrap()).collect();
        let diag: Vec<f64> =
            (0..(lmax + 1) * (lmax + 1)).map(|k| if k / (lmax + 1) == k % (lmax + 1) { 1e-6 } else { 0.0 }).collect();
        let gls = fit_model_gls(&orders, &f, &diag, model, Some((1e-200, 1.0))).unwrap();
        assert!(gls.chi2_min.is_finite() && (gls.parameter / 0.1 - 1.0).abs() < 0.05, "{}", gls.parameter);
    }

    #[test]
    fn gls_with_a_diagonal_covariance_is_the_weighted_fit_and_correlations_matter() {
        let s_true = 32.0;
        let g = Model::Phong.transfer(s_true).lambda_rho(12);
        let sig: Vec<f64> = (0..13).map(|l| 2e-3 * (1.0 + 0.1 * l as f64)).collect();
        let f: Vec<f64> =
            g.iter().enumerate().map(|(l, v)| 0.9 * v + if l % 3 == 0 { sig[l] } else { -0.5 * sig[l] }).collect();
        let est: Vec<OrderEstimate> = (0..13)
            .map(|l| OrderEstimate {
                l,
                energy: [1.0; 3],
                estimate: [Some(f[l]), None, None],
                stderr: [Some(sig[l]), None, None],
            })
            .collect();
        let diag: Vec<f64> = (0..169).map(|k| if k / 13 == k % 13 { sig[k / 13].powi(2) } else { 0.0 }).collect();
        let a = fit_model(&est, Model::Phong, None).unwrap();
        let orders: Vec<usize> = (0..13).collect();
        let b = fit_model_gls(&orders, &f, &diag, Model::Phong, None).unwrap();
        // Same χ² up to rounding; the minimum is flat, so p̂ agrees to the search's precision.
        assert!((a.parameter / b.parameter - 1.0).abs() < 1e-6, "{} vs {}", a.parameter, b.parameter);
        let (ai, bi) = (a.interval, b.interval);
        assert!(
            (ai.0.unwrap() / bi.0.unwrap() - 1.0).abs() < 1e-5 && (ai.1.unwrap() / bi.1.unwrap() - 1.0).abs() < 1e-5
        );
        assert!((b.scale[0].unwrap() / a.scale[0].unwrap() - 1.0).abs() < 1e-6);
        // Strongly correlated errors (ρ = 0.9 between all orders) move the interval.
        let corr: Vec<f64> = (0..169)
            .map(|k| {
                let (i, j) = (k / 13, k % 13);
                sig[i] * sig[j] * if i == j { 1.0 } else { 0.9 }
            })
            .collect();
        let c = fit_model_gls(&orders, &f, &corr, Model::Phong, None).unwrap();
        assert!(
            (c.relative_width() / b.relative_width() - 1.0).abs() > 0.1,
            "{} vs {}",
            c.relative_width(),
            b.relative_width()
        );
        assert!(fit_model_gls(&orders, &f, &corr[..168], Model::Phong, None).is_err());
        assert!(fit_model_gls(&orders[..12], &f, &corr, Model::Phong, None).is_err());
    }

    #[test]
    fn probe_covariance_diagonal_is_the_per_order_variance() {
        // The diagonal of the covariance must be the squared standard errors estimate_transfer
        // propagates independently (same quadrature weights), for every channel.
        let lmax = 6;
        let (w, h) = (64, 32);
        let mut img = crate::image::Image { width: w, height: h, ..Default::default() };
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            img.channels.insert(n.to_string(), (0..w * h).map(|i| 1.0 + 0.1 * ((i * (c + 3)) % 7) as f32).collect());
            img.channels.insert(
                format!("stderr.{n}"),
                (0..w * h).map(|i| 0.01 + 0.02 * ((i / w) as f32 / h as f32).powi(2) * (c + 1) as f32).collect(),
            );
        }
        let light: Vec<[f64; 3]> = (0..num_coefficients(lmax))
            .map(|k| [1.0 / (1.0 + k as f64), 0.5 - 0.05 * k as f64, if k % 3 == 0 { 0.3 } else { 0.0 }])
            .collect();
        let (b, se) = crate::projection::project_normal_probe(&img, lmax).unwrap();
        let est = estimate_transfer(&b, se.as_deref(), &light, lmax).unwrap();
        let cov = transfer_covariance_probe(&img, &light, lmax).unwrap().unwrap();
        let n = lmax + 1;
        for o in &est {
            for ch in 0..3 {
                let v = cov[ch][o.l * n + o.l];
                match o.stderr[ch] {
                    Some(s) => assert!((v.sqrt() / s - 1.0).abs() < 1e-6, "l {} ch {ch}: {} vs {s}", o.l, v.sqrt()),
                    None => assert_eq!(v, 0.0),
                }
            }
        }
        // Non-uniform noise correlates the orders.
        let r01 = cov[0][1] / (cov[0][0] * cov[0][n + 1]).sqrt();
        assert!(r01.abs() > 1e-3, "{r01}");
        let mut plain = img.clone();
        plain.channels.retain(|k, _| !k.starts_with("stderr"));
        assert!(transfer_covariance_probe(&plain, &light, lmax).unwrap().is_none());
    }

    #[test]
    fn cramer_rao_of_the_phong_exponent() {
        // Noise scales the bound linearly; one order cannot separate s from k_s; more orders of the
        // same noise can only tighten it.
        let id = |n: usize| (0..n * n).map(|k| if k / n == k % n { 1.0 } else { 0.0 }).collect::<Vec<f64>>();
        let a = linearised_sd_ln_s(32.0, &id(9), 8);
        let b = linearised_sd_ln_s(32.0, &id(9).iter().map(|v| 4.0 * v).collect::<Vec<_>>(), 8);
        assert!((b / a - 2.0).abs() < 1e-9, "{a} {b}");
        assert!(linearised_sd_ln_s(32.0, &[1.0], 0).is_infinite());
        assert!(linearised_sd_ln_s(32.0, &id(3), 2) > a);
        assert!(linearised_sd_ln_s(32.0, &[1.0, 2.0, 2.0, 1.0], 1).is_nan());
    }
}
