//! Up to eight rays walked through the float-plane tree together: a packet.
//!
//! The integrator's lanes are eight samples of one pixel, so their camera rays are nearly one ray,
//! and their shadow and bounce rays leave from nearly one point: their walks visit mostly the same
//! nodes (measured in the guide, "Performance notes and their history"). A packet visits each node
//! once for all of its rays that entered it: each of those rays runs its own node test
//! ([`test_min`], the single walk's), and the choices a visit makes (which children, in what
//! order, pushed or entered, popped or skipped) are made once for the packet, with a mask of the
//! rays they concern. The visit's load and its branches are then shared, where eight walks would
//! each wait for the same node and mispredict their own choices. Each ray's leaf tests are its
//! own, with its own closest hit so far. Rays that go different ways only cost their own tests:
//! a node's test runs only for the rays that met its box.
//!
//! **Same answers as the single walk.** A ray of the packet runs the single walk's node test on
//! every node whose parent's test it passed, and the triangle tests on every leaf child it meets,
//! so it visits every node and tests every primitive its single walk would (and possibly more:
//! the packet's order is not each ray's). Any-hit: the same answer. Closest hit: the least t of
//! the primitives tested, as for the single walk, which can differ from it only where several
//! triangles are hit at nearly the same t (`bvh/wide.rs`, "Exact hits").
//!
//! The stack holds a node, the mask of rays that met it, and the least entry distance of those
//! rays (a lower bound of each one's): an entry is skipped, for each ray, where that bound lies
//! beyond the ray's closest hit so far.

use super::SceneGeometry;
use super::leaf::{LANES, LaneRay};
use super::wide::{GROW, LEAF, STACK, WideBvh, WideRay, prefetch_node, sort_farthest_first, test_min};
use crate::geometry::Ray;
use glam::Vec3A;
use std::mem::MaybeUninit;

/// Rays in a packet: the integrator's lanes.
pub const PACKET: usize = 8;

/// An entry of a packet's stack: a node, the rays that met its box, and the least of their entry
/// distances.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    rays: u32,
    t: f32,
}

/// Transposes the 8 × 8 bit matrix whose byte r holds row r: bit 8 r + c moves to 8 c + r
/// (Warren, "Hacker's Delight", §7-3). Byte r = ray r's hit children in, byte c = child c's rays
/// out.
#[inline(always)]
fn transpose8(mut x: u64) -> u64 {
    let t = (x ^ (x >> 7)) & 0x00AA_00AA_00AA_00AA;
    x ^= t ^ (t << 7);
    let t = (x ^ (x >> 14)) & 0x0000_CCCC_0000_CCCC;
    x ^= t ^ (t << 14);
    let t = (x ^ (x >> 28)) & 0x0000_0000_F0F0_F0F0;
    x ^ t ^ (t << 28)
}

