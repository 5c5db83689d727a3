//! Icosphere: a unit-radius sphere tessellation centred at the origin.
//!
//! - `subdivisions` n: the regular icosahedron's 20 faces are split 4-to-1 n times (edge
//!   midpoints pushed onto the sphere), giving 20·4ⁿ triangles and 10·4ⁿ + 2 shared vertices.
//! - Every vertex lies on the unit sphere; triangles are counter-clockwise seen from outside;
//!   smooth normals equal the positions.
//!
//! Midpoints are shared between the two triangles of an edge through an edge → vertex map keyed
//! by the sorted index pair. n = 8 (1.31 M triangles) builds in well under a second.

use super::TriangleMesh;
use crate::math::Vec3;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A unit-radius icosphere centred at the origin with `subdivisions` levels (20·4^n triangles).
pub fn icosphere(subdivisions: u32) -> TriangleMesh {
    // Icosahedron vertices: cyclic permutations of (0, ±1, ±φ), normalised.
    let phi = (1.0 + 5.0f64.sqrt()) / 2.0;
    let raw: [[f64; 3]; 12] = [
        [-1.0, phi, 0.0],
        [1.0, phi, 0.0],
        [-1.0, -phi, 0.0],
        [1.0, -phi, 0.0],
        [0.0, -1.0, phi],
        [0.0, 1.0, phi],
        [0.0, -1.0, -phi],
        [0.0, 1.0, -phi],
        [phi, 0.0, -1.0],
        [phi, 0.0, 1.0],
        [-phi, 0.0, -1.0],
        [-phi, 0.0, 1.0],
    ];
    let mut positions: Vec<glam::DVec3> = raw.iter().map(|p| glam::DVec3::from(*p).normalize()).collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    // Enforce outward CCW winding (the face centroid and normal must agree) rather than trusting
    // the table above.
    for t in &mut triangles {
        let [a, b, c] = t.map(|k| positions[k as usize]);
        if (b - a).cross(c - a).dot(a + b + c) < 0.0 {
            t.swap(1, 2);
        }
    }

    let final_tris = 20usize << (2 * subdivisions);
    positions.reserve(final_tris / 2 + 2 - positions.len());
    for _ in 0..subdivisions {
        let mut mid: HashMap<u64, u32, BuildHasherDefault<EdgeHasher>> =
            HashMap::with_capacity_and_hasher(triangles.len() * 3 / 2, Default::default());
        let mut next = Vec::with_capacity(triangles.len() * 4);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<glam::DVec3>| -> u32 {
            let key = if a < b { (a as u64) << 32 | b as u64 } else { (b as u64) << 32 | a as u64 };
            *mid.entry(key).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                (positions.len() - 1) as u32
            })
        };
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            // Four children, each keeping the parent's orientation.
            next.extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        triangles = next;
    }

    let positions: Vec<Vec3> = positions.iter().map(|p| p.as_vec3()).collect();
    TriangleMesh { normals: positions.clone(), positions, triangles }
}

/// A multiplicative (Fibonacci) hash for the u64 edge keys: SipHash is needlessly slow here and
/// there is no adversarial input.
#[derive(Default)]
struct EdgeHasher(u64);

impl Hasher for EdgeHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    #[inline]
    fn write_u64(&mut self, k: u64) {
        self.0 = (k ^ (k >> 29)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every directed edge appears exactly once and its reverse exactly once: the mesh is closed,
    /// 2-manifold and consistently oriented.
    fn assert_closed_consistent(m: &TriangleMesh) {
        let mut edges = std::collections::HashSet::new();
        for t in &m.triangles {
            for k in 0..3 {
                assert!(edges.insert((t[k], t[(k + 1) % 3])), "directed edge used twice");
            }
        }
        for &(a, b) in &edges {
            assert!(edges.contains(&(b, a)), "edge ({a},{b}) has no opposite");
        }
    }

    #[test]
    fn counts_radius_and_normals() {
        for n in 0..=4u32 {
            let m = icosphere(n);
            assert_eq!(m.triangles.len(), 20 * 4usize.pow(n));
            assert_eq!(m.positions.len(), 10 * 4usize.pow(n) + 2);
            assert_eq!(m.normals, m.positions);
            for p in &m.positions {
                assert!((p.length() - 1.0).abs() < 1e-6);
            }
            assert!(m.validate().is_ok());
            assert_closed_consistent(&m);
        }
        assert_eq!(icosphere(5).triangles.len(), 20_480);
    }

    #[test]
    fn outward_winding_and_volume() {
        let m = icosphere(5);
        assert_closed_consistent(&m);
        for i in 0..m.len() {
            let [a, b, c] = m.vertices(i);
            assert!(m.face_normal_area(i).dot(a + b + c) > 0.0, "triangle {i} wound inward");
        }
        // The polyhedron is inscribed in the unit ball and contains the ball of radius d_min
        // (the smallest face-plane distance), so 4π/3·d_min³ ≤ V ≤ 4π/3.
        let d_min = (0..m.len())
            .map(|i| {
                let [a, ..] = m.vertices(i);
                m.face_normal_area(i).normalize().dot(a) as f64
            })
            .fold(f64::INFINITY, f64::min);
        let ball = 4.0 / 3.0 * std::f64::consts::PI;
        let v = m.signed_volume();
        assert!(v <= ball && v >= ball * d_min.powi(3) - 1e-6, "V = {v}, d_min = {d_min}");
        assert!((v - ball).abs() / ball < 2e-3, "V = {v}");
    }

    #[test]
    fn level_8_is_large() {
        // Speed belongs in `benches/`, not in a test's verdict.
        let m = icosphere(8);
        assert_eq!(m.triangles.len(), 1_310_720);
        assert_eq!(m.positions.len(), 655_362);
        assert!(m.positions.iter().all(|p| (p.length() - 1.0).abs() < 1e-6));
    }
}
