//! Error against a reference and the time to reach a target error: the two numbers that make
//! renderers with different samplers comparable (equal spp is not equal quality).
//!
//! **RMS relative error.** Over the reference's object pixels P (mask = 1, every channel > 0) and
//! the three channels c, with x the image, r the reference and s_r its standard error,
//!
//! e² = (1 / 3|P|) Σ_{p,c} ((x − r)² − s_r²) / r²,
//!
//! the mean squared relative deviation with the reference's own noise subtracted (E[(x − r)²] =
//! Var x + Var r + bias², so subtracting s_r² leaves the image's error; e is reported as 0 when the
//! difference is below the reference's noise). The reference's error bars must be calibrated for
//! this to be unbiased: references are rendered with the independent sampler.
//!
//! **Samples to a target.** Monte Carlo error falls as a power of the samples per pixel n,
//! e = a·n^(−b) (b = ½ for independent samples, up to 1 or more for a low-discrepancy sampler on
//! smooth integrands). Where two rungs of a ladder of renders bracket the target e*, n* is
//! interpolated on the line through those two (ln n, ln e) points; beyond the ladder, a
//! least-squares line through all of them gives n* = (a / e*)^(1/b), marked as extrapolated
//! ([`SamplesToTarget`]). Only the points whose error the subtraction can resolve
//! ([`Reference::min_measurable`]) count. The abscissa is n, not the render time: n is exact,
//! while the short renders' times carry the host's noise, which a line through (ln t, ln e)
//! turns into a wrong slope and, extrapolated, a wrong time (the caller converts n* to time with
//! the sample rate of the ladder's longest render).

use vocab::image::Image;

/// Object pixels and values of a reference image: per pixel (index, [r; 3], [s_r²; 3]).
#[derive(Clone, Debug)]
pub struct Reference {
    pub width: usize,
    pub height: usize,
    pixels: Vec<(usize, [f64; 3], [f64; 3])>,
}

/// Why an image cannot be compared with the reference.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConvergenceError {
    #[error("the reference has no {0} channel")]
    MissingChannel(String),
    #[error("the reference has no object pixel (mask = 1 with every channel > 0)")]
    NoObject,
    #[error("size {0}×{1} differs from the reference's {2}×{3}")]
    Size(usize, usize, usize, usize),
    #[error("the image has no {0} channel")]
    ImageChannel(String),
}

impl Reference {
    /// From a render with `R, G, B`, `stderr.R/G/B` and `mask.Y` layers.
    pub fn new(img: &Image) -> Result<Reference, ConvergenceError> {
        let ch = |n: &str| img.channel(n).ok_or_else(|| ConvergenceError::MissingChannel(n.into()));
        let (rgb, se, mask) =
            ([ch("R")?, ch("G")?, ch("B")?], [ch("stderr.R")?, ch("stderr.G")?, ch("stderr.B")?], ch("mask.Y")?);
        let pixels: Vec<_> = (0..img.width * img.height)
            .filter(|&i| mask[i] >= 1.0 && rgb.iter().all(|c| c[i] > 0.0) && se.iter().all(|c| c[i].is_finite()))
            .map(|i| (i, rgb.map(|c| c[i] as f64), se.map(|c| (c[i] as f64).powi(2))))
            .collect();
        if pixels.is_empty() {
            return Err(ConvergenceError::NoObject);
        }
        Ok(Reference { width: img.width, height: img.height, pixels })
    }

    /// Object pixels compared.
    pub fn pixel_count(&self) -> usize {
        self.pixels.len()
    }

    /// The reference's own RMS relative noise, √(mean s_r² / r²): the floor of [`Reference::rms_rel_error`].
    pub fn noise_floor(&self) -> f64 {
        let s: f64 = self.pixels.iter().map(|(_, r, v)| (0..3).map(|c| v[c] / (r[c] * r[c])).sum::<f64>()).sum();
        (s / (3 * self.pixels.len()) as f64).sqrt()
    }

    /// The least error this reference resolves: the estimate of e² has a standard error of about
    /// √(2/n)·(e² + f²) (n = 3 × pixels terms of χ²₁-like spread, f = [`Reference::noise_floor`]), and
    /// an error counts when e² is at least 3 of those: e_min = f·√(c / (1 − c)), c = 3√(2/n).
    pub fn min_measurable(&self) -> f64 {
        let c = 3.0 * (2.0 / (3 * self.pixels.len()) as f64).sqrt();
        if c >= 1.0 {
            return f64::INFINITY;
        }
        self.noise_floor() * (c / (1.0 - c)).sqrt()
    }

