//! The BVH8 every ray walks: obvhs's compressed tree decoded to float planes.
//!
//! obvhs builds a compressed wide BVH (`CwBvh`, Ylitie et al. 2017): each node stores its
//! children's boxes as bytes on a per-node grid, and its traversal orders children by the ray's
//! octant and keeps node groups with hit bits on its stack, a design made for GPUs. On a CPU each
//! visit then spends more on decoding and bookkeeping than on the box test itself. This module
//! converts the finished tree, node for node and child for child, into [`WideNode`]s with the
//! children's boxes as floats and a child reference per slot, and walks it as CPU ray tracers do
//! (Wald et al. 2008; Embree's BVH8 kernels): one node test gives the hit children and their
//! entry distances, the leaf children hit are tested at once (their primitives are stored by
//! node, four lanes a block: `bvh/leaf.rs`), the nearest internal child hit is entered directly
//! and the others pushed nearest last, and a popped entry farther than the closest hit so far is
//! skipped.
//!
//! **Same boxes, never smaller.** A child's box is obvhs's quantised box, p + q · 2^e per plane,
//! computed exactly in f64 and rounded outward to f32: it contains the compressed box, which
//! contains the child's primitives.
//!
//! **Exact hits.** The slab test is conservative: t = (plane − o) · (1/d) in single precision,
//! with the exit distance, and the closest hit's distance that culls boxes, scaled up by 1 + 2γ₃
//! (pbrt-v4 §6.1.2) so that rounding never drops a box the ray meets before that hit; 1/d is ±∞
//! on an axis the ray runs parallel to, where the one undefined case (0 · ∞, a ray in a box's
//! face plane) comes out as NaN and the test's min/max order turns a NaN into "no bound" (the box
//! is kept). Boxes behind the origin (exit < 0) are dropped. So the hit is that of a test of every
//! primitive with t in (0, t_max), up to the triangle test's own rounding: where several triangles
//! are hit at nearly the same t (a ray through a shared edge or vertex), the t of the one the walk
//! keeps can exceed the least by a few units in the last place, as a box is culled by its
//! geometric entry and a triangle's t carries Möller–Trumbore's error. The walk keeps the same one
//! for a ray on every run and in every copy (tested).

use super::leaf::{Block, LANES, LaneRay};
use super::{Prim, PrimRef, SceneGeometry};
use crate::geometry::Ray;
use crate::geometry::mesh::TriangleRecord;
use glam::Vec3A;
use obvhs::cwbvh::CwBvh;
use std::mem::MaybeUninit;

/// Entries of a walk's stack: a node leaves at most 7 of its 8 children behind at each level, so
/// a tree of depth D needs at most 7 (D − 1) + 1, and `build_cwbvh` keeps D below
/// `MAX_CWBVH_DEPTH`. A power of two, so that the index's wrap (which keeps every access in
/// bounds without a check) is a mask.
pub(super) const STACK: usize = 256;
const _: () = assert!(7 * super::MAX_CWBVH_DEPTH < STACK);

/// A child reference with this bit set is a leaf: bits 0–30 are the mask of its primitives' lanes
/// in the node's run of [`Block`]s (bit 4 k + i: block k, lane i). Otherwise it is the index
/// of an internal node.
pub(super) const LEAF: u32 = 1 << 31;

/// The most primitives a tree is built for: slots and lane ids (a block's index × 4 + its lane,
/// with at most one block a primitive) are `u32`, with room to spare (a tree of 2^29 primitives
/// alone takes some 50 GB).
pub(super) const MAX_SLOTS: usize = 1 << 29;

/// A node of eight children: their boxes by plane (rows min x, min y, min z, max x, max y, max z;
/// an empty slot has min +∞ and max −∞, which no ray enters), their references (`LEAF`), the
/// first of the blocks that hold its leaf children's primitives, and which children are leaves.
/// 256 bytes on a 64-byte boundary: four cache lines a node.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct WideNode {
    bounds: [[f32; 8]; 6],
    pub(super) child: [u32; 8],
    /// The index in [`WideBvh::blocks`] of the node's first block.
    pub(super) block: u32,
    /// Bit i set when child i is a leaf.
    pub(super) leaf_children: u32,
}

