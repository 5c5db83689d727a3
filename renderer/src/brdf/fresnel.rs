//! Fresnel reflectance terms used by the `microfacet` model (cosine = ω_i·h, the angle between the
//! light and the microfacet normal).
//!
//! - `schlick(c, f0)`: F0 + (1 − F0)(1 − c)⁵ (Schlick 1994).
//! - `conductor(c, η, k)`: the exact unpolarised reflectance of a conductor with complex relative
//!   index η + ik (the average of R_s and R_p, in the closed form of pbrt's `FrConductor`), per channel.
use crate::math::Rgb;
use crate::simd::{Float, Float3, Isa};

/// Schlick's reflectance of one cosine.
#[inline]
pub fn schlick(cos_i: f32, f0: Rgb) -> Rgb {
    schlick_of(Float::<1>::splat(cos_i), f0).lane(0)
}

/// Schlick's reflectance of each lane's cosine.
#[inline(always)]
pub fn schlick_of<const N: usize, S: Isa>(cos_i: Float<N, S>, f0: Rgb) -> Float3<N, S> {
    let m = (1.0 - cos_i.clamp(0.0, 1.0)).max(Float::ZERO);
    let m2 = m * m;
    Float3::splat(f0) + (Rgb::ONE - f0) * (m2 * m2 * m)
}

/// Exact conductor Fresnel for one wavelength.
#[inline]
pub fn conductor_scalar(cos_i: f32, eta: f32, k: f32) -> f32 {
    conductor_channel(Float::<1>::splat(cos_i), eta, k).lane(0)
}

/// Exact conductor Fresnel for one wavelength, each lane's cosine.
#[inline(always)]
pub fn conductor_channel<const N: usize, S: Isa>(cos_i: Float<N, S>, eta: f32, k: f32) -> Float<N, S> {
    let c = cos_i.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let eta2 = eta * eta;
    let k2 = k * k;
    let t0 = eta2 - k2 - s2;
    // a² + b² = |(η + ik)² − sin²θ|, with a = Re sqrt((η + ik)² − sin²θ).
    let a2b2 = (t0 * t0 + 4.0 * eta2 * k2).sqrt();
    let t1 = a2b2 + c2;
    let a = (0.5 * (a2b2 + t0)).max(Float::ZERO).sqrt();
    let t2 = 2.0 * c * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    0.5 * (rp + rs)
}

/// Exact conductor Fresnel, per channel, of one cosine.
#[inline]
pub fn conductor(cos_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    conductor_of(Float::<1>::splat(cos_i), eta, k).lane(0)
}

/// Exact conductor Fresnel, per channel, of each lane's cosine.
#[inline(always)]
pub fn conductor_of<const N: usize, S: Isa>(cos_i: Float<N, S>, eta: Rgb, k: Rgb) -> Float3<N, S> {
    Float3::new(
        conductor_channel(cos_i, eta.x, k.x),
        conductor_channel(cos_i, eta.y, k.y),
        conductor_channel(cos_i, eta.z, k.z),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Textbook dielectric Fresnel (k = 0) from Snell's law, for comparison.
    fn dielectric(c: f64, eta: f64) -> f64 {
        let s = (1.0 - c * c).sqrt() / eta;
        let ct = (1.0 - s * s).sqrt();
        let rs = (c - eta * ct) / (c + eta * ct);
        let rp = (eta * c - ct) / (eta * c + ct);
        0.5 * (rs * rs + rp * rp)
    }

    #[test]
    fn conductor_normal_incidence_and_grazing() {
        // Normal incidence: ((η−1)² + k²) / ((η+1)² + k²). Gold-like values.
        let (eta, k) = (0.2f32, 3.5f32);
        let f0 = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        assert!((conductor_scalar(1.0, eta, k) - f0).abs() < 1e-6);
        // Grazing: total reflection.
        assert!((conductor_scalar(0.0, eta, k) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn conductor_with_zero_k_is_the_dielectric_formula() {
        for c in [0.05f32, 0.3, 0.7, 0.95] {
            let f = conductor_scalar(c, 1.5, 0.0) as f64;
            assert!((f - dielectric(c as f64, 1.5)).abs() < 1e-5, "c = {c}: {f}");
        }
    }

    #[test]
    fn schlick_end_points() {
        let f0 = Rgb::new(0.04, 0.5, 0.9);
        assert!((schlick(1.0, f0) - f0).abs().max_element() < 1e-7);
        assert!((schlick(0.0, f0) - Rgb::ONE).abs().max_element() < 1e-7);
    }
}