    /// e of the module docs for an image of the same size (its R, G, B channels).
    pub fn rms_rel_error(&self, img: &Image) -> Result<f64, ConvergenceError> {
        if (img.width, img.height) != (self.width, self.height) {
            return Err(ConvergenceError::Size(img.width, img.height, self.width, self.height));
        }
        let ch = |n: &str| img.channel(n).ok_or_else(|| ConvergenceError::ImageChannel(n.into()));
        let x = [ch("R")?, ch("G")?, ch("B")?];
        let mut s = 0.0;
        for (i, r, v) in &self.pixels {
            for c in 0..3 {
                let d = x[c][*i] as f64 - r[c];
                s += (d * d - v[c]) / (r[c] * r[c]);
            }
        }
        Ok((s / (3 * self.pixels.len()) as f64).max(0.0).sqrt())
    }
}

/// The points a fit may use: n > 0 and a finite error of at least `min_error` (above the
/// reference's noise floor) and above zero.
fn resolvable(points: &[(f64, f64)], min_error: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
    points.iter().copied().filter(move |(n, e)| *n > 0.0 && *e >= min_error && *e > 0.0 && e.is_finite())
}

/// A power law e = a·n^(−b) fitted to (samples per pixel, error) points.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PowerLaw {
    /// Error at n = 1.
    pub a: f64,
    /// Convergence exponent (½ for independent samples).
    pub b: f64,
    /// Points used.
    pub points: usize,
}

impl PowerLaw {
    /// Least squares through (ln n, ln e) of the points with n > 0 and e ≥ `min_error`; None with
    /// fewer than two such points, equal abscissae, or an error that does not fall (b ≤ 0).
    pub fn fit(points: &[(f64, f64)], min_error: f64) -> Option<PowerLaw> {
        let p: Vec<(f64, f64)> = resolvable(points, min_error).map(|(t, e)| (t.ln(), e.ln())).collect();
        if p.len() < 2 {
            return None;
        }
        let n = p.len() as f64;
        let (mx, my) = (p.iter().map(|q| q.0).sum::<f64>() / n, p.iter().map(|q| q.1).sum::<f64>() / n);
        let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
        if sxx <= 0.0 {
            return None;
        }
        let slope = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum::<f64>() / sxx;
        (slope < 0.0).then(|| PowerLaw { a: (my - slope * mx).exp(), b: -slope, points: p.len() })
    }

    /// The abscissa at which the law reaches `error`: (a / error)^(1/b).
    pub fn samples_to(&self, error: f64) -> f64 {
        (self.a / error).powf(1.0 / self.b)
    }
}

/// The samples per pixel a ladder needs to reach a target error (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplesToTarget {
    /// n*, samples per pixel (not rounded).
    pub spp: f64,
    /// The fitted law over the ladder's resolvable points.
    pub law: PowerLaw,
    /// n* lies outside the ladder's resolvable rungs (found with `law`, not between two rungs).
    pub extrapolated: bool,
}

impl SamplesToTarget {
    /// From (spp, e) points of one ladder: interpolated between the two consecutive resolvable
    /// rungs (e ≥ `min_error`) whose errors bracket `target`, else extrapolated with the power law
    /// fitted to all resolvable rungs. None where no law can be fitted ([`PowerLaw::fit`]).
    pub fn find(points: &[(f64, f64)], target: f64, min_error: f64) -> Option<SamplesToTarget> {
        let law = PowerLaw::fit(points, min_error)?;
        let mut p: Vec<(f64, f64)> = resolvable(points, min_error).collect();
        p.sort_by(|x, y| x.0.total_cmp(&y.0));
        for w in p.windows(2) {
            let ((n0, e0), (n1, e1)) = (w[0], w[1]);
            if e0 >= target && target >= e1 && e0 > e1 {
                let f = (e0 / target).ln() / (e0 / e1).ln();
                let spp = (n0.ln() + f * (n1 / n0).ln()).exp();
                return Some(SamplesToTarget { spp, law, extrapolated: false });
            }
        }
        Some(SamplesToTarget { spp: law.samples_to(target), law, extrapolated: true })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: usize, h: usize, v: f32, se: f32) -> Image {
        let mut img = Image { width: w, height: h, ..Default::default() };
        for c in ["R", "G", "B"] {
            img.channels.insert(c.into(), vec![v; w * h]);
            img.channels.insert(format!("stderr.{c}"), vec![se; w * h]);
        }
        img.channels.insert("mask.Y".into(), vec![1.0; w * h]);
        img
    }

