//! The scene's geometry: every object (spheres and triangle meshes) in one bounding volume
//! hierarchy.
//!
//! - One obvhs compressed wide BVH8 (`CwBvh`, Ylitie et al. 2017) is built over the AABBs of all
//!   primitives: each triangle of each mesh, and each sphere as a single custom primitive. The
//!   binary tree it is converted from is obvhs's PLOC tree, or an object-median tree where PLOC
//!   degenerates or builds too deep a tree (`build_cwbvh`): no input makes the conversion's
//!   recursion or the walk's stack overflow.
//! - After the build the primitive records are made node by node (`bvh/leaf.rs`): the primitives
//!   of all of a node's leaf children in blocks of four lanes, triangles as (v0, e1, e2) for
//!   Möller–Trumbore, tested four at once; spheres as (centre, radius), tested one by one. Each
//!   lane carries its primitive's object and index, so that a hit names its primitive from the
//!   block it was found in, without a table read at a random address.
//! - The finished tree is decoded into nodes with float planes (`bvh/wide.rs`), which a ray
//!   walks nearest child first, with a conservative slab test of eight children at once (AVX2
//!   chosen at run time, SSE2 otherwise; same bits); the leaf children it meets are tested at the
//!   node, the blocks holding their lanes once each. Two kinds of load are started before they are
//!   needed: the internal children a ray leaves on its stack, and, as a visit starts, the node's
//!   first leaf blocks (from a table of each node's first block, so that the blocks do not wait
//!   for the node's own lines). Any hit (`occluded`) stops at the first primitive hit. The renderer's
//!   any-hit rays, eight or sixteen of one pixel's samples at a time, walk it as packets
//!   (`bvh/packet.rs`, [`SceneGeometry::occluded_packet`]), which visit a node once for all of
//!   their rays that entered it and give each ray its own walk's answer.
//!   The compressed tree itself is dropped after the decoding (the tests keep it for obvhs's own
//!   traversal, their oracle).
//! - A scene that is a single sphere bypasses the BVH (one analytic test per ray), and an empty
//!   scene always misses.
//!
//! Parameters: `BUILD_PARAMS` (the obvhs build preset, chosen so 1.3 M triangles build in ~1 s
//! on one core while keeping traversal fast: on the 1.3 M-triangle icosphere, a higher PLOC search
//! radius or 6× more reinsertion changed the nodes visited per hitting ray by < 2% (14.1 → 13.9)
//! at 2–3× the build time).
//!
//! Hits have t in (0, t_max) for triangles and above the round-off of the root for spheres (see
//! [`super::sphere`]); the closest hit is exact up to the triangle test's rounding where several
//! triangles are hit at nearly the same t (`bvh/wide.rs`); rays with non-finite origin or
//! direction hit nothing.