/// The decoded tree: node 0 is the root. A primitive's slot is its position in obvhs's leaf order
/// (`primitive_indices`); a node's leaf children's primitives fill consecutive slots, which its
/// blocks hold in order (`bvh/leaf.rs`).
pub(super) struct WideBvh {
    pub(super) nodes: Vec<WideNode>,
    pub(super) blocks: Vec<Block>,
    /// For node i, its [`WideNode::block`] if it has leaf children, else [`NO_BLOCKS`]: read
    /// before the node itself ([`prefetch_leaf_blocks`]), so that the lines of the blocks a visit
    /// may test load alongside the node's instead of after them. 4 bytes a node (0.5 MB for the
    /// 1.31 M-triangle icosphere), small enough to stay in cache where the nodes do not.
    pub(super) first_block: Vec<u32>,
}

/// [`WideBvh::first_block`] of a node without leaf children.
pub(super) const NO_BLOCKS: u32 = u32::MAX;

impl WideNode {
    /// The blocks that hold the lanes of the leaf children in `leaves` (bit i: child i, which
    /// must be a leaf), each once and in order, as (block index, mask of those lanes in it).
    #[inline(always)]
    pub(super) fn leaf_blocks(&self, leaves: u32) -> LeafBlocks {
        let (mut lanes, mut l) = (0, leaves);
        while l != 0 {
            lanes |= self.child[l.trailing_zeros() as usize & 7];
            l &= l - 1;
        }
        LeafBlocks { lanes: lanes & !LEAF, first: self.block }
    }
}

/// The iterator of [`WideNode::leaf_blocks`]: the lanes still to test, in the node's run of blocks
/// from `first`.
pub(super) struct LeafBlocks {
    lanes: u32,
    first: u32,
}

impl Iterator for LeafBlocks {
    type Item = (u32, u32);

    #[inline(always)]
    fn next(&mut self) -> Option<(u32, u32)> {
        if self.lanes == 0 {
            return None;
        }
        const BLOCK: u32 = (1 << LANES) - 1;
        let shift = self.lanes.trailing_zeros() & !(LANES as u32 - 1);
        let want = (self.lanes >> shift) & BLOCK;
        self.lanes &= !(BLOCK << shift);
        Some((self.first + shift / LANES as u32, want))
    }
}

/// An entry of a walk's stack: an internal node's index and the distance at which the ray enters
/// its box.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    t: f32,
}

