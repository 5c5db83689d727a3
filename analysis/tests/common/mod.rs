//! Helpers shared by the analysis crate's integration tests.
#![allow(dead_code)]

use std::f64::consts::PI;

/// SplitMix64, for deterministic test inputs (no dependency on the renderer).
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in [0, 1), 53 bits.
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.next().max(1e-300), self.next());
        (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
    }

    /// A unit direction, uniform on the sphere.
    pub fn dir(&mut self) -> [f64; 3] {
        let z = 2.0 * self.next() - 1.0;
        let phi = 2.0 * PI * self.next();
        let s = (1.0 - z * z).sqrt();
        [s * phi.cos(), s * phi.sin(), z]
    }
}
