//! The scene's geometry: every object (spheres and triangle meshes) in one bounding volume
//! hierarchy.
//!
//! - One obvhs compressed wide BVH8 (`CwBvh`, Ylitie et al. 2017) is built over the AABBs of all
//!   primitives: each triangle of each mesh, and each sphere as a single custom primitive. The
//!   binary tree it is converted from is obvhs's PLOC tree, or an object-median tree where PLOC
//!   degenerates or builds too deep a tree (`build_cwbvh`): no input makes the conversion's
//!   recursion or the traversal stack overflow.
//! - After the build the primitive records are made in the BVH's leaf order
//!   (`primitive_indices`), so a leaf slot indexes a `Prim` directly with no indirection.
//! - Each `Prim` is three 16-byte lanes: triangles store (v0, e1, e2) for Möller–Trumbore, spheres
//!   store (centre, radius); the `w` lane of the first vector tags the kind, so the leaf test reads
//!   one 48-byte record.
//! - Traversal is an own loop over obvhs's nodes (`Walk`: obvhs's `traverse!` order and node-test
//!   arithmetic, so every hit is bit for bit obvhs's), with a node test that widens each axis's
//!   eight quantised planes at once (AVX2 plus POPCNT/LZCNT/BMI1/BMI2 chosen at run time, SSE2
//!   otherwise; same bits) and a software prefetch of the hit children and leaf primitives of each
//!   node (~5–8 % on a 1.3 M-triangle mesh, whose traversal is bound by cache misses). Any-hit
//!   (`occluded`) stops at the first hit. The batch functions interleave several rays' walks;
//!   `intersect_packet` (`bvh/packet.rs`) walks a pixel's camera rays as one packet.
//! - A scene that is a single sphere bypasses the BVH (one analytic test per ray), and an empty
//!   scene always misses.
//!
//! Parameters: `BUILD_PARAMS` (the obvhs build preset, chosen so 1.3 M triangles build in ~1 s
//! on one core while keeping traversal fast: on the 1.3 M-triangle icosphere, a higher PLOC search
//! radius or 6× more reinsertion changed the nodes visited per hitting ray by < 2% (14.1 → 13.9)
//! at 2–3× the build time).
//!
//! Hits have t in (0, t_max) for triangles and above the round-off of the root for spheres (see
//! [`super::sphere`]); rays with non-finite origin or direction hit nothing.