impl WideBvh {
    /// The float-plane copy of `bvh` (non-empty: node 0 is its root; its leaves index fewer than
    /// [`MAX_SLOTS`] primitives), with the record, object and index of the primitive in slot k
    /// from `prim(k)`.
    pub(super) fn new(bvh: &CwBvh, prim: impl Fn(u32) -> (Prim, PrimRef)) -> WideBvh {
        let mut blocks = Vec::with_capacity(bvh.primitive_indices.len().div_ceil(LANES));
        let nodes = bvh
            .nodes
            .iter()
            .map(|n| {
                let extent = [n.e[0], n.e[1], n.e[2]].map(|e| f32::from_bits((e as u32) << 23) as f64);
                let p = [n.p.x as f64, n.p.y as f64, n.p.z as f64];
                let rows = [n.child_min_x, n.child_min_y, n.child_min_z, n.child_max_x, n.child_max_y, n.child_max_z];
                let mut node =
                    WideNode { bounds: [[0.0; 8]; 6], child: [0; 8], block: blocks.len() as u32, leaf_children: 0 };
                // The lanes of the node's primitive run that some leaf child owns.
                let mut owned = 0u32;
                for (i, &meta) in n.child_meta.iter().enumerate() {
                    let meta = meta as u32;
                    if meta == 0 {
                        for k in 0..3 {
                            node.bounds[k][i] = f32::INFINITY;
                            node.bounds[k + 3][i] = f32::NEG_INFINITY;
                        }
                        continue;
                    }
                    for k in 0..6 {
                        let exact = p[k % 3] + rows[k][i] as f64 * extent[k % 3];
                        node.bounds[k][i] = if k < 3 { round_down(exact) } else { round_up(exact) };
                    }
                    // Internal children follow each other from child_base_idx; a leaf's primitives
                    // are the run's lanes from its offset (meta bits 0–4), as many as its unary
                    // count (bits 5–7).
                    if n.imask & (1 << i) != 0 {
                        node.child[i] = n.child_base_idx + (n.imask as u32 & ((1 << i) - 1)).count_ones();
                    } else {
                        let (offset, count) = (meta & 0x1f, (meta >> 5).count_ones());
                        assert!(offset + count <= 31, "a leaf's lanes {offset} + {count} beyond a reference's 31 bits");
                        let lanes = ((1 << count) - 1) << offset;
                        node.child[i] = LEAF | lanes;
                        node.leaf_children |= 1 << i;
                        owned |= lanes;
                    }
                }
                let run = 32 - owned.leading_zeros();
                for k in 0..run.div_ceil(LANES as u32) {
                    let first = n.primitive_base_idx + LANES as u32 * k;
                    blocks.push(Block::new(std::array::from_fn(|i| {
                        let lane = LANES as u32 * k + i as u32;
                        (owned & (1 << lane) != 0).then(|| prim(first + i as u32))
                    })));
                }
                node
            })
            .collect::<Vec<_>>();
        // The walk reads nodes and blocks without bounds checks: every reference must be in range.
        // Lane ids are u32 (a block holds at least one primitive, so this holds below MAX_SLOTS).
        assert!(!nodes.is_empty() && blocks.len() <= (u32::MAX as usize + 1) / LANES);
        for node in &nodes {
            for (i, &c) in node.child.iter().enumerate() {
                if node.leaf_children & (1 << i) != 0 {
                    let lanes = c & !LEAF;
                    let last_block = || node.block as usize + (31 - lanes.leading_zeros() as usize) / LANES;
                    assert!(
                        c & LEAF != 0 && lanes != 0 && last_block() < blocks.len(),
                        "a leaf child beyond the blocks"
                    );
                } else {
                    assert!((c as usize) < nodes.len(), "a child reference beyond the nodes");
                }
            }
        }
        // Every ray walks the nodes at random addresses: in huge pages where the kernel gives them.
        crate::memory::advise_huge_pages(&nodes);
        crate::memory::advise_huge_pages(&blocks);
        let first_block = nodes.iter().map(|n| if n.leaf_children != 0 { n.block } else { NO_BLOCKS }).collect();
        WideBvh { nodes, blocks, first_block }
    }

    /// The object and index of the primitive in block lane `id` (as [`SceneGeometry::walk_wide`]
    /// returns it).
    #[inline(always)]
    pub(super) fn prim_ref(&self, id: u32) -> PrimRef {
        self.blocks[id as usize / LANES].prim_ref(id as usize % LANES)
    }

    /// The triangle in block lane `id` (a triangle's lane).
    #[inline(always)]
    pub(super) fn triangle(&self, id: u32) -> TriangleRecord {
        self.blocks[id as usize / LANES].triangle(id as usize % LANES)
    }
}

/// The largest f32 not above `x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x { f.next_down() } else { f }
}

/// The least f32 not below `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x { f.next_up() } else { f }
}

/// γ₃ = 3u / (1 − 3u), u = 2⁻²⁴: the bound on the relative error of the slab distances.
const GAMMA3: f32 = 3.0 * (f32::EPSILON * 0.5) / (1.0 - 3.0 * (f32::EPSILON * 0.5));

