//! An indexed triangle mesh.
//!
//! - `positions`: vertex positions.
//! - `normals`: empty (flat shading: the shading normal is the face normal) or one unit normal per
//!   vertex (smooth shading: barycentric interpolation, renormalised).
//! - `triangles`: vertex indices, counter-clockwise seen from outside, so the geometric normal
//!   (v1 − v0) × (v2 − v0) points outward for a consistently wound closed mesh.
//!
//! Ray–triangle intersection is Möller–Trumbore ("Fast, Minimum Storage Ray/Triangle
//! Intersection", 1997) on a precomputed (v0, e1, e2) record ([`TriangleRecord`]), the form the BVH
//! stores for its leaves.

use crate::math::Vec3;
use glam::{Affine3A, Mat3, Vec3A};

/// An indexed triangle mesh. `normals` is empty for flat shading or has one unit normal per vertex.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Vertex positions of triangle `i`.
    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Unnormalised geometric normal (v1 − v0) × (v2 − v0) of triangle `i`: twice its area.
    #[inline]
    pub fn face_normal_area(&self, i: usize) -> Vec3 {
        let [a, b, c] = self.vertices(i);
        (b - a).cross(c - a)
    }

    /// Checks that every index is in range and every position and normal is finite.
    /// Returns a one-line description of the first problem.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.positions.len();
        if let Some(p) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {p} has a non-finite coordinate"));
        }
        if !self.normals.is_empty() {
            if self.normals.len() != n {
                return Err(format!("{} normals for {} vertices", self.normals.len(), n));
            }
            if let Some(p) = self.normals.iter().position(|v| !v.is_finite()) {
                return Err(format!("normal {p} has a non-finite coordinate"));
            }
        }
        for (i, t) in self.triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&k| k as usize >= n) {
                return Err(format!("triangle {i} has vertex index {bad} out of range (only {n} vertices)"));
            }
        }
        Ok(())
    }

    /// Applies an affine transform: positions by `m`, normals by the inverse transpose of its
    /// linear part (renormalised). A transform that mirrors (det < 0) would turn outward CCW
    /// triangles inward, so the winding is flipped to keep geometric normals outward.
    pub fn transform(&mut self, m: Affine3A) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let lin = Mat3::from(m.matrix3);
        let normal_matrix = lin.inverse().transpose();
        for n in &mut self.normals {
            *n = (normal_matrix * *n).normalize_or_zero();
        }
        if lin.determinant() < 0.0 {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
    }

    /// Replaces `normals` by angle-weighted vertex normals (Thürmer & Wüthrich 1998): each face
    /// contributes its unit normal weighted by its interior angle at the vertex, which is
    /// independent of how the surface is triangulated. Sums in f64.
    pub fn compute_smooth_normals(&mut self) {
        let mut acc = vec![glam::DVec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let p = t.map(|k| self.positions[k as usize].as_dvec3());
            let nf = (p[1] - p[0]).cross(p[2] - p[0]);
            let len = nf.length();
            if len.is_nan() || len <= 0.0 {
                continue; // degenerate: no direction to contribute
            }
            let nf = nf / len;
            for k in 0..3 {
                let e1 = p[(k + 1) % 3] - p[k];
                let e2 = p[(k + 2) % 3] - p[k];
                let angle = e1.angle_between(e2);
                if angle.is_finite() {
                    acc[t[k] as usize] += angle * nf;
                }
            }
        }
        self.normals = acc.into_iter().map(|n| n.normalize_or_zero().as_vec3()).collect();
    }

    /// The shading normal at barycentrics (b1, b2) of triangle `i` (smooth: interpolated vertex
    /// normals; flat: `ng`). Falls back to `ng` where the interpolated normal vanishes.
    #[inline]
    pub fn shading_normal(&self, i: usize, b1: f32, b2: f32, ng: Vec3) -> Vec3 {
        if self.normals.is_empty() {
            return ng;
        }
        let [a, b, c] = self.triangles[i];
        let n =
            (1.0 - b1 - b2) * self.normals[a as usize] + b1 * self.normals[b as usize] + b2 * self.normals[c as usize];
        let n = n.normalize_or_zero();
        if n == Vec3::ZERO { ng } else { n }
    }

    /// Orientation problems that would make the mesh render black seen from outside, one line
    /// each (empty when there are none):
    /// - a closed mesh, consistently wound ([`Self::is_closed_and_consistent`]), whose signed
    ///   volume is negative: every face is wound clockwise seen from outside (inside-out);
    /// - faces whose three vertex normals all point against the face's winding (file normals that
    ///   contradict the face order).
    pub fn orientation_warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.is_closed_and_consistent() {
            let v = self.signed_volume();
            if v < 0.0 {
                out.push(format!(
                    "closed mesh is wound inside-out (faces clockwise seen from outside, signed volume {v:.4} < 0): \
                     it is seen from behind everywhere and renders black; reverse the vertex order of its faces"
                ));
            }
        }
        if !self.normals.is_empty() {
            let against = (0..self.triangles.len())
                .filter(|&i| {
                    let ng = self.face_normal_area(i);
                    ng != Vec3::ZERO && self.triangles[i].iter().all(|&k| self.normals[k as usize].dot(ng) < 0.0)
                })
                .count();
            if against > 0 {
                out.push(format!(
                    "{against} of {} faces have vertex normals pointing against their winding (the normals \
                     contradict the face order); those faces render black from outside",
                    self.triangles.len()
                ));
            }
        }
        out
    }

    /// True when the mesh is closed and consistently wound: vertices identified by position, every
    /// edge of a non-degenerate face is shared by exactly two faces that traverse it in opposite
    /// directions. (Only then is the sign of [`Self::signed_volume`] meaningful.)
    pub fn is_closed_and_consistent(&self) -> bool {
        use std::collections::HashMap;
        let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.positions.len());
        let welded: Vec<u32> = self
            .positions
            .iter()
            .map(|&p| {
                let n = ids.len() as u32;
                *ids.entry(key(p)).or_insert(n)
            })
            .collect();
        // (min, max) → (faces using the edge, a→b minus b→a traversals with a < b).
        let mut edges: HashMap<(u32, u32), (u32, i32)> = HashMap::with_capacity(3 * self.triangles.len());
        let mut any = false;
        for t in &self.triangles {
            let w = t.map(|k| welded[k as usize]);
            if w[0] == w[1] || w[1] == w[2] || w[2] == w[0] {
                continue;
            }
            any = true;
            for k in 0..3 {
                let (a, b) = (w[k], w[(k + 1) % 3]);
                let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
                e.0 += 1;
                e.1 += if a < b { 1 } else { -1 };
            }
        }
        any && edges.values().all(|&(n, d)| n == 2 && d == 0)
    }

    /// Signed volume enclosed by the mesh, Σ v0·(v1 × v2)/6 (positive for a closed mesh wound
    /// outward). f64 sum.
    pub fn signed_volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|i| {
                let [a, b, c] = self.vertices(i).map(|v| v.as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }
}