use super::mesh::TriangleRecord;
use super::{Hit, PrimitiveHit, Ray, Shape, Sphere};
use crate::math::Vec3;
use glam::{Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
/// obvhs's build settings, for [`SceneGeometry::with_build_params`] (`benches/bvh.rs` tunes them).
pub use obvhs::{BvhBuildParams, ploc::PlocSearchDistance, ploc::SortPrecision};

/// The most primitives (triangles and spheres) one scene's BVH holds: 2^29, within what its slots
/// and lane ids (`u32`) address (`bvh/wide.rs`). Scene files beyond it are refused when they are
/// built.
pub const MAX_PRIMITIVES: usize = wide::MAX_SLOTS;
use std::time::{Duration, Instant};

mod leaf;
mod packet;
mod wide;

pub use packet::PACKET;

/// The build preset: PLOC with a medium search radius, a small reinsertion pass, up to 3
/// primitives per leaf (the CwBvh maximum).
pub const BUILD_PARAMS: BvhBuildParams = BvhBuildParams {
    pre_split: false,
    ploc_search_distance: PlocSearchDistance::Medium,
    search_depth_threshold: 3,
    reinsertion_batch_ratio: 0.05,
    post_collapse_reinsertion_batch_ratio_multiplier: 0.0,
    sort_precision: SortPrecision::U64,
    max_prims_per_leaf: 3,
    collapse_traversal_cost: 3.0,
};

const KIND_TRIANGLE: f32 = 0.0;
const KIND_SPHERE: f32 = 1.0;

/// One BVH primitive's record, as a block of leaf primitives is made of them and as a lane of a
/// block holding a sphere is tested (`bvh/leaf.rs`). Triangle: a = (v0, 0), b = (e1, ·), c = (e2, ·).
/// Sphere: a = (centre, 1), b = (radius, ·, ·, ·).
#[derive(Clone, Copy, Debug)]
struct Prim {
    a: Vec4,
    b: Vec4,
    c: Vec4,
}

impl Prim {
    fn triangle(t: &TriangleRecord) -> Self {
        Prim { a: t.v0.extend(KIND_TRIANGLE), b: t.e1.extend(0.0), c: t.e2.extend(0.0) }
    }
    fn sphere(s: &Sphere) -> Self {
        Prim { a: s.center.extend(KIND_SPHERE), b: Vec4::new(s.radius, 0.0, 0.0, 0.0), c: Vec4::ZERO }
    }
    #[inline(always)]
    fn as_triangle(&self) -> TriangleRecord {
        TriangleRecord { v0: Vec3A::from_vec4(self.a), e1: Vec3A::from_vec4(self.b), e2: Vec3A::from_vec4(self.c) }
    }
    #[inline(always)]
    fn as_sphere(&self) -> Sphere {
        Sphere { center: self.a.truncate(), radius: self.b.x }
    }
    /// Closest hit distance in (0, t_max) with the triangle's barycentrics (zero for spheres).
    #[inline(always)]
    fn intersect(&self, origin: Vec3A, dir: Vec3A, t_max: f32) -> Option<(f32, f32, f32)> {
        if self.a.w == KIND_TRIANGLE {
            self.as_triangle().intersect(origin, dir, t_max)
        } else {
            self.as_sphere().intersect_t(origin.into(), dir.into(), t_max).map(|t| (t, 0.0, 0.0))
        }
    }
}

/// Which object a primitive belongs to and its index inside the object.
#[derive(Clone, Copy, Debug)]
struct PrimRef {
    object: u32,
    index: u32,
}

pub struct SceneGeometry {
    pub shapes: Vec<Shape>,
    /// obvhs's tree, kept in tests for its own traversal (the oracle of the walk's hits).
    #[cfg(test)]
    bvh: Option<CwBvh>,
    /// The tree every ray walks: obvhs's, with float planes (`bvh/wide.rs`); `None` for an empty
    /// scene and a single sphere.
    wide: Option<wide::WideBvh>,
    /// For each slot (position in obvhs's leaf order), its primitive's object and index, for the
    /// tests' oracles (the walk reads them from the blocks).
    #[cfg(test)]
    refs: Vec<PrimRef>,
    /// Primitives in the BVH.
    num_prims: usize,
    /// The primitives' records by slot, for the tests' oracles (the walk reads the leaves').
    #[cfg(test)]
    prims: Vec<Prim>,
    /// Fast path for a scene that is exactly one sphere.
    single_sphere: Option<Sphere>,
    build_time: Duration,
}

impl SceneGeometry {
    /// Builds the BVH over all objects; `shapes[i]` is object i.
    pub fn new(shapes: Vec<Shape>) -> Self {
        Self::with_build_params(shapes, BUILD_PARAMS)
    }

    /// [`SceneGeometry::new`] with other obvhs build settings than [`BUILD_PARAMS`] (for tuning
    /// them: `benches/bvh.rs`). The hits are the same whatever the settings (closest hit).
    ///
    /// # Panics
    /// If the shapes hold more than [`MAX_PRIMITIVES`] primitives (a scene file's are checked
    /// before: `Scene::build`).
    pub fn with_build_params(shapes: Vec<Shape>, params: BvhBuildParams) -> Self {
        let start = Instant::now();
        if let [Shape::Sphere(s)] = shapes.as_slice() {
            let single_sphere = Some(*s);
            return SceneGeometry {
                shapes,
                #[cfg(test)]
                bvh: None,
                wide: None,
                #[cfg(test)]
                refs: Vec::new(),
                num_prims: 1,
                #[cfg(test)]
                prims: Vec::new(),
                single_sphere,
                build_time: start.elapsed(),
            };
        }

        // Primitive k of the build is primitive k − first[o] of object o, where first[o] ≤ k < first[o + 1].
        let count: usize = shapes.iter().map(Shape::primitive_count).sum();
        assert!(count <= MAX_PRIMITIVES, "{count} primitives, more than the {MAX_PRIMITIVES} a BVH holds");
        let mut first = Vec::with_capacity(shapes.len() + 1);
        first.push(0u32);
        for shape in &shapes {
            // Below 2^29 in all: no overflow.
            first.push(first.last().unwrap() + shape.primitive_count() as u32);
        }
        let aabbs = || {
            let mut aabbs = Vec::with_capacity(count);
            for shape in &shapes {
                match shape {
                    Shape::Sphere(s) => {
                        let (lo, hi) = s.bounds();
                        aabbs.push(Aabb::new(lo.into(), hi.into()));
                    }
                    Shape::Mesh(m) => {
                        for i in 0..m.triangles.len() {
                            let v = m.vertices(i);
                            let mut bb = Aabb::from_point(v[0].into());
                            bb.extend(v[1].into()).extend(v[2].into());
                            aabbs.push(bb);
                        }
                    }
                }
            }
            aabbs
        };

        let (bvh, wide) = if count == 0 {
            (None, None)
        } else {
            let bvh = build_cwbvh(aabbs, params);
            // The leaves' records and the references are made after the build, in leaf order:
            // they and the build's boxes are never in memory together with the build's largest
            // buffers (guide, "Performance notes and their history": peak memory).
            let locate = |k: u32| {
                let object = first.partition_point(|&f| f <= k) - 1;
                (object, k - first[object])
            };
            let prim = |slot: u32| {
                let (object, index) = locate(bvh.primitive_indices[slot as usize]);
                let p = match &shapes[object] {
                    Shape::Sphere(s) => Prim::sphere(s),
                    Shape::Mesh(m) => Prim::triangle(&TriangleRecord::new(m.vertices(index as usize))),
                };
                (p, PrimRef { object: object as u32, index })
            };
            let wide = wide::WideBvh::new(&bvh, prim);
            // The tests' oracle walks obvhs's tree, by slot.
            #[cfg(test)]
            let wide = (wide, (0..count as u32).map(prim).unzip());
            (Some(bvh), Some(wide))
        };
        #[cfg(test)]
        let (wide, (prims, refs)) = match wide {
            Some((w, p)) => (Some(w), p),
            None => (None, (Vec::new(), Vec::new())),
        };
        // Only the tests walk obvhs's own tree (their oracle).
        #[cfg(not(test))]
        drop(bvh);
        SceneGeometry {
            shapes,
            #[cfg(test)]
            bvh,
            wide,
            #[cfg(test)]
            refs,
            num_prims: count,
            #[cfg(test)]
            prims,
            single_sphere: None,
            build_time: start.elapsed(),
        }
    }

    /// True when the scene is exactly one sphere: nothing can occlude a direction above the
    /// horizon of any of its points (the integrator then skips those shadow rays).
    pub fn is_single_sphere(&self) -> bool {
        self.single_sphere.is_some()
    }

    /// The sphere of a scene made of one sphere alone (object 0; see
    /// [`SceneGeometry::is_single_sphere`]): [`SceneGeometry::intersect`] is its intersection.
    #[inline]
    pub fn single_sphere(&self) -> Option<&Sphere> {
        self.single_sphere.as_ref()
    }

    /// Number of BVH primitives (triangles plus spheres); 1 for the single-sphere fast path.
    pub fn num_primitives(&self) -> usize {
        self.num_prims
    }

    /// Wall time of [`SceneGeometry::new`] (primitive setup, BVH build and reordering).
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// A NaN/infinite origin or direction would poison the slab tests (and trip obvhs's debug
    /// assertions); such a ray hits nothing.
    #[inline(always)]
    fn is_valid(ray: &Ray) -> bool {
        ray.origin.is_finite() && ray.dir.is_finite()
    }

    /// The ray as obvhs's traversal takes it (for the tests' oracle).
    #[cfg(test)]
    fn bvh_ray(ray: &Ray) -> obvhs::ray::Ray {
        // obvhs takes the ray octant from `d < 0` but the slab sign from signum(d): a −0.0
        // component would disagree between the two and miss whole subtrees, so map it to +0.0
        // (x + 0.0 = +0.0 for x = −0.0 and x otherwise).
        let dir = Vec3A::from(ray.dir) + Vec3A::ZERO;
        obvhs::ray::Ray::new(ray.origin.into(), dir, 0.0, ray.t_max)
    }

    /// Closest hit with t in (0, ray.t_max): the closest of every primitive's hit, the same t bit
    /// for bit, except where several triangles are hit at nearly the same t (a ray through a shared
    /// edge or vertex): then one of them, whose t exceeds the least by the triangle test's rounding,
    /// always the same one for a ray (`bvh/wide.rs`).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if let Some(s) = &self.single_sphere {
            return s.intersect(ray, 0);
        }
        let wide = self.wide.as_ref()?;
        if !Self::is_valid(ray) {
            return None;
        }
        let (id, t, b1, b2) = self.walk_wide_here::<false>(wide, ray)?;
        // The block was just read: its lane gives the triangle without another miss.
        Some(self.make_hit(ray, wide.prim_ref(id), || wide.triangle(id), t, (b1, b2)))
    }

    /// The closest hit as [`SceneGeometry::intersect`] finds it (the same t, bit for bit), without
    /// the hit record's point and normals: the primitive, its distance and barycentrics. What a
    /// caller needs that shades nothing (visibility, distances), and the query Embree's
    /// `rtcIntersect1` answers (`benches/bvh.rs` times both).
    #[inline]
    pub fn intersect_primitive(&self, ray: &Ray) -> Option<PrimitiveHit> {
        if let Some(s) = &self.single_sphere {
            let t = s.intersect_t(ray.origin, ray.dir, ray.t_max)?;
            return Some(PrimitiveHit { t, b1: 0.0, b2: 0.0, object: 0, index: 0 });
        }
        let wide = self.wide.as_ref()?;
        if !Self::is_valid(ray) {
            return None;
        }
        let (id, t, b1, b2) = self.walk_wide_here::<false>(wide, ray)?;
        let r = wide.prim_ref(id);
        Some(PrimitiveHit { t, b1, b2, object: r.object, index: r.index })
    }

    /// [`SceneGeometry::walk_wide`] in the copy this CPU runs: AVX2 where [`avx2_walk`] holds,
    /// SSE2 otherwise (the same bits, tested).
    #[inline(always)]
    fn walk_wide_here<const ANY: bool>(&self, wide: &wide::WideBvh, ray: &Ray) -> Option<(u32, f32, f32, f32)> {
        if avx2_walk() {
            // SAFETY: avx2_walk() found every feature walk_wide_avx2 is compiled for.
            unsafe { self.walk_wide_avx2::<ANY>(wide, ray) }
        } else {
            self.walk_wide::<ANY, false>(wide, ray)
        }
    }

    /// [`SceneGeometry::walk_wide`] compiled for AVX2 and the bit instructions of [`avx2_walk`]'s
    /// list (the child choice's TZCNT and BLSR are BMI1). Run-time dispatch: call only where
    /// [`avx2_walk`] holds, which checks exactly these features.
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,popcnt,lzcnt,bmi1,bmi2"))]
    fn walk_wide_avx2<const ANY: bool>(&self, wide: &wide::WideBvh, ray: &Ray) -> Option<(u32, f32, f32, f32)> {
        self.walk_wide::<ANY, true>(wide, ray)
    }

    /// Assembles the hit record of primitive `r` (a triangle: `triangle()` its record) at distance `t`.
    #[inline]
    fn make_hit(
        &self,
        ray: &Ray,
        r: PrimRef,
        triangle: impl FnOnce() -> TriangleRecord,
        t: f32,
        (b1, b2): (f32, f32),
    ) -> Hit {
        match &self.shapes[r.object as usize] {
            Shape::Sphere(s) => s.hit_at(ray, t, r.object),
            Shape::Mesh(m) => {
                let tri = triangle();
                // Barycentric interpolation is more accurate than o + t d (pbrt 4, §6.8.6).
                let p = Vec3::from(tri.v0 + b1 * tri.e1 + b2 * tri.e2);
                let ng = Vec3::from(tri.e1.cross(tri.e2)).normalize_or_zero();
                let n = m.shading_normal(r.index as usize, b1, b2, ng);
                Hit { t, p, n, ng, object: r.object }
            }
        }
    }

    /// Any hit with t in (0, ray.t_max); stops at the first primitive hit (children in node
    /// order, not sorted by distance).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if let Some(s) = &self.single_sphere {
            return s.intersect_t(ray.origin, ray.dir, ray.t_max).is_some();
        }
        let Some(wide) = self.wide.as_ref() else { return false };
        if !Self::is_valid(ray) {
            return false;
        }
        self.walk_wide_here::<true>(wide, ray).is_some()
    }

    /// Which of `N` = 8 or 16 rays hit something (bit r: `rays[r]`, for the bits of `want`):
    /// [`SceneGeometry::occluded`] of each, walked as one packet (`bvh/packet.rs`), the same
    /// answers whatever rays share the packet. Any other `N` fails to compile.
    #[inline]
    pub fn occluded_packet<const N: usize>(&self, rays: &[Ray; N], want: u32) -> u32 {
        let Some(wide) = self.wide.as_ref().filter(|_| self.single_sphere.is_none()) else {
            let mut out = 0;
            for (r, ray) in rays.iter().enumerate() {
                out |= ((want & (1 << r) != 0 && self.occluded(ray)) as u32) << r;
            }
            return out;
        };
        let valid = Self::valid_rays(rays, want);
        if avx2_walk() {
            // SAFETY: avx2_walk() found every feature walk_packet_avx2 is compiled for.
            unsafe { self.walk_packet_avx2::<N>(wide, rays, valid) }
        } else {
            self.walk_packet::<false, N>(wide, rays, valid)
        }
    }

    /// The bits of `want` whose ray is valid (`is_valid`).
    #[inline(always)]
    fn valid_rays<const N: usize>(rays: &[Ray; N], want: u32) -> u32 {
        let mut valid = 0;
        for (r, ray) in rays.iter().enumerate() {
            valid |= (Self::is_valid(ray) as u32) << r;
        }
        valid & want
    }

    /// [`SceneGeometry::walk_packet`] compiled for AVX2 (as `walk_wide_avx2`).
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,popcnt,lzcnt,bmi1,bmi2"))]
    fn walk_packet_avx2<const N: usize>(&self, wide: &wide::WideBvh, rays: &[Ray; N], want: u32) -> u32 {
        self.walk_packet::<true, N>(wide, rays, want)
    }

    /// The closest hit through obvhs's own `traverse!` loop and node test on its compressed tree:
    /// the oracle of the tests.
    #[cfg(test)]
    fn intersect_obvhs(&self, ray: &Ray) -> Option<Hit> {
        use glam::UVec2; // named by obvhs's `traverse!`
        if let Some(s) = &self.single_sphere {
            return s.intersect(ray, 0);
        }
        let bvh = self.bvh.as_ref()?;
        if !Self::is_valid(ray) {
            return None;
        }
        let mut traverse_ray = Self::bvh_ray(ray);
        let mut state = bvh.new_traversal(traverse_ray.direction);
        let mut node;
        let mut best: Option<(u32, f32, f32, f32)> = None;
        obvhs::traverse!(bvh, node, state, node.intersect_ray(&traverse_ray, state.oct_inv4), {
            let slot = state.primitive_id;
            let p = &self.prims[slot as usize];
            if let Some((t, b1, b2)) = p.intersect(traverse_ray.origin, traverse_ray.direction, traverse_ray.tmax) {
                traverse_ray.tmax = t;
                best = Some((slot, t, b1, b2));
            }
        });
        let (slot, t, b1, b2) = best?;
        Some(self.make_hit(ray, self.refs[slot as usize], || self.prims[slot as usize].as_triangle(), t, (b1, b2)))
    }

    /// Any hit through obvhs's `ray_traverse_miss` on its compressed tree; for tests.
    #[cfg(test)]
    fn occluded_obvhs(&self, ray: &Ray) -> bool {
        if let Some(s) = &self.single_sphere {
            return s.intersect_t(ray.origin, ray.dir, ray.t_max).is_some();
        }
        let Some(bvh) = self.bvh.as_ref() else { return false };
        if !Self::is_valid(ray) {
            return false;
        }
        !bvh.ray_traverse_miss(Self::bvh_ray(ray), |r, slot| {
            match self.prims[slot].intersect(r.origin, r.direction, r.tmax) {
                Some((t, ..)) => t,
                None => f32::INFINITY,
            }
        })
    }

    /// Reference closest hit by testing every primitive of every shape (no BVH); for tests.
    pub fn intersect_brute_force(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        for (object, shape) in self.shapes.iter().enumerate() {
            let object = object as u32;
            match shape {
                Shape::Sphere(s) => {
                    if let Some(t) = s.intersect_t(ray.origin, ray.dir, t_max) {
                        t_max = t;
                        best = Some(s.hit_at(ray, t, object));
                    }
                }
                Shape::Mesh(m) => {
                    for i in 0..m.triangles.len() {
                        let tri = TriangleRecord::new(m.vertices(i));
                        if let Some((t, b1, b2)) = tri.intersect(o, d, t_max) {
                            t_max = t;
                            let p = Vec3::from(tri.v0 + b1 * tri.e1 + b2 * tri.e2);
                            let ng = Vec3::from(tri.e1.cross(tri.e2)).normalize_or_zero();
                            let n = m.shading_normal(i, b1, b2, ng);
                            best = Some(Hit { t, p, n, ng, object });
                        }
                    }
                }
            }
        }
        best
    }
}

