//! An analytic sphere: centre `center`, radius `radius` (> 0).
//!
//! Ray–sphere intersection uses the numerically robust form of Haines et al., "Precision
//! Improvements for Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7):
//! - the discriminant is computed as r² − |f − (f·d)d|² (f = o − c) instead of b² − c, which
//!   avoids the catastrophic cancellation of b² − c when the origin is far away (eq. 7.12);
//! - the two roots come from the stable quadratic q = b' + sign(b')·√Δ, t₀ = c/q, t₁ = q
//!   (eq. 7.10 with a = 1), so the near root does not lose digits to cancellation either.
//!
//! Hits with t ≤ `SPHERE_T_EPSILON`·radius are rejected so that a ray leaving the surface does not
//! re-hit it at a round-off distance; the hit point is re-projected onto the sphere and the normal
//! is the outward (p − c)/r.

use super::{Hit, Ray};
use crate::math::Vec3;

/// Relative (to the radius) lower bound of accepted hit distances: the root of a ray starting on
/// the surface is O(ε_machine·r/cosθ); 1e-4·r covers it down to cosθ ≈ 1e-3.
pub const SPHERE_T_EPSILON: f32 = 1e-4;

#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn new(center: Vec3, radius: f32) -> Self {
        Sphere { center, radius }
    }

    /// Distance of the closest hit in (ε·r, t_max), or `None`.
    #[inline]
    pub fn intersect_t(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let r = self.radius;
        let f = origin - self.center;
        // b' = −f·d (the half-b of a quadratic with a = |d|² = 1).
        let b = -f.dot(dir);
        let c = f.length_squared() - r * r;
        // Δ = r² − |f + b'd|² (RTG eq. 7.12): the perpendicular distance from c to the ray, squared.
        let perp = f + b * dir;
        let disc = r * r - perp.length_squared();
        if disc < 0.0 {
            return None;
        }
        let q = b + disc.sqrt().copysign(b);
        // Roots c/q and q (RTG eq. 7.10 with a = 1); q = 0 only when b = Δ = 0 (tangent through c).
        let (mut t0, mut t1) = (c / q, q);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t_min = SPHERE_T_EPSILON * r;
        if t0 > t_min && t0 < t_max {
            Some(t0)
        } else if t1 > t_min && t1 < t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// [`Sphere::intersect_t`] of `N` rays at once: lane k is `Some(t)` of `intersect_t(rays[k].origin,
    /// rays[k].dir, rays[k].t_max)` where `hit[k]`, `None` where not (the same operations lane by
    /// lane, so the same bits; a test compares them). Branch-free lane loops, which LLVM runs in
    /// SIMD registers inside the x86-64-v3 copy of the render's tile loop: where Δ < 0 the square
    /// root is NaN and every comparison below fails, as the scalar early return does.
    #[inline(always)]
    pub fn intersect_t_lanes<const N: usize>(&self, rays: &[Ray; N]) -> ([f32; N], [bool; N]) {
        let r = self.radius;
        let t_min = SPHERE_T_EPSILON * r;
        let (mut t, mut hit) = ([0.0; N], [false; N]);
        for k in 0..N {
            let (o, d) = (rays[k].origin, rays[k].dir);
            let (fx, fy, fz) = (o.x - self.center.x, o.y - self.center.y, o.z - self.center.z);
            let b = -((fx * d.x) + (fy * d.y) + (fz * d.z));
            let c = ((fx * fx) + (fy * fy) + (fz * fz)) - r * r;
            let (px, py, pz) = (fx + b * d.x, fy + b * d.y, fz + b * d.z);
            let disc = r * r - ((px * px) + (py * py) + (pz * pz));
            let q = b + disc.sqrt().copysign(b);
            let (a0, a1) = (c / q, q);
            let (t0, t1) = if a0 > a1 { (a1, a0) } else { (a0, a1) };
            let t_max = rays[k].t_max;
            let near = t0 > t_min && t0 < t_max;
            let far = t1 > t_min && t1 < t_max;
            t[k] = if near { t0 } else { t1 };
            hit[k] = near || far;
        }
        (t, hit)
    }

    /// The full hit record for a hit at distance `t` (from [`Sphere::intersect_t`]).
    #[inline]
    pub fn hit_at(&self, ray: &Ray, t: f32, object: u32) -> Hit {
        let p = ray.origin + t * ray.dir;
        // Re-project onto the surface (RTG ch. 6): removes the error of o + t d along the normal.
        let n = (p - self.center).normalize();
        let p = self.center + self.radius * n;
        Hit { t, p, n, ng: n, object }
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray, object: u32) -> Option<Hit> {
        self.intersect_t(ray.origin, ray.dir, ray.t_max).map(|t| self.hit_at(ray, t, object))
    }

    /// Axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let r = Vec3::splat(self.radius.abs());
        (self.center - r, self.center + r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `intersect_t_lanes` gives `intersect_t`'s bits: rays from outside, inside, on the surface,
    /// tangent, missing, behind, with short t_max and a NaN direction.
    #[test]
    fn lanes_give_the_scalar_bits() {
        let s = unit();
        let mut state = 0x1234_5678_9abc_def0u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let mut rays = Vec::new();
        for i in 0..4096 {
            let o = s.center + Vec3::new(next(), next(), next()) * [0.5, 3.0, 8.0, 1000.0][i % 4];
            let aim = s.center + Vec3::new(next(), next(), next()) * 2.5 - o;
            let mut ray = Ray::new(o, aim.normalize());
            if i % 7 == 0 {
                ray.t_max = next().abs() * 4.0;
            }
            rays.push(ray);
        }
        // On the surface, leaving it, and a NaN direction.
        let p = s.center + Vec3::new(0.0, 0.0, s.radius);
        rays.push(Ray::new(p, Vec3::Z));
        rays.push(Ray::new(p, -Vec3::Z));
        rays.push(Ray::new(p, Vec3::new(f32::NAN, 0.0, 1.0)));
        while !rays.len().is_multiple_of(8) {
            rays.push(Ray::new(Vec3::new(0.0, 0.0, 100.0), Vec3::X));
        }
        let mut hits = 0;
        for chunk in rays.chunks_exact(8) {
            let batch: [Ray; 8] = chunk.try_into().unwrap();
            let (t, hit) = s.intersect_t_lanes(&batch);
            for k in 0..8 {
                let scalar = s.intersect_t(batch[k].origin, batch[k].dir, batch[k].t_max);
                assert_eq!(scalar.map(f32::to_bits), hit[k].then_some(t[k].to_bits()), "{:?}", batch[k]);
                hits += hit[k] as u32;
            }
        }
        assert!(hits > 1000 && hits < 4000, "{hits} hits: the rays do not exercise both outcomes");
    }

    fn unit() -> Sphere {
        Sphere::new(Vec3::new(1.0, -2.0, 0.5), 2.0)
    }

    #[test]
    fn hit_from_outside_inside_behind_miss() {
        let s = unit();
        // From outside along −x toward the centre: t = 10 − 2.
        let r = Ray::new(s.center + Vec3::new(10.0, 0.0, 0.0), -Vec3::X);
        let h = s.intersect(&r, 3).expect("hit");
        assert!((h.t - 8.0).abs() < 1e-5, "{}", h.t);
        assert!((h.n - Vec3::X).length() < 1e-6);
        assert_eq!(h.object, 3);
        // From inside (centre): exits at t = r.
        let r = Ray::new(s.center, Vec3::Z);
        let h = s.intersect(&r, 0).expect("hit");
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!((h.n - Vec3::Z).length() < 1e-6, "normal is outward even from inside");
        // Behind: sphere is behind the origin.
        let r = Ray::new(s.center + Vec3::new(10.0, 0.0, 0.0), Vec3::X);
        assert!(s.intersect(&r, 0).is_none());
        // Miss: passes at distance 2.5 > r.
        let r = Ray::new(s.center + Vec3::new(10.0, 2.5, 0.0), -Vec3::X);
        assert!(s.intersect(&r, 0).is_none());
        // t_max before the sphere.
        let mut r = Ray::new(s.center + Vec3::new(10.0, 0.0, 0.0), -Vec3::X);
        r.t_max = 7.9;
        assert!(s.intersect(&r, 0).is_none());
        r.t_max = 8.1;
        assert!(s.intersect(&r, 0).is_some());
    }

    #[test]
    fn off_centre_hit_matches_closed_form() {
        // Ray along −x at height y = h: hits at x = sqrt(r² − h²), t = d − sqrt(r² − h²).
        let s = Sphere::new(Vec3::ZERO, 1.0);
        for &h in &[0.0f32, 0.3, 0.7, 0.99, 0.9999] {
            let r = Ray::new(Vec3::new(5.0, h, 0.0), -Vec3::X);
            let hit = s.intersect(&r, 0).expect("hit");
            let expect = 5.0 - (1.0f64 - (h as f64).powi(2)).sqrt();
            assert!((hit.t as f64 - expect).abs() < 2e-6, "h={h}: {} vs {expect}", hit.t);
            let n_expect = Vec3::new((1.0 - h * h).sqrt(), h, 0.0);
            assert!((hit.n - n_expect).length() < 1e-3, "h={h}");
        }
    }

    #[test]
    fn grazing() {
        let s = Sphere::new(Vec3::ZERO, 1.0);
        // Just outside the silhouette: miss; just inside: hit near x = 0.
        let r = Ray::new(Vec3::new(5.0, 1.0 + 1e-5, 0.0), -Vec3::X);
        assert!(s.intersect(&r, 0).is_none());
        let r = Ray::new(Vec3::new(5.0, 1.0 - 1e-4, 0.0), -Vec3::X);
        let h = s.intersect(&r, 0).expect("grazing hit");
        // x_hit = sqrt(1 − y²) ≈ 0.01414.
        assert!((h.t - (5.0 - (1.0f32 - (1.0 - 1e-4f32).powi(2)).sqrt())).abs() < 1e-4);
        assert!((h.p.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn normal_is_exact_and_unit() {
        let s = unit();
        let mut rng = crate::sampling::chi2::TestRng::new(7);
        for _ in 0..1000 {
            let o = s.center + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 1.0) * 20.0;
            let target = s.center + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            let r = Ray::new(o, (target - o).normalize());
            let h = s.intersect(&r, 0).expect("aimed inside the ball");
            assert!((h.n.length() - 1.0).abs() < 1e-6);
            assert!((h.n - (h.p - s.center) / s.radius).length() < 1e-6);
            assert!(((h.p - s.center).length() - s.radius).abs() < 1e-5);
            assert!(h.n.dot(r.dir) < 0.0, "outside hit faces the ray");
        }
    }

    #[test]
    fn far_origin_error_is_small() {
        // A unit sphere seen from 1e4 away: the naive b² − c discriminant loses all digits of the
        // off-axis offset; the robust form keeps the hit point within a few ulps·distance of the
        // surface and the computed t within relative 1e-6 of the f64 reference.
        let s = Sphere::new(Vec3::ZERO, 1.0);
        let mut rng = crate::sampling::chi2::TestRng::new(11);
        for _ in 0..500 {
            let (u, v) = (rng.next_f32() - 0.5, rng.next_f32() - 0.5);
            let o = Vec3::new(1.0e4, 0.0, 0.0);
            let target = Vec3::new(0.0, u, v);
            let d = (target - o).normalize();
            let r = Ray::new(o, d);
            let h = s.intersect(&r, 0).expect("hit");
            // f64 reference with the same f32 inputs.
            let (od, dd) = (o.as_dvec3(), d.as_dvec3());
            let b = -od.dot(dd);
            let disc = 1.0 - (od + b * dd).length_squared();
            let t_ref = b - disc.sqrt();
            assert!(((h.t as f64 - t_ref) / t_ref).abs() < 1e-6, "{} vs {t_ref}", h.t);
            // Unprojected hit point o + t d lies within 1e-3 of the surface (|o| ε ≈ 1e-3 bound).
            let p = o + h.t * d;
            assert!((p.length() - 1.0).abs() < 2e-3, "{}", p.length());
        }
    }

    #[test]
    fn ray_leaving_surface_does_not_self_hit() {
        let s = Sphere::new(Vec3::new(0.3, 0.2, 0.1), 1.5);
        let mut rng = crate::sampling::chi2::TestRng::new(5);
        for _ in 0..1000 {
            let n = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let p = s.center + s.radius * n;
            // Outgoing direction in the outer hemisphere: must miss.
            let mut d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            if d.dot(n) < 0.0 {
                d = -d;
            }
            if d.dot(n) < 1e-2 {
                continue;
            }
            assert!(s.intersect(&Ray::new(p, d), 0).is_none());
            // Inward direction: hits the far side at t = 2r|cosθ|.
            let h = s.intersect(&Ray::new(p, -d), 0).expect("through");
            assert!((h.t - 2.0 * s.radius * d.dot(n)).abs() < 1e-4);
        }
    }
}
