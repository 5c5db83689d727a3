//! An analytic sphere: centre `center`, radius `radius` (> 0).
//!
//! Ray–sphere intersection uses the numerically robust form of Haines et al., "Precision
//! Improvements for Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7):
//! - the discriminant is computed as r² − |f − (f·d)d|² (f = o − c) instead of b² − c, which
//!   avoids the catastrophic cancellation of b² − c when the origin is far away (eq. 7.12);
//! - the two roots come from the stable quadratic q = b' + sign(b')·√Δ, t₀ = c/q, t₁ = q
//!   (eq. 7.10 with a = 1), so the near root does not lose digits to cancellation either.
//!
//! A root is accepted only above its own round-off: c = |f|² − r² carries an error of a few
//! u·(|f|² + r²) (u the unit round-off of the precision used), so the near root c/q is
//! indistinguishable from 0 below `ROOT_ULPS`·u·(|f|² + r²)/|q| (a ray leaving the surface must
//! not re-hit it there). The bound grows with the sphere and the origin's
//! distance, not with the radius alone: a camera ray 5 units above a ground sphere of radius 2e5 is a
//! hit. The hit point is re-projected onto the sphere and the normal is the outward (p − c)/r.
//!
//! Single precision resolves the surface to about u·(|c| + r): a sphere whose bounds reach beyond
//! [`SINGLE_PRECISION_EXTENT`] from the origin is intersected and re-projected in double precision
//! (a ground sphere of radius 1e9 then stays within ~1e-7 of its surface near the origin, where f32
//! would put it anywhere within ±64). Beyond [`MAX_EXTENT`] even double precision cannot place the
//! surface near the origin, and a scene is refused.

use super::{Hit, Ray};
use crate::math::Vec3;
use crate::simd::{Float, Float3, Isa, Mask, Sse2};

/// Accepted roots exceed `ROOT_ULPS`·u·(|f|² + r²)/|q|: the error of c = |f|² − r² (three products
/// and two sums for |f|², one product for r², the difference: under 5 ulps of |f|² + r²), with a
/// margin of 3 for the rounding of f = o − c and of q.
const ROOT_ULPS: f32 = 16.0;

/// Largest |centre| + radius (largest coordinate of the bounds) intersected in single precision.
/// f32's error in the hit distance is about u·(|c| + r)/cosθ: 4e-6 at this extent, below the
/// integrator's ray offsets (1e-4); larger spheres take the double-precision path.
pub const SINGLE_PRECISION_EXTENT: f32 = 64.0;

/// Largest |centre| + radius a scene may hold (`scene::build` refuses more, naming the object): the
/// double-precision path resolves the surface near the origin to ~2⁻⁵²·1e10 ≈ 2e-6, still under
/// the ray offsets; beyond it even f64 puts the surface of a ground sphere visibly off, and f32's
/// r² overflows past 1.8e19 (a sphere of radius 1e30 is hit by nothing).
pub const MAX_EXTENT: f32 = 1e10;