use super::mesh::TriangleRecord;
use super::{Hit, Ray, Shape, Sphere};
use crate::math::Vec3;
use glam::{UVec2, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
/// obvhs's build settings, for [`SceneGeometry::with_build_params`] (`benches/bvh.rs` tunes them).
pub use obvhs::{BvhBuildParams, ploc::PlocSearchDistance, ploc::SortPrecision};
use std::mem::MaybeUninit;
use std::time::{Duration, Instant};

mod packet;

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

/// One BVH primitive in leaf order. Triangle: a = (v0, 0), b = (e1, ·), c = (e2, ·).
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
    bvh: Option<CwBvh>,
    /// Primitives in BVH slot order.
    prims: Vec<Prim>,
    refs: Vec<PrimRef>,
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
    pub fn with_build_params(shapes: Vec<Shape>, params: BvhBuildParams) -> Self {
        let start = Instant::now();
        if let [Shape::Sphere(s)] = shapes.as_slice() {
            let single_sphere = Some(*s);
            return SceneGeometry {
                shapes,
                bvh: None,
                prims: Vec::new(),
                refs: Vec::new(),
                single_sphere,
                build_time: start.elapsed(),
            };
        }

        // Primitive k of the build is primitive k − first[o] of object o, where first[o] ≤ k < first[o + 1].
        let mut first = Vec::with_capacity(shapes.len() + 1);
        first.push(0u32);
        for shape in &shapes {
            let n = match shape {
                Shape::Sphere(_) => 1,
                Shape::Mesh(m) => m.triangles.len() as u32,
            };
            first.push(first.last().unwrap() + n);
        }
        let count = *first.last().unwrap() as usize;
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

        let (bvh, prims, refs) = if count == 0 {
            (None, Vec::new(), Vec::new())
        } else {
            let bvh = build_cwbvh(aabbs, params);
            // The records are made after the build, straight in leaf order (a slot id indexes them
            // directly): they and the build's boxes are never in memory together with the build's
            // largest buffers (guide, "Performance notes and their history": peak memory).
            let locate = |k: u32| {
                let object = first.partition_point(|&f| f <= k) - 1;
                (object, k - first[object])
            };
            let prims: Vec<Prim> = bvh
                .primitive_indices
                .iter()
                .map(|&k| {
                    let (object, index) = locate(k);
                    match &shapes[object] {
                        Shape::Sphere(s) => Prim::sphere(s),
                        Shape::Mesh(m) => Prim::triangle(&TriangleRecord::new(m.vertices(index as usize))),
                    }
                })
                .collect();
            let refs: Vec<PrimRef> = bvh
                .primitive_indices
                .iter()
                .map(|&k| {
                    let (object, index) = locate(k);
                    PrimRef { object: object as u32, index }
                })
                .collect();
            // Every ray walks the nodes and reads the records of the leaves it reaches, at
            // random addresses: in huge pages where the kernel gives them.
            crate::memory::advise_huge_pages(&bvh.nodes);
            crate::memory::advise_huge_pages(&prims);
            crate::memory::advise_huge_pages(&refs);
            (Some(bvh), prims, refs)
        };
        SceneGeometry { shapes, bvh, prims, refs, single_sphere: None, build_time: start.elapsed() }
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
        if self.single_sphere.is_some() { 1 } else { self.prims.len() }
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

    #[inline]
    fn bvh_ray(ray: &Ray) -> obvhs::ray::Ray {
        // obvhs takes the ray octant from `d < 0` but the slab sign from signum(d): a −0.0
        // component would disagree between the two and miss whole subtrees, so map it to +0.0
        // (x + 0.0 = +0.0 for x = −0.0 and x otherwise).
        let dir = Vec3A::from(ray.dir) + Vec3A::ZERO;
        obvhs::ray::Ray::new(ray.origin.into(), dir, 0.0, ray.t_max)
    }

    /// Closest hit with t in (0, ray.t_max).
    ///
    /// The same hit, bit for bit, as obvhs's `traverse!` loop with `CwBvhNode::intersect_ray` (the
    /// implementation before `Walk`; kept as a test oracle): same node test arithmetic, same child
    /// and primitive order, so ties between primitives at equal t resolve the same way.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if let Some(s) = &self.single_sphere {
            return s.intersect(ray, 0);
        }
        let bvh = self.bvh.as_ref()?;
        if !Self::is_valid(ray) {
            return None;
        }
        let (slot, t, b1, b2) = self.walk_here::<false>(bvh, ray)?;
        Some(self.make_hit(ray, slot as usize, t, (b1, b2)))
    }

    /// One ray's whole walk: the closest hit (`ANY` false) or the first hit found (`ANY` true),
    /// as (slot, t, b1, b2); `AVX` selects the AVX2 node test ([`slab8`]).
    #[inline(always)]
    fn walk<const ANY: bool, const AVX: bool>(&self, bvh: &CwBvh, ray: &Ray) -> Option<(u32, f32, f32, f32)> {
        let mut lane = Lane::EMPTY;
        lane.reset(ray);
        while !self.step::<ANY, AVX>(bvh, &mut lane) {}
        lane.best
    }

    /// [`SceneGeometry::walk`] in the copy this CPU runs: [`SceneGeometry::walk_avx2`] where
    /// [`avx2_walk`] holds, the SSE2 node test otherwise (the same bits, tested).
    #[inline(always)]
    fn walk_here<const ANY: bool>(&self, bvh: &CwBvh, ray: &Ray) -> Option<(u32, f32, f32, f32)> {
        if avx2_walk() {
            // SAFETY: avx2_walk() found every feature walk_avx2 is compiled for.
            unsafe { self.walk_avx2::<ANY>(bvh, ray) }
        } else {
            self.walk::<ANY, false>(bvh, ray)
        }
    }

    /// [`SceneGeometry::run_batch`] in the copy this CPU runs, as [`SceneGeometry::walk_here`].
    #[inline(always)]
    fn run_batch_here<const ANY: bool>(&self, bvh: &CwBvh, rays: &[Ray], finish: impl FnMut(usize, Option<&Lane>)) {
        if avx2_walk() {
            // SAFETY: as in walk_here.
            unsafe { self.run_batch_avx2::<ANY>(bvh, rays, finish) }
        } else {
            self.run_batch::<ANY, false>(bvh, rays, finish)
        }
    }

    /// [`SceneGeometry::walk`] with the AVX2 node test, compiled for AVX2 and for the bit
    /// instructions the walk's child-slot arithmetic needs: POPCNT, LZCNT, BMI1 (TZCNT, BLSR) and
    /// BMI2 (BZHI, SHLX). Without them a `count_ones` of a node's child bits is five instructions
    /// (two multiplies) and the mask below a child slot four, where POPCNT and BZHI are one each.
    /// Run-time dispatch: call only where [`avx2_walk`] holds, which checks exactly these features.
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,popcnt,lzcnt,bmi1,bmi2"))]
    fn walk_avx2<const ANY: bool>(&self, bvh: &CwBvh, ray: &Ray) -> Option<(u32, f32, f32, f32)> {
        self.walk::<ANY, true>(bvh, ray)
    }

    /// [`SceneGeometry::run_batch`] compiled as [`SceneGeometry::walk_avx2`] (call only where
    /// [`avx2_walk`] holds).
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,popcnt,lzcnt,bmi1,bmi2"))]
    fn run_batch_avx2<const ANY: bool>(&self, bvh: &CwBvh, rays: &[Ray], finish: impl FnMut(usize, Option<&Lane>)) {
        self.run_batch::<ANY, true>(bvh, rays, finish)
    }

    /// One step of a lane: [`SceneGeometry::step_closest`] or [`SceneGeometry::step_any`].
    #[inline(always)]
    fn step<const ANY: bool, const AVX: bool>(&self, bvh: &CwBvh, lane: &mut Lane) -> bool {
        if ANY { self.step_any::<AVX>(bvh, lane) } else { self.step_closest::<AVX>(bvh, lane) }
    }

    /// Closest hits of many rays: `hits[i]` is exactly [`SceneGeometry::intersect`]`(&rays[i])`,
    /// bit for bit.
    ///
    /// [`BATCH_LANES`] rays are traversed at once, interleaved one node visit at a time: each visit
    /// prefetches the nodes and primitives it will need next, and the other lanes' visits run while
    /// those loads are in flight, so node fetches of different rays overlap instead of each ray
    /// waiting on its own chain of misses. Any order of rays works; coherent rays (a tile's camera
    /// rays) share more of the tree's cache lines.
    ///
    /// # Panics
    /// If `rays` and `hits` differ in length.
    pub fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "intersect_batch: {} rays but {} hit slots", rays.len(), hits.len());
        let Some(bvh) = self.bvh.as_ref().filter(|_| self.single_sphere.is_none()) else {
            for (h, r) in hits.iter_mut().zip(rays) {
                *h = self.intersect(r);
            }
            return;
        };
        let finish = |i: usize, lane: Option<&Lane>| {
            hits[i] =
                lane.and_then(|l| l.best).map(|(slot, t, b1, b2)| self.make_hit(&rays[i], slot as usize, t, (b1, b2)));
        };
        self.run_batch_here::<false>(bvh, rays, finish)
    }

    /// Any hit of many rays: `occluded[i]` is exactly [`SceneGeometry::occluded`]`(&rays[i])`.
    /// Interleaved like [`SceneGeometry::intersect_batch`] (shadow rays towards one light direction
    /// are the coherent case).
    ///
    /// # Panics
    /// If `rays` and `occluded` differ in length.
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "occluded_batch: {} rays but {} slots", rays.len(), occluded.len());
        let Some(bvh) = self.bvh.as_ref().filter(|_| self.single_sphere.is_none()) else {
            for (o, r) in occluded.iter_mut().zip(rays) {
                *o = self.occluded(r);
            }
            return;
        };
        let finish = |i: usize, lane: Option<&Lane>| occluded[i] = lane.is_some_and(|l| l.best.is_some());
        self.run_batch_here::<true>(bvh, rays, finish)
    }

    /// The interleaving loop of the batch functions: keeps up to [`BATCH_LANES`] rays in flight,
    /// advancing each by one [`SceneGeometry::step`] in turn. `finish` receives each ray's index with
    /// its finished lane, or `None` for a ray that hits nothing because it is not finite.
    #[inline(always)]
    fn run_batch<const ANY: bool, const AVX: bool>(
        &self,
        bvh: &CwBvh,
        rays: &[Ray],
        mut finish: impl FnMut(usize, Option<&Lane>),
    ) {
        // Hands a lane the next valid ray; false when none is left.
        fn refill(
            rays: &[Ray],
            next: &mut usize,
            lane: &mut Lane,
            slot: &mut usize,
            finish: &mut impl FnMut(usize, Option<&Lane>),
        ) -> bool {
            while *next < rays.len() {
                let i = *next;
                *next += 1;
                if SceneGeometry::is_valid(&rays[i]) {
                    lane.reset(&rays[i]);
                    *slot = i;
                    return true;
                }
                finish(i, None);
            }
            *slot = usize::MAX;
            false
        }
        let mut lanes = [Lane::EMPTY; BATCH_LANES];
        let mut index = [usize::MAX; BATCH_LANES];
        let mut next = 0;
        let mut active = 0;
        for (lane, slot) in lanes.iter_mut().zip(index.iter_mut()) {
            active += refill(rays, &mut next, lane, slot, &mut finish) as usize;
        }
        while active > 0 {
            for (lane, slot) in lanes.iter_mut().zip(index.iter_mut()) {
                if *slot != usize::MAX && self.step::<ANY, AVX>(bvh, lane) {
                    finish(*slot, Some(lane));
                    if !refill(rays, &mut next, lane, slot, &mut finish) {
                        active -= 1;
                    }
                }
            }
        }
    }

    /// One iteration of the CwBvh traversal loop (Ylitie et al. 2017, as obvhs's `traverse!`) for
    /// closest hit: the primitives of the current leaf group, then at most one node. Returns true
    /// when the traversal is finished.
    #[inline(always)]
    fn step_closest<const AVX: bool>(&self, bvh: &CwBvh, lane: &mut Lane) -> bool {
        while lane.walk.prims.y != 0 {
            let k = 31 - lane.walk.prims.y.leading_zeros();
            lane.walk.prims.y &= !(1u32 << k);
            let slot = lane.walk.prims.x + k;
            let p = &self.prims[slot as usize];
            let r = &mut lane.ray.ray;
            count_primitive_test();
            if let Some((t, b1, b2)) = p.intersect(r.origin, r.direction, r.tmax) {
                r.tmax = t;
                lane.best = Some((slot, t, b1, b2));
            }
        }
        self.step_node::<AVX>(bvh, lane)
    }

    /// As [`SceneGeometry::step_closest`] for any hit: finished at the first primitive hit.
    #[inline(always)]
    fn step_any<const AVX: bool>(&self, bvh: &CwBvh, lane: &mut Lane) -> bool {
        while lane.walk.prims.y != 0 {
            let k = 31 - lane.walk.prims.y.leading_zeros();
            lane.walk.prims.y &= !(1u32 << k);
            let slot = lane.walk.prims.x + k;
            let r = &lane.ray.ray;
            if let Some((t, ..)) = self.prims[slot as usize].intersect(r.origin, r.direction, r.tmax) {
                lane.best = Some((slot, t, 0.0, 0.0));
                return true;
            }
        }
        self.step_node::<AVX>(bvh, lane)
    }

    /// The node half of one traversal iteration (obvhs's `traverse!` after its primitive loop):
    /// visits the next hit child of the current node group, if any, and pops the stack when the
    /// group and the leaf group are both exhausted. Returns true when the stack is empty.
    #[inline(always)]
    fn step_node<const AVX: bool>(&self, bvh: &CwBvh, lane: &mut Lane) -> bool {
        let w = &mut lane.walk;
        w.prims = UVec2::ZERO;
        if w.current.y & 0xff00_0000 != 0 {
            let hits_imask = w.current.y;
            let child_offset = 31 - hits_imask.leading_zeros();
            let child_base = w.current.x;
            w.current.y &= !(1u32 << child_offset);
            if w.current.y & 0xff00_0000 != 0 {
                w.push(w.current);
            }
            let slot = (child_offset - 24) ^ (lane.ray.oct_inv4 & 0xff);
            let relative = (hits_imask & !(0xffff_ffffu32 << slot)).count_ones();
            let node = &bvh.nodes[(child_base + relative) as usize];
            let hitmask = lane.ray.node_hitmask::<AVX>(node);
            self.prefetch(bvh, node, hitmask, lane.ray.oct_inv4);
            w.current = UVec2::new(node.child_base_idx, (hitmask & 0xff00_0000) | node.imask as u32);
            w.prims = UVec2::new(node.primitive_base_idx, hitmask & 0x00ff_ffff);
        } else {
            w.current = UVec2::ZERO;
        }
        if w.prims.y == 0 && w.current.y & 0xff00_0000 == 0 {
            if w.sp == 0 {
                return true;
            }
            w.current = w.pop();
        }
        false
    }

    /// Software prefetch of everything a node's hit mask will visit next: the hit child nodes
    /// (80 bytes, two cache lines each) and the hit leaf primitives (48 bytes each). Traversal of a
    /// large mesh is bound by memory latency; issuing these loads together overlaps their misses
    /// instead of paying them one after another as the depth-first walk reaches each child.
    #[inline(always)]
    fn prefetch(&self, bvh: &CwBvh, node: &obvhs::cwbvh::node::CwBvhNode, hitmask: u32, oct_inv4: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            // Internal children: hit bit 24 + j belongs to child slot j ^ octant, whose node is at
            // child_base_idx + (number of internal children in lower slots) (Ylitie et al. 2017).
            let mut internal = hitmask >> 24;
            while internal != 0 {
                let slot = internal.trailing_zeros() ^ (oct_inv4 & 7);
                internal &= internal - 1;
                let rel = (node.imask as u32 & ((1u32 << slot) - 1)).count_ones();
                let ptr = bvh.nodes.as_ptr().wrapping_add((node.child_base_idx + rel) as usize) as *const i8;
                // SAFETY: prefetch is a hint and never faults, whatever the address.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(ptr);
                    _mm_prefetch::<_MM_HINT_T0>(ptr.wrapping_add(79));
                }
            }
            // Leaf primitives: bit k of the low 24 is primitive slot primitive_base_idx + k.
            let mut leaves = hitmask & 0x00ff_ffff;
            while leaves != 0 {
                let k = leaves.trailing_zeros();
                leaves &= leaves - 1;
                let ptr = self.prims.as_ptr().wrapping_add((node.primitive_base_idx + k) as usize) as *const i8;
                // SAFETY: as above.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(ptr);
                    _mm_prefetch::<_MM_HINT_T0>(ptr.wrapping_add(47));
                }
            }
        }
    }

    /// Assembles the hit record of slot `slot` at distance `t`.
    #[inline]
    fn make_hit(&self, ray: &Ray, slot: usize, t: f32, (b1, b2): (f32, f32)) -> Hit {
        let r = self.refs[slot];
        match &self.shapes[r.object as usize] {
            Shape::Sphere(s) => s.hit_at(ray, t, r.object),
            Shape::Mesh(m) => {
                let tri = self.prims[slot].as_triangle();
                // Barycentric interpolation is more accurate than o + t d (pbrt 4, §6.8.6).
                let p = Vec3::from(tri.v0 + b1 * tri.e1 + b2 * tri.e2);
                let ng = Vec3::from(tri.e1.cross(tri.e2)).normalize_or_zero();
                let n = m.shading_normal(r.index as usize, b1, b2, ng);
                Hit { t, p, n, ng, object: r.object }
            }
        }
    }

    /// Any hit with t in (0, ray.t_max); stops at the first primitive hit (children in the same
    /// octant order as closest hit, no sorting by distance).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if let Some(s) = &self.single_sphere {
            return s.intersect_t(ray.origin, ray.dir, ray.t_max).is_some();
        }
        let Some(bvh) = self.bvh.as_ref() else { return false };
        if !Self::is_valid(ray) {
            return false;
        }
        self.walk_here::<true>(bvh, ray).is_some()
    }

    /// The closest hit through obvhs's own `traverse!` loop and node test (the implementation
    /// before `Walk`): the oracle of the tests.
    #[cfg(test)]
    fn intersect_obvhs(&self, ray: &Ray) -> Option<Hit> {
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
        Some(self.make_hit(ray, slot as usize, t, (b1, b2)))
    }

    /// Any hit through obvhs's `ray_traverse_miss` (the implementation before `Walk`); for tests.
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
/// traversal stack ([`STACK`]); otherwise the median-split tree of [`median_split_bvh2`], whose depth
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
            if cwbvh_depth(&cw) < STACK {
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

#[cfg(test)]
thread_local! {
    /// Primitive tests of closest-hit walks on this thread (tests only): the packet walk must run
    /// exactly the tests its rays' single walks run.
    static PRIMITIVE_TESTS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// Counts one closest-hit primitive test in tests; nothing otherwise.
#[inline(always)]
fn count_primitive_test() {
    #[cfg(test)]
    PRIMITIVE_TESTS.with(|c| c.set(c.get() + 1));
}

/// Rays in flight in [`SceneGeometry::intersect_batch`] and [`SceneGeometry::occluded_batch`].
pub const BATCH_LANES: usize = 8;

/// Depth of the traversal stack: obvhs's `TRAVERSAL_STACK_SIZE` (its `CwBvh::validate` asserts the
/// tree is shallower). Like obvhs's `StackStack`, a push onto a full stack overwrites the top.
const STACK: usize = 32;

/// The traversal state of one ray: obvhs's `Traversal` (node group, leaf group, stack of node
/// groups; x = base index, y = hit bits) without the fields the loop does not need.
#[derive(Clone, Copy)]
struct Walk {
    current: UVec2,
    prims: UVec2,
    sp: usize,
    /// Entries below `sp` are written (a lane starts empty, so its stack needs no clearing).
    stack: [MaybeUninit<UVec2>; STACK],
}

impl Walk {
    #[inline(always)]
    fn push(&mut self, g: UVec2) {
        self.stack[self.sp & (STACK - 1)] = MaybeUninit::new(g);
        self.sp = (self.sp + 1).min(STACK - 1);
    }
    /// Called only when `sp > 0`.
    #[inline(always)]
    fn pop(&mut self) -> UVec2 {
        debug_assert!(self.sp > 0);
        self.sp = self.sp.saturating_sub(1);
        // SAFETY: the step loop pops only when sp > 0, and every entry below sp was pushed (a push
        // onto a full stack rewrites the top entry, which was written).
        unsafe { self.stack[self.sp & (STACK - 1)].assume_init() }
    }
}

/// A ray prepared for the node test: obvhs's ray (origin, direction with −0 mapped to +0, the
/// safe inverse direction, t_max shrinking as hits are found), its octant code, and the byte
/// offsets in a `CwBvhNode` of the near planes (x, y, z) then the far planes: the min planes on an
/// axis the ray runs up, the max planes on an axis it runs down.
#[derive(Clone, Copy)]
struct NodeRay {
    ray: obvhs::ray::Ray,
    oct_inv4: u32,
    planes: [usize; 6],
}

impl NodeRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let ray = SceneGeometry::bvh_ray(ray);
        let d = ray.direction;
        // obvhs's ray_get_octant_inv4.
        let oct_inv4 = (if d.x < 0.0 { 0 } else { 0x0404_0404 })
            | (if d.y < 0.0 { 0 } else { 0x0202_0202 })
            | (if d.z < 0.0 { 0 } else { 0x0101_0101 });
        use std::mem::offset_of;
        let axis = |c: f32, lo: usize, hi: usize| if c < 0.0 { (hi, lo) } else { (lo, hi) };
        let x = axis(d.x, offset_of!(CwBvhNode, child_min_x), offset_of!(CwBvhNode, child_max_x));
        let y = axis(d.y, offset_of!(CwBvhNode, child_min_y), offset_of!(CwBvhNode, child_max_y));
        let z = axis(d.z, offset_of!(CwBvhNode, child_min_z), offset_of!(CwBvhNode, child_max_z));
        NodeRay { ray, oct_inv4, planes: [x.0, y.0, z.0, x.1, y.1, z.1] }
    }

    /// The hit mask of a node's children (obvhs's encoding: bits 24–31 internal children by
    /// traversal priority, bits 0–23 leaf primitives), with exactly the arithmetic of obvhs's
    /// `CwBvhNode::intersect_ray_simd` (t = q·(extent/d) + (p − o)/d in single precision, no fused
    /// multiply-add; entry clamped to 1e-4, exit to t_max) so the same nodes are visited. What
    /// differs is the work around it: the eight quantised planes of an axis are read as one
    /// 8-byte word (near or far by a per-ray offset, no branch) and widened together (obvhs
    /// converts byte by byte), internal children are encoded by one table lookup and only hit
    /// leaf children one by one.
    #[inline(always)]
    fn node_hitmask<const AVX: bool>(&self, node: &CwBvhNode) -> u32 {
        let r = &self.ray;
        let dir_inv = node.compute_extent() * r.inv_direction;
        let orig = (Vec3A::from(node.p) - r.origin) * r.inv_direction;
        let plane = |k: usize| self.plane(node, k);
        let hit = slab8::<AVX>([plane(0), plane(1), plane(2)], [plane(3), plane(4), plane(5)], dir_inv, orig, r.tmax);
        self.encode(node, hit)
    }

    /// The eight quantised planes (one byte a child) of `node` at this ray's plane `k`, in the
    /// order of `planes` (near x, y, z, then far).
    #[inline(always)]
    fn plane(&self, node: &CwBvhNode, k: usize) -> u64 {
        let base = (node as *const CwBvhNode).cast::<u8>();
        // SAFETY: every offset in `planes` is that of one of the node's six 8-byte plane arrays
        // (`NodeRay::new`), so the read stays inside the node; it needs no alignment.
        u64::from_le(unsafe { base.add(self.planes[k]).cast::<u64>().read_unaligned() })
    }

    /// [`NodeRay::node_hitmask`] for a ray of a packet whose rays all have this ray's direction,
    /// bit for bit: `scaled` holds the node's planes times the shared scale (computed once per node
    /// by [`ScaledPlanes::new`]), and only the ray's own offset and t_max are applied here.
    #[inline(always)]
    fn node_hitmask_scaled<const AVX: bool>(&self, node: &CwBvhNode, scaled: &ScaledPlanes) -> u32 {
        let r = &self.ray;
        let orig = (Vec3A::from(node.p) - r.origin) * r.inv_direction;
        self.encode(node, scaled.hits::<AVX>(orig, orig, r.tmax))
    }

    /// The hit mask of [`NodeRay::node_hitmask`] from the node's child hit bits `hit` (bit i:
    /// child i's box is entered).
    #[inline(always)]
    fn encode(&self, node: &CwBvhNode, hit: u32) -> u32 {
        // Internal child i hit: bit 24 + (i ^ octant) (its meta is 24 + i; Ylitie et al. 2017).
        let octant = (self.oct_inv4 & 7) as usize;
        let mut mask = (XOR_PERMUTE[octant][(hit & node.imask as u32) as usize] as u32) << 24;
        // Leaf child i hit: its primitive count in unary (meta bits 5–7) at its offset (bits 0–4).
        let mut leaves = hit & !(node.imask as u32);
        while leaves != 0 {
            let meta = node.child_meta[leaves.trailing_zeros() as usize & 7] as u32;
            leaves &= leaves - 1;
            mask |= (meta >> 5) << (meta & 0x1f);
        }
        mask
    }
}

