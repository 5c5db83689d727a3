//! Pixel noise correlated by a reconstruction filter wider than a pixel, and the variance
//! inflation it implies for every linear fit over pixels.
//!
//! A renderer that splats each sample into every pixel its filter reaches (Mitsuba 3's
//! `ImageBlock`: the default `gaussian` filter, stddev 0.5 px, radius 4 σ; any `tent`) writes pixel
//! values v_p = Σ_i k(x_i − p) f_i / Σ_i k(x_i − p) that share samples with their neighbours. With N
//! samples per pixel spread uniformly and independent estimates f_i of variance σ_f²,
//! Cov(v_p, v_q) ≈ σ_f² ∫ k(x − p) k(x − q) dx / (N (∫k)²), so the noise correlation at lag d is
//! the kernel's normalized autocorrelation
//!
//! ```text
//! ρ(d) = ∫ k(x) k(x + d) dx / ∫ k(x)² dx,    for a separable kernel ρ(dx, dy) = ρ₁(dx) ρ₁(dy).
//! ```
//!
//! A box filter of one pixel gives ρ = 0 at every lag ≠ 0. pbrt-v4 *samples* its filter (filter
//! importance sampling: each sample goes to one pixel with weight ≈ 1), so its pixels' noise is
//! independent even though the image is blurred: [`PixelFilter`] describes splatting renderers.
//!
//! **Variance inflation.** Any fitted coefficient is linear in the pixels, ĉ = Σ_p a_p v_p. With
//! noise covariance σ_p σ_q ρ(p − q),
//! Var(ĉ) = Σ_p Σ_q a_p a_q σ_p σ_q ρ(p − q). When a_p σ_p varies little over the correlation
//! length (a smooth design: low-order spherical harmonics over a sphere many pixels wide),
//! a_q σ_q ≈ a_p σ_p for every q with ρ(p − q) ≠ 0, so
//!
//! ```text
//! Var(ĉ) ≈ F · Σ_p a_p² σ_p²,    F = Σ_d ρ(d)   (over all lags, ρ(0) = 1),
//! ```
//!
//! i.e. the covariance a fit computes for independent pixels, times F: its standard errors times
//! √F. A separable kernel gives F = (Σ_d ρ₁(d))²; Mitsuba's default Gaussian F ≈ π (√F ≈ 1.77: the
//! continuous limit of a Gaussian autocorrelation of stddev σ√2 = 0.71 px, (√(4π) σ)², is π).
//! The approximation is off where the design changes within a few pixels (the used region's edge:
//! a pixel there lacks half its neighbours, so F slightly overstates its share) — a small,
//! conservative error on spheres tens of pixels across.
//!
//! **Estimating ρ from an image** ([`estimate_correlation`]): the fit's residuals r_p contain the
//! noise and a smooth remainder (truncation above the fitted order, an imperfect model), which is
//! strongly correlated at short lags and must not be taken for noise. The semivariogram of the
//! residuals, γ(d) = ½ E[(r_{p+d} − r_p)²] = σ²(1 − ρ(d)) + ½ E[(s_{p+d} − s_p)²], separates them:
//! the smooth part s contributes ½ E[(∇s·d)²] + O(|d|⁴) = a dx² + b dy² + c dx dy (odd terms cancel
//! in the average over pairs), the noise a constant σ² beyond the correlation length. Fitting
//! γ(d) = σ² + a dx² + b dy² + c dx dy at far lags (3 ≤ max(|dx|, |dy|) ≤ 6, where a pixel filter of
//! radius ≤ 2 leaves ρ < 10⁻³) gives the noise variance σ² free of the smooth part, and at near
//! lags (max(|dx|, |dy|) ≤ 2) ρ(d) = 1 − (γ(d) − a dx² − b dy² − c dx dy) / σ². Differences of
//! neighbouring pixels are thus what carries the estimate; the smooth remainder enters only through
//! the fitted drift. F is the sum of the near-lag ρ (each a noisy estimate, standard error ≈ 1/√n
//! for n pixel pairs; 24 lags, so F has a standard error of about 5/√n).