/// A ray prepared for [`WideNode`] tests: origin, negated inverse direction, and for each
/// axis the offsets (in floats, from the node's start) of the rows of its entry and exit planes:
/// min where the ray runs up the axis, max where it runs down.
///
/// A plane's distance is computed as (o − plane) · (−1/d), which has the bits of
/// (plane − o) · (1/d) (rounding is symmetric; only a zero's sign can differ, which no comparison
/// sees) and lets the node's row be the subtraction's memory operand.
#[derive(Clone, Copy)]
pub(super) struct WideRay {
    origin: [f32; 3],
    neg_inv: [f32; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl WideRay {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Self {
        // 1/±0 = ±∞, whose sign picks the rows as any other direction's does.
        let inv = ray.dir.recip().to_array();
        // The octant (bit a: the ray runs down axis a) picks both rows of every axis from one
        // table entry, without a branch: the rows' order is as random as the rays.
        let octant = (0..3).fold(0, |o, a| o | ((inv[a].to_bits() >> 31) as usize) << a);
        let (near, far) = ROWS[octant];
        WideRay { origin: ray.origin.to_array(), neg_inv: inv.map(|x| -x), near, far }
    }
}

/// For each octant (bit a set: the ray runs down axis a), the float offsets of the entry rows
/// (min a where the ray runs up axis a, max a where down) and of the exit rows.
const ROWS: [([usize; 3], [usize; 3]); 8] = {
    let mut rows = [([0; 3], [0; 3]); 8];
    let mut octant = 0;
    while octant < 8 {
        let mut a = 0;
        while a < 3 {
            let down = (octant >> a) & 1;
            rows[octant].0[a] = 8 * a + 24 * down;
            rows[octant].1[a] = 8 * a + 24 * (1 - down);
            a += 1;
        }
        octant += 1;
    }
    rows
};

/// Bit i set when child i's box meets the ray within [0, `t_max`] (up to rounding, never
/// dropping a box that does: the exit and `t_max` scaled by 1 + 2γ₃), and the children's
/// entry distances in `entry`. `AVX`: eight children per instruction with AVX2 (only inside
/// `walk_wide_avx2`), else four with SSE2; the same bits either way (separate subtract and
/// multiply, no fused operation).
#[inline(always)]
pub(super) fn test<const AVX: bool>(node: &WideNode, ray: &WideRay, t_max: f32, entry: &mut [f32; 8]) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: AVX is true only in the copy compiled with AVX2 (`walk_wide_avx2`, called where
        // `avx2_walk()` holds); every row offset of `ray` is that of one of the node's six rows.
        unsafe { if AVX { test_avx2(node, ray, t_max, entry) } else { test_sse2(node, ray, t_max, entry) } }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let b = node.bounds.as_flattened();
        let mut hit = 0;
        for i in 0..8 {
            let t = |off: usize, a: usize| (ray.origin[a] - b[off + i]) * ray.neg_inv[a];
            let tn = t(ray.near[0], 0).max(t(ray.near[1], 1)).max(t(ray.near[2], 2)).max(0.0);
            let tf = t(ray.far[0], 0).min(t(ray.far[1], 1)).min(t(ray.far[2], 2)).min(t_max) * GROW;
            entry[i] = tn;
            if tn <= tf {
                hit |= 1 << i;
            }
        }
        hit
    }
}

/// 1 + 2γ₃: the exit distances' scale.
const GROW: f32 = 1.0 + 2.0 * GAMMA3;

/// [`test`] with AVX2. Not a `target_feature` function, so that it is always inlined: call it
/// only from code compiled with AVX2, with row offsets inside the node.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn test_avx2(node: &WideNode, ray: &WideRay, t_max: f32, entry: &mut [f32; 8]) -> u32 {
    use std::arch::x86_64::*;
    let b = node.bounds.as_ptr().cast::<f32>();
    // SAFETY (caller): the offsets are rows of the node, 32-byte aligned as the node is.
    unsafe {
        let t = |off: usize, a: usize| {
            _mm256_mul_ps(
                _mm256_sub_ps(_mm256_set1_ps(ray.origin[a]), _mm256_load_ps(b.add(off))),
                _mm256_set1_ps(ray.neg_inv[a]),
            )
        };
        let tn = _mm256_max_ps(
            _mm256_max_ps(t(ray.near[0], 0), t(ray.near[1], 1)),
            _mm256_max_ps(t(ray.near[2], 2), _mm256_setzero_ps()),
        );
        let tf = _mm256_min_ps(t(ray.far[0], 0), _mm256_min_ps(t(ray.far[1], 1), t(ray.far[2], 2)));
        let tf = _mm256_mul_ps(_mm256_min_ps(tf, _mm256_set1_ps(t_max)), _mm256_set1_ps(GROW));
        _mm256_storeu_ps(entry.as_mut_ptr(), tn);
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tn, tf)) as u32
    }
}