/// `XOR_PERMUTE[o][m]` moves bit i of m to bit i ^ o: the traversal-priority order of a node's
/// internal children for a ray of octant code o.
static XOR_PERMUTE: [[u8; 256]; 8] = {
    let mut t = [[0u8; 256]; 8];
    let mut o = 0;
    while o < 8 {
        let mut m = 0;
        while m < 256 {
            let mut i = 0;
            while i < 8 {
                if m & (1 << i) != 0 {
                    t[o][m] |= 1 << (i ^ o);
                }
                i += 1;
            }
            m += 1;
        }
        o += 1;
    }
    t
};

/// True when the CPU has every feature [`SceneGeometry::walk_avx2`] is compiled for (the list of
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

/// The entry distance obvhs clamps a child's slab interval to (its `node::EPSILON`).
const NODE_T_MIN: f32 = 1e-4;

/// Bit i set when child i's slab interval [max(near·s + o, 1e-4), min(far·s + o, t_max)] is not
/// empty; `near`/`far` hold each axis's eight quantised planes, one byte per child. `AVX`: eight
/// children per instruction with AVX2 (the caller has checked [`avx2_walk`]), else four with SSE2; both
/// round identically (separate multiply and add), so they give the same bits.
#[inline(always)]
fn slab8<const AVX: bool>(near: [u64; 3], far: [u64; 3], s: Vec3A, o: Vec3A, t_max: f32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        if AVX {
            // SAFETY: AVX is true only on the paths taken when `avx2_walk()` holds.
            unsafe { slab8_avx2(near, far, s, o, t_max) }
        } else {
            slab8_sse2(near, far, s, o, t_max)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut hit = 0;
        for i in 0..8 {
            let b = |v: u64| ((v >> (8 * i)) & 0xff) as f32;
            let t = |v: [u64; 3]| Vec3A::new(b(v[0]), b(v[1]), b(v[2])) * s + o;
            let (tn, tf) = (t(near), t(far));
            if tn.max_element().max(NODE_T_MIN) <= tf.min_element().min(t_max) {
                hit |= 1 << i;
            }
        }
        hit
    }
}

