//! `normal-probe` camera (docs/src/conventions.md §6): pixel (r, c) of a W × H image looks at the point of a
//! sphere (centre `center`, radius `radius`: the scene's first object) whose outward normal n is
//! the lat-long direction of that pixel (docs/src/conventions.md §2), from the outgoing direction
//! ω_o = cos(θ_o) n + sin(θ_o) (cos(φ_o) t + sin(φ_o) b), with t = (cosθ cosφ, cosθ sinφ, −sinθ)
//! the unit tangent of increasing θ and b = n × t = (−sinφ, cosφ, 0) that of increasing φ. So
//! (θ_o, φ_o) are the local outgoing angles (θ'_o, φ'_o) of the paper's eq. 5–10 in the frame
//! (t, b, n); φ_o = 0 is docs/src/conventions.md §6, and other azimuths (an extension of it) sample the 4D
//! reflected light field B(α, β, θ'_o, φ'_o) that factorization (eq. 18) needs.
//! At θ_o = 0 (normal exitance) R = n, and the image is the reflection map B(α, β) of eq. 13–14.
//!
//! Parameters: `theta_o_deg` (default 0), `phi_o_deg` (default 0), `jitter` (default false: the pixel centre, as the
//! convention says; true: average uniformly over the pixel's solid angle, i.e. uniform in cosθ and
//! φ inside the pixel, which makes plain lat-long quadrature of the image exact for L_00).

use super::PrimarySample;
use crate::math::{PI, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct NormalProbe {
    pub theta_o: f32,
    pub phi_o: f32,
    /// (sin θ_o, cos θ_o, sin φ_o, cos φ_o), computed once rather than per sample.
    trig: [f32; 4],
    pub jitter: bool,
    pub center: Vec3,
    pub radius: f32,
    pub width: u32,
    pub height: u32,
}

impl NormalProbe {
    pub fn new(
        theta_o_deg: f32,
        phi_o_deg: f32,
        jitter: bool,
        center: Vec3,
        radius: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, String> {
        if !(0.0..90.0).contains(&theta_o_deg) {
            return Err(format!("normal-probe theta_o_deg must be in [0, 90), got {theta_o_deg}"));
        }
        if !phi_o_deg.is_finite() || phi_o_deg.abs() > 360.0 {
            return Err(format!("normal-probe phi_o_deg must be in [-360, 360], got {phi_o_deg}"));
        }
        let (theta_o, phi_o) = (theta_o_deg.to_radians(), phi_o_deg.to_radians());
        let ((so, co), (sp, cp)) = (theta_o.sin_cos(), phi_o.sin_cos());
        Ok(NormalProbe { theta_o, phi_o, trig: [so, co, sp, cp], jitter, center, radius, width, height })
    }

    /// (θ, φ) of film point `u` of pixel (row, col); `u = (½, ½)` is the pixel centre.
    #[inline]
    pub fn angles(&self, row: u32, col: u32, u: Vec2) -> (f32, f32) {
        let (w, h) = (self.width as f32, self.height as f32);
        let theta = if self.jitter {
            // Uniform in cosθ between the row's edges: uniform in solid angle.
            let (z0, z1) = ((PI * row as f32 / h).cos(), (PI * (row as f32 + 1.0) / h).cos());
            (z0 + (z1 - z0) * u.y).clamp(-1.0, 1.0).acos()
        } else {
            PI * (row as f32 + 0.5) / h
        };
        let uc = if self.jitter { u.x } else { 0.5 };
        (theta, 2.0 * PI * (col as f32 + uc) / w)
    }

    #[inline]
    pub fn generate(&self, row: u32, col: u32, u: Vec2) -> PrimarySample {
        let (theta, phi) = self.angles(row, col, u);
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let n = Vec3::new(st * cp, st * sp, ct);
        let t = Vec3::new(ct * cp, ct * sp, -st);
        let b = Vec3::new(-sp, cp, 0.0);
        let [so, co, spo, cpo] = self.trig;
        let wo = (co * n + so * (cpo * t + spo * b)).normalize();
        PrimarySample::Surface { p: self.center + self.radius * n, n, wo }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_exitance_looks_along_the_normal() {
        let c = NormalProbe::new(0.0, 0.0, false, Vec3::ZERO, 1.0, 64, 32).unwrap();
        let PrimarySample::Surface { n, wo, p } = c.generate(3, 10, Vec2::splat(0.5)) else { panic!() };
        assert!((n - wo).length() < 1e-6 && (p - n).length() < 1e-6);
        let theta = PI * 3.5 / 32.0;
        assert!((n.z - theta.cos()).abs() < 1e-6);
    }

    #[test]
    fn oblique_exitance_angle_is_theta_o() {
        let c = NormalProbe::new(60.0, 0.0, false, Vec3::ZERO, 1.0, 64, 32).unwrap();
        let PrimarySample::Surface { n, wo, .. } = c.generate(20, 50, Vec2::splat(0.5)) else { panic!() };
        assert!((n.dot(wo) - 0.5).abs() < 1e-5);
    }

    #[test]
    fn azimuth_phi_o_turns_the_view_about_the_normal() {
        // ω_o has local coordinates (sinθ_o cosφ_o, sinθ_o sinφ_o, cosθ_o) in the frame (t, b, n).
        for (row, col) in [(5, 7), (20, 50), (31, 63)] {
            let c = NormalProbe::new(50.0, 120.0, false, Vec3::ZERO, 1.0, 64, 32).unwrap();
            let PrimarySample::Surface { n, wo, .. } = c.generate(row, col, Vec2::splat(0.5)) else { panic!() };
            let (theta, phi) = c.angles(row, col, Vec2::splat(0.5));
            let t = Vec3::new(theta.cos() * phi.cos(), theta.cos() * phi.sin(), -theta.sin());
            let b = n.cross(t);
            assert!((b - Vec3::new(-phi.sin(), phi.cos(), 0.0)).length() < 1e-5);
            let (to, po) = (50f32.to_radians(), 120f32.to_radians());
            assert!((wo.dot(n) - to.cos()).abs() < 1e-5);
            assert!((wo.dot(t) - to.sin() * po.cos()).abs() < 1e-5);
            assert!((wo.dot(b) - to.sin() * po.sin()).abs() < 1e-5);
        }
        assert!(NormalProbe::new(10.0, f32::NAN, false, Vec3::ZERO, 1.0, 8, 4).is_err());
    }
}