/// A reconstruction (pixel) filter of a splatting renderer, separable, in pixel units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFilter {
    /// One pixel wide: each sample counts in one pixel, independent pixels.
    Box,
    /// exp(−x²/(2σ²)) − exp(−r²/(2σ²)) for |x| < r (Mitsuba 3's `gaussian`: r = 4σ, default σ 0.5;
    /// pbrt-v4's: r = 1.5, σ 0.5, but pbrt-v4 samples its filter rather than splatting it).
    Gaussian { stddev: f64, radius: f64 },
    /// 1 − |x|/r for |x| < r (Mitsuba 3's `tent`, pbrt's `triangle`).
    Tent { radius: f64 },
}

impl std::str::FromStr for PixelFilter {
    type Err = String;

    /// `box`, `gaussian:STDDEV` (radius 4σ, as Mitsuba 3), `gaussian:STDDEV:RADIUS`, `tent:RADIUS`;
    /// lengths in pixels, positive and finite.
    fn from_str(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(':').collect();
        let num = |t: &str, what: &str| -> Result<f64, String> {
            match t.trim().parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 && v <= 16.0 => Ok(v),
                _ => Err(format!("pixel filter '{s}': {what} must be a number of pixels in (0, 16], got '{t}'")),
            }
        };
        match parts.as_slice() {
            ["box"] => Ok(PixelFilter::Box),
            ["gaussian", sd] => {
                let stddev = num(sd, "the stddev")?;
                Ok(PixelFilter::Gaussian { stddev, radius: 4.0 * stddev })
            }
            ["gaussian", sd, r] => {
                Ok(PixelFilter::Gaussian { stddev: num(sd, "the stddev")?, radius: num(r, "the radius")? })
            }
            ["tent", r] => Ok(PixelFilter::Tent { radius: num(r, "the radius")? }),
            _ => Err(format!("pixel filter '{s}': expected box, gaussian:STDDEV[:RADIUS] or tent:RADIUS")),
        }
    }
}

impl std::fmt::Display for PixelFilter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PixelFilter::Box => write!(f, "box"),
            PixelFilter::Gaussian { stddev, radius } => write!(f, "gaussian:{stddev}:{radius}"),
            PixelFilter::Tent { radius } => write!(f, "tent:{radius}"),
        }
    }
}

impl PixelFilter {
    /// Half-width of the kernel's support (pixels).
    pub fn radius(&self) -> f64 {
        match *self {
            PixelFilter::Box => 0.5,
            PixelFilter::Gaussian { radius, .. } | PixelFilter::Tent { radius } => radius,
        }
    }

    /// The one-dimensional kernel k₁(x), x in pixels (unnormalized).
    pub fn eval(&self, x: f64) -> f64 {
        let x = x.abs();
        match *self {
            PixelFilter::Box => f64::from(u8::from(x <= 0.5)),
            PixelFilter::Gaussian { stddev, radius } => {
                let g = |t: f64| (-t * t / (2.0 * stddev * stddev)).exp();
                if x < radius { (g(x) - g(radius)).max(0.0) } else { 0.0 }
            }
            PixelFilter::Tent { radius } => (1.0 - x / radius).max(0.0),
        }
    }

    /// ρ₁(d) = ∫ k₁(x) k₁(x + d) dx / ∫ k₁², by the midpoint rule on 4000 intervals over the
    /// support (relative error < 10⁻⁶ for these kernels; exactly 0 for the box at integer d ≠ 0, as
    /// no midpoint lies on a pixel border).
    pub fn correlation_1d(&self, d: f64) -> f64 {
        let r = self.radius();
        let n = 4000;
        let h = 2.0 * r / n as f64;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..n {
            let x = -r + (i as f64 + 0.5) * h;
            let k = self.eval(x);
            num += k * self.eval(x + d);
            den += k * k;
        }
        if den > 0.0 { num / den } else { 0.0 }
    }

    /// ρ(dx, dy) = ρ₁(dx) ρ₁(dy) at an integer lag (module docs).
    pub fn correlation(&self, dx: i64, dy: i64) -> f64 {
        self.correlation_1d(dx as f64) * self.correlation_1d(dy as f64)
    }