/// Bit i set where byte i of `x` is not zero.
#[inline(always)]
fn nonzero_bytes(x: u64) -> u32 {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    // The high bit of each byte: set where the byte's low seven bits carry into it or it was set.
    let high = (((x & LOW7) + LOW7) | x) & !LOW7;
    // The eight high bits gathered into the top byte (no two partial products overlap).
    ((high >> 7).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
}

/// The OR of the eight bytes of `x`.
#[inline(always)]
fn or_bytes(x: u64) -> u32 {
    let x = x | x >> 32;
    let x = x | x >> 16;
    (x | x >> 8) as u32 & 0xff
}

/// The rays of `rays` (bit r: ray r) whose closest hit so far lies at or beyond `t`, so that a box
/// they enter at `t` can still hold a closer one.
#[inline(always)]
fn within<const N: usize>(t: f32, t_max: &[f32; N], rays: u32) -> u32 {
    let mut keep = 0;
    for (r, &t_max) in t_max.iter().enumerate() {
        keep |= ((t <= t_max * GROW) as u32) << r;
    }
    keep & rays
}

impl SceneGeometry {
    /// The walks of the rays `rays[r]` for the bits r of `want` (valid rays), as one packet of
    /// `N` = 8 or 16 rays: for each, the closest hit (`ANY` false) or a hit (`ANY` true) as
    /// [`SceneGeometry::walk_wide`] returns it; `None` for the rays not wanted. `AVX` selects the
    /// AVX2 node test.
    #[inline(always)]
    pub(super) fn walk_packet<const ANY: bool, const AVX: bool, const N: usize>(
        &self,
        wide: &WideBvh,
        rays: &[Ray; N],
        want: u32,
    ) -> [Option<(u32, f32, f32, f32)>; N] {
        const { assert!(N == 8 || N == 16) };
        let mut best = [None; N];
        if want == 0 {
            return best;
        }
        let w: [WideRay; N] = std::array::from_fn(|r| WideRay::new(&rays[r]));
        let lane_rays: [LaneRay; N] =
            std::array::from_fn(|r| LaneRay::new(Vec3A::from(rays[r].origin), Vec3A::from(rays[r].dir)));
        let mut t_max: [f32; N] = std::array::from_fn(|r| rays[r].t_max);
        // Any hit: the rays still looking for one.
        let mut live = want;
        let mut stack = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut sp = 0usize;
        let mut entry = [[0.0f32; 8]; N];
        let (mut index, mut active) = (0u32, want);
        loop {
            // SAFETY: node 0 and every internal child reference are nodes (checked by
            // `WideBvh::new`).
            let node = unsafe { wide.nodes.get_unchecked(index as usize) };
            // Each active ray's test: byte r % 8 of `hits[r / 8]` its hit children; `near` each
            // child's least entry distance over the rays that meet it.
            let mut near = [f32::INFINITY; 8];
            let mut hits = [0u64; 2];
            let mut a = active;
            while a != 0 {
                let r = a.trailing_zeros() as usize % N;
                a &= a - 1;
                let h = test_min::<AVX>(node, &w[r], t_max[r], &mut entry[r], &mut near);
                hits[r / 8] |= (h as u64) << (8 * (r % 8));
            }
            let leaf_bytes = (node.leaf_children as u64) * 0x0101_0101_0101_0101;
            let leaf_hits = hits.map(|h| h & leaf_bytes);
            if leaf_hits[0] | leaf_hits[1] != 0 {
                hits = hits.map(|h| h & !leaf_bytes);
                // Ray by ray, as the single walk: the lanes of every leaf child it meets, then each
                // block holding some of them.
                let mut with_leaves = nonzero_bytes(leaf_hits[0]) | nonzero_bytes(leaf_hits[1]) << 8;
                while with_leaves != 0 {
                    let r = with_leaves.trailing_zeros() as usize % N;
                    with_leaves &= with_leaves - 1;
                    let (g, byte) = (r / 8, 8 * (r % 8));
                    let (mut lanes, mut l) = (0, (leaf_hits[g] >> byte) as u32 & 0xff);
                    while l != 0 {
                        lanes |= node.child[l.trailing_zeros() as usize & 7];
                        l &= l - 1;
                    }
                    lanes &= !LEAF;
                    let t_before = t_max[r];
                    while lanes != 0 {
                        let shift = lanes.trailing_zeros() & !(LANES as u32 - 1);
                        let lane_mask = (lanes >> shift) & ((1 << LANES) - 1);
                        lanes &= !(((1 << LANES) - 1) << shift);
                        let block = node.block + shift / LANES as u32;
                        // SAFETY: a node's blocks are in `blocks` (checked by `WideBvh::new`).
                        let b = unsafe { wide.blocks.get_unchecked(block as usize) };
                        if let Some((lane, t, b1, b2)) = b.intersect::<ANY>(&lane_rays[r], t_max[r], lane_mask) {
                            let id = block * LANES as u32 + lane;
                            best[r] = Some((id, t, b1, b2));
                            if ANY {
                                break;
                            }
                            t_max[r] = t;
                        }
                    }
                    if ANY {
                        if best[r].is_some() {
                            live &= !(1 << r);
                            hits[g] &= !(0xff << byte);
                        }
                    } else if t_max[r] < t_before {
                        // Internal children this ray enters only beyond its new closest hit.
                        let mut h = (hits[g] >> byte) as u32 & 0xff;
                        while h != 0 {
                            let i = h.trailing_zeros() as usize & 7;
                            h &= h - 1;
                            if entry[r][i] > t_max[r] * GROW {
                                hits[g] &= !(1u64 << (byte + i));
                            }
                        }
                    }
                }
                if ANY && live == 0 {
                    return best;
                }
            }
            let children = or_bytes(hits[0]) | or_bytes(hits[1]);
            if children != 0 {
                // Byte c of `by_child[g]`: the rays 8 g … 8 g + 7 that enter internal child c.
                let by_child = hits.map(transpose8);
                let rays_of =
                    |c: usize| (by_child[0] >> (8 * c)) as u32 & 0xff | ((by_child[1] >> (8 * c)) as u32 & 0xff) << 8;
                let rest = children & (children - 1);
                if rest == 0 {
                    let c = children.trailing_zeros() as usize & 7;
                    (index, active) = (node.child[c], rays_of(c));
                    continue;
                }
                // Several: as the single walk, the child that would be popped next is entered and
                // the others pushed (for the closest hit farthest first by their least entry
                // distance; for any hit in child order, the highest entered).
                if rest & (rest - 1) == 0 {
                    let (i, j) = (children.trailing_zeros() as usize & 7, rest.trailing_zeros() as usize & 7);
                    let (enter, push) = if ANY || near[j] <= near[i] { (j, i) } else { (i, j) };
                    let e = Entry { node: node.child[push], rays: rays_of(push), t: near[push] };
                    prefetch_node(wide, e.node);
                    stack[sp % STACK] = MaybeUninit::new(e);
                    sp += 1;
                    (index, active) = (node.child[enter], rays_of(enter));
                    continue;
                }
                let base = sp;
                let mut ch = children;
                while ch != 0 {
                    let c = ch.trailing_zeros() as usize & 7;
                    ch &= ch - 1;
                    let e = Entry { node: node.child[c], rays: rays_of(c), t: near[c] };
                    prefetch_node(wide, e.node);
                    stack[sp % STACK] = MaybeUninit::new(e);
                    sp += 1;
                }
                if !ANY {
                    sort_farthest_first(&mut stack, base, sp, |e| e.t);
                }
                sp -= 1;
                // SAFETY: written just above.
                let e = unsafe { stack[sp % STACK].assume_init() };
                (index, active) = (e.node, e.rays);
                continue;
            }
            // The next entry that some ray can still find a closer hit (any hit: a first hit) in.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                // SAFETY: every entry below sp was written by a push above.
                let e = unsafe { stack[sp % STACK].assume_init() };
                let rays = if ANY { e.rays & live } else { within(e.t, &t_max, e.rays) };
                if rays != 0 {
                    (index, active) = (e.node, rays);
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transpose8_moves_bit_8r_plus_c_to_8c_plus_r() {
        for r in 0..8 {
            for c in 0..8 {
                assert_eq!(transpose8(1 << (8 * r + c)), 1 << (8 * c + r), "row {r} column {c}");
            }
        }
        let x = 0x0123_4567_89ab_cdef;
        assert_eq!(transpose8(transpose8(x)), x);
    }

    #[test]
    fn byte_masks() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..10_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Clear random bytes so that every pattern of zero bytes occurs.
            let y = x & (0..8).fold(0u64, |m, i| if (x >> (60 - i)) & 1 != 0 { m | 0xff << (8 * i) } else { m });
            let bytes = y.to_le_bytes();
            let nonzero = (0..8).fold(0, |m, i| m | ((bytes[i] != 0) as u32) << i);
            assert_eq!(nonzero_bytes(y), nonzero, "{y:#x}");
            assert_eq!(or_bytes(y), bytes.iter().fold(0, |m, &b| m | b as u32), "{y:#x}");
        }
        assert_eq!(nonzero_bytes(u64::MAX), 0xff);
        assert_eq!(nonzero_bytes(0x8000_0000_0000_0001), 0x81);
    }
}
