//! The film: per-pixel estimates with their standard errors, and the AOVs of CONVENTIONS §5.
//!
//! Each pixel's samples are accumulated in f64 by one thread (a pixel never straddles tiles), with
//! Welford's update for the variance, so the result does not depend on the thread count. The
//! standard error is √(s²/n) of the pixel mean: exact for independent samples and conservative for
//! the scrambled Sobol sampler (whose error decays faster than 1/√n).

use crate::math::{Rgb, Vec3};

/// Running statistics of one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelAccumulator {
    n: u32,
    mean: [f64; 3],
    m2: [f64; 3],
    normal: [f64; 3],
    hits: u32,
}

impl PixelAccumulator {
    #[inline]
    pub fn add(&mut self, radiance: Rgb, normal: Vec3, hit: bool) {
        self.n += 1;
        let inv = 1.0 / self.n as f64;
        let v = [radiance.x as f64, radiance.y as f64, radiance.z as f64];
        for ((x, mean), m2) in v.iter().zip(&mut self.mean).zip(&mut self.m2) {
            let d = x - *mean;
            *mean += d * inv;
            *m2 += d * (x - *mean);
        }
        if hit {
            self.hits += 1;
            self.normal[0] += normal.x as f64;
            self.normal[1] += normal.y as f64;
            self.normal[2] += normal.z as f64;
        }
    }

    pub fn finish(&self) -> Pixel {
        let n = self.n.max(1) as f64;
        let se = |c: usize| if self.n > 1 { (self.m2[c] / (n - 1.0) / n).sqrt() } else { 0.0 };
        let nl = (self.normal[0].powi(2) + self.normal[1].powi(2) + self.normal[2].powi(2)).sqrt();
        let normal = if nl > 0.0 { self.normal.map(|v| (v / nl) as f32) } else { [0.0; 3] };
        Pixel {
            rgb: self.mean.map(|v| v as f32),
            stderr: [se(0) as f32, se(1) as f32, se(2) as f32],
            normal,
            mask: (self.hits as f64 / n) as f32,
        }
    }
}

/// The finished value of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pixel {
    pub rgb: [f32; 3],
    pub stderr: [f32; 3],
    pub normal: [f32; 3],
    pub mask: f32,
}

/// A finished image, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Pixel>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film { width, height, pixels: vec![Pixel::default(); (width * height) as usize] }
    }

    #[inline]
    pub fn get(&self, row: u32, col: u32) -> &Pixel {
        &self.pixels[(row * self.width + col) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welford_matches_two_pass() {
        let xs = [1.0f32, 2.0, 4.0, 8.0, 3.0];
        let mut a = PixelAccumulator::default();
        for &x in &xs {
            a.add(Rgb::splat(x), Vec3::Z, x > 2.0);
        }
        let p = a.finish();
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / 5.0;
        let var = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / 4.0;
        assert!((p.rgb[0] as f64 - mean).abs() < 1e-6);
        assert!((p.stderr[1] as f64 - (var / 5.0).sqrt()).abs() < 1e-6);
        assert!((p.mask - 0.6).abs() < 1e-6);
        assert_eq!(p.normal, [0.0, 0.0, 1.0]);
    }
}