    /// The variance inflation F = Σ_d ρ(d) = (Σ_k ρ₁(k))² over integer lags (module docs).
    pub fn inflation(&self) -> f64 {
        let reach = (2.0 * self.radius()).ceil() as i64;
        let s: f64 = (-reach..=reach).map(|k| self.correlation_1d(k as f64)).sum();
        s * s
    }
}

/// Residuals of one channel of one view on its pixel grid (row-major `width` × `height`, NaN at
/// pixels the fit did not use).
#[derive(Clone, Debug)]
pub struct ResidualGrid {
    pub width: usize,
    pub height: usize,
    pub values: Vec<f64>,
}

/// Lags (dx, dy) whose correlation [`estimate_correlation`] estimates: one of each ±d pair,
/// max(|dx|, |dy|) ≤ 2; the first four are the lag-1 neighbours (1,0), (0,1), (1,1), (1,−1).
pub fn near_lags() -> Vec<(i64, i64)> {
    let mut v = vec![(1, 0), (0, 1), (1, 1), (1, -1)];
    for dx in 0..=2i64 {
        for dy in -2..=2i64 {
            if (dx > 0 || dy > 0) && !v.contains(&(dx, dy)) {
                v.push((dx, dy));
            }
        }
    }
    v
}

/// Lags of the far (noise-variance and drift) part of the semivariogram: 3 ≤ max(|dx|, |dy|) ≤ 6.
fn far_lags() -> Vec<(i64, i64)> {
    let mut v = Vec::new();
    for dx in 0..=6i64 {
        for dy in -6..=6i64 {
            if (dx > 0 || dy > 0) && dx.abs().max(dy.abs()) >= 3 {
                v.push((dx, dy));
            }
        }
    }
    v
}

/// The noise correlation measured from residuals ([`estimate_correlation`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MeasuredCorrelation {
    /// ρ̂(d) at each lag of [`near_lags`] (averaged over the channels), in that order.
    pub rho: Vec<((i64, i64), f64)>,
    /// F̂ = 1 + 2 Σ ρ̂(d) over the near lags (module docs).
    pub inflation: f64,
    /// Standard error of one ρ̂ for independent pixels, ≈ 1/√n (n the pixel pairs at lag (1, 0)).
    pub rho_stderr: f64,
    /// Pixel pairs at lag (1, 0) over all grids of one channel.
    pub pairs: usize,
    /// The smooth part dominates the residuals' short-lag differences (its fitted drift at lag 3
    /// exceeds the noise variance, or the far semivariogram is not noise plus a quadratic drift):
    /// ρ̂ is then not a measurement of the noise.
    pub signal_dominated: bool,
}

/// Semivariogram of `grids` (one channel) at `lags`: (γ(d), pair count) each.
fn semivariogram(grids: &[&ResidualGrid], lags: &[(i64, i64)]) -> Vec<(f64, usize)> {
    lags.iter()
        .map(|&(dx, dy)| {
            let (mut s, mut n) = (0.0, 0usize);
            for g in grids {
                let (w, h) = (g.width as i64, g.height as i64);
                for y in 0..h {
                    let y2 = y + dy;
                    if y2 < 0 || y2 >= h {
                        continue;
                    }
                    for x in 0..w - dx.max(0) {
                        let x2 = x + dx;
                        if x2 < 0 {
                            continue;
                        }
                        let (a, b) = (g.values[(y * w + x) as usize], g.values[(y2 * w + x2) as usize]);
                        if a.is_finite() && b.is_finite() {
                            s += (b - a) * (b - a);
                            n += 1;
                        }
                    }
                }
            }
            (if n > 0 { s / (2.0 * n as f64) } else { f64::NAN }, n)
        })
        .collect()
}