    #[test]
    fn power_law_is_recovered_and_inverted() {
        let pts: Vec<(f64, f64)> = [0.1, 0.4, 1.6, 6.4].iter().map(|t: &f64| (*t, 0.05 * t.powf(-0.75))).collect();
        let f = PowerLaw::fit(&pts, 0.0).unwrap();
        assert!((f.a - 0.05).abs() < 1e-12 && (f.b - 0.75).abs() < 1e-12, "{f:?}");
        assert!((f.samples_to(0.01) - 5f64.powf(1.0 / 0.75)).abs() < 1e-9);
        // Points under the floor are left out; a flat or rising series has no law.
        assert_eq!(PowerLaw::fit(&pts, 0.2).map(|f| f.points), None);
        assert!(PowerLaw::fit(&[(1.0, 0.1), (2.0, 0.1)], 0.0).is_none());
    }

    /// Inside the ladder n* comes from the two rungs that bracket the target, whatever the others
    /// say; beyond it, from the law of all resolvable rungs, and says so.
    #[test]
    fn samples_to_target_interpolate_inside_the_ladder_and_extrapolate_beyond() {
        // e = 0.4 n^(−½) on four rungs, but the top rung's error too small by 30 % (a reference
        // whose noise was over-subtracted): the target 0.03 lies between 64 and 256 spp.
        let pts = [(16.0, 0.1), (64.0, 0.05), (256.0, 0.025), (1024.0, 0.0125 * 0.7)];
        let s = SamplesToTarget::find(&pts, 0.03, 0.0).unwrap();
        let exact = (0.4f64 / 0.03).powi(2);
        assert!(!s.extrapolated && (s.spp - exact).abs() < 1e-9 * exact, "{s:?} against {exact}");
        // The global fit alone would be pulled by the low top rung.
        assert!((s.law.samples_to(0.03) - exact).abs() > 0.02 * exact, "{s:?}");
        // Beyond the top: the fitted law, marked. Below the lowest rung's error: the same.
        let clean: Vec<(f64, f64)> = [16.0f64, 64.0, 256.0].iter().map(|n| (*n, 0.4 / n.sqrt())).collect();
        let beyond = SamplesToTarget::find(&clean, 0.01, 0.0).unwrap();
        assert!(beyond.extrapolated && (beyond.spp - 1600.0).abs() < 1e-6, "{beyond:?}");
        let before = SamplesToTarget::find(&clean, 0.2, 0.0).unwrap();
        assert!(before.extrapolated && (before.spp - 4.0).abs() < 1e-9, "{before:?}");
        // A rung below the reference's resolution neither brackets nor fits.
        let floor = SamplesToTarget::find(&pts, 0.011, 0.02).unwrap();
        assert!(floor.extrapolated && floor.law.points == 3, "{floor:?}");
    }

    #[test]
    fn error_subtracts_the_reference_noise() {
        let r = Reference::new(&image(4, 4, 2.0, 0.02)).unwrap();
        assert!((r.noise_floor() - 0.01).abs() < 1e-9);
        // x − r = 0.06 everywhere: e² = (0.06² − 0.02²) / 4 = 0.0008.
        let e = r.rms_rel_error(&image(4, 4, 2.06, 0.0)).unwrap();
        assert!((e - 0.0008f64.sqrt()).abs() < 1e-6, "{e}");
        // Within the reference's noise: 0, not a negative square.
        assert_eq!(r.rms_rel_error(&image(4, 4, 2.01, 0.0)).unwrap(), 0.0);
        assert_eq!(r.rms_rel_error(&image(2, 4, 2.0, 0.0)), Err(ConvergenceError::Size(2, 4, 4, 4)));
        let mut empty = image(4, 4, 2.0, 0.02);
        empty.channels.insert("mask.Y".into(), vec![0.5; 16]);
        assert_eq!(Reference::new(&empty).unwrap_err(), ConvergenceError::NoObject);
    }
}
