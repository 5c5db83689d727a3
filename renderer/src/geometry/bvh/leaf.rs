//! The primitives of a node's leaf children, four to a block in structure-of-arrays form, so
//! that one Möller–Trumbore test covers four of them.
//!
//! obvhs's conversion gives a node up to eight children, and its cost model (made for GPUs, where
//! a leaf child's box is tested with its node's) spreads the primitives over as many leaf
//! children as it can: on the 1.31 M-triangle icosphere a leaf child holds 1.44 primitives on
//! average. So the walk does not visit leaf children one by one. The primitives of all of a
//! node's leaf children are stored together, in obvhs's order, as [`Block`] blocks of four lanes,
//! and a leaf child's reference is the mask of its lanes in that run. After the node test the
//! walk ORs the masks of the leaf children the ray meets and tests each block that holds one of
//! those lanes once, the other lanes masked off: one straight run of arithmetic and one mask per
//! four primitives, and no stack traffic. Lanes no leaf child owns are degenerate triangles (all
//! zero), which the determinant test rejects, and are masked off as well.
//!
//! **Same bits as one triangle at a time.** Each lane performs the operations of
//! [`TriangleRecord::intersect`] in the same order (glam's `cross` and `dot` as written out
//! below, no fused multiply-add), so t and the barycentrics are those of the scalar test bit for
//! bit; of several hits the nearest is kept, the lowest lane on a tie.
//!
//! A block holding a sphere (scenes mixing spheres and meshes) is tested lane by lane with each
//! primitive's own test.

use super::{KIND_SPHERE, KIND_TRIANGLE, Prim, PrimRef};
use crate::geometry::mesh::TriangleRecord;
use glam::{Vec3A, Vec4};

/// Lanes of a block: the SIMD width (a lane id is a block's index × `LANES` + its lane).
pub(super) const LANES: usize = 4;

/// Four primitives, lane by lane (a node's leaf primitives in obvhs's order); a lane is one
/// primitive or unused (all zero). Triangle: rows 0–2 v0, 3–5 e1 = v1 − v0, 6–8
/// e2 = v2 − v0 (x, y, z each). Sphere: rows 0–2 its centre, row 3 its radius, and its bit set in
/// `spheres`. Each lane's object and index beside them, so that a hit finds its primitive in the
/// block the walk has just read rather than in a table at a random address. 192 bytes, three
/// cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Block {
    rows: [[f32; LANES]; 9],
    /// Lane i's object and index inside it (unused lanes: zero).
    refs: [PrimRef; LANES],
    /// Bit i set when lane i is a sphere.
    spheres: u32,
}

// The size stated above: three whole cache lines (64-byte aligned).
const _: () = assert!(size_of::<Block>() == 192);

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

impl Block {
    /// The block whose lane i holds `prims[i]` (`None`: unused): a primitive's record and its
    /// object and index.
    pub(super) fn new(prims: [Option<(Prim, PrimRef)>; LANES]) -> Block {
        let mut block = Block { rows: [[0.0; LANES]; 9], refs: [PrimRef { object: 0, index: 0 }; LANES], spheres: 0 };
        for (i, p) in prims.iter().enumerate() {
            let Some((p, r)) = p else { continue };
            block.refs[i] = *r;
            let v = [p.a.x, p.a.y, p.a.z, p.b.x, p.b.y, p.b.z, p.c.x, p.c.y, p.c.z];
            for (row, x) in block.rows.iter_mut().zip(v) {
                row[i] = x;
            }
            if p.a.w == KIND_SPHERE {
                block.spheres |= 1 << i;
            }
        }
        block
    }

    /// The object and index of lane `i`'s primitive (a lane in use).
    #[inline(always)]
    pub(super) fn prim_ref(&self, i: usize) -> PrimRef {
        self.refs[i]
    }

    /// The primitive of lane `i` (a lane in use).
    fn prim(&self, i: usize) -> Prim {
        let r = |k: usize| self.rows[k][i];
        let kind = if self.spheres & (1 << i) != 0 { KIND_SPHERE } else { KIND_TRIANGLE };
        Prim {
            a: Vec4::new(r(0), r(1), r(2), kind),
            b: Vec4::new(r(3), r(4), r(5), 0.0),
            c: Vec4::new(r(6), r(7), r(8), 0.0),
        }
    }