/// [`slab8`] with AVX2: each axis's eight planes widened by one `vpmovzxbd`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn slab8_avx2(near: [u64; 3], far: [u64; 3], s: Vec3A, o: Vec3A, t_max: f32) -> u32 {
    use std::arch::x86_64::*;
    let q = |v: u64| _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_cvtsi64_si128(v as i64)));
    let t = |v: u64, s: f32, o: f32| _mm256_add_ps(_mm256_mul_ps(q(v), _mm256_set1_ps(s)), _mm256_set1_ps(o));
    let tmin = _mm256_max_ps(t(near[0], s.x, o.x), _mm256_max_ps(t(near[1], s.y, o.y), t(near[2], s.z, o.z)));
    let tmax = _mm256_min_ps(t(far[0], s.x, o.x), _mm256_min_ps(t(far[1], s.y, o.y), t(far[2], s.z, o.z)));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(NODE_T_MIN));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(t_max));
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tmin, tmax)) as u32
}

/// [`slab8`] with SSE2 (part of x86_64): children 0–3 and 4–7 in two halves.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn slab8_sse2(near: [u64; 3], far: [u64; 3], s: Vec3A, o: Vec3A, t_max: f32) -> u32 {
    // SAFETY: SSE2 is part of x86_64; the intrinsics only compute on their arguments.
    unsafe {
        use std::arch::x86_64::*;
        // Bytes 0–7 of v as two vectors of four f32 (children 0–3 and 4–7).
        let q = |v: u64| {
            let z = _mm_setzero_si128();
            let w = _mm_unpacklo_epi8(_mm_cvtsi64_si128(v as i64), z);
            (_mm_cvtepi32_ps(_mm_unpacklo_epi16(w, z)), _mm_cvtepi32_ps(_mm_unpackhi_epi16(w, z)))
        };
        let (n, f) = (near.map(q), far.map(q));
        let (sx, sy, sz) = (_mm_set1_ps(s.x), _mm_set1_ps(s.y), _mm_set1_ps(s.z));
        let (ox, oy, oz) = (_mm_set1_ps(o.x), _mm_set1_ps(o.y), _mm_set1_ps(o.z));
        let (eps, tm) = (_mm_set1_ps(NODE_T_MIN), _mm_set1_ps(t_max));
        let half = |nx: __m128, ny: __m128, nz: __m128, fx: __m128, fy: __m128, fz: __m128| {
            let t = |q: __m128, s: __m128, o: __m128| _mm_add_ps(_mm_mul_ps(q, s), o);
            let tmin = _mm_max_ps(t(nx, sx, ox), _mm_max_ps(t(ny, sy, oy), t(nz, sz, oz)));
            let tmax = _mm_min_ps(t(fx, sx, ox), _mm_min_ps(t(fy, sy, oy), t(fz, sz, oz)));
            _mm_movemask_ps(_mm_cmple_ps(_mm_max_ps(tmin, eps), _mm_min_ps(tmax, tm))) as u32
        };
        half(n[0].0, n[1].0, n[2].0, f[0].0, f[1].0, f[2].0) | half(n[0].1, n[1].1, n[2].1, f[0].1, f[1].1, f[2].1) << 4
    }
}