/// Deepest binary tree handed to obvhs's CwBvh conversion, whose cost pass and node pass recurse
/// once per level (a few hundred bytes of stack each: 64 levels stay far inside any thread's
/// stack). PLOC builds trees of 2–3 × log₂(primitives) levels; degenerate input makes it chain
/// primitives one by one (a fan of slivers sharing a vertex: 100,000 levels, which overflowed a
/// 2 MiB worker stack).
const MAX_BVH2_DEPTH: usize = 64;

/// The scene's CwBvh: obvhs's `build_cwbvh` (PLOC, reinsertion, conversion; the same calls, so the
/// same tree) when PLOC's tree is at most [`MAX_BVH2_DEPTH`] deep and its CwBvh shallower than the
/// traversal stack ([`MAX_CWBVH_DEPTH`]); otherwise the median-split tree of [`median_split_bvh2`], whose depth
/// is ⌈log₂ n⌉ (at most 24 for the 2^24 triangles a scene may hold). Inputs on which PLOC degrades
/// ([`ploc_degenerates`]) skip PLOC, whose passes then merge only a few pairs each (quadratic time).
///
/// `make_aabbs` gives the primitives' boxes; they are dropped once PLOC has built its tree (the
/// reinsertion and the conversion read only the tree), so that they are not in memory beside the
/// conversion's buffers, and made again in the rare case the median split is needed after PLOC.
fn build_cwbvh(make_aabbs: impl Fn() -> Vec<Aabb>, params: BvhBuildParams) -> CwBvh {
    use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
    use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
    let leaf = params.max_prims_per_leaf.clamp(1, 3);
    let aabbs = make_aabbs();
    if ploc_degenerates(&aabbs) {
        return bvh2_to_cwbvh(&median_split_bvh2(&aabbs), leaf, true, false);
    }
    let indices = (0..aabbs.len() as u32).collect();
    let mut bvh2 = obvhs::ploc::PlocBuilder::with_capacity(aabbs.len()).build(
        params.ploc_search_distance,
        &aabbs,
        indices,
        params.sort_precision,
        params.search_depth_threshold,
    );
    drop(aabbs);
    if bvh2_depth(&bvh2) <= MAX_BVH2_DEPTH {
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        if bvh2_depth(&bvh2) <= MAX_BVH2_DEPTH {
            let cw = bvh2_to_cwbvh(&bvh2, leaf, true, false);
            if cwbvh_depth(&cw) < MAX_CWBVH_DEPTH {
                return cw;
            }
        }
    }
    drop(bvh2);
    bvh2_to_cwbvh(&median_split_bvh2(&make_aabbs()), leaf, true, false)
}