    /// The triangle of lane `i` (a triangle's lane).
    #[inline(always)]
    pub(super) fn triangle(&self, i: usize) -> TriangleRecord {
        let r = |k: usize| self.rows[k][i];
        TriangleRecord {
            v0: Vec3A::new(r(0), r(1), r(2)),
            e1: Vec3A::new(r(3), r(4), r(5)),
            e2: Vec3A::new(r(6), r(7), r(8)),
        }
    }

    /// The nearest hit of the primitives of lanes `want` (bit i: lane i, lanes in use) with t in
    /// (0, `t_max`), as (lane, t, b1, b2) (barycentrics zero for a sphere); with `ANY`, the lowest
    /// lane hit.
    #[inline(always)]
    pub(super) fn intersect<const ANY: bool>(
        &self,
        ray: &LaneRay,
        t_max: f32,
        want: u32,
    ) -> Option<(u32, f32, f32, f32)> {
        if self.spheres != 0 {
            return self.intersect_each(ray, t_max, want);
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
        let mut mask = hit.bitmask() & want;
        if mask == 0 {
            return None;
        }
        let t = t.to_array();
        let mut lane = mask.trailing_zeros() as usize & (LANES - 1);
        if !ANY {
            mask &= mask - 1;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize & (LANES - 1);
                mask &= mask - 1;
                if t[i] < t[lane] {
                    lane = i;
                }
            }
        }
        Some((lane as u32, t[lane], b1.to_array()[lane], b2.to_array()[lane]))
    }

    /// [`Block::intersect`] one lane at a time with each primitive's own test (blocks with spheres).
    #[cold]
    fn intersect_each(&self, ray: &LaneRay, mut t_max: f32, mut want: u32) -> Option<(u32, f32, f32, f32)> {
        let mut best = None;
        while want != 0 {
            let i = want.trailing_zeros() as usize;
            want &= want - 1;
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

    /// Every lane gives the bits of the one-triangle test, and the block keeps the nearest hit of
    /// the lanes asked for (lowest lane on a tie), as a scalar loop over those lanes: random
    /// triangles with random rays, rays aimed at a vertex, an edge and a shared vertex, a
    /// degenerate triangle, unused lanes, and masks that leave lanes out.
    #[test]
    fn lanes_give_the_bits_of_one_triangle_at_a_time() {
        let mut rng = TestRng::new(11);
        let (mut hits, mut several) = (0, 0);
        for k in 0..20_000 {
            let n = 1 + k % LANES;
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
            // Every lane in use, or a random non-empty subset of them.
            let used = (1u32 << tris.len()) - 1;
            let want = if k % 3 == 0 { used } else { (rng.next_f32() * used as f32) as u32 % used + 1 };
            let mut expected = None;
            let mut t_best = t_max;
            let mut n_hit = 0;
            for (i, tri) in tris.iter().enumerate().filter(|&(i, _)| want & (1 << i) != 0) {
                if let Some((t, b1, b2)) = tri.intersect(o, d, t_best) {
                    t_best = t;
                    expected = Some((i as u32, t.to_bits(), b1.to_bits(), b2.to_bits()));
                }
                n_hit += tri.intersect(o, d, t_max).is_some() as usize;
            }
            let block = Block::new(std::array::from_fn(|i| {
                tris.get(i).map(|t| (Prim::triangle(t), PrimRef { object: 0, index: i as u32 }))
            }));
            let bits =
                |h: Option<(u32, f32, f32, f32)>| h.map(|(l, t, b1, b2)| (l, t.to_bits(), b1.to_bits(), b2.to_bits()));
            let ray = LaneRay::new(o, d);
            let got = block.intersect::<false>(&ray, t_max, want);
            assert_eq!(bits(got), expected, "case {k}: lanes {want:b} of {tris:?}, {o}, {d}");
            let any = block.intersect::<true>(&ray, t_max, want);
            assert_eq!(any.is_some(), expected.is_some(), "case {k}");
            hits += expected.is_some() as usize;
            several += (n_hit > 1) as usize;
        }
        assert!(hits > 3_500 && several > 300, "{hits} hits, {several} blocks hit more than once");
    }
}