/// A node's quantised planes times the scale of a direction (q · extent/d, per axis), in the
/// order of [`NodeRay::planes`] (near x, y, z, then far), eight children each: the part of
/// [`slab8`] that depends on the ray's direction only. The rays of an orthographic camera's packet
/// share their direction, so this is computed once per node for all of them; each ray then adds
/// its own offset (p − o)/d and clamps by its own t_max. The arithmetic is [`slab8`]'s (a product,
/// rounded, then a sum), so the hit bits are the same.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct ScaledPlanes([[f32; 8]; 6]);

impl ScaledPlanes {
    /// The planes of `node` scaled for `ray`'s direction (and octant).
    #[inline(always)]
    fn new<const AVX: bool>(node: &CwBvhNode, ray: &NodeRay) -> Self {
        let s = node.compute_extent() * ray.ray.inv_direction;
        let scale = [s.x, s.y, s.z];
        let mut out = ScaledPlanes([[0.0; 8]; 6]);
        for (k, row) in out.0.iter_mut().enumerate() {
            *row = scale8::<AVX>(ray.plane(node, k), scale[k % 3]);
        }
        out
    }

    /// Bit i set when child i's interval [max(near + o_near, 1e-4), min(far + o_far, t_max)] is
    /// not empty, per axis; with o_near = o_far = (p − origin)/d this is [`slab8`] with the products
    /// already taken. Every step is monotone in each of o_near, o_far and t_max (rounding is), which
    /// is what lets a packet bound its rays' answers by two calls (`bvh/packet.rs`).
    #[inline(always)]
    fn hits<const AVX: bool>(&self, o_near: Vec3A, o_far: Vec3A, t_max: f32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            if AVX {
                // SAFETY: AVX is true only on the paths taken when `avx2_walk()` holds.
                unsafe { scaled_hits_avx2(&self.0, o_near, o_far, t_max) }
            } else {
                scaled_hits_sse2(&self.0, o_near, o_far, t_max)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let q = &self.0;
            let mut hit = 0;
            for i in 0..8 {
                let tn = Vec3A::new(q[0][i], q[1][i], q[2][i]) + o_near;
                let tf = Vec3A::new(q[3][i], q[4][i], q[5][i]) + o_far;
                if tn.max_element().max(NODE_T_MIN) <= tf.min_element().min(t_max) {
                    hit |= 1 << i;
                }
            }
            hit
        }
    }
}