/// Measures the noise correlation of the residuals `grids[channel][view]` (module docs): per
/// channel the far semivariogram gives σ² and the smooth drift, the near one ρ(d); ρ̂ is averaged
/// over the channels whose σ² > 0. `None` when no channel has enough pixel pairs (fewer than 100 at
/// some far lag) or a positive σ².
pub fn estimate_correlation(grids: &[Vec<ResidualGrid>]) -> Option<MeasuredCorrelation> {
    let near = near_lags();
    let far = far_lags();
    let mut rho_sum = vec![0.0; near.len()];
    let (mut used, mut pairs, mut signal_dominated) = (0usize, 0usize, false);
    for channel in grids {
        let refs: Vec<&ResidualGrid> = channel.iter().collect();
        let g_far = semivariogram(&refs, &far);
        if g_far.iter().any(|&(_, n)| n < 100) {
            continue;
        }
        // Least squares γ = s + a dx² + b dy² + c dx dy over the far lags, weighted by pair counts.
        let rows: Vec<Vec<f64>> =
            far.iter().map(|&(dx, dy)| vec![1.0, (dx * dx) as f64, (dy * dy) as f64, (dx * dy) as f64]).collect();
        let value: Vec<f64> = g_far.iter().map(|g| g.0).collect();
        let weight: Vec<f64> = g_far.iter().map(|g| g.1 as f64).collect();
        let Some(fit) = crate::fit::lsq(&rows, &value, &vec![0.0; rows.len()], &weight) else { continue };
        let [s, a, b, c] = [fit.coef[0], fit.coef[1], fit.coef[2], fit.coef[3]];
        if !(s > 0.0) {
            continue;
        }
        let drift = |dx: i64, dy: i64| a * (dx * dx) as f64 + b * (dy * dy) as f64 + c * (dx * dy) as f64;
        // Is the far semivariogram noise plus a quadratic drift? Its weighted RMS misfit relative to σ².
        let (mut m, mut wsum) = (0.0, 0.0);
        for ((&(dx, dy), g), w) in far.iter().zip(&value).zip(&weight) {
            m += w * (g - s - drift(dx, dy)).powi(2);
            wsum += w;
        }
        let misfit = (m / wsum).sqrt() / s;
        if drift(3, 0).abs().max(drift(0, 3).abs()) > s || misfit > 0.1 {
            signal_dominated = true;
        }
        let g_near = semivariogram(&refs, &near);
        pairs = pairs.max(g_near[0].1);
        for (k, (&(dx, dy), g)) in near.iter().zip(&g_near).enumerate() {
            rho_sum[k] += 1.0 - (g.0 - drift(dx, dy)) / s;
        }
        used += 1;
    }
    if used == 0 {
        return None;
    }
    let rho: Vec<((i64, i64), f64)> = near.iter().zip(&rho_sum).map(|(&d, &r)| (d, r / used as f64)).collect();
    let inflation = 1.0 + 2.0 * rho.iter().map(|r| r.1).sum::<f64>();
    Some(MeasuredCorrelation {
        rho,
        inflation,
        rho_stderr: 1.0 / (pairs.max(1) as f64).sqrt(),
        pairs,
        signal_dominated,
    })
}

impl MeasuredCorrelation {
    /// Mean of ρ̂(1, 0) and ρ̂(0, 1).
    pub fn lag1(&self) -> f64 {
        0.5 * (self.rho[0].1 + self.rho[1].1)
    }

    /// The noise is measurably correlated: the mean lag-1 correlation exceeds 4 standard errors
    /// (≈ 4/√(2n)) and F̂ > 1, on residuals whose short-lag differences are noise.
    pub fn detected(&self) -> bool {
        !self.signal_dominated && self.lag1() > 4.0 * self.rho_stderr / 2f64.sqrt() && self.inflation > 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Standard normal variates from a fixed LCG (Box–Muller).
    fn normals(n: usize, seed: u64) -> Vec<f64> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut u = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
        };
        (0..n).map(|_| (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()).collect()
    }