#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn new(center: Vec3, radius: f32) -> Self {
        Sphere { center, radius }
    }

    /// True when the sphere's bounds reach beyond [`SINGLE_PRECISION_EXTENT`] from the origin:
    /// its intersection and hit point are computed in double precision.
    #[inline(always)]
    pub fn is_large(&self) -> bool {
        self.center.abs().max_element() + self.radius > SINGLE_PRECISION_EXTENT
    }

    /// Distance of the closest hit in (round-off bound, t_max), or `None` (see the module notes):
    /// the one-lane [`Sphere::intersect_ts`].
    #[inline]
    pub fn intersect_t(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let (t, hit) = self.intersect_ts(Float3::<1>::splat(origin), Float3::splat(dir), Float::splat(t_max));
        hit.lane(0).then_some(t.lane(0))
    }

    /// [`Sphere::intersect_t`] in double precision (the same formulas; f = o − c is exact for f32
    /// inputs of the magnitudes [`MAX_EXTENT`] allows, so the only round-off is the quadratic's).
    #[cold]
    #[inline(never)]
    fn intersect_t_f64(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let r = self.radius as f64;
        let d = dir.as_dvec3();
        let f = origin.as_dvec3() - self.center.as_dvec3();
        let b = -f.dot(d);
        let ff = f.length_squared();
        let c = ff - r * r;
        let perp = f + b * d;
        let disc = r * r - perp.length_squared();
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let q = b + disc.sqrt().copysign(b);
        let (mut t0, mut t1) = (c / q, q);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t_min = ROOT_ULPS as f64 * f64::EPSILON * 0.5 * (ff + r * r) / q.abs();
        let t_max = t_max as f64;
        let t = if t0 > t_min && t0 < t_max {
            t0
        } else if t1 > t_min && t1 < t_max {
            t1
        } else {
            return None;
        };
        // Rounded to f32, a root just under t_max may equal it: keep the open interval.
        let t32 = t as f32;
        (t32 > 0.0 && t32 < t_max as f32).then_some(t32)
    }

    /// The closest hits of `N` rays (origins, unit directions, t_max): lane k's distance where
    /// `hit[k]` (unspecified elsewhere). Branch-free over the lanes, in SIMD registers inside the
    /// x86-64-v3 copy of the render's tile loop: where Δ < 0 the square root is NaN and every
    /// comparison below fails, so the lane has no hit.
    #[inline(always)]
    pub fn intersect_ts<const N: usize, S: Isa>(
        &self,
        origin: Float3<N, S>,
        dir: Float3<N, S>,
        t_max: Float<N, S>,
    ) -> (Float<N, S>, Mask<N, S>) {
        if self.is_large() {
            let (mut t, mut hit) = (Float::ZERO, Mask::NONE);
            for k in 0..N {
                let found = self.intersect_t_f64(origin.lane(k), dir.lane(k), t_max.0[k]);
                t.0[k] = found.unwrap_or(0.0);
                hit.set(k, found.is_some());
            }
            return (t, hit);
        }
        let r = self.radius;
        let f = origin - Float3::splat(self.center);
        // b' = −f·d (the half-b of a quadratic with a = |d|² = 1).
        let b = -f.dot(dir);
        let ff = f.dot(f);
        let c = ff - r * r;
        // Δ = r² − |f + b'd|² (RTG eq. 7.12): the perpendicular distance from c to the ray, squared.
        let perp = f + dir * b;
        let disc = r * r - perp.dot(perp);
        let q = b + disc.sqrt().copysign(b);
        // Roots c/q and q (RTG eq. 7.10 with a = 1); q = 0 only when b = Δ = 0 (tangent through c).
        let (a0, a1) = (c / q, q);
        let swap = a0.gt(a1);
        let (t0, t1) = (swap.select(a1, a0), swap.select(a0, a1));
        let t_min = ROOT_ULPS * f32::EPSILON * 0.5 * (ff + r * r) / q.abs();
        let near = t0.gt(t_min) & t0.lt(t_max);
        let far = t1.gt(t_min) & t1.lt(t_max);
        (near.select(t0, t1), near | far)
    }

    /// The full hit record for a hit at distance `t` (from [`Sphere::intersect_t`]).
    #[inline]
    pub fn hit_at(&self, ray: &Ray, t: f32, object: u32) -> Hit {
        if self.is_large() {
            // In f32, c + r n would put the point anywhere within ε·(|c| + r) of the surface.
            let p = ray.origin.as_dvec3() + t as f64 * ray.dir.as_dvec3();
            let n = (p - self.center.as_dvec3()).normalize();
            let p = self.center.as_dvec3() + self.radius as f64 * n;
            let n = n.as_vec3();
            return Hit { t, p: p.as_vec3(), n, ng: n, object };
        }
        let (p, n) = self.surface_at::<1, Sse2>(Float3::splat(ray.origin), Float3::splat(ray.dir), Float::splat(t));
        let (p, n) = (p.lane(0), n.lane(0));
        Hit { t, p, n, ng: n, object }
    }

    /// The point and normal of each lane's hit at distance `t` along (`origin`, `dir`), for a
    /// sphere that is not [large](Sphere::is_large): o + t d re-projected onto the surface (RTG
    /// ch. 6), which removes its error along the normal. [`Sphere::hit_at`] is the one-lane call.
    #[inline(always)]
    pub fn surface_at<const N: usize, S: Isa>(
        &self,
        origin: Float3<N, S>,
        dir: Float3<N, S>,
        t: Float<N, S>,
    ) -> (Float3<N, S>, Float3<N, S>) {
        let center = Float3::splat(self.center);
        let n = (origin + dir * t - center).normalize();
        (center + n * self.radius, n)
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

    fn intersect8(s: &Sphere, rays: &[Ray; 8]) -> ([f32; 8], [bool; 8]) {
        let t_max = Float::<8>::from_array(rays.map(|r| r.t_max));
        let (t, hit) =
            s.intersect_ts(Float3::from_vecs(&rays.map(|r| r.origin)), Float3::from_vecs(&rays.map(|r| r.dir)), t_max);
        (t.0, std::array::from_fn(|k| hit.lane(k)))
    }

    /// `intersect_ts` at eight lanes gives its one-lane call's bits (`intersect_t`): rays from
    /// outside, inside, on the surface, tangent, missing, behind, with short t_max and a NaN direction.
    #[test]
    fn eight_wide_is_one_wide() {
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
            let (t, hit) = intersect8(&s, &batch);
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

    /// A ground sphere of radius R whose top is the plane z = −1, seen from a camera 2 units above
    /// it, at R from 1e4 to the limit: every camera ray toward the plane near the origin hits the
    /// ground where the surface is (residual | |p − c| − R | in f64 within 1e-5·(1 + t)); a ray
    /// leaving a hit point upwards (offset as the integrator offsets) never re-hits it; a ray from
    /// just below the surface going up leaves it at the right distance.
    #[test]
    fn huge_ground_sphere_is_hit_where_its_surface_is() {
        let mut rng = crate::sampling::chi2::TestRng::new(23);
        for r in [1e4f32, 2e5, 1e6, 1e9, MAX_EXTENT / 2.0] {
            let s = Sphere::new(Vec3::new(0.0, 0.0, -r - 1.0), r);
            assert!(s.is_large());
            let (c, rr) = (s.center.as_dvec3(), r as f64);
            for i in 0..400 {
                let o = Vec3::new(5.0, 0.0, 1.0);
                let target = Vec3::new(40.0 * rng.next_f32() - 30.0, 40.0 * rng.next_f32() - 20.0, -1.0);
                let ray = Ray::new(o, (target - o).normalize());
                let h = s.intersect(&ray, 0).unwrap_or_else(|| panic!("R = {r}: ray {i} misses the ground"));
                let p = ray.origin.as_dvec3() + h.t as f64 * ray.dir.as_dvec3();
                let residual = ((p - c).length() - rr).abs();
                assert!(residual < 1e-5 * (1.0 + h.t as f64), "R = {r}: ray {i}: residual {residual}");
                assert!(((h.p.as_dvec3() - c).length() - rr).abs() < 1e-5, "R = {r}: hit point off the surface");
                let up = crate::integrator::path::offset_origin(h.p, h.ng, Vec3::Z);
                assert!(s.intersect(&Ray::new(up, Vec3::Z), 0).is_none(), "R = {r}: ray {i} re-hits the ground");
                let below = h.p - 1e-3 * h.ng;
                let t = s.intersect(&Ray::new(below, h.ng), 0).map(|h| h.t);
                assert!(t.is_some_and(|t| (t - 1e-3).abs() < 1e-5), "R = {r}: exit at {t:?}, not 1e-3");
            }
        }
    }

    /// Single-sphere scenes hit a huge sphere through eight lanes as through one.
    #[test]
    fn huge_sphere_eight_wide_is_one_wide() {
        let s = Sphere::new(Vec3::new(0.0, 0.0, -1e6 - 1.0), 1e6);
        let rays: [Ray; 8] = std::array::from_fn(|k| {
            let o = Vec3::new(5.0, k as f32 - 4.0, 1.0);
            Ray::new(o, (Vec3::new(-3.0 * k as f32, 1.0, -1.0) - o).normalize())
        });
        let (t, hit) = intersect8(&s, &rays);
        for k in 0..8 {
            let scalar = s.intersect_t(rays[k].origin, rays[k].dir, rays[k].t_max);
            assert!(scalar.is_some());
            assert_eq!(scalar.map(f32::to_bits), hit[k].then_some(t[k].to_bits()));
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