/// A triangle prepared for Möller–Trumbore: v0 and the edges e1 = v1 − v0, e2 = v2 − v0.
#[derive(Clone, Copy, Debug, Default)]
pub struct TriangleRecord {
    pub v0: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
}

impl TriangleRecord {
    #[inline]
    pub fn new(v: [Vec3; 3]) -> Self {
        let v0 = Vec3A::from(v[0]);
        TriangleRecord { v0, e1: Vec3A::from(v[1]) - v0, e2: Vec3A::from(v[2]) - v0 }
    }

    /// Möller–Trumbore: returns (t, b1, b2) for a hit with t in (0, t_max), barycentrics in
    /// [0, 1]. Rays parallel to the plane (det = 0) and degenerate triangles never hit.
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3A, dir: Vec3A, t_max: f32) -> Option<(f32, f32, f32)> {
        let pvec = dir.cross(self.e2);
        let det = self.e1.dot(pvec);
        // det = 0 (parallel or degenerate) makes inv_det infinite and every test below false
        // except through NaN; reject explicitly.
        if det == 0.0 {
            return None;
        }
        let inv_det = 1.0 / det;
        let tvec = origin - self.v0;
        let b1 = tvec.dot(pvec) * inv_det;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let qvec = tvec.cross(self.e1);
        let b2 = dir.dot(qvec) * inv_det;
        if !(b2 >= 0.0 && b1 + b2 <= 1.0) {
            return None;
        }
        let t = self.e2.dot(qvec) * inv_det;
        if t > 0.0 && t < t_max { Some((t, b1, b2)) } else { None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> TriangleMesh {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        // Outward CCW.
        let triangles = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        TriangleMesh { positions, normals: vec![], triangles }
    }

    #[test]
    fn tetra_volume_and_outward_normals() {
        let m = tetra();
        assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-12);
        let centroid = Vec3::splat(0.25);
        for i in 0..m.len() {
            let [a, ..] = m.vertices(i);
            assert!(m.face_normal_area(i).dot(a - centroid) > 0.0, "face {i} outward");
        }
    }

    #[test]
    fn transform_positions_normals_and_mirror() {
        let mut m = tetra();
        m.compute_smooth_normals();
        // Vertex 0 (corner at origin): the three faces meeting there have right angles at it,
        // so the angle-weighted normal is −(1,1,1)/√3.
        assert!((m.normals[0] + Vec3::ONE.normalize()).length() < 1e-6);
        let s = Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, 1.0, 1.0),
            glam::Quat::IDENTITY,
            Vec3::new(0.0, 0.0, 5.0),
        );
        let mut t = m.clone();
        t.transform(s);
        assert_eq!(t.positions[1], Vec3::new(2.0, 0.0, 5.0));
        // Normal by inverse transpose: (−1,−1,−1) → (−1/2,−1,−1), renormalised.
        assert!((t.normals[0] - Vec3::new(-0.5, -1.0, -1.0).normalize()).length() < 1e-6);
        assert!((t.signed_volume() - 2.0 / 6.0).abs() < 1e-6);
        // A mirror keeps the volume positive because the winding is flipped.
        let mut mirrored = m.clone();
        mirrored.transform(Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        assert!((mirrored.signed_volume() - 1.0 / 6.0).abs() < 1e-6);
    }

    #[test]
    fn moller_trumbore_barycentrics() {
        let tri = TriangleRecord::new([Vec3::ZERO, Vec3::X, Vec3::Y]);
        let o = Vec3A::new(0.25, 0.5, 2.0);
        let (t, b1, b2) = tri.intersect(o, -Vec3A::Z, f32::INFINITY).expect("hit");
        assert!((t - 2.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.5).abs() < 1e-6);
        // From below (back side) also hits: no culling.
        assert!(tri.intersect(Vec3A::new(0.25, 0.5, -2.0), Vec3A::Z, f32::INFINITY).is_some());
        // Outside the triangle, behind, beyond t_max, parallel.
        assert!(tri.intersect(Vec3A::new(0.75, 0.5, 2.0), -Vec3A::Z, f32::INFINITY).is_none());
        assert!(tri.intersect(o, Vec3A::Z, f32::INFINITY).is_none());
        assert!(tri.intersect(o, -Vec3A::Z, 1.9).is_none());
        assert!(tri.intersect(Vec3A::new(0.1, 0.1, 0.0), Vec3A::X, f32::INFINITY).is_none());
        // Degenerate triangle.
        let deg = TriangleRecord::new([Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]);
        assert!(deg.intersect(Vec3A::new(0.5, 0.0, 1.0), -Vec3A::Z, f32::INFINITY).is_none());
    }

    #[test]
    fn validate_catches_bad_indices_and_nan() {
        let mut m = tetra();
        assert!(m.validate().is_ok());
        m.triangles.push([0, 1, 4]);
        assert!(m.validate().unwrap_err().contains("out of range"));
        let mut m = tetra();
        m.positions[2].y = f32::NAN;
        assert!(m.validate().is_err());
    }
}