/// The eight quantised planes of `v` (one byte each) times `s`, rounded as [`slab8`]'s product.
#[inline(always)]
fn scale8<const AVX: bool>(v: u64, s: f32) -> [f32; 8] {
    #[cfg(target_arch = "x86_64")]
    {
        let mut out = [0.0f32; 8];
        if AVX {
            // SAFETY: AVX is true only on the paths taken when `avx2_walk()` holds; the store writes
            // the eight floats of `out`.
            unsafe { scale8_avx2(v, s, &mut out) }
        } else {
            // SAFETY: SSE2 is part of x86_64; the stores write the eight floats of `out`.
            unsafe {
                use std::arch::x86_64::*;
                let z = _mm_setzero_si128();
                let w = _mm_unpacklo_epi8(_mm_cvtsi64_si128(v as i64), z);
                let s = _mm_set1_ps(s);
                _mm_storeu_ps(out.as_mut_ptr(), _mm_mul_ps(_mm_cvtepi32_ps(_mm_unpacklo_epi16(w, z)), s));
                _mm_storeu_ps(out.as_mut_ptr().add(4), _mm_mul_ps(_mm_cvtepi32_ps(_mm_unpackhi_epi16(w, z)), s));
            }
        }
        out
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        std::array::from_fn(|i| ((v >> (8 * i)) & 0xff) as f32 * s)
    }
}