/// [`test`] with SSE2: children 0–3 and 4–7 in two halves (row offsets inside the node).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn test_sse2(node: &WideNode, ray: &WideRay, t_max: f32, entry: &mut [f32; 8]) -> u32 {
    use std::arch::x86_64::*;
    let b = node.bounds.as_ptr().cast::<f32>();
    // SAFETY (caller): the offsets are rows of the node; each load reads four of a row's eight
    // floats (16-byte aligned), each store four of `entry`'s.
    unsafe {
        let o = ray.origin.map(|x| _mm_set1_ps(x));
        let neg_inv = ray.neg_inv.map(|x| _mm_set1_ps(x));
        let (zero, tm, grow) = (_mm_setzero_ps(), _mm_set1_ps(t_max), _mm_set1_ps(GROW));
        let mut half = |h: usize| {
            let t = |off: usize, a: usize| _mm_mul_ps(_mm_sub_ps(o[a], _mm_load_ps(b.add(off + 4 * h))), neg_inv[a]);
            let tn = _mm_max_ps(_mm_max_ps(t(ray.near[0], 0), t(ray.near[1], 1)), _mm_max_ps(t(ray.near[2], 2), zero));
            let tf = _mm_min_ps(t(ray.far[0], 0), _mm_min_ps(t(ray.far[1], 1), t(ray.far[2], 2)));
            let tf = _mm_mul_ps(_mm_min_ps(tf, tm), grow);
            _mm_storeu_ps(entry.as_mut_ptr().add(4 * h), tn);
            _mm_movemask_ps(_mm_cmple_ps(tn, tf)) as u32
        };
        half(0) | half(1) << 4
    }
}

impl SceneGeometry {
    /// One ray's walk of the float-plane tree: the closest hit (`ANY` false) or the first hit
    /// found (`ANY` true), as (lane id, t, b1, b2), a lane id being a block's index × 4 + the lane
    /// ([`WideBvh::prim_ref`], [`WideBvh::triangle`]); `AVX` selects the AVX2 node test.
    ///
    /// A node's leaf children that the ray meets are tested at the node, block by block
    /// (`bvh/leaf.rs`); only internal children go on the stack.
    #[inline(always)]
    pub(super) fn walk_wide<const ANY: bool, const AVX: bool>(
        &self,
        wide: &WideBvh,
        ray: &Ray,
    ) -> Option<(u32, f32, f32, f32)> {
        let w = WideRay::new(ray);
        let lane_ray = LaneRay::new(Vec3A::from(ray.origin), Vec3A::from(ray.dir));
        let mut t_max = ray.t_max;
        let mut best = None;
        let mut stack = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut sp = 0usize;
        let mut entry = [0.0f32; 8];
        let mut index = 0u32;
        loop {
            // SAFETY: node 0 and every internal child reference are nodes (checked by
            // `WideBvh::new`).
            let node = unsafe { wide.nodes.get_unchecked(index as usize) };
            prefetch_leaf_blocks(wide, index);
            let mut hit = test::<AVX>(node, &w, t_max, &mut entry);
            let leaves = hit & node.leaf_children;
            if leaves != 0 {
                hit &= !leaves;
                // Each block holding lanes of the leaf children met.
                let t_before = t_max;
                for (block, want) in node.leaf_blocks(leaves) {
                    // SAFETY: a node's blocks are in `blocks` (checked by `WideBvh::new`).
                    let b = unsafe { wide.blocks.get_unchecked(block as usize) };
                    if let Some((lane, t, b1, b2)) = b.intersect::<ANY>(&lane_ray, t_max, want) {
                        let id = block * LANES as u32 + lane;
                        if ANY {
                            return Some((id, t, 0.0, 0.0));
                        }
                        t_max = t;
                        best = Some((id, t, b1, b2));
                    }
                }
                if t_max < t_before {
                    // Internal children the ray enters only beyond the new closest hit.
                    let mut h = hit;
                    while h != 0 {
                        let i = h.trailing_zeros() as usize & 7;
                        h &= h - 1;
                        if entry[i] > t_max * GROW {
                            hit &= !(1 << i);
                        }
                    }
                }
            }
            if hit != 0 {
                let rest = hit & (hit - 1);
                if rest == 0 {
                    index = node.child[hit.trailing_zeros() as usize & 7];
                    continue;
                }
                // Several. The child the ray would pop next is entered directly and the others
                // pushed, in the order a push of all of them (sorted farthest first for the
                // closest hit) would leave: the same walk, without a push and pop of the child
                // entered. Any hit: the highest child is entered, the others pushed in order.
                if ANY {
                    let last = (31 - hit.leading_zeros() as usize) & 7;
                    hit &= !(1 << last);
                    while hit != 0 {
                        let i = hit.trailing_zeros() as usize & 7;
                        hit &= hit - 1;
                        prefetch_node(wide, node.child[i]);
                        stack[sp % STACK] = MaybeUninit::new(Entry { node: node.child[i], t: entry[i] });
                        sp += 1;
                    }
                    index = node.child[last];
                    continue;
                }
                if rest & (rest - 1) == 0 {
                    // Two: the nearer is entered (the second on a tie, as the sort leaves it on
                    // top), the farther pushed.
                    let (i, j) = (hit.trailing_zeros() as usize & 7, rest.trailing_zeros() as usize & 7);
                    let (near, far) = if entry[j] <= entry[i] { (j, i) } else { (i, j) };
                    prefetch_node(wide, node.child[far]);
                    stack[sp % STACK] = MaybeUninit::new(Entry { node: node.child[far], t: entry[far] });
                    sp += 1;
                    index = node.child[near];
                    continue;
                }
                // Three or more: push them all, then order the new entries farthest first so
                // that the nearest is popped next.
                let base = sp;
                while hit != 0 {
                    let i = hit.trailing_zeros() as usize & 7;
                    hit &= hit - 1;
                    let e = Entry { node: node.child[i], t: entry[i] };
                    prefetch_node(wide, e.node);
                    stack[sp % STACK] = MaybeUninit::new(e);
                    sp += 1;
                }
                sort_farthest_first(&mut stack, base, sp);
            }
            // The next entry that can still hold a closer hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: every entry below sp was written by a push above.
                let e = unsafe { stack[sp % STACK].assume_init() };
                if ANY || e.t <= t_max * GROW {
                    index = e.node;
                    break;
                }
            }
        }
    }
}