/// Levels of a binary tree (1 for a single leaf), walked without recursion.
fn bvh2_depth(bvh2: &obvhs::bvh2::Bvh2) -> usize {
    let mut stack = vec![(0usize, 1usize)];
    let mut deepest = 0;
    while let Some((i, level)) = stack.pop() {
        deepest = deepest.max(level);
        let node = &bvh2.nodes[i];
        if !node.is_leaf() {
            stack.push((node.first_index as usize, level + 1));
            stack.push((node.first_index as usize + 1, level + 1));
        }
    }
    deepest
}

/// Levels of a CwBvh's internal nodes (1 for the root alone): the most node groups a traversal
/// can hold on its stack.
fn cwbvh_depth(bvh: &CwBvh) -> usize {
    let mut stack = vec![(0usize, 1usize)];
    let mut deepest = 0;
    while let Some((i, level)) = stack.pop() {
        deepest = deepest.max(level);
        let node = &bvh.nodes[i];
        for k in 0..node.imask.count_ones() as usize {
            stack.push((node.child_base_idx as usize + k, level + 1));
        }
    }
    deepest
}

/// True when obvhs's PLOC would chain rather than pair. Its first passes pair each node with the
/// neighbour (in Morton order) whose union box has the smaller area, and a pair forms only where
/// both agree, i.e. at the local minima of the neighbours' union areas. Where that area changes
/// monotonically along long runs (slivers sharing a vertex, whose boxes all reach it) only the
/// ends of the runs pair and each pass removes a few nodes instead of a fraction: quadratic time
/// and a chain of a tree. Simulated here for [`PAIRING_PASSES`] passes on the centroids' Morton
/// order: on ordinary meshes each pass pairs a third or more of the nodes (under a quarter of them
/// remain), on a fan of slivers next to none.
fn ploc_degenerates(aabbs: &[Aabb]) -> bool {
    const PAIRING_PASSES: usize = 4;
    // Small inputs build fast whatever PLOC does (the depth checks still apply).
    if aabbs.len() < 4096 {
        return false;
    }
    let mut cb = Aabb::empty();
    for b in aabbs {
        cb.extend(b.center());
    }
    let scale = Vec3A::splat(((1u32 << 21) - 1) as f32) / cb.diagonal().max(Vec3A::splat(f32::MIN_POSITIVE));
    let spread = obvhs::ploc::morton::split_by_3_u64;
    let mut keyed: Vec<(u64, u32)> = aabbs
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let q = ((b.center() - cb.min) * scale).as_uvec3();
            (spread(q.x) << 2 | spread(q.y) << 1 | spread(q.z), i as u32)
        })
        .collect();
    keyed.sort_unstable();
    let mut nodes: Vec<Aabb> = keyed.iter().map(|&(_, i)| aabbs[i as usize]).collect();
    for _ in 0..PAIRING_PASSES {
        let cost: Vec<f32> = nodes.windows(2).map(|w| w[0].union(&w[1]).half_area()).collect();
        let mut next = Vec::with_capacity(nodes.len());
        let mut i = 0;
        while i < nodes.len() {
            // Pair i with i + 1 where both prefer each other: pair (i, i+1) cheaper than (i−1, i)
            // and than (i+1, i+2).
            let left = if i > 0 { cost[i - 1] } else { f32::INFINITY };
            let right = cost.get(i + 1).copied().unwrap_or(f32::INFINITY);
            if i + 1 < nodes.len() && cost[i] <= left && cost[i] < right {
                next.push(nodes[i].union(&nodes[i + 1]));
                i += 2;
            } else {
                next.push(nodes[i]);
                i += 1;
            }
        }
        nodes = next;
    }
    nodes.len() > aabbs.len() / 2
}

/// A binary tree over `aabbs` by recursive object-median splits along the longest axis of the
/// centroids' bounds (ties by index, so the tree is deterministic): ⌈log₂ n⌉ levels whatever the
/// input, O(n log n) time, one primitive per leaf (what obvhs's conversion expects).
fn median_split_bvh2(aabbs: &[Aabb]) -> obvhs::bvh2::Bvh2 {
    use obvhs::bvh2::{Bvh2, node::Bvh2Node};
    let n = aabbs.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let centroid: Vec<Vec3A> = aabbs.iter().map(|b| b.center()).collect();
    let mut nodes = vec![Bvh2Node::default(); 1];
    nodes.reserve(2 * n);
    // (node, first, end) ranges of `order` still to split.
    let mut todo = vec![(0usize, 0usize, n)];
    while let Some((node, first, end)) = todo.pop() {
        let range = &mut order[first..end];
        let mut bounds = Aabb::empty();
        let mut cbounds = Aabb::empty();
        for &k in range.iter() {
            bounds = bounds.union(&aabbs[k as usize]);
            cbounds.extend(centroid[k as usize]);
        }
        if range.len() == 1 {
            nodes[node] = Bvh2Node::new(bounds, 1, first as u32);
            continue;
        }
        let axis = cbounds.largest_axis();
        let mid = range.len() / 2;
        range.select_nth_unstable_by(mid, |&a, &b| {
            centroid[a as usize][axis].total_cmp(&centroid[b as usize][axis]).then(a.cmp(&b))
        });
        let child = nodes.len();
        nodes.push(Bvh2Node::default());
        nodes.push(Bvh2Node::default());
        nodes[node] = Bvh2Node::new(bounds, 0, child as u32);
        todo.push((child, first, first + mid));
        todo.push((child + 1, first + mid, end));
    }
    Bvh2 { nodes, primitive_indices: order, ..Default::default() }
}