/// [`scale8`] with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn scale8_avx2(v: u64, s: f32, out: &mut [f32; 8]) {
    use std::arch::x86_64::*;
    let q = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_cvtsi64_si128(v as i64)));
    // SAFETY: `out` holds eight floats; the store needs no alignment.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), _mm256_mul_ps(q, _mm256_set1_ps(s))) }
}

/// [`ScaledPlanes::hits`] with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn scaled_hits_avx2(q: &[[f32; 8]; 6], n: Vec3A, f: Vec3A, t_max: f32) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY: each row holds eight floats; the loads need no alignment.
    let t = |k: usize, o: f32| _mm256_add_ps(unsafe { _mm256_loadu_ps(q[k].as_ptr()) }, _mm256_set1_ps(o));
    let tmin = _mm256_max_ps(t(0, n.x), _mm256_max_ps(t(1, n.y), t(2, n.z)));
    let tmax = _mm256_min_ps(t(3, f.x), _mm256_min_ps(t(4, f.y), t(5, f.z)));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(NODE_T_MIN));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(t_max));
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tmin, tmax)) as u32
}

/// [`ScaledPlanes::hits`] with SSE2: children 0–3 and 4–7 in two halves.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn scaled_hits_sse2(q: &[[f32; 8]; 6], n: Vec3A, f: Vec3A, t_max: f32) -> u32 {
    // SAFETY: SSE2 is part of x86_64; each load reads four of a row's eight floats.
    unsafe {
        use std::arch::x86_64::*;
        let (nx, ny, nz) = (_mm_set1_ps(n.x), _mm_set1_ps(n.y), _mm_set1_ps(n.z));
        let (fx, fy, fz) = (_mm_set1_ps(f.x), _mm_set1_ps(f.y), _mm_set1_ps(f.z));
        let (eps, tm) = (_mm_set1_ps(NODE_T_MIN), _mm_set1_ps(t_max));
        let half = |h: usize| {
            let t = |k: usize, o: __m128| _mm_add_ps(_mm_loadu_ps(q[k].as_ptr().add(4 * h)), o);
            let tmin = _mm_max_ps(t(0, nx), _mm_max_ps(t(1, ny), t(2, nz)));
            let tmax = _mm_min_ps(t(3, fx), _mm_min_ps(t(4, fy), t(5, fz)));
            _mm_movemask_ps(_mm_cmple_ps(_mm_max_ps(tmin, eps), _mm_min_ps(tmax, tm))) as u32
        };
        half(0) | half(1) << 4
    }
}

