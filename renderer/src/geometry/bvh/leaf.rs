//! A leaf of the float-plane tree: its (up to four) primitives in structure-of-arrays form, so
//! that one Möller–Trumbore test covers all of them.
//!
//! obvhs's leaves hold one to three primitives. Tested one after another, each triangle test
//! ends in a different early exit, and the branches they take are as random as the rays; tested
//! four at a time, on glam's `Vec4` (an SSE register on x86-64, NEON or four floats elsewhere),
//! the whole leaf is one straight run of arithmetic and one mask. Lanes a leaf does not fill are
//! degenerate triangles (all zero), which the determinant test rejects.
//!
//! **Same bits as one triangle at a time.** Each lane performs the operations of
//! [`TriangleRecord::intersect`] in the same order (glam's `cross` and `dot` as written out
//! below, no fused multiply-add), so t and the barycentrics are those of the scalar test bit for
//! bit, and of several hits the nearest is kept, the lowest lane on a tie, as the scalar loop over
//! the leaf's slots did.
//!
//! A leaf holding a sphere (scenes mixing spheres and meshes) is tested lane by lane with each
//! primitive's own test.

use super::{KIND_SPHERE, KIND_TRIANGLE, Prim};
use crate::geometry::mesh::TriangleRecord;
use glam::{Vec3A, Vec4};

/// Lanes of a leaf: the most primitives an obvhs leaf holds (3), rounded up to a SIMD width.
pub(super) const LANES: usize = 4;

/// One leaf's primitives, lane by lane. Triangle: rows 0–2 v0, 3–5 e1 = v1 − v0, 6–8 e2 = v2 − v0
/// (x, y, z each). Sphere: rows 0–2 its centre, row 3 its radius, and its bit set in `spheres`.
/// 160 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Leaf {
    rows: [[f32; LANES]; 9],
    /// The slot (position in obvhs's leaf order) of lane 0's primitive; lane i's is `first + i`.
    first: u32,
    /// Bit i set when lane i is a sphere.
    spheres: u16,
    /// Lanes in use (1–4), from lane 0.
    count: u16,
}

/// A ray spread over the lanes: origin and direction, each component in every lane.
#[derive(Clone, Copy)]
pub(super) struct LaneRay {
    origin: [Vec4; 3],
    dir: [Vec4; 3],
    o: Vec3A,
    d: Vec3A,
}

impl LaneRay {
    #[inline(always)]
    pub(super) fn new(origin: Vec3A, dir: Vec3A) -> Self {
        LaneRay {
            origin: [origin.x, origin.y, origin.z].map(Vec4::splat),
            dir: [dir.x, dir.y, dir.z].map(Vec4::splat),
            o: origin,
            d: dir,
        }
    }
}

impl Leaf {
    /// The leaf of `prims` (one to [`LANES`]), which are the primitives of slots `first`, `first + 1`, ….
    pub(super) fn new(first: u32, prims: impl ExactSizeIterator<Item = Prim>) -> Leaf {
        assert!((1..=LANES).contains(&prims.len()), "a leaf of {} primitives", prims.len());
        let mut leaf = Leaf { rows: [[0.0; LANES]; 9], first, spheres: 0, count: prims.len() as u16 };
        for (i, p) in prims.enumerate() {
            let v = [p.a.x, p.a.y, p.a.z, p.b.x, p.b.y, p.b.z, p.c.x, p.c.y, p.c.z];
            for (row, x) in leaf.rows.iter_mut().zip(v) {
                row[i] = x;
            }
            if p.a.w == KIND_SPHERE {
                leaf.spheres |= 1 << i;
            }
        }
        leaf
    }

    /// Lanes in use.
    pub(super) fn len(&self) -> usize {
        self.count as usize
    }

    /// The slot of lane 0's primitive.
    #[inline(always)]
    pub(super) fn first(&self) -> u32 {
        self.first
    }

    /// The primitive of lane `i` (below [`Leaf::len`]).
    fn prim(&self, i: usize) -> Prim {
        let r = |k: usize| self.rows[k][i];
        let kind = if self.spheres & (1 << i) != 0 { KIND_SPHERE } else { KIND_TRIANGLE };
        Prim {
            a: Vec4::new(r(0), r(1), r(2), kind),
            b: Vec4::new(r(3), r(4), r(5), 0.0),
            c: Vec4::new(r(6), r(7), r(8), 0.0),
        }
    }

    /// The triangle of lane `i` (a triangle's lane below [`Leaf::len`]).
    #[inline(always)]
    pub(super) fn triangle(&self, i: usize) -> TriangleRecord {
        let r = |k: usize| self.rows[k][i];
        TriangleRecord {
            v0: Vec3A::new(r(0), r(1), r(2)),
            e1: Vec3A::new(r(3), r(4), r(5)),
            e2: Vec3A::new(r(6), r(7), r(8)),
        }
    }

