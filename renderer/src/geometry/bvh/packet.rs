//! Eight or sixteen any-hit rays walked through the float-plane tree together: a packet.
//!
//! The integrator's lanes are eight samples of one pixel, so their shadow and bounce rays leave
//! from nearly one point, and their walks visit mostly the same nodes (measured in the guide,
//! "Performance notes and their history"). A packet visits each node once for all of its rays
//! that entered it: each of those rays runs its own node test (the single walk's, [`test`]), and
//! the choices a visit makes (which children, pushed or entered, popped or skipped) are made once
//! for the packet, with a mask of the rays they concern. The wait for the node's lines and the
//! branches of those choices are then shared, where eight walks would each wait for the same node
//! and mispredict their own choices. Rays that go different ways cost only their own tests: a
//! node's test runs only for the rays that met its box.
//!
//! **The single walk's answers.** A ray of the packet runs its node test at every node whose
//! parent's test it passed, until it finds a hit, and tests the primitives of every leaf child it
//! meets: it reaches every node and primitive its single any-hit walk would, and finds a hit
//! exactly when that walk does. Whether a ray is blocked does not depend on the order of the visits
//! nor on which other rays share its packet.
//!
//! Closest hits stay with the single walk: which of several triangles hit at nearly the same t a
//! walk keeps depends on the order of its visits (`bvh/wide.rs`, "Exact hits"), and in a packet
//! that order depends on the other rays, so a sample's value would depend on how the samples are
//! batched (a shard or a round that starts inside a batch), which it must not.

use super::SceneGeometry;
use super::leaf::LaneRay;
use super::wide::{STACK, WideBvh, WideRay, prefetch_leaf_blocks, prefetch_node, test};
use crate::geometry::Ray;
use glam::Vec3A;
use std::mem::MaybeUninit;

/// Rays in the integrator's packets: its lanes.
pub const PACKET: usize = 8;

/// An entry of a packet's stack: a node and the rays that met its box.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    rays: u32,
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

impl SceneGeometry {
    /// Which of the rays `rays[r]` for the bits r of `want` (valid rays) hit something with t in
    /// (0, t_max), walked as one packet of `N` = 8 or 16 rays: bit r set where ray r's single
    /// any-hit walk ([`SceneGeometry::walk_wide`]) finds a hit. `AVX` selects the AVX2 node test.
    #[inline(always)]
    pub(super) fn walk_packet<const AVX: bool, const N: usize>(
        &self,
        wide: &WideBvh,
        rays: &[Ray; N],
        want: u32,
    ) -> u32 {
        const { assert!(N == 8 || N == 16) };
        if want == 0 {
            return 0;
        }
        let w: [WideRay; N] = std::array::from_fn(|r| WideRay::new(&rays[r]));
        let lane_rays: [LaneRay; N] =
            std::array::from_fn(|r| LaneRay::new(Vec3A::from(rays[r].origin), Vec3A::from(rays[r].dir)));
        // The rays still looking for a hit.
        let mut live = want;
        let mut stack = [MaybeUninit::<Entry>::uninit(); STACK];
        let mut sp = 0usize;
        let mut entry = [0.0f32; 8];
        let (mut index, mut active) = (0u32, want);
        loop {
            // SAFETY: node 0 and every internal child reference are nodes (checked by
            // `WideBvh::new`).
            let node = unsafe { wide.nodes.get_unchecked(index as usize) };
            prefetch_leaf_blocks(wide, index);
            // Each active ray's test: byte r % 8 of `hits[r / 8]` its hit children.
            let mut hits = [0u64; 2];
            let mut a = active;
            while a != 0 {
                let r = a.trailing_zeros() as usize % N;
                a &= a - 1;
                let h = test::<AVX>(node, &w[r], rays[r].t_max, &mut entry);
                hits[r / 8] |= (h as u64) << (8 * (r % 8));
            }
            let leaf_bytes = (node.leaf_children as u64) * 0x0101_0101_0101_0101;
            let leaf_hits = hits.map(|h| h & leaf_bytes);
            if leaf_hits[0] | leaf_hits[1] != 0 {
                hits = hits.map(|h| h & !leaf_bytes);
                // Ray by ray, as the single walk: the lanes of every leaf child it meets, then each
                // block holding some of them, until one is hit.
                let mut with_leaves = nonzero_bytes(leaf_hits[0]) | nonzero_bytes(leaf_hits[1]) << 8;
                while with_leaves != 0 {
                    let r = with_leaves.trailing_zeros() as usize % N;
                    with_leaves &= with_leaves - 1;
                    let (g, byte) = (r / 8, 8 * (r % 8));
                    for (block, lane_mask) in node.leaf_blocks((leaf_hits[g] >> byte) as u32 & 0xff) {
                        // SAFETY: a node's blocks are in `blocks` (checked by `WideBvh::new`).
                        let b = unsafe { wide.blocks.get_unchecked(block as usize) };
                        if b.intersect::<true>(&lane_rays[r], rays[r].t_max, lane_mask).is_some() {
                            live &= !(1 << r);
                            hits[g] &= !(0xff << byte);
                            break;
                        }
                    }
                }
                if live == 0 {
                    return want;
                }
            }
            let children = or_bytes(hits[0]) | or_bytes(hits[1]);
            if children != 0 {
                // Byte c of `by_child[g]`: the rays 8 g … 8 g + 7 that enter internal child c.
                let by_child = hits.map(transpose8);
                let rays_of =
                    |c: usize| (by_child[0] >> (8 * c)) as u32 & 0xff | ((by_child[1] >> (8 * c)) as u32 & 0xff) << 8;
                // As the single any-hit walk: the highest child is entered, the others pushed.
                let last = (31 - children.leading_zeros() as usize) & 7;
                let mut rest = children & !(1 << last);
                while rest != 0 {
                    let c = rest.trailing_zeros() as usize & 7;
                    rest &= rest - 1;
                    prefetch_node(wide, node.child[c]);
                    stack[sp % STACK] = MaybeUninit::new(Entry { node: node.child[c], rays: rays_of(c) });
                    sp += 1;
                }
                (index, active) = (node.child[last], rays_of(last));
                continue;
            }
            // The next entry that a ray still looking for a hit entered.
            loop {
                if sp == 0 {
                    return want & !live;
                }
                sp -= 1;
                // SAFETY: every entry below sp was written by a push above.
                let e = unsafe { stack[sp % STACK].assume_init() };
                if e.rays & live != 0 {
                    (index, active) = (e.node, e.rays & live);
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