/// True when the CPU has every feature [`SceneGeometry::walk_wide_avx2`] is compiled for (the list of
/// its `target_feature`; AVX2 alone does not imply the others): always when the build's target
/// has them all (`-C target-cpu`), else asked once at run time and kept.
#[inline(always)]
fn avx2_walk() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::sync::atomic::{AtomicU8, Ordering::Relaxed};
        if cfg!(all(
            target_feature = "avx2",
            target_feature = "popcnt",
            target_feature = "lzcnt",
            target_feature = "bmi1",
            target_feature = "bmi2"
        )) {
            return true;
        }
        // 0: not asked yet, 1: no, 2: yes. Every ray asks, and std's cache costs a load, a test and
        // two branches per feature (~25 instructions a ray for five); this is one load. Relaxed
        // suffices: every thread that asks computes the same answer.
        static ANSWER: AtomicU8 = AtomicU8::new(0);
        #[cold]
        fn ask() -> bool {
            let yes = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("popcnt")
                && std::arch::is_x86_feature_detected!("lzcnt")
                && std::arch::is_x86_feature_detected!("bmi1")
                && std::arch::is_x86_feature_detected!("bmi2");
            ANSWER.store(1 + yes as u8, Relaxed);
            yes
        }
        match ANSWER.load(Relaxed) {
            0 => ask(),
            a => a == 2,
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The deepest CwBvh `build_cwbvh` keeps (obvhs's `TRAVERSAL_STACK_SIZE`, which its own
/// traversal needs); the walk's stack in `bvh/wide.rs` is sized from it.
const MAX_CWBVH_DEPTH: usize = 32;

#[cfg(test)]
mod tests {
    use super::super::icosphere;
    use super::*;
    use crate::sampling::chi2::TestRng;

    pub(super) fn uniform_dir(rng: &mut TestRng) -> Vec3 {
        let z = 1.0 - 2.0 * rng.next_f32();
        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    pub(super) fn in_box(rng: &mut TestRng, half: f32) -> Vec3 {
        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * (2.0 * half) - Vec3::splat(half)
    }

    pub(super) fn scene() -> SceneGeometry {
        let mut ico = icosphere(3);
        ico.transform(glam::Affine3A::from_scale_rotation_translation(
            Vec3::splat(1.2),
            glam::Quat::from_rotation_z(0.3),
            Vec3::new(0.5, 0.0, 0.0),
        ));
        SceneGeometry::new(vec![
            Shape::Sphere(Sphere::new(Vec3::new(-2.0, 0.5, 0.0), 0.7)),
            Shape::Mesh(ico),
            Shape::Sphere(Sphere::new(Vec3::new(0.0, 2.5, 1.0), 0.5)),
        ])
    }

    #[test]
    fn bvh_matches_brute_force() {
        let g = scene();
        assert_eq!(g.num_primitives(), 20 * 64 + 2);
        let mut rng = TestRng::new(42);
        let (mut hits, mut per_object) = (0, [0usize; 3]);
        for i in 0..5000 {
            // Half the rays aimed at a random point near the objects so most of them hit.
            let o = in_box(&mut rng, 4.0);
            let d = match i % 4 {
                0 | 1 => uniform_dir(&mut rng),
                // Aimed at a random point near one of the objects.
                k => {
                    let c = [Vec3::new(-2.0, 0.5, 0.0), Vec3::new(0.0, 2.5, 1.0)][k - 2];
                    let target = if rng.next_f32() < 0.5 { c } else { Vec3::new(0.5, 0.0, 0.0) };
                    (target + in_box(&mut rng, 0.5) - o).normalize()
                }
            };
            // Every 10th ray is axis-aligned (±0.0 components exercise the octant/sign handling).
            let d =
                if i % 10 == 9 { [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z][(i / 10) % 6] } else { d };
            let mut ray = Ray::new(o, d);
            if i % 7 == 0 {
                ray.t_max = 3.0 * rng.next_f32();
            }
            let a = g.intersect(&ray);
            let b = g.intersect_brute_force(&ray);
            assert_eq!(g.occluded(&ray), a.is_some(), "ray {i}");
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    per_object[a.object as usize] += 1;
                    assert_eq!(a.object, b.object, "ray {i}");
                    assert!((a.t - b.t).abs() <= 1e-4 * b.t, "ray {i}: {} vs {}", a.t, b.t);
                    assert!((a.p - b.p).length() < 1e-4 * (1.0 + b.t));
                    assert!((a.n - b.n).length() < 1e-3 && (a.ng - b.ng).length() < 1e-3, "ray {i}");
                    assert!(a.t > 0.0 && a.t < ray.t_max);
                }
                (a, b) => panic!("ray {i}: bvh {a:?} vs brute force {b:?}"),
            }
        }
        // The test must exercise every object.
        assert!(hits > 1000 && per_object.iter().all(|&c| c > 50), "{hits} {per_object:?}");
    }

    #[test]
    fn mesh_hit_normals() {
        let g = SceneGeometry::new(vec![Shape::Mesh(icosphere(4))]);
        let mut rng = TestRng::new(3);
        for _ in 0..500 {
            let o = 3.0 * uniform_dir(&mut rng);
            let target = 0.5 * in_box(&mut rng, 1.0);
            let ray = Ray::new(o, (target - o).normalize());
            let h = g.intersect(&ray).expect("aimed inside");
            // Smooth normals of an icosphere interpolate the positions: close to p/|p|.
            assert!((h.n - h.p.normalize()).length() < 1e-2);
            assert!((h.n.length() - 1.0).abs() < 1e-5 && (h.ng.length() - 1.0).abs() < 1e-5);
            assert!(h.ng.dot(h.p) > 0.0, "geometric normal outward");
            assert!(h.ng.dot(ray.dir) < 0.0);
        }
        // Flat shading: shading normal = geometric normal.
        let mut flat = icosphere(2);
        flat.normals.clear();
        let g = SceneGeometry::new(vec![Shape::Mesh(flat)]);
        // −Vec3::Z has −0.0 components: exercises the octant/sign fix in `bvh_ray`.
        let h = g.intersect(&Ray::new(Vec3::new(0.1, 0.2, 5.0), -Vec3::Z)).expect("hit");
        assert_eq!(h.n, h.ng);
    }

    #[test]
    fn empty_and_single_sphere() {
        let g = SceneGeometry::new(vec![]);
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        assert!(g.intersect(&r).is_none() && !g.occluded(&r));
        assert_eq!(g.num_primitives(), 0);
        let g = SceneGeometry::new(vec![Shape::Mesh(TriangleMesh::default())]);
        assert!(g.intersect(&r).is_none() && !g.occluded(&r));

        let g = SceneGeometry::new(vec![Shape::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0))]);
        assert_eq!(g.num_primitives(), 1);
        let h = g.intersect(&r).expect("hit");
        assert!((h.t - 2.0).abs() < 1e-6 && h.object == 0);
        assert!(g.occluded(&r));
        let mut short = r;
        short.t_max = 1.5;
        assert!(!g.occluded(&short) && g.intersect(&short).is_none());

        // Non-finite rays hit nothing in a BVH scene.
        let g = SceneGeometry::new(vec![Shape::Mesh(icosphere(1)), Shape::Sphere(Sphere::new(Vec3::Z * 3.0, 1.0))]);
        let bad = Ray::new(Vec3::new(0.0, 0.0, f32::NAN), Vec3::Z);
        assert!(g.intersect(&bad).is_none() && !g.occluded(&bad));
        assert!(g.intersect(&r).is_some());
    }

    /// `intersect_primitive` names the primitive `intersect` hits: the same t and object, bit for
    /// bit, and its index is the primitive whose own test gives that t and the barycentrics (each
    /// lane of a block carries its own reference). On a mesh-only, a mixed and a single-sphere
    /// scene, with the walk tests' rays.
    #[test]
    fn primitive_hits_name_the_walks_primitive() {
        let mut rng = TestRng::new(11);
        let single = SceneGeometry::new(vec![Shape::Sphere(Sphere::new(Vec3::new(0.3, 0.0, 0.2), 0.9))]);
        for g in [SceneGeometry::new(vec![Shape::Mesh(icosphere(4))]), scene(), single] {
            // `ray_sets` aims some rays along triangles' edges: the sphere alone gets random rays.
            let rays = if g.is_single_sphere() {
                (0..4000).map(|_| Ray::new(in_box(&mut rng, 2.0), uniform_dir(&mut rng))).collect()
            } else {
                ray_sets(&g, &mut rng)
            };
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                let (h, p) = (g.intersect(r), g.intersect_primitive(r));
                assert_eq!(h.is_some(), p.is_some(), "ray {i}: {r:?}");
                let (Some(h), Some(p)) = (h, p) else { continue };
                hits += 1;
                assert_eq!((h.t.to_bits(), h.object), (p.t.to_bits(), p.object), "ray {i}: {r:?}");
                let (o, d) = (Vec3A::from(r.origin), Vec3A::from(r.dir));
                match &g.shapes[p.object as usize] {
                    Shape::Mesh(m) => {
                        let own = TriangleRecord::new(m.vertices(p.index as usize)).intersect(o, d, f32::INFINITY);
                        let bits = |x: (f32, f32, f32)| (x.0.to_bits(), x.1.to_bits(), x.2.to_bits());
                        assert_eq!(own.map(bits), Some(bits((p.t, p.b1, p.b2))), "ray {i}: {r:?}: {p:?}");
                    }
                    Shape::Sphere(s) => {
                        assert_eq!((p.index, p.b1, p.b2), (0, 0.0, 0.0), "ray {i}");
                        assert_eq!(s.intersect_t(r.origin, r.dir, r.t_max).map(f32::to_bits), Some(p.t.to_bits()));
                    }
                }
            }
            assert!(hits > rays.len() / 20, "{hits} hits of {}", rays.len());
        }
    }

    /// Bitwise equality of two hit results (every field, as bits).
    pub(super) fn same(a: &Option<Hit>, b: &Option<Hit>) -> bool {
        let bits = |h: &Hit| {
            let v = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            (h.t.to_bits(), v(h.p), v(h.n), v(h.ng), h.object)
        };
        match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => bits(a) == bits(b),
            _ => false,
        }
    }

    /// The ray sets of the batch tests: PEERS.md's "box" and "aimed" rays (origins in [−2, 2]³;
    /// directions uniform, or towards a point of the unit ball), grazing rays along triangle edges
    /// and tangent to the unit sphere, rays from on-surface origins (hit points, vertices) in every
    /// direction, axis-aligned rays (±0 components), short rays and non-finite rays.
    fn ray_sets(g: &SceneGeometry, rng: &mut TestRng) -> Vec<Ray> {
        let mut rays = Vec::new();
        for i in 0..6000 {
            let o = in_box(rng, 2.0);
            let d = if i % 2 == 0 {
                uniform_dir(rng)
            } else {
                let p = loop {
                    let p = in_box(rng, 1.0);
                    if p.length_squared() <= 1.0 {
                        break p;
                    }
                };
                (p - o).normalize()
            };
            rays.push(Ray::new(o, d));
        }
        let tris: Vec<TriangleRecord> =
            g.prims.iter().filter(|p| p.a.w == KIND_TRIANGLE).map(Prim::as_triangle).collect();
        for i in 0..2000 {
            let tri = tris[(rng.next_f32() * tris.len() as f32) as usize % tris.len()];
            let (v0, e1) = (Vec3::from(tri.v0), Vec3::from(tri.e1));
            match i % 4 {
                // Along an edge, from outside it and from its vertex.
                0 => rays.push(Ray::new(v0 - e1 * (0.5 + rng.next_f32()), e1.normalize())),
                1 => rays.push(Ray::new(v0, (e1 + Vec3::from(tri.e2) * 1e-7).normalize())),
                // From the vertex (on the surface) in a random direction.
                2 => rays.push(Ray::new(v0, uniform_dir(rng))),
                // Tangent to the unit sphere at a random point.
                _ => {
                    let n = uniform_dir(rng);
                    let t = n.any_orthonormal_vector();
                    rays.push(Ray::new(n - 2.0 * t, t));
                }
            }
        }
        // From the hit points of the rays so far (on-surface origins), both hemispheres.
        let hits: Vec<Hit> = rays.iter().take(3000).filter_map(|r| g.intersect(r)).collect();
        for h in hits {
            rays.push(Ray::new(h.p, uniform_dir(rng)));
        }
        for (i, d) in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z].into_iter().enumerate() {
            rays.push(Ray::new(Vec3::new(0.1, -0.2, 0.3) - 3.0 * d, d));
            let mut short = Ray::new(in_box(rng, 2.0), uniform_dir(rng));
            short.t_max = 0.5 * i as f32;
            rays.push(short);
        }
        // Two edge rays of the 20,480-triangle icosphere that another draw of these sets found: one
        // whose hit obvhs's node test misses at t = 0.039, one that Möller–Trumbore counts as a hit
        // of a triangle it passes beside (`edge_artefact`).
        rays.push(Ray::new(Vec3::new(0.519525, -0.36236763, -0.773811), Vec3::new(0.647802, -0.40060386, 0.647973)));
        rays.push(Ray::new(Vec3::new(-0.9946181, 0.0, 0.10360892), Vec3::new(-0.086388536, -9.648477e-8, -0.99626154)));
        rays.push(Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z));
        rays.push(Ray::new(Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0)));
        rays
    }

    /// True when every triangle whose Möller–Trumbore test puts `ray`'s hit at `t` lies in a box
    /// that the ray misses in exact arithmetic (f64 slab test of the triangle's own vertices): the
    /// test's rounding made a hit of a ray passing beside the triangle.
    fn edge_artefact(g: &SceneGeometry, ray: &Ray, t: f32) -> bool {
        let (o, d) = (ray.origin.as_dvec3().to_array(), ray.dir.as_dvec3().to_array());
        let misses = |v: [Vec3; 3]| {
            let (mut near, mut far) = (0.0f64, f64::INFINITY);
            for a in 0..3 {
                let lo = v.iter().map(|p| p[a] as f64).fold(f64::INFINITY, f64::min);
                let hi = v.iter().map(|p| p[a] as f64).fold(f64::NEG_INFINITY, f64::max);
                if d[a] == 0.0 {
                    if o[a] < lo || o[a] > hi {
                        return true;
                    }
                    continue;
                }
                let (t0, t1) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
                near = near.max(t0.min(t1));
                far = far.min(t0.max(t1));
            }
            near > far
        };
        let (ro, rd) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        let mut any = false;
        for shape in &g.shapes {
            if let Shape::Mesh(m) = shape {
                for i in 0..m.triangles.len() {
                    if TriangleRecord::new(m.vertices(i)).intersect(ro, rd, f32::INFINITY).is_some_and(|x| x.0 == t) {
                        if !misses(m.vertices(i)) {
                            return false;
                        }
                        any = true;
                    }
                }
            }
        }
        any
    }

    /// The walk of the float-plane tree finds the closest hit: the t of a test of every primitive
    /// (`intersect_brute_force`), bit for bit, and the same hit record, except where several
    /// triangles are hit at nearly the same t (a shared edge or vertex): there the walk's t is a
    /// primitive's and exceeds the least by at most a relative 10⁻⁵ (Möller–Trumbore's rounding;
    /// `bvh/wide.rs`), and where Möller–Trumbore's rounding counts a ray that passes beside a
    /// triangle's edge as a hit: the walk's box test culls what lies outside the triangle's box
    /// (`edge_artefact`, at most 3 rays of a set). obvhs's own traversal of its compressed tree
    /// agrees as closely, except where its node test drops boxes the ray leaves before t = 1e-4
    /// (obvhs's node epsilon), and with them hits at smaller t (rays from surface points), or,
    /// rarely, the box of a triangle whose edge the ray runs along (the edge rays): there the walk
    /// must find the hit of every primitive's test; elsewhere any hit agrees with obvhs's too. The
    /// SSE2 and AVX2 copies give the same bits. On a mesh-only scene (a 20,480-triangle unit
    /// icosphere, PEERS.md's mesh at n = 5) and the mixed scene, with rays along edges and from
    /// surface points (`ray_sets`).
    #[test]
    fn walk_finds_the_closest_hits() {
        let mut rng = TestRng::new(7);
        let close = |a: Option<Hit>, b: Option<Hit>| match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => a.t >= b.t && a.t <= b.t * (1.0 + 1e-5),
            _ => false,
        };
        for g in [SceneGeometry::new(vec![Shape::Mesh(icosphere(5))]), scene()] {
            let rays = ray_sets(&g, &mut rng);
            let (mut n_hit, mut near_ties, mut obvhs_farther, mut obvhs_grazing, mut edge_artefacts) = (0, 0, 0, 0, 0);
            for (i, r) in rays.iter().enumerate() {
                let (h, exact) = (g.intersect(r), g.intersect_brute_force(r));
                if let Some(e) = exact.filter(|e| !close(h, exact) && edge_artefact(&g, r, e.t)) {
                    // Möller–Trumbore's rounding counts a ray that passes just beside a triangle's
                    // edge as a hit, outside the triangle's box, which the walk's (exact) box test
                    // culls. The walk's hit, if any, is a farther primitive's.
                    assert!(h.is_none_or(|h| h.t > e.t), "ray {i}: {r:?}: {h:?} vs every primitive's {exact:?}");
                    edge_artefacts += 1;
                    continue;
                }
                assert!(close(h, exact), "ray {i}: {r:?}: {h:?} vs every primitive's {exact:?}");
                if !same(&h, &exact) {
                    // The walk's t is one primitive's t.
                    let b = SceneGeometry::bvh_ray(r);
                    let t = h.unwrap().t;
                    let at_t = g
                        .prims
                        .iter()
                        .filter(|p| p.intersect(b.origin, b.direction, f32::INFINITY).is_some_and(|x| x.0 == t));
                    assert!(at_t.count() >= 1, "ray {i}: {r:?}: {h:?} is no primitive's hit");
                    near_ties += 1;
                }
                let oracle = g.intersect_obvhs(r);
                if close(h, oracle) || close(oracle, h) {
                    assert_eq!(g.occluded(r), g.occluded_obvhs(r), "ray {i}: {r:?}");
                } else {
                    // obvhs missed the closest hit, which every primitive's test confirms.
                    let t = h.unwrap().t;
                    assert!(
                        same(&h, &exact) && oracle.is_none_or(|o| o.t > t),
                        "ray {i}: {r:?}: {h:?} vs obvhs {oracle:?}"
                    );
                    obvhs_grazing += (t >= 1e-4) as usize;
                    obvhs_farther += 1;
                }
                n_hit += h.is_some() as usize;
                assert_eq!(g.occluded(r), h.is_some(), "ray {i}: {r:?}");
            }
            eprintln!(
                "{} rays: {n_hit} hits, {near_ties} near ties, {obvhs_farther} where obvhs misses the closest \
                 ({obvhs_grazing} beyond t = 1e-4), {edge_artefacts} hits beside an edge",
                rays.len()
            );
            assert!(obvhs_grazing <= 3 && edge_artefacts <= 3, "{obvhs_grazing}, {edge_artefacts}");
            assert!(
                near_ties < rays.len() / 100 && obvhs_farther < rays.len() / 100,
                "{near_ties} near ties, {obvhs_farther}"
            );
            assert!(n_hit > rays.len() / 3 && n_hit < rays.len() - 1000, "{n_hit} of {}", rays.len());
            // The SSE2 and AVX2 node tests visit the same nodes: same hits, bit for bit.
            let wide = g.wide.as_ref().expect("a BVH scene");
            let bits =
                |h: Option<(u32, f32, f32, f32)>| h.map(|(s, t, b1, b2)| (s, t.to_bits(), b1.to_bits(), b2.to_bits()));
            let mut compared = 0;
            for r in rays.iter().filter(|r| SceneGeometry::is_valid(r)) {
                let (sse, sse_any) = (g.walk_wide::<false, false>(wide, r), g.walk_wide::<true, false>(wide, r));
                assert_eq!(sse_any.is_some(), sse.is_some(), "{r:?}");
                if avx2_walk() {
                    // SAFETY: avx2_walk() checked the CPU.
                    let (avx, avx_any) =
                        unsafe { (g.walk_wide_avx2::<false>(wide, r), g.walk_wide_avx2::<true>(wide, r)) };
                    assert_eq!(bits(sse), bits(avx), "{r:?}");
                    assert_eq!(bits(sse_any), bits(avx_any), "{r:?}");
                    compared += 1;
                }
            }
            if !avx2_walk() {
                eprintln!("walk_finds_the_closest_hits: no AVX2 on this CPU, the AVX2 copy is not compared");
            }
            assert!(compared == 0 || compared > rays.len() / 2);
        }
    }

    /// Any-hit packets (`bvh/packet.rs`) give each ray its single walk's answer, whatever rays
    /// share the packet, and the SSE2 and AVX2 copies agree. Three kinds of packet of eight, with
    /// random masks of wanted rays: eight consecutive rays of `ray_sets` (every direction, short,
    /// invalid and edge rays mixed; the set's last rays padded with its first), a pixel's camera
    /// rays (origins within 0.004 of each other, one direction), and rays leaving one surface point
    /// in random directions (a pixel's shadow and bounce rays); and pairs of them as packets of
    /// sixteen.
    #[test]
    fn packets_give_the_single_walks_answers() {
        let mut rng = TestRng::new(11);
        for g in [SceneGeometry::new(vec![Shape::Mesh(icosphere(5))]), scene()] {
            let set = ray_sets(&g, &mut rng);
            let mut packets: Vec<[Ray; PACKET]> = (0..set.len().div_ceil(PACKET))
                .map(|i| std::array::from_fn(|r| set[(PACKET * i + r) % set.len()]))
                .collect();
            for _ in 0..600 {
                let (o, target) = (in_box(&mut rng, 2.0), in_box(&mut rng, 1.0));
                let d = (target - o).normalize();
                packets.push(std::array::from_fn(|_| Ray::new(o + in_box(&mut rng, 0.002), d)));
                if let Some(h) = g.intersect(&Ray::new(o, d)) {
                    packets.push(std::array::from_fn(|_| {
                        let dir = uniform_dir(&mut rng);
                        Ray::new(crate::integrator::path::offset_origin(h.p, h.ng, dir), dir)
                    }));
                }
            }
            let wide = g.wide.as_ref().expect("a BVH scene");
            let mut want = || (rng.next_f32() * 65536.0) as u32 | if rng.next_f32() < 0.5 { 0xffff } else { 0 };
            let (mut rays, mut blocked) = (0, 0);
            let mut check = |p: &[Ray], got: u32, want: u32| {
                for (r, ray) in p.iter().enumerate() {
                    let single = want & (1 << r) != 0 && g.occluded(ray);
                    assert_eq!(got & (1 << r) != 0, single, "ray {r} of {p:?}, wanted {want:#x}");
                    rays += (want & (1 << r) != 0) as usize;
                    blocked += single as usize;
                }
            };
            for p in &packets {
                let bits = want() & 0xff;
                check(p, g.occluded_packet(p, bits), bits);
                if avx2_walk() {
                    let valid = SceneGeometry::valid_rays(p, bits);
                    // SAFETY: avx2_walk() checked the CPU.
                    let avx = unsafe { g.walk_packet_avx2::<PACKET>(wide, p, valid) };
                    assert_eq!(avx, g.walk_packet::<false, PACKET>(wide, p, valid), "{p:?}");
                }
            }
            for pair in packets.chunks_exact(2) {
                let p: [Ray; 2 * PACKET] = std::array::from_fn(|r| pair[r / PACKET][r % PACKET]);
                let bits = want() & 0xffff;
                check(&p, g.occluded_packet(&p, bits), bits);
                if avx2_walk() {
                    let valid = SceneGeometry::valid_rays(&p, bits);
                    // SAFETY: avx2_walk() checked the CPU.
                    let avx = unsafe { g.walk_packet_avx2::<{ 2 * PACKET }>(wide, &p, valid) };
                    assert_eq!(avx, g.walk_packet::<false, { 2 * PACKET }>(wide, &p, valid), "{p:?}");
                }
            }
            eprintln!("{} packets of eight, {rays} wanted rays, {blocked} blocked", packets.len());
            assert!(blocked > rays / 3 && blocked < rays - 1000, "{blocked} blocked of {rays}");
        }
        // Single-sphere and empty scenes answer ray by ray.
        for g in [SceneGeometry::new(vec![Shape::Sphere(Sphere::new(Vec3::ZERO, 1.0))]), SceneGeometry::new(vec![])] {
            let p: [Ray; PACKET] =
                std::array::from_fn(|r| Ray::new(Vec3::new(r as f32 * 0.3 - 1.0, 0.0, -3.0), Vec3::Z));
            let got = g.occluded_packet(&p, 0b1011_0111);
            for (r, ray) in p.iter().enumerate() {
                assert_eq!(got & (1 << r) != 0, 0b1011_0111 & (1 << r) != 0 && g.occluded(ray), "ray {r}");
            }
        }
    }

    /// The prefetch table names each node's first leaf block (and none for a node without leaf
    /// children), and a node's leaf blocks are those holding its leaf children's lanes, each once,
    /// in order, with exactly those lanes: on the icosphere and the mixed scene.
    #[test]
    fn leaf_blocks_and_their_prefetch_table() {
        for g in [SceneGeometry::new(vec![Shape::Mesh(icosphere(5))]), scene()] {
            let wide = g.wide.as_ref().expect("a BVH scene");
            assert_eq!(wide.first_block.len(), wide.nodes.len());
            let mut tested = 0;
            for (i, node) in wide.nodes.iter().enumerate() {
                let hint = if node.leaf_children != 0 { node.block } else { wide::NO_BLOCKS };
                assert_eq!(wide.first_block[i], hint, "node {i}");
                for leaves in [node.leaf_children, node.leaf_children & node.leaf_children.wrapping_neg()] {
                    let lanes =
                        (0..8).filter(|c| leaves & (1 << c) != 0).fold(0, |m, c| m | node.child[c]) & !wide::LEAF;
                    let blocks: Vec<(u32, u32)> = node.leaf_blocks(leaves).collect();
                    let mut rebuilt = 0u32;
                    for (k, &(block, mask)) in blocks.iter().enumerate() {
                        assert!(mask != 0 && mask < 1 << leaf::LANES, "node {i}: block {block} mask {mask:#b}");
                        assert!(k == 0 || block > blocks[k - 1].0, "node {i}: blocks {blocks:?}");
                        let shift = (block - node.block) * leaf::LANES as u32;
                        rebuilt |= mask << shift;
                    }
                    assert_eq!(rebuilt, lanes, "node {i}, leaf children {leaves:#b}: {blocks:?}");
                    tested += blocks.len();
                }
            }
            assert!(tested > 100, "{tested} blocks");
        }
    }

    /// The kept answer is the CPU's, whether this call asks or reads what another call kept (the
    /// second call always reads it).
    #[test]
    fn avx2_walk_is_the_cpus_answer() {
        #[cfg(target_arch = "x86_64")]
        let cpu = std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("lzcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2");
        #[cfg(not(target_arch = "x86_64"))]
        let cpu = false;
        assert_eq!((avx2_walk(), avx2_walk()), (cpu, cpu));
    }

    /// A disc of radius 1 in the x = 0 plane as one fan of `n` slivers from the rim vertex (0, 1, 0)
    /// (the `mesh-long-fan` case's layout, generated at any size).
    pub(crate) fn sliver_fan(n: usize) -> TriangleMesh {
        let k = n + 2;
        let positions = (0..k)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / k as f32;
                Vec3::new(0.0, a.cos(), a.sin())
            })
            .collect();
        let triangles = (1..k as u32 - 1).map(|i| [0, i, i + 1]).collect();
        TriangleMesh { positions, normals: Vec::new(), triangles }
    }

    fn mesh_aabbs(m: &TriangleMesh) -> Vec<Aabb> {
        (0..m.len())
            .map(|i| {
                let v = m.vertices(i);
                let mut bb = Aabb::from_point(v[0].into());
                bb.extend(v[1].into()).extend(v[2].into());
                bb
            })
            .collect()
    }

    /// Closest hits equal brute force on rays through the disc of a fan (and its depth bound holds).
    fn check_fan_hits(g: &SceneGeometry, rng: &mut TestRng) {
        let bvh = g.bvh.as_ref().expect("a BVH");
        assert!(cwbvh_depth(bvh) < MAX_CWBVH_DEPTH, "CwBvh depth {}", cwbvh_depth(bvh));
        let mut hits = 0;
        for i in 0..3000 {
            let target = Vec3::new(0.0, 2.2 * rng.next_f32() - 1.1, 2.2 * rng.next_f32() - 1.1);
            let o = Vec3::new(if i % 2 == 0 { 3.0 } else { -3.0 }, 0.0, 0.0) + in_box(rng, 1.0);
            let ray = Ray::new(o, (target - o).normalize());
            let (a, b) = (g.intersect(&ray), g.intersect_brute_force(&ray));
            // At the rim the slivers are ~1e-4 wide and a hit lies on the corner of its box, where
            // obvhs's quantised node test can round it out (obvhs's own PLOC tree misses the same
            // ray): those rays are left out.
            if b.is_some_and(|h| h.p.length() > 0.999) {
                continue;
            }
            assert_eq!(a.is_some(), b.is_some(), "ray {i}: bvh {a:?} vs brute force {b:?}");
            assert_eq!(g.occluded(&ray), b.is_some(), "ray {i}");
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a.t - b.t).abs() <= 1e-5 * b.t, "ray {i}: {} vs {}", a.t, b.t);
                hits += 1;
            }
        }
        assert!(hits > 1500, "{hits} of 3000 rays hit the disc");
    }

    /// A fan of slivers sharing a vertex: PLOC's pairing degenerates (detected before PLOC runs),
    /// the median-split tree replaces it, ⌈log₂ n⌉ levels deep, and it finds every hit. Ordinary
    /// meshes are not taken for degenerate.
    #[test]
    fn long_fan_skips_ploc_and_builds_shallow() {
        let n = 50_000;
        let fan = sliver_fan(n);
        assert!(ploc_degenerates(&mesh_aabbs(&fan)), "a fan of {n} slivers is not detected");
        for sub in [5, 6] {
            assert!(!ploc_degenerates(&mesh_aabbs(&icosphere(sub))), "icosphere({sub}) taken for degenerate");
        }
        let mut bunny = icosphere(6);
        bunny.transform(glam::Affine3A::from_scale(Vec3::new(3.0, 1.0, 0.2)));
        assert!(!ploc_degenerates(&mesh_aabbs(&bunny)));
        let tree = median_split_bvh2(&mesh_aabbs(&fan));
        assert_eq!(bvh2_depth(&tree), (n as f64).log2().ceil() as usize + 1);
        let start = Instant::now();
        let g = SceneGeometry::new(vec![Shape::Mesh(fan)]);
        assert!(start.elapsed() < Duration::from_secs(5), "{:?}", start.elapsed());
        check_fan_hits(&g, &mut TestRng::new(17));
    }

    /// A fan below the pre-check's size: PLOC runs and chains it (hundreds of levels, a CwBvh deeper
    /// than the traversal stack); the depth checks replace the tree, and every hit is found.
    #[test]
    fn chained_ploc_tree_is_replaced() {
        let fan = sliver_fan(3000);
        let aabbs = mesh_aabbs(&fan);
        assert!(!ploc_degenerates(&aabbs), "below the pre-check's size");
        let p = BUILD_PARAMS;
        let ploc = obvhs::ploc::PlocBuilder::with_capacity(aabbs.len()).build(
            p.ploc_search_distance,
            &aabbs,
            (0..aabbs.len() as u32).collect(),
            p.sort_precision,
            p.search_depth_threshold,
        );
        assert!(bvh2_depth(&ploc) > MAX_BVH2_DEPTH, "PLOC's tree is {} deep", bvh2_depth(&ploc));
        check_fan_hits(&SceneGeometry::new(vec![Shape::Mesh(fan)]), &mut TestRng::new(18));
    }

    /// Ordinary scenes keep obvhs's own tree, node for node (so their renders keep their bits).
    #[test]
    fn ordinary_scenes_keep_obvhs_tree() {
        let mut t = Duration::ZERO;
        for mesh in [icosphere(6), icosphere(2)] {
            let aabbs = mesh_aabbs(&mesh);
            let ours = build_cwbvh(|| aabbs.clone(), BUILD_PARAMS);
            let theirs = obvhs::cwbvh::builder::build_cwbvh(&aabbs, BUILD_PARAMS, &mut t);
            assert!(ours.nodes == theirs.nodes && ours.primitive_indices == theirs.primitive_indices);
        }
    }

    #[test]
    fn geometry_is_sync() {
        fn assert_sync<T: Sync + Send>() {}
        assert_sync::<SceneGeometry>();
    }

    use super::super::TriangleMesh;
}
