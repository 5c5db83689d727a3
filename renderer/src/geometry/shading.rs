//! Shading normals that disagree with the geometry.
//!
//! An interpolated (smooth) normal n_s differs from the geometric normal n_g of the flat triangle.
//! Near a low-poly silhouette the viewing direction ω_o can be above the geometric surface
//! (ω_o·n_g > 0) but below the shading hemisphere (ω_o·n_s ≤ 0): the BRDF is then undefined and a
//! one-sided path tracer returns black. More generally, the mirror direction of ω_o about n_s can
//! fall below the geometric surface, where the (convex) object itself is in the way.
//!
//! Treatment: the view-dependent shading normal adaptation of Keller et al. 2017, "The Iray Light
//! Transport Simulation and Rendering System" (arXiv:1705.01263, §"Shading normals"; also NVIDIA's
//! US patent 10,565,781): if the reflection r = 2(ω_o·n_s)n_s − ω_o lies below the geometric surface
//! (r·n_g < ε), r is lifted along n_g until it lies just above it, r' = normalize(r + (ε − r·n_g) n_g),
//! and the shading normal becomes the half vector n' = normalize(ω_o + r'), whose mirror direction of
//! ω_o is exactly r'. Then ω_o·n' > 0 always (ω_o and r' are both above the geometric surface), so
//! no view direction between the two horizons is black; where r is already above the surface, n_s
//! is used unchanged (the adaptation is continuous across that boundary).

use crate::math::Vec3;

/// How far above the geometric tangent plane the adapted reflection direction is put (the cosine
/// of its angle to n_g is at least about this).
pub const ADAPT_EPSILON: f32 = 0.01;

/// The shading normal to use at a hit seen from `wo` (unit, pointing away from the surface):
/// `ns` adapted per Keller et al. 2017 (see the module documentation), or `ns` itself when the
/// reflection of `wo` about it is above the geometric surface, when `ns == ng` (flat shading) or
/// when the surface is seen from behind (`wo·ng ≤ 0`, left to the caller). `ns`, `ng`: unit.
#[inline]
pub fn adapt_shading_normal(ns: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    if ns == ng || wo.dot(ng) <= 0.0 {
        return ns;
    }
    let r = 2.0 * wo.dot(ns) * ns - wo;
    let rg = r.dot(ng);
    if rg >= ADAPT_EPSILON {
        return ns;
    }
    let r_adapted = (r + (ADAPT_EPSILON - rg) * ng).normalize_or_zero();
    let n = (wo + r_adapted).normalize_or_zero();
    if n == Vec3::ZERO { ng } else { n }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic unit vectors (golden-angle spiral over the sphere).
    fn dirs(n: usize) -> impl Iterator<Item = Vec3> {
        (0..n).map(move |i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let phi = i as f32 * 2.399_963;
            let s = (1.0 - z * z).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        })
    }

    #[test]
    fn adapted_normal_sees_wo_and_reflects_above_the_surface() {
        let ng = Vec3::Z;
        let mut adapted = 0;
        for ns in dirs(200).filter(|n| n.z > 0.05) {
            for wo in dirs(400).filter(|w| w.z > 1e-3) {
                let n = adapt_shading_normal(ns, ng, wo);
                assert!((n.length() - 1.0).abs() < 1e-5);
                assert!(wo.dot(n) > 0.0, "ω_o above the adapted shading hemisphere: ns {ns} wo {wo} n {n}");
                let r = 2.0 * wo.dot(n) * n - wo;
                assert!(r.dot(ng) > 0.0, "reflection above the geometric surface: {r}");
                if n != ns {
                    adapted += 1;
                    // The adapted reflection is at least ε above the tangent plane (exactly ε before
                    // normalisation, which only shortens its tangential part).
                    assert!(r.dot(ng) > 0.99 * ADAPT_EPSILON, "{}", r.dot(ng));
                }
            }
        }
        assert!(adapted > 1000, "the test exercises the adaptation ({adapted} cases)");
    }

    #[test]
    fn unchanged_where_not_needed() {
        let ng = Vec3::Z;
        // Flat shading, head-on view with a mildly tilted normal, and a back-facing view.
        assert_eq!(adapt_shading_normal(ng, ng, Vec3::new(0.999, 0.0, 0.001).normalize()), ng);
        let ns = Vec3::new(0.2, 0.0, 1.0).normalize();
        assert_eq!(adapt_shading_normal(ns, ng, Vec3::Z), ns);
        assert_eq!(adapt_shading_normal(ns, ng, -Vec3::Z), ns);
    }
}