    /// The nearest hit of the leaf's primitives with t in (0, `t_max`), as (lane, t, b1, b2)
    /// (barycentrics zero for a sphere); with `ANY`, the lowest lane hit.
    #[inline(always)]
    pub(super) fn intersect<const ANY: bool>(&self, ray: &LaneRay, t_max: f32) -> Option<(u32, f32, f32, f32)> {
        if self.spheres != 0 {
            return self.intersect_each(ray, t_max);
        }
        let [v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z] = self.rows.map(Vec4::from_array);
        let [ox, oy, oz] = ray.origin;
        let [dx, dy, dz] = ray.dir;
        // pvec = d × e2, det = e1 · pvec (glam: x = a.y b.z − a.z b.y, dot = (x x' + y y') + z z').
        let (px, py, pz) = (dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x);
        let det = e1x * px + e1y * py + e1z * pz;
        let inv_det = Vec4::ONE / det;
        let (tx, ty, tz) = (ox - v0x, oy - v0y, oz - v0z);
        let b1 = (tx * px + ty * py + tz * pz) * inv_det;
        // qvec = tvec × e1.
        let (qx, qy, qz) = (ty * e1z - tz * e1y, tz * e1x - tx * e1z, tx * e1y - ty * e1x);
        let b2 = (dx * qx + dy * qy + dz * qz) * inv_det;
        let t = (e2x * qx + e2y * qy + e2z * qz) * inv_det;
        // Every comparison is false on NaN, as the scalar test's are.
        let hit = det.cmpne(Vec4::ZERO)
            & b1.cmpge(Vec4::ZERO)
            & b1.cmple(Vec4::ONE)
            & b2.cmpge(Vec4::ZERO)
            & (b1 + b2).cmple(Vec4::ONE)
            & t.cmpgt(Vec4::ZERO)
            & t.cmplt(Vec4::splat(t_max));
        let mut mask = hit.bitmask();
        if mask == 0 {
            return None;
        }
        let t = t.to_array();
        let mut lane = mask.trailing_zeros() as usize;
        if !ANY {
            mask &= mask - 1;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if t[i] < t[lane] {
                    lane = i;
                }
            }
        }
        Some((lane as u32, t[lane], b1.to_array()[lane], b2.to_array()[lane]))
    }

    /// [`Leaf::intersect`] one lane at a time with each primitive's own test (leaves with spheres).
    #[cold]
    fn intersect_each(&self, ray: &LaneRay, mut t_max: f32) -> Option<(u32, f32, f32, f32)> {
        let mut best = None;
        for i in 0..self.len() {
            if let Some((t, b1, b2)) = self.prim(i).intersect(ray.o, ray.d, t_max) {
                t_max = t;
                best = Some((i as u32, t, b1, b2));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{in_box, uniform_dir};
    use super::*;
    use crate::math::Vec3;
    use crate::sampling::chi2::TestRng;

    /// Every lane gives the bits of the one-triangle test, and the leaf keeps the nearest hit
    /// (lowest lane on a tie), as the scalar loop over the leaf's slots: random triangles with
    /// random rays, rays aimed at a vertex, an edge and a shared vertex, and a degenerate triangle.
    #[test]
    fn lanes_give_the_bits_of_one_triangle_at_a_time() {
        let mut rng = TestRng::new(11);
        let (mut hits, mut several) = (0, 0);
        for k in 0..20_000 {
            let n = 1 + k % 3;
            let mut tris: Vec<TriangleRecord> = (0..n)
                .map(|_| TriangleRecord::new([in_box(&mut rng, 1.0), in_box(&mut rng, 1.0), in_box(&mut rng, 1.0)]))
                .collect();
            if k % 7 == 0 {
                // A triangle sharing its first vertex with lane 0's, and a degenerate one.
                let v = tris[0].v0.into();
                tris.push(TriangleRecord::new([v, in_box(&mut rng, 1.0), in_box(&mut rng, 1.0)]));
                tris.truncate(LANES);
                let last = tris.len() - 1;
                if last > 1 {
                    tris[last] = TriangleRecord::new([v, v, in_box(&mut rng, 1.0)]);
                }
            }
            let origin = in_box(&mut rng, 3.0);
            let target = match k % 4 {
                0 => in_box(&mut rng, 1.0),
                1 => Vec3::from(tris[0].v0),
                2 => Vec3::from(tris[0].v0 + 0.5 * tris[0].e1),
                _ => origin + uniform_dir(&mut rng),
            };
            let (o, d) = (Vec3A::from(origin), Vec3A::from((target - origin).normalize()));
            let t_max = if k % 5 == 0 { 2.0 } else { f32::INFINITY };
            let mut expected = None;
            let mut t_best = t_max;
            let mut n_hit = 0;
            for (i, tri) in tris.iter().enumerate() {
                if let Some((t, b1, b2)) = tri.intersect(o, d, t_best) {
                    t_best = t;
                    expected = Some((i as u32, t.to_bits(), b1.to_bits(), b2.to_bits()));
                }
                n_hit += tri.intersect(o, d, t_max).is_some() as usize;
            }
            let leaf = Leaf::new(0, tris.iter().map(Prim::triangle));
            let bits =
                |h: Option<(u32, f32, f32, f32)>| h.map(|(l, t, b1, b2)| (l, t.to_bits(), b1.to_bits(), b2.to_bits()));
            let ray = LaneRay::new(o, d);
            assert_eq!(bits(leaf.intersect::<false>(&ray, t_max)), expected, "case {k}: {tris:?}, {o}, {d}");
            let any = leaf.intersect::<true>(&ray, t_max);
            assert_eq!(any.is_some(), expected.is_some(), "case {k}");
            hits += expected.is_some() as usize;
            several += (n_hit > 1) as usize;
        }
        assert!(hits > 5_000 && several > 300, "{hits} hits, {several} leaves hit more than once");
    }
}