    #[test]
    fn kernel_correlations_and_inflation() {
        assert_eq!(PixelFilter::Box.inflation(), 1.0);
        assert_eq!(PixelFilter::Box.correlation(1, 0), 0.0);
        // Mitsuba's default: the continuous limit ρ₁(d) = exp(−d²/(4σ²)) = e^-1 at d = 1; the
        // truncation at 4σ changes it by < 1e-3. F ≈ π.
        let g: PixelFilter = "gaussian:0.5".parse().unwrap();
        assert_eq!(g, PixelFilter::Gaussian { stddev: 0.5, radius: 2.0 });
        assert!((g.correlation_1d(1.0) - (-1.0f64).exp()).abs() < 2e-3, "{}", g.correlation_1d(1.0));
        assert!((g.inflation() - std::f64::consts::PI).abs() < 0.02, "{}", g.inflation());
        // Tent of radius 1: ρ₁(1) = ∫₀¹ (1 − x) x dx / (2/3) = (1/6)/(2/3) = 1/4.
        let t: PixelFilter = "tent:1".parse().unwrap();
        assert!((t.correlation_1d(1.0) - 0.25).abs() < 1e-6);
        assert!((t.inflation() - 2.25).abs() < 1e-5);
        assert!("gaussian:-1".parse::<PixelFilter>().is_err());
        assert!("lanczos".parse::<PixelFilter>().is_err());
        assert_eq!("gaussian:0.5:1.5".parse::<PixelFilter>().unwrap().radius(), 1.5);
    }

    /// White noise on a fine grid (4 × 4 sub-pixels per pixel) splatted with the kernel's weights
    /// into pixels, plus a smooth, strongly correlated field (a stand-in for truncation): the
    /// estimate recovers the kernel's ρ at lag 1 and its F, and finds none for a box.
    #[test]
    fn measured_correlation_matches_the_kernel() {
        let (w, h, sub) = (120usize, 120usize, 4usize);
        let fine = normals(w * h * sub * sub, 7);
        for (filter, expect_detected) in [("gaussian:0.5", true), ("tent:1", true), ("box", false)] {
            let f: PixelFilter = filter.parse().unwrap();
            let reach = f.radius().ceil() as i64;
            let mut values = vec![f64::NAN; w * h];
            for py in 0..h as i64 {
                for px in 0..w as i64 {
                    let (mut s, mut ws) = (0.0, 0.0);
                    for fy in (py - reach) * sub as i64..(py + reach + 1) * sub as i64 {
                        for fx in (px - reach) * sub as i64..(px + reach + 1) * sub as i64 {
                            if fy < 0 || fx < 0 || fy >= (h * sub) as i64 || fx >= (w * sub) as i64 {
                                continue;
                            }
                            let x = (fx as f64 + 0.5) / sub as f64 - (px as f64 + 0.5);
                            let y = (fy as f64 + 0.5) / sub as f64 - (py as f64 + 0.5);
                            let k = f.eval(x) * f.eval(y);
                            s += k * fine[fy as usize * w * sub + fx as usize];
                            ws += k;
                        }
                    }
                    let (cx, cy) = (px as f64 - 60.0, py as f64 - 60.0);
                    if cx * cx + cy * cy < 55.0 * 55.0 {
                        // Smooth part ~ 3 noise σ over the disc.
                        let smooth = 0.02 * (cx * cx - 0.5 * cy * cy) / 55.0 + 0.1 * (cx / 20.0).sin();
                        values[py as usize * w + px as usize] = s / ws + smooth;
                    }
                }
            }
            let m = estimate_correlation(&[vec![ResidualGrid { width: w, height: h, values }]]).unwrap();
            assert_eq!(m.detected(), expect_detected, "{filter}: {m:?}");
            let want1 = f.correlation(1, 0);
            // The 4 × 4 sub-pixel grid approximates the continuous kernel: allow 0.03 plus 4 se.
            assert!(
                (m.rho[0].1 - want1).abs() < 0.03 + 4.0 * m.rho_stderr,
                "{filter}: ρ(1,0) {} vs {want1}",
                m.rho[0].1
            );
            assert!(
                (m.inflation - f.inflation()).abs() < 0.15 * f.inflation() + 8.0 * m.rho_stderr,
                "{filter}: F {} vs {}",
                m.inflation,
                f.inflation()
            );
        }
    }
}