/// Starts loading node `index`'s four cache lines. The entries a node pushes are visited later,
/// after the nearest one's subtree; their loads then overlap with that walk instead of each
/// waiting in turn.
#[inline(always)]
pub(super) fn prefetch_node(wide: &WideBvh, index: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let ptr = wide.nodes.as_ptr().wrapping_add(index as usize) as *const i8;
        for line in 0..size_of::<WideNode>() / 64 {
            // SAFETY: prefetch is a hint and never faults, whatever the address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(ptr.wrapping_add(64 * line)) };
        }
    }
}

/// Starts loading the first two of node `index`'s leaf blocks (six cache lines), if it has any, from
/// [`WideBvh::first_block`]. Called as a visit starts: the node's test decides which blocks the
/// ray needs, but waiting for it would put a second miss after the node's on the walk's chain.
/// Two blocks, because prefetching one or four was no faster (guide, "Performance notes and their
/// history", 2026-12-06 late morning).
#[inline(always)]
pub(super) fn prefetch_leaf_blocks(wide: &WideBvh, index: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: `first_block` has an entry for every node, and `index` is a node.
        let first = unsafe { *wide.first_block.get_unchecked(index as usize) };
        if first != NO_BLOCKS {
            let ptr = wide.blocks.as_ptr().wrapping_add(first as usize) as *const i8;
            for line in 0..2 * size_of::<Block>() / 64 {
                // SAFETY: prefetch is a hint and never faults, whatever the address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(ptr.wrapping_add(64 * line)) };
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (wide, index);
}

/// Orders `stack[base..end]` (entries written just before) by descending entry distance:
/// insertion sort, as there are at most eight.
#[inline(always)]
fn sort_farthest_first(stack: &mut [MaybeUninit<Entry>; STACK], base: usize, end: usize) {
    for i in base + 1..end {
        // SAFETY: entries base..end were written by the caller.
        let x = unsafe { stack[i % STACK].assume_init() };
        let mut j = i;
        while j > base {
            // SAFETY: as above (base ≤ j − 1 < end).
            let y = unsafe { stack[(j - 1) % STACK].assume_init() };
            if y.t >= x.t {
                break;
            }
            stack[j % STACK] = MaybeUninit::new(y);
            j -= 1;
        }
        stack[j % STACK] = MaybeUninit::new(x);
    }
}
