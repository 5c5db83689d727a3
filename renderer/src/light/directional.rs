//! A directional (delta) light: parallel light from one direction, like a very distant sun.
//!
//! Parameters: `direction` (toward the source; normalised) and `irradiance` (RGB, on a surface
//! perpendicular to `direction`). Its radiance is a Dirac delta, so `eval` and `pdf` are 0 and
//! `sample` returns the direction with `value` = irradiance and `delta` = true: the integrator
//! multiplies by ρ̂(ω_i) (= BRDF·cosθ'_i) directly, without MIS.

use super::{DistantLight, LightSample};
use crate::math::{Rgb, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Directional {
    /// Unit direction toward the source.
    pub direction: Vec3,
    /// Irradiance on a surface perpendicular to `direction`.
    pub irradiance: Rgb,
}

impl Directional {
    /// A zero or non-finite direction falls back to +z (the scene loader rejects it first).
    pub fn new(direction: Vec3, irradiance: Rgb) -> Self {
        Directional { direction: direction.try_normalize().unwrap_or(Vec3::Z), irradiance }
    }
}

impl DistantLight for Directional {
    #[inline]
    fn eval(&self, _wi: Vec3) -> Rgb {
        Rgb::ZERO
    }

    #[inline]
    fn sample(&self, _u: Vec2) -> Option<LightSample> {
        Some(LightSample { wi: self.direction, value: self.irradiance, pdf: 0.0, delta: true })
    }

    #[inline]
    fn pdf(&self, _wi: Vec3) -> f32 {
        0.0
    }

    fn is_delta(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directional_is_a_delta() {
        let l = Directional::new(Vec3::new(0.0, 3.0, 4.0), Rgb::new(1.0, 2.0, 3.0));
        assert!((l.direction - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);
        let s = l.sample(Vec2::new(0.3, 0.7)).unwrap();
        assert!(s.delta && s.pdf == 0.0);
        assert_eq!(s.wi, l.direction);
        assert_eq!(s.value, Rgb::new(1.0, 2.0, 3.0));
        assert_eq!(l.eval(l.direction), Rgb::ZERO);
        assert_eq!(l.pdf(l.direction), 0.0);
        assert!(l.is_delta());
        assert_eq!(Directional::new(Vec3::ZERO, Rgb::ONE).direction, Vec3::Z);
    }
}