/// One ray in flight: its node-test form, traversal state and best hit so far (slot, t, b1, b2).
#[derive(Clone, Copy)]
struct Lane {
    ray: NodeRay,
    walk: Walk,
    best: Option<(u32, f32, f32, f32)>,
}

impl Lane {
    const EMPTY: Lane = Lane {
        ray: NodeRay {
            ray: obvhs::ray::Ray {
                origin: Vec3A::ZERO,
                direction: Vec3A::ZERO,
                inv_direction: Vec3A::ZERO,
                tmin: 0.0,
                tmax: 0.0,
            },
            oct_inv4: 0,
            planes: [0; 6],
        },
        walk: Walk { current: UVec2::ZERO, prims: UVec2::ZERO, sp: 0, stack: [MaybeUninit::uninit(); STACK] },
        best: None,
    };

    /// Starts the lane on `ray` at the root of a non-empty tree (obvhs's initial group: bit 31
    /// selects node 0); the stack's old entries are left as they are (unread).
    #[inline(always)]
    fn reset(&mut self, ray: &Ray) {
        self.ray = NodeRay::new(ray);
        self.walk.current = UVec2::new(0, 0x8000_0000);
        self.walk.prims = UVec2::ZERO;
        self.walk.sp = 0;
        self.best = None;
    }
}

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
        rays.push(Ray::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z));
        rays.push(Ray::new(Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 0.0)));
        rays
    }

    /// The batch functions give every ray exactly (bit for bit) its single-ray result, and the
    /// single-ray traversal gives exactly obvhs's own loop's result, on a mesh-only scene (a
    /// 20,480-triangle unit icosphere, PEERS.md's mesh at n = 5) and the mixed scene.
    #[test]
    fn batch_and_walk_equal_single_ray_and_obvhs_bit_for_bit() {
        let mut rng = TestRng::new(7);
        for g in [SceneGeometry::new(vec![Shape::Mesh(icosphere(5))]), scene()] {
            let rays = ray_sets(&g, &mut rng);
            let single: Vec<Option<Hit>> = rays.iter().map(|r| g.intersect(r)).collect();
            let n_hit = single.iter().filter(|h| h.is_some()).count();
            assert!(n_hit > rays.len() / 3 && n_hit < rays.len() - 1000, "{n_hit} of {}", rays.len());
            for (i, (r, h)) in rays.iter().zip(&single).enumerate() {
                assert!(same(h, &g.intersect_obvhs(r)), "ray {i}: {r:?}: {h:?} vs obvhs {:?}", g.intersect_obvhs(r));
                assert_eq!(g.occluded(r), g.occluded_obvhs(r), "ray {i}: {r:?}");
                assert_eq!(g.occluded(r), h.is_some(), "ray {i}: {r:?}");
            }
            // The SSE2 and AVX2 node tests visit the same nodes: same hits, bit for bit.
            let bvh = g.bvh.as_ref().expect("a BVH scene");
            let bits =
                |h: Option<(u32, f32, f32, f32)>| h.map(|(s, t, b1, b2)| (s, t.to_bits(), b1.to_bits(), b2.to_bits()));
            for r in rays.iter().filter(|r| SceneGeometry::is_valid(r)) {
                let (sse, sse_any) = (g.walk::<false, false>(bvh, r), g.walk::<true, false>(bvh, r));
                assert_eq!(sse_any.is_some(), sse.is_some(), "{r:?}");
                if avx2_walk() {
                    // SAFETY: avx2_walk() checked the CPU.
                    let (avx, avx_any) = unsafe { (g.walk_avx2::<false>(bvh, r), g.walk_avx2::<true>(bvh, r)) };
                    assert_eq!(bits(sse), bits(avx), "{r:?}");
                    assert_eq!(bits(sse_any), bits(avx_any), "{r:?}");
                }
            }
            // Whole set, an odd-sized part (lanes refilled unevenly), one ray, none.
            for range in [0..rays.len(), 5..5 + 2 * BATCH_LANES + 3, 17..18, 0..0] {
                let part = &rays[range.clone()];
                let mut hits = vec![None; part.len()];
                g.intersect_batch(part, &mut hits);
                let mut occ = vec![true; part.len()];
                g.occluded_batch(part, &mut occ);
                for (k, i) in range.enumerate() {
                    assert!(same(&hits[k], &single[i]), "ray {i}: batch {:?} vs single {:?}", hits[k], single[i]);
                    assert_eq!(occ[k], g.occluded(&rays[i]), "ray {i}");
                }
            }
        }
        // The single-sphere and empty scenes go through the per-ray functions.
        for g in [SceneGeometry::new(vec![Shape::Sphere(Sphere::new(Vec3::ZERO, 1.0))]), SceneGeometry::new(vec![])] {
            let rays = ray_sets(&scene(), &mut rng);
            let mut hits = vec![None; rays.len()];
            g.intersect_batch(&rays, &mut hits);
            let mut occ = vec![false; rays.len()];
            g.occluded_batch(&rays, &mut occ);
            for (i, r) in rays.iter().enumerate() {
                assert!(same(&hits[i], &g.intersect(r)) && occ[i] == g.occluded(r), "ray {i}");
            }
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
        assert!(cwbvh_depth(bvh) < STACK, "CwBvh depth {}", cwbvh_depth(bvh));
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
