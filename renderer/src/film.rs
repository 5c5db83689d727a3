//! The film: per-pixel estimates with their standard errors, and the AOVs of docs/src/conventions.md §5.
//!
//! # Accumulation in a fixed dyadic tree (bit-exact shards)
//!
//! Floating-point addition is not associative, so an image merged from shards equals a single render
//! bit for bit only if both add the same numbers in the same tree. Every pixel's samples are therefore
//! combined in one fixed binary tree over the sample index: the statistics of an *aligned dyadic
//! block* `[j·2^k, (j+1)·2^k)` are those of its left half combined with those of its right half
//! ([`Stats::join`]), down to single samples. A block's value is thus the same bits whoever computed
//! it. A render of the sample range `[a, b)` keeps the canonical decomposition of its range into
//! maximal aligned blocks ([`canonical_blocks`]; a binary counter produces it while the samples
//! arrive in increasing index order); merging ranges coalesces sibling blocks into parents
//! ([`Partial::merge`]); and the image is the left-to-right fold of the canonical decomposition of
//! `[0, spp)` ([`Partial::finish`]). A single render does exactly the same, so a merge of any
//! partition of `[0, spp)` into ranges, in any order, equals the single render in every bit.
//!
//! # Blocks of lanes (where renders may split)
//!
//! The renderer traces a pixel's samples 8 at a time (the batch's lanes) and hands each batch
//! that is an aligned block `[8 j, 8 j + 8)` to the film at once ([`PixelAccumulator::add_8`]):
//! its statistics are computed in registers ([`octet_stats`], a fixed order: the tree's own 4
//! pairs, 2 quadruples and octet) and joined to the pixel's stack once, with no per-sample block
//! records. That computation *is* the tree's: the same operations on the same operands in the same
//! order, so an octet's statistics are the bits that 8 single samples joined one by one give.
//! Hence the rule: **a render may split anywhere.** A range whose start or end falls inside an
//! octet (`--shard` ranges, checkpoint and progressive passes that are not multiples of 8) adds
//! the samples of that partial octet one at a time ([`PixelAccumulator::add`], the exact
//! per-sample path), and the octets inside the range in registers; both give the tree's bits, so
//! the merge of any partition still equals the single render in every bit. (Splitting at
//! multiples of 8, as whole Sobol rounds of [`REPLICATES`] = 16 are, keeps every octet on the
//! fast path.) Tested by `add_8_is_eight_adds` and `shards_split_inside_octets_merge_bit_exactly`.
//!
//! # Standard error and its reliability flag
//!
//! Each block carries M2, the sum of squared deviations of its *batch sums*, where batches are the
//! aligned blocks of `B = 2^batch_log2` samples, combined pairwise with Chan, Golub & LeVeque's update
//! (1979) so that a constant pixel has exactly zero error and there is no cancellation; `stderr =
//! √(M2 / (K (K−1))) / B` over the K full batches (the batch-means estimator; samples of a final
//! partial batch count in the mean only). Renders use B = 1 ([`batch_log2`]), which is the sample
//! standard error of the mean: the error bar of the independent sampler.
//!
//! **Replicates (the Sobol sampler).** The points of one Owen-scrambled Sobol sequence are not
//! independent, and the sample standard error overstated their mean's error (1.35× at 16 spp, 4.55×
//! at 4096 on a Lambert sphere). The Sobol sampler therefore draws [`REPLICATES`] = R independent
//! scrambles, sample i in replicate i mod R (`crate::sampling::sampler`), and each block also carries
//! the sum of every replicate's samples (joined by addition in the same tree, so the same bits for
//! any partition). An aligned block of at least R samples holds equally many samples of every
//! replicate; over the canonical blocks of `[0, spp)` of that size (the q = ⌊spp / R⌋ full rounds),
//! the replicate means m_r are independent and identically distributed, and
//!
//! stderr = √(Σ_r (m_r − m)² / (R (R − 1))), m = Σ_r m_r / R,
//!
//! is unbiased in square for the variance of their mean, with R − 1 degrees of freedom ([`Partial::replicates`]
//! = R). Samples past the last full round count in the pixel value only (as a partial batch does).
//! Below one round (spp < R) every sample is in its own replicate, so the samples are independent and
//! the error is their sample standard error. **Where renders may split:** anywhere, for the bits (the
//! tree is the same); progressive and checkpointed passes are whole rounds from R spp on
//! (`src/cli/passes.rs`), so that a pass's image uses all its samples for its error bar.
//!
//! The reliability flag below reads the samples' own M2 (batches of one sample) for either sampler,
//! so its meaning does not depend on the sampler.
//!
//! Under a heavy-tailed estimator (a sun-like texel that light sampling misses in fewer than one
//! sample in a hundred), no error bar computed from a pixel's own samples can be trusted when the
//! rare event was drawn once or not at all. The first case is detected and *flagged*
//! ([`Pixel::unreliable`], the `stderr_flag.Y` layer; rule at [`UNRELIABLE_SHARE`]). The second
//! case cannot be seen in the pixel, but it can in its neighbours: the estimator's variance is a
//! smooth function of the pixel's normal and view (the rare outcome has about the same probability
//! and size in adjacent pixels), and a flag shows that the rare outcome occurs in this part of the
//! image. So [`Partial::finish_pooled`] raises, in every channel, the error bar of each pixel within
//! [`POOL_TRIGGER_RADIUS`] pixels of a flagged one (the flagged one included) to the *pooled* error
//! of its (2 [`POOL_RADIUS`] + 1)² window:
//!
//! σ_p ← max(σ_p, √(Σ_q σ_q² / |W|)), q over the window W (clipped at the image edges),
//!
//! where σ_q are the pixels' own standard errors ([`pool_heavy_tails`]). The pooled variance rests on
//! the rare events of nine pixels instead of one, and it does not depend on the pixel's own luck:
//! under a skewed estimator a pixel that drew fewer rare heavy samples than expected has both a low
//! value and a low own σ (its z is then large and negative), so neither its own σ nor a relative
//! error scaled by its own value can be trusted there. The max keeps a pixel's own larger error.
//! Pixels with no flag near them keep their own σ bit for bit, so the error bars of a scene without
//! flags do not change. Measured by tests/stderr_coverage.rs (`env-sun`, 64 seeds × 512 pixels at
//! 256 spp, |z| < 3 against the leave-one-out mean; nominal 99.73 %): the pixels' own σ covers the
//! unflagged pixels at 91.9 %, the pooled σ at 99.90 %, and the flagged at 100.00 % (own σ:
//! 99.70 %); the Grace probe at 64 spp, which flags 8.7 % of its pixels, goes from 98.42 % (flagged:
//! 92.49 %) to 99.69 % (flagged: 99.89 %; guide "Error bars"). The pooled bound is conservative where the rare event was
//! seen and honest where it was not; an event too rare to be flagged anywhere in a pixel's
//! neighbourhood stays a documented limit.
//!
//! **Too few batches for the flag.** Below [`UNRELIABLE_MIN_BATCHES`] batches (renders at < 16
//! spp) the flag is not computed, and the own σ is itself too noisy to be a pixel's error bar: from
//! n samples σ² has n − 1 degrees of freedom (at 4 spp a pixel's σ is below half the true value with
//! probability ≈ 0.14, and exactly 0 wherever the few samples happened to agree). There every pixel
//! is bounded by the same rule, σ_p = max(σ_own,p, √(Σ_q σ_own,q² / |W|)): the window's variance has
//! |W| (n − 1) degrees of freedom (27 at 4 spp). Measured in tests/stderr_coverage.rs.
//!
//! **One batch: no estimate.** A pixel with fewer than two batches (a render at 1 spp) has no
//! variance estimate: its `stderr` and `stderr_own` are +inf (unknown), not 0. Readers of the layer
//! treat it as absent (`vocab::image::Image::stderr_layer`) and the noise summary as no estimate.
//!
//! **Two layers.** `stderr` ([`Pixel::stderr`]) is the error bar: what renders write, and what every
//! error bar, k·σ tolerance and χ² of the analyses uses. `stderr_own` ([`Pixel::stderr_own`]) is the
//! pixel's own value, whose square is unbiased for the variance of the pixel mean: a sum of noise
//! energy Σ w σ² that must be *subtracted* (debiasing, `verify`'s `subspace`) uses it, because the
//! bound's square is biased high by construction.
//!
//! **Near flags: not written by renders.** [`Partial::finish`] (what `reflect render` writes)
//! applies the bound at low batch counts only; the bound near flags is [`Partial::finish_pooled`],
//! and `reflect verify` applies [`pool_heavy_tails`] to every render it judges. In renders it makes
//! the two-view filter fits of tests/partial_view_coverage.rs cover 47 % at 1σ but 96 % at 2σ (a
//! fixed bias in some coefficients that the own σ's χ²/ν inflation hid; guide "Error bars").
//!
//! The pooling is a fixed sequential function of the finished own values, so the result is the same
//! bits whatever the thread count or shard partition.

use crate::math::{Rgb, Vec3};
use crate::sampling::sampler::REPLICATES;

/// Number of f64 statistics per block: Σ rgb, M2 of batch sums (rgb), Σ normal over hits, hits, the
/// largest and smallest batch sum per channel (for the reliability flag), and Σ rgb of each of the
/// [`REPLICATES`] replicates (replicate r, channel c at `REP + 3 r + c`; zero for a sampler without
/// replicates).
pub const NSTAT: usize = 16 + 3 * REPLICATES as usize;
const SUM: usize = 0;
const M2: usize = 3;
const NORMAL: usize = 6;
const HITS: usize = 9;
const MAXB: usize = 10;
const MINB: usize = 13;
const REP: usize = 16;
// `PixelAccumulator::add_8`'s aligned octets hold 8 consecutive replicates.
const _: () = assert!(REPLICATES.is_multiple_of(8) && REPLICATES as f64 >= UNRELIABLE_MIN_BATCHES);

/// A pixel is flagged unreliable when, in some channel, one batch sum alone accounts for more than
/// this share of the batch sums' squared deviations M2 (with at least [`UNRELIABLE_MIN_BATCHES`]
/// batches). Its error bar then rests on one rare, heavy sample (a sun-like texel hit or missed): the
/// estimate of the variance is itself dominated by one event and is not to be trusted. For normal
/// batch means with 32 batches a share above ½ has probability ≈ 1e-4.
pub const UNRELIABLE_SHARE: f64 = 0.5;
/// The fewest batches for which the reliability flag is computed.
pub const UNRELIABLE_MIN_BATCHES: f64 = 16.0;

/// Radius of the window of the pooled error: (2 r + 1)² pixels (see the module docs).
pub const POOL_RADIUS: usize = 1;
/// A pixel's error bar is pooled when a flagged pixel is within this many pixels (Chebyshev
/// distance). 2 rather than 1: measured on `env-sun`, the unflagged pixels farther than 1 but within
/// 2 pixels of a flag cover at 97.4 % with their own σ; beyond 2, 66 of 32768 (seed, pixel) pairs remain.
pub const POOL_TRIGGER_RADIUS: usize = 2;

/// log2 of the batch size B of the standard error used by renders: 0, i.e. batches of one sample.
///
/// Batches of B > 1 samples were measured on the `env-sun` case (tests/stderr_coverage.rs, guide
/// "Error bars"): with the independent sampler the samples are already independent, so batching only
/// removes degrees of freedom, and the coverage failures come from rare events that were never drawn,
/// which no batching can see. A fixed B (not a function of spp) also keeps a render to a target error,
/// whose final spp is unknown in advance, equal to a plain render of the spp it reached. The film
/// supports any B ([`Partial::batch_log2`]) for estimators whose samples are correlated.
pub const fn batch_log2(_spp: u32) -> u32 {
    0
}

/// An aligned dyadic block of sample indices: `[start, start + 2^log2)`, `start` a multiple of `2^log2`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Block {
    pub start: u64,
    pub log2: u32,
}

impl Block {
    /// Number of samples in the block.
    pub fn size(&self) -> u64 {
        1 << self.log2
    }
    pub fn end(&self) -> u64 {
        self.start + self.size()
    }
    /// Whether `self` is the left sibling of `right` (together they form their parent block).
    pub fn is_left_sibling_of(&self, right: &Block) -> bool {
        self.log2 == right.log2 && self.end() == right.start && self.start.is_multiple_of(2 * self.size())
    }
}

/// The canonical decomposition of `[a, b)` into maximal aligned dyadic blocks, left to right.
pub fn canonical_blocks(a: u64, b: u64) -> Vec<Block> {
    let mut out = Vec::new();
    let mut s = a;
    while s < b {
        let mut k = if s == 0 { 63 } else { s.trailing_zeros() };
        while k > 0 && s + (1u64 << k) > b {
            k -= 1;
        }
        out.push(Block { start: s, log2: k });
        s += 1 << k;
    }
    out
}

/// The statistics of one block of one pixel. Plain data: combined only by [`Stats::join`] (siblings)
/// and the final left-to-right fold of [`Partial::finish`], both fixed functions of their inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats(pub [f64; NSTAT]);

impl Default for Stats {
    fn default() -> Self {
        Stats([0.0; NSTAT])
    }
}

impl Stats {
    /// The statistics of one sample; `replicate` is its replicate (sample index mod
    /// [`REPLICATES`]), or `None` for a sampler without replicates.
    #[inline(always)]
    pub fn sample(radiance: Rgb, normal: Vec3, hit: bool, batch_log2: u32, replicate: Option<usize>) -> Stats {
        let mut s = [0.0; NSTAT];
        s[SUM] = radiance.x as f64;
        s[SUM + 1] = radiance.y as f64;
        s[SUM + 2] = radiance.z as f64;
        if let Some(r) = replicate {
            // + 0.0: a −0.0 sample becomes +0.0, as any sum with the other replicates' zeros does,
            // so that the sums are the same bits however the block was put together.
            for c in 0..3 {
                s[REP + 3 * r + c] = s[SUM + c] + 0.0;
            }
        }
        if hit {
            s[NORMAL] = normal.x as f64;
            s[NORMAL + 1] = normal.y as f64;
            s[NORMAL + 2] = normal.z as f64;
            s[HITS] = 1.0;
        }
        if batch_log2 == 0 {
            for i in 0..3 {
                s[MAXB + i] = s[SUM + i];
                s[MINB + i] = s[SUM + i];
            }
        }
        Stats(s)
    }

    /// The statistics of the parent of two sibling blocks of `2^log2` samples each (`self` left).
    #[inline]
    pub fn join(&self, r: &Stats, log2: u32, batch_log2: u32) -> Stats {
        let mut parent = *self;
        parent.join_right(r, log2, batch_log2);
        parent
    }

    /// Makes `self`, the left one of two sibling blocks of `2^log2` samples each, their parent
    /// ([`Stats::join`] in place: every field is written, by the same operations on the same
    /// operands; the M2 terms read the two sums before they are added).
    #[inline(always)]
    pub fn join_right(&mut self, r: &Stats, log2: u32, batch_log2: u32) {
        let (a, b) = (&mut self.0, &r.0);
        if log2 + 1 == batch_log2 {
            // The parent is one batch.
            for i in 0..3 {
                let sum = a[SUM + i] + b[SUM + i];
                (a[M2 + i], a[MAXB + i], a[MINB + i]) = (0.0, sum, sum);
            }
        } else if log2 >= batch_log2 {
            // Chan et al.: M2 = M2_l + M2_r + (S_l − S_r)² / (2 k), k batches in each half.
            let k = (1u64 << (log2 - batch_log2)) as f64;
            for i in 0..3 {
                let d = a[SUM + i] - b[SUM + i];
                a[M2 + i] = a[M2 + i] + b[M2 + i] + d * d / (2.0 * k);
                a[MAXB + i] = a[MAXB + i].max(b[MAXB + i]);
                a[MINB + i] = a[MINB + i].min(b[MINB + i]);
            }
        } else {
            for i in 0..3 {
                (a[M2 + i], a[MAXB + i], a[MINB + i]) = (0.0, 0.0, 0.0);
            }
        }
        for i in 0..3 {
            a[SUM + i] += b[SUM + i];
            a[NORMAL + i] += b[NORMAL + i];
        }
        a[HITS] += b[HITS];
        for i in REP..NSTAT {
            a[i] += b[i];
        }
    }
}

/// The left-to-right fold of a canonical decomposition of `[0, n)` (block sizes decreasing).
#[derive(Clone, Copy, Debug)]
struct Fold {
    all: [f64; NSTAT],
    /// Σ rgb over the full batches only, and their number.
    batch_sum: [f64; 3],
    batches: f64,
    m2: [f64; 3],
    maxb: [f64; 3],
    minb: [f64; 3],
    /// Σ rgb per replicate over the blocks of at least [`REPLICATES`] samples (the full rounds, which
    /// hold the same number of samples of every replicate), and the number of those samples.
    rep: [f64; 3 * REPLICATES as usize],
    rounds_samples: u64,
}

impl Default for Fold {
    fn default() -> Self {
        Fold {
            all: [0.0; NSTAT],
            batch_sum: [0.0; 3],
            batches: 0.0,
            m2: [0.0; 3],
            maxb: [0.0; 3],
            minb: [0.0; 3],
            rep: [0.0; 3 * REPLICATES as usize],
            rounds_samples: 0,
        }
    }
}

impl Fold {
    fn push(&mut self, s: &Stats, block: &Block, batch_log2: u32) {
        let b = &s.0;
        for i in 0..3 {
            self.all[SUM + i] += b[SUM + i];
            self.all[NORMAL + i] += b[NORMAL + i];
        }
        self.all[HITS] += b[HITS];
        if block.size() >= REPLICATES as u64 {
            for (acc, x) in self.rep.iter_mut().zip(&b[REP..]) {
                *acc += x;
            }
            self.rounds_samples += block.size();
        }
        if block.log2 >= batch_log2 {
            let kr = (1u64 << (block.log2 - batch_log2)) as f64;
            if self.batches == 0.0 {
                self.m2 = [b[M2], b[M2 + 1], b[M2 + 2]];
                self.batch_sum = [b[SUM], b[SUM + 1], b[SUM + 2]];
                self.maxb = [b[MAXB], b[MAXB + 1], b[MAXB + 2]];
                self.minb = [b[MINB], b[MINB + 1], b[MINB + 2]];
            } else {
                let kl = self.batches;
                for i in 0..3 {
                    let d = self.batch_sum[i] / kl - b[SUM + i] / kr;
                    self.m2[i] += b[M2 + i] + d * d * kl * kr / (kl + kr);
                    self.batch_sum[i] += b[SUM + i];
                    self.maxb[i] = self.maxb[i].max(b[MAXB + i]);
                    self.minb[i] = self.minb[i].min(b[MINB + i]);
                }
            }
            self.batches += kr;
        }
    }

    fn finish(&self, n: u64, batch_log2: u32, replicates: u32) -> Pixel {
        let nf = n.max(1) as f64;
        let k = self.batches;
        let bsize = (1u64 << batch_log2) as f64;
        // Fewer than two batches have no spread to estimate a variance from: the error is unknown,
        // written as +inf (never 0, which would claim an exact pixel).
        let batch_se = |c: usize| if k > 1.0 { (self.m2[c] / (k - 1.0) / k).sqrt() / bsize } else { f64::INFINITY };
        // The replicate estimator (module docs): from the R replicate means of the full rounds.
        let rounds = self.rounds_samples / REPLICATES as u64;
        let replicate_se = |c: usize| {
            let r = REPLICATES as usize;
            let q = rounds as f64;
            let means: [f64; REPLICATES as usize] = std::array::from_fn(|i| self.rep[3 * i + c] / q);
            let mean = means.iter().sum::<f64>() / r as f64;
            let ss: f64 = means.iter().map(|m| (m - mean) * (m - mean)).sum();
            (ss / (r * (r - 1)) as f64).sqrt()
        };
        let se = |c: usize| if replicates > 1 && rounds >= 1 { replicate_se(c) } else { batch_se(c) };
        let a = &self.all;
        let nl = (a[NORMAL].powi(2) + a[NORMAL + 1].powi(2) + a[NORMAL + 2].powi(2)).sqrt();
        let normal =
            if nl > 0.0 { [a[NORMAL], a[NORMAL + 1], a[NORMAL + 2]].map(|v| (v / nl) as f32) } else { [0.0; 3] };
        let unreliable = k >= UNRELIABLE_MIN_BATCHES
            && (0..3).any(|c| {
                let mean = self.batch_sum[c] / k;
                let dev = (self.maxb[c] - mean).max(mean - self.minb[c]);
                self.m2[c] > 0.0 && dev * dev > UNRELIABLE_SHARE * self.m2[c]
            });
        Pixel {
            rgb: [a[SUM], a[SUM + 1], a[SUM + 2]].map(|v| (v / nf) as f32),
            stderr: [se(0) as f32, se(1) as f32, se(2) as f32],
            stderr_own: [se(0) as f32, se(1) as f32, se(2) as f32],
            normal,
            mask: (a[HITS] / nf) as f32,
            unreliable,
        }
    }
}

/// Combines one pixel's samples, arriving in increasing index order from `start`, into the
/// canonical blocks of their range (a binary counter: a new block is joined with its left sibling
/// while there is one).
///
/// The stack lives inline (no allocation per pixel, no call to `memcpy` per sample: ~20 % of the
/// film's instructions were these); [`PixelAccumulator::reset`] reuses one accumulator for the
/// pixels of a tile. The joins are the same, in the same order, so the statistics are the same bits.
#[derive(Clone, Debug)]
pub struct PixelAccumulator {
    batch_log2: u32,
    /// Whether the samples' replicate sums are kept (a sampler with replicates).
    replicated: bool,
    next: u64,
    /// Number of blocks on the stack: `blocks[..len]`, `stats[..len]`.
    len: usize,
    blocks: [Block; ACC_STACK],
    stats: [Stats; ACC_STACK],
}

/// Capacity of a [`PixelAccumulator`]'s stack: the canonical decomposition of any `[start, next)`
/// of u64 sample indices has at most 2 · 64 blocks (sizes increasing, then decreasing).
const ACC_STACK: usize = 128;

impl PixelAccumulator {
    /// An accumulator for samples `start, start + 1, …`, with batches of `2^batch_log2` samples and,
    /// if `replicates` > 1 (it must then be [`REPLICATES`]), the sums of each replicate.
    pub fn new(start: u64, batch_log2: u32, replicates: u32) -> Self {
        assert!(replicates == 1 || replicates == REPLICATES, "{replicates} replicates");
        PixelAccumulator {
            batch_log2,
            replicated: replicates > 1,
            next: start,
            len: 0,
            blocks: [Block { start: 0, log2: 0 }; ACC_STACK],
            stats: [Stats::default(); ACC_STACK],
        }
    }

    /// Empties the accumulator for another pixel's samples `start, start + 1, …` (the same as
    /// `new(start, batch_log2)` without initialising the stack again).
    #[inline]
    pub fn reset(&mut self, start: u64) {
        self.next = start;
        self.len = 0;
    }

    /// Adds the next sample. (Always inlined: see `render::render_tile`'s instruction-set versions.)
    #[inline(always)]
    pub fn add(&mut self, radiance: Rgb, normal: Vec3, hit: bool) {
        self.stats[self.len] = Stats::sample(radiance, normal, hit, self.batch_log2, self.replicate_of(self.next));
        let block = Block { start: self.next, log2: 0 };
        self.next += 1;
        self.push_written(block);
    }

    /// The replicate of sample `i`, if replicate sums are kept.
    #[inline(always)]
    fn replicate_of(&self, i: u64) -> Option<usize> {
        self.replicated.then_some((i % REPLICATES as u64) as usize)
    }

    /// Adds the next 8 samples (`radiance[k]`, `normal[k]`, `hit[k]` in sample order): the same
    /// statistics, bit for bit, as 8 calls of [`PixelAccumulator::add`] (module docs, "Blocks of
    /// lanes"). Where the next sample's index is a multiple of 8 the 8 samples are one aligned block,
    /// summed in registers ([`octet_stats`]) and joined to the stack once; elsewhere this is the 8
    /// `add`s.
    #[inline(always)]
    pub fn add_8(&mut self, radiance: &[Rgb; 8], normal: &[Vec3; 8], hit: &[bool; 8]) {
        if !self.next.is_multiple_of(8) {
            for k in 0..8 {
                self.add(radiance[k], normal[k], hit[k]);
            }
            return;
        }
        // The octet is aligned and 8 divides REPLICATES: its replicates are rep, rep + 1, …, rep + 7.
        let replicate = self.replicate_of(self.next);
        octet_stats(radiance, normal, hit, self.batch_log2, replicate, &mut self.stats[self.len]);
        let block = Block { start: self.next, log2: 3 };
        self.next += 8;
        self.push_written(block);
    }

    /// Pushes `block`, whose statistics the caller has written into the stack's next slot
    /// (`stats[len]`), joining it into its left sibling on the stack while there is one (a binary
    /// counter's carries; [`Stats::join_right`] in place, no copies of the statistics).
    #[inline(always)]
    fn push_written(&mut self, mut block: Block) {
        let mut top = self.len;
        while top > 0 && self.blocks[top - 1].is_left_sibling_of(&block) {
            let (left, right) = self.stats.split_at_mut(top);
            left[top - 1].join_right(&right[0], block.log2, self.batch_log2);
            block = Block { start: self.blocks[top - 1].start, log2: block.log2 + 1 };
            top -= 1;
        }
        self.blocks[top] = block;
        self.len = top + 1;
    }

    /// The canonical blocks of the samples added so far, left to right.
    pub fn blocks(&self) -> impl Iterator<Item = (Block, &Stats)> {
        self.blocks[..self.len].iter().copied().zip(&self.stats[..self.len])
    }
}

/// The statistics of an aligned block of 8 samples (`radiance[k]`, `normal[k]`, `hit[k]` of
/// samples `8 j + k`; `replicate`: that of sample 8 j, or `None`), computed in registers and
/// written into every field of `out` (the accumulator's stack slot: no copy): the same
/// bits as the tree of [`Stats::sample`] and [`Stats::join`] over the block (4 pairs, 2 quadruples,
/// the octet), because it makes the same operations on the same operands in the same order, only
/// on the fields a block of 8 can make non-zero. The replicate sums of the block are its samples
/// themselves (+ 0.0, as in `Stats::sample`): within an aligned octet every sample has its own
/// replicate, and a join adds +0.0 to them.
#[inline(always)]
// Lane loops index every operand by the lane: the form LLVM vectorizes.
#[allow(clippy::needless_range_loop)]
pub fn octet_stats(
    radiance: &[Rgb; 8],
    normal: &[Vec3; 8],
    hit: &[bool; 8],
    batch_log2: u32,
    replicate: Option<usize>,
    out: &mut Stats,
) {
    let bl = batch_log2;
    let s = &mut out.0;
    // The replicate sums of the 8 replicates the octet does not hold (all 16 without replicates):
    // zeros, written a group of 8 replicates at a time (a fixed size: stores, no call to memset).
    for g in 0..REPLICATES as usize / 8 {
        if replicate != Some(8 * g) {
            s[REP + 24 * g..REP + 24 * (g + 1)].copy_from_slice(&[0.0; 24]);
        }
    }
    // Per channel: a sum, M2 and the extreme batch sums of each node of the tree, level by level,
    // node j of a level from nodes 2 j and 2 j + 1 of the level below (in place: j ≤ 2 j).
    for c in 0..3 {
        let mut sum = [0.0f64; 8];
        for k in 0..8 {
            sum[k] = radiance[k][c] as f64;
        }
        let leaf_batch = if bl == 0 { sum } else { [0.0; 8] };
        let (mut m2, mut maxb, mut minb) = ([0.0f64; 8], leaf_batch, leaf_batch);
        for level in 0..3u32 {
            for j in 0..(4 >> level) {
                let (a, b) = (2 * j, 2 * j + 1);
                let parent = sum[a] + sum[b];
                // `Stats::join`'s three cases, in its expressions.
                if level + 1 == bl {
                    (m2[j], maxb[j], minb[j]) = (0.0, parent, parent);
                } else if level >= bl {
                    let k = (1u64 << (level - bl)) as f64;
                    let d = sum[a] - sum[b];
                    m2[j] = m2[a] + m2[b] + d * d / (2.0 * k);
                    maxb[j] = maxb[a].max(maxb[b]);
                    minb[j] = minb[a].min(minb[b]);
                } else {
                    (m2[j], maxb[j], minb[j]) = (0.0, 0.0, 0.0);
                }
                sum[j] = parent;
            }
        }
        s[SUM + c] = sum[0];
        s[M2 + c] = m2[0];
        s[MAXB + c] = maxb[0];
        s[MINB + c] = minb[0];
        if let Some(r) = replicate {
            for k in 0..8 {
                s[REP + 3 * (r + k) + c] = radiance[k][c] as f64 + 0.0;
            }
        }
        // The normals of the hits and the hit count: plain pairwise sums.
        let mut nsum = [0.0f64; 8];
        for k in 0..8 {
            nsum[k] = if hit[k] { normal[k][c] as f64 } else { 0.0 };
        }
        s[NORMAL + c] = pairwise_8(nsum);
    }
    let mut hits = [0.0f64; 8];
    for k in 0..8 {
        hits[k] = if hit[k] { 1.0 } else { 0.0 };
    }
    s[HITS] = pairwise_8(hits);
}

/// ((x0 + x1) + (x2 + x3)) + ((x4 + x5) + (x6 + x7)): the order of the film's tree.
#[inline(always)]
fn pairwise_8(x: [f64; 8]) -> f64 {
    ((x[0] + x[1]) + (x[2] + x[3])) + ((x[4] + x[5]) + (x[6] + x[7]))
}

/// The finished value of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pixel {
    pub rgb: [f32; 3],
    /// The error bar of the pixel mean (the `stderr` layer): the bound of [`pool_heavy_tails`] after
    /// [`Partial::finish_pooled`], and after [`Partial::finish`] at low spp; elsewhere (and where the
    /// bound does not raise it) equal to [`Pixel::stderr_own`].
    pub stderr: [f32; 3],
    /// The standard error from the pixel's own samples alone (batch means, module docs; the
    /// `stderr_own` layer): calibrated in expectation (its square is unbiased for the variance of the
    /// mean), which is what debiasing a noise energy Σ σ² needs, but not a bound for the one pixel
    /// (module docs).
    pub stderr_own: [f32; 3],
    pub normal: [f32; 3],
    pub mask: f32,
    /// The pixel's own error bar rests on one rare heavy contribution and is not to be trusted (see
    /// [`UNRELIABLE_SHARE`]); written as the `stderr_flag.Y` layer (1 = unreliable). `stderr` of this
    /// pixel and of its neighbours within [`POOL_TRIGGER_RADIUS`] is the pooled bound of
    /// [`pool_heavy_tails`].
    pub unreliable: bool,
}

/// A finished image, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Pixel>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film { width, height, pixels: vec![Pixel::default(); (width * height) as usize] }
    }

    #[inline]
    pub fn get(&self, row: u32, col: u32) -> &Pixel {
        &self.pixels[(row * self.width + col) as usize]
    }

    /// Number of pixels flagged [`Pixel::unreliable`].
    pub fn unreliable_count(&self) -> usize {
        self.pixels.iter().filter(|p| p.unreliable).count()
    }

    /// Number of pixels whose `stderr` the bound of [`pool_heavy_tails`] raised above their own
    /// (`stderr` > `stderr_own` in some channel).
    pub fn pooled_count(&self) -> usize {
        self.pixels.iter().filter(|p| p.stderr.iter().zip(&p.stderr_own).any(|(b, o)| b > o)).count()
    }
}

/// The mergeable state of a render of the sample range `[start, end)` of every pixel of a
/// `width × height` image at `spp` samples per pixel: per pixel, the [`Stats`] of the canonical
/// blocks of the range (the same blocks for every pixel), pixel-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Partial {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// log2 of the batch size of the standard error (see [`batch_log2`]).
    pub batch_log2: u32,
    /// The sampler's number of replicates: [`REPLICATES`] (the replicate estimator of the standard
    /// error) or 1 (the batch-means estimator; module docs).
    pub replicates: u32,
    pub start: u64,
    pub end: u64,
    pub blocks: Vec<Block>,
    pub stats: Vec<Stats>,
}

/// Why two partial renders cannot be merged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MergeError {
    /// Different image sizes or spp.
    Mismatch(String),
    /// Sample ranges that overlap.
    Overlap { a: (u64, u64), b: (u64, u64) },
    /// A gap between consecutive ranges.
    Gap { from: u64, to: u64 },
}

impl std::fmt::Display for MergeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MergeError::Mismatch(m) => write!(f, "{m}"),
            MergeError::Overlap { a, b } => {
                write!(f, "sample range [{}, {}) overlaps [{}, {})", b.0, b.1, a.0, a.1)
            }
            MergeError::Gap { from, to } => write!(f, "samples [{from}, {to}) are in no part"),
        }
    }
}

impl Partial {
    /// An empty range at `start` (the identity of [`Partial::merge`] for ranges starting there).
    pub fn empty(width: u32, height: u32, spp: u32, batch_log2: u32, replicates: u32, start: u64) -> Self {
        Partial { width, height, spp, batch_log2, replicates, start, end: start, blocks: Vec::new(), stats: Vec::new() }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The blocks' statistics of pixel `p`.
    pub fn pixel(&self, p: usize) -> &[Stats] {
        let nb = self.blocks.len();
        &self.stats[p * nb..(p + 1) * nb]
    }

    /// Whether this holds every sample of the render.
    pub fn is_complete(&self) -> bool {
        self.start == 0 && self.end == self.spp as u64
    }

    /// Merges partial renders whose ranges are contiguous and disjoint (any order), coalescing
    /// sibling blocks. The result is the same bits as a render of the union range.
    pub fn merge(mut parts: Vec<Partial>) -> Result<Partial, MergeError> {
        if parts.is_empty() {
            return Err(MergeError::Mismatch("nothing to merge".into()));
        }
        let (w, h, spp, bl, reps) =
            (parts[0].width, parts[0].height, parts[0].spp, parts[0].batch_log2, parts[0].replicates);
        for p in &parts {
            if (p.width, p.height, p.spp, p.batch_log2, p.replicates) != (w, h, spp, bl, reps) {
                return Err(MergeError::Mismatch(format!(
                    "{}×{} at {} spp (batches of 2^{}, {} replicates), expected {w}×{h} at {spp} spp (batches of \
                     2^{bl}, {reps} replicates)",
                    p.width, p.height, p.spp, p.batch_log2, p.replicates
                )));
            }
        }
        let first_start = parts.iter().map(|p| p.start).min().unwrap_or(0);
        parts.retain(|p| p.end > p.start);
        if parts.is_empty() {
            return Ok(Partial::empty(w, h, spp, bl, reps, first_start));
        }
        parts.sort_by_key(|p| (p.start, p.end));
        for pair in parts.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            if b.start < a.end {
                return Err(MergeError::Overlap { a: (a.start, a.end), b: (b.start, b.end) });
            }
            if b.start > a.end {
                return Err(MergeError::Gap { from: a.end, to: b.start });
            }
        }
        if parts.len() == 1 {
            return Ok(parts.swap_remove(0));
        }
        let (start, end) = (parts[0].start, parts[parts.len() - 1].end);
        let npix = w as usize * h as usize;
        let blocks = canonical_blocks(start, end);
        let mut stats = Vec::with_capacity(npix * blocks.len());
        let mut stack: Vec<(Block, Stats)> = Vec::with_capacity(64);
        for px in 0..npix {
            stack.clear();
            for part in &parts {
                for (b, s) in part.blocks.iter().zip(part.pixel(px)) {
                    let (mut b, mut s) = (*b, *s);
                    while let Some((top, ts)) = stack.last() {
                        if !top.is_left_sibling_of(&b) {
                            break;
                        }
                        s = ts.join(&s, b.log2, bl);
                        b = Block { start: top.start, log2: b.log2 + 1 };
                        stack.pop();
                    }
                    stack.push((b, s));
                }
            }
            debug_assert!(stack.iter().map(|(b, _)| *b).eq(blocks.iter().copied()));
            stats.extend(stack.iter().map(|(_, s)| *s));
        }
        Ok(Partial { width: w, height: h, spp, batch_log2: bl, replicates: reps, start, end, blocks, stats })
    }

    /// The image of a complete render (what `reflect render` and `merge` write): per pixel, the
    /// left-to-right fold of the canonical blocks of `[0, spp)` ([`Partial::finish_own`]); when the
    /// render has fewer than [`UNRELIABLE_MIN_BATCHES`] batches, every error bar bounded by
    /// [`pool_heavy_tails`] (module docs). The bound near flagged pixels is [`Partial::finish_pooled`],
    /// not written by renders (module docs, "Near flags: not written by renders"). `stderr_own` keeps the own
    /// value. Panics if the range is not complete (check [`Partial::is_complete`]).
    pub fn finish(&self) -> Film {
        let mut film = self.finish_own();
        if self.low_batch_count() {
            pool_heavy_tails(&mut film, true);
        }
        film
    }

    /// [`Partial::finish`] with the error bars near flagged pixels bounded too: the full bound of
    /// [`pool_heavy_tails`]. Equal to `finish` below [`UNRELIABLE_MIN_BATCHES`] batches (no flags
    /// there) and wherever no pixel is flagged. Panics like `finish`.
    pub fn finish_pooled(&self) -> Film {
        let mut film = self.finish_own();
        pool_heavy_tails(&mut film, self.low_batch_count());
        film
    }

    /// Whether the render has too few batches for the reliability flag ([`UNRELIABLE_MIN_BATCHES`]):
    /// then every pixel's error bar is bounded by its window's ([`pool_heavy_tails`]).
    pub fn low_batch_count(&self) -> bool {
        ((self.spp as u64 >> self.batch_log2) as f64) < UNRELIABLE_MIN_BATCHES
    }

    /// The image with every pixel's error bar from its own samples only (`stderr` = `stderr_own`, no
    /// bound): what [`Partial::finish`] starts from. Panics like `finish`.
    pub fn finish_own(&self) -> Film {
        assert!(self.is_complete(), "finish() of an incomplete range [{}, {})", self.start, self.end);
        let bl = self.batch_log2;
        let mut film = Film::new(self.width, self.height);
        for (px, out) in film.pixels.iter_mut().enumerate() {
            let mut f = Fold::default();
            for (b, s) in self.blocks.iter().zip(self.pixel(px)) {
                f.push(s, b, bl);
            }
            *out = f.finish(self.spp as u64, bl, self.replicates);
        }
        film
    }
}

/// Bounds the error bars of a finished film: every pixel within [`POOL_TRIGGER_RADIUS`] of a
/// [flagged](Pixel::unreliable) pixel, or every pixel when `everywhere` (a render with fewer batches
/// than the flag needs, [`Partial::low_batch_count`]), gets, per channel, the larger of its own
/// error and the pooled error of its (2 [`POOL_RADIUS`] + 1)² window W:
/// σ_p = max(σ_own,p, √(Σ_q σ_own,q² / |W|)) (module docs, "Standard error and its reliability flag").
/// Reads only [`Pixel::stderr_own`], in a fixed order in f64: deterministic, and idempotent. Pixels
/// that are not bounded get `stderr` = `stderr_own` bit for bit.
pub fn pool_heavy_tails(film: &mut Film, everywhere: bool) {
    let (w, h) = (film.width as usize, film.height as usize);
    for p in film.pixels.iter_mut() {
        p.stderr = p.stderr_own;
    }
    if !everywhere && !film.pixels.iter().any(|p| p.unreliable) {
        return;
    }
    let own: Vec<([f32; 3], bool)> = film.pixels.iter().map(|p| (p.stderr_own, p.unreliable)).collect();
    let window = |r: usize, c: usize, rad: usize| {
        let rows = r.saturating_sub(rad)..(r + rad + 1).min(h);
        let cols = c.saturating_sub(rad)..(c + rad + 1).min(w);
        rows.flat_map(move |rr| cols.clone().map(move |cc| rr * w + cc))
    };
    for r in 0..h {
        for c in 0..w {
            if !everywhere && !window(r, c, POOL_TRIGGER_RADIUS).any(|q| own[q].1) {
                continue;
            }
            let p = &mut film.pixels[r * w + c];
            for ch in 0..3 {
                let (mut var, mut n) = (0.0f64, 0.0f64);
                for q in window(r, c, POOL_RADIUS) {
                    var += (own[q].0[ch] as f64).powi(2);
                    n += 1.0;
                }
                p.stderr[ch] = p.stderr_own[ch].max((var / n).sqrt() as f32);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `add_8` gives the statistics of 8 `add`s, bit for bit, for aligned and unaligned starts
    /// (the tree of joins and the fallback), batch sizes below, at and above 8 samples, hits and
    /// misses, and ranges that end inside a batch of 8.
    #[test]
    fn add_8_is_eight_adds() {
        let mut rng = crate::sampling::chi2::TestRng::new(5);
        for (batch_log2, reps) in [(0u32, 1u32), (2, 1), (3, 1), (5, 1), (0, REPLICATES), (3, REPLICATES)] {
            for start in [0u64, 3, 8, 40, 1 << 20, (1 << 20) + 5] {
                for n in [8u64, 16, 24, 61, 200] {
                    let mut one = PixelAccumulator::new(start, batch_log2, reps);
                    let mut eight = PixelAccumulator::new(start, batch_log2, reps);
                    let mut done = 0;
                    while done < n {
                        let m = (n - done).min(8);
                        let mut r = [Rgb::ZERO; 8];
                        let mut nl = [Vec3::ZERO; 8];
                        let mut h = [false; 8];
                        for k in 0..8 {
                            // Some −0.0 samples: the replicate sums keep the same bits either way.
                            let z = if rng.next_f32() < 0.2 { -0.0 } else { rng.next_f32() };
                            r[k] = Rgb::new(z, rng.next_f32() * 10.0, rng.next_f32().powi(8));
                            nl[k] = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                            h[k] = rng.next_f32() < 0.7;
                        }
                        for k in 0..m as usize {
                            one.add(r[k], nl[k], h[k]);
                        }
                        if m == 8 {
                            eight.add_8(&r, &nl, &h);
                        } else {
                            for k in 0..m as usize {
                                eight.add(r[k], nl[k], h[k]);
                            }
                        }
                        done += m;
                    }
                    let a: Vec<_> = one.blocks().map(|(b, s)| (b, s.0.map(f64::to_bits))).collect();
                    let b: Vec<_> = eight.blocks().map(|(b, s)| (b, s.0.map(f64::to_bits))).collect();
                    assert_eq!(a, b, "batch_log2 {batch_log2}, {reps} replicates, start {start}, {n} samples");
                }
            }
        }
    }

    fn acc_range(xs: &[f32], a: usize, b: usize, bl: u32, reps: u32) -> Vec<(Block, Stats)> {
        let mut acc = PixelAccumulator::new(a as u64, bl, reps);
        for &x in &xs[a..b] {
            acc.add(Rgb::new(x, 2.0 * x, 0.5), Vec3::Z, x > 2.0);
        }
        acc.blocks().map(|(b, s)| (b, *s)).collect()
    }

    /// A pixel's range `[a, b)` handed to the film in batches of up to 8 samples: with `aligned`
    /// as the renderer does (the rest of an octet the range starts in one sample at a time, then
    /// whole aligned octets through `add_8`, then the samples of an octet the range ends in one at
    /// a time); without, 8 at a time from `a` on, so that a range starting inside an octet hands
    /// every full batch to `add_8` unaligned (its per-sample path), and only the last, short batch
    /// goes one sample at a time.
    fn partial_lanes(xs: &[f32], a: usize, b: usize, bl: u32, reps: u32, aligned: bool) -> Partial {
        let mut acc = PixelAccumulator::new(a as u64, bl, reps);
        let sample = |i: usize| {
            let x = xs[i];
            (Rgb::new(x, 2.0 * x, -x), Vec3::new(x, 1.0, -0.5), !(i * 7).is_multiple_of(3))
        };
        let mut i = a;
        while i < b {
            let n = if aligned { (b - i).min(8 - i % 8) } else { (b - i).min(8) };
            if n == 8 {
                let (mut r, mut nl, mut h) = ([Rgb::ZERO; 8], [Vec3::ZERO; 8], [false; 8]);
                for k in 0..8 {
                    (r[k], nl[k], h[k]) = sample(i + k);
                }
                acc.add_8(&r, &nl, &h);
            } else {
                for k in i..i + n {
                    let (r, nl, h) = sample(k);
                    acc.add(r, nl, h);
                }
            }
            i += n;
        }
        let v: Vec<(Block, Stats)> = acc.blocks().map(|(b, s)| (b, *s)).collect();
        Partial {
            width: 1,
            height: 1,
            spp: xs.len() as u32,
            batch_log2: bl,
            replicates: reps,
            start: a as u64,
            end: b as u64,
            blocks: v.iter().map(|x| x.0).collect(),
            stats: v.iter().map(|x| x.1).collect(),
        }
    }

    /// The film's rule "a render may split anywhere" (module docs, "Blocks of lanes"): shards whose
    /// ends fall inside octets (per-sample path there, octets in registers elsewhere) merge to the
    /// bits of the single render, whose octets all take the register path; and those bits are the
    /// per-sample tree's. Each shard is handed over both ways of `partial_lanes`: octets aligned, as
    /// the renderer does, and batches of 8 from the shard's start, which give `add_8` unaligned
    /// octets wherever a cut falls inside one (the cuts below do in nearly every draw). Batch sizes
    /// below, at and above 8, with and without replicates.
    #[test]
    fn shards_split_inside_octets_merge_bit_exactly() {
        let mut rng = crate::sampling::chi2::TestRng::new(21);
        let mut unaligned_octets = 0;
        for (bl, reps) in [(0u32, REPLICATES), (0, 1), (2, 1), (4, REPLICATES)] {
            for spp in [8usize, 16, 40, 64, 203] {
                // Some −0.0 and heavy samples.
                let xs: Vec<f32> =
                    (0..spp).map(|_| if rng.next_f32() < 0.1 { -0.0 } else { rng.next_f32().powi(6) * 50.0 }).collect();
                let single = partial_lanes(&xs, 0, spp, bl, reps, true);
                let mut one_by_one = PixelAccumulator::new(0, bl, reps);
                for (i, &x) in xs.iter().enumerate() {
                    one_by_one.add(Rgb::new(x, 2.0 * x, -x), Vec3::new(x, 1.0, -0.5), !(i * 7).is_multiple_of(3));
                }
                let tree: Vec<u64> = one_by_one.blocks().flat_map(|(_, s)| s.0.map(f64::to_bits)).collect();
                let fast: Vec<u64> = single.stats.iter().flat_map(|s| s.0.map(f64::to_bits)).collect();
                assert_eq!(fast, tree, "bl {bl}, {reps} replicates, spp {spp}: octets in registers");
                let single = single.finish_own();
                for _ in 0..10 {
                    let mut cuts: Vec<usize> =
                        (0..1 + rng.next_u64() % 4).map(|_| (rng.next_u64() as usize) % (spp + 1)).collect();
                    cuts.extend([0, spp]);
                    cuts.sort();
                    // A shard [a, b) starting inside an octet with 8 samples or more gives add_8 an
                    // unaligned octet when batched from its start.
                    unaligned_octets += cuts.windows(2).filter(|c| c[0] % 8 != 0 && c[1] - c[0] >= 8).count();
                    for aligned in [true, false] {
                        let parts =
                            cuts.windows(2).map(|c| partial_lanes(&xs, c[0], c[1], bl, reps, aligned)).collect();
                        let merged = Partial::merge(parts).unwrap().finish_own();
                        let bits = |f: &Film| f.pixels.iter().map(|p| format!("{p:?}")).collect::<Vec<_>>();
                        assert_eq!(
                            bits(&merged),
                            bits(&single),
                            "bl {bl}, spp {spp}, cuts {cuts:?}, aligned {aligned}"
                        );
                    }
                }
            }
        }
        // The unaligned path was taken, in many shards (the draws are fixed: this guards the seed).
        assert!(unaligned_octets >= 20, "{unaligned_octets} shards gave add_8 an unaligned octet");
    }

    fn partial(xs: &[f32], a: usize, b: usize) -> Partial {
        partial_b(xs, a, b, 0)
    }

    fn partial_b(xs: &[f32], a: usize, b: usize, bl: u32) -> Partial {
        partial_r(xs, a, b, bl, 1)
    }

    fn partial_r(xs: &[f32], a: usize, b: usize, bl: u32, reps: u32) -> Partial {
        let spp = xs.len() as u32;
        let v = acc_range(xs, a, b, bl, reps);
        Partial {
            width: 1,
            height: 1,
            spp,
            batch_log2: bl,
            replicates: reps,
            start: a as u64,
            end: b as u64,
            blocks: v.iter().map(|x| x.0).collect(),
            stats: v.iter().map(|x| x.1).collect(),
        }
    }

    #[test]
    fn canonical_blocks_are_maximal_and_cover() {
        for a in 0..40u64 {
            for b in a..80u64 {
                let bl = canonical_blocks(a, b);
                let mut s = a;
                for x in &bl {
                    assert_eq!(x.start, s);
                    assert_eq!(x.start % x.size(), 0);
                    // Maximal: the parent is not inside [a, b).
                    let p = Block { start: x.start - x.start % (2 * x.size()), log2: x.log2 + 1 };
                    assert!(p.start < a || p.end() > b, "{a} {b} {x:?}");
                    s = x.end();
                }
                assert_eq!(s, b);
            }
        }
    }

    #[test]
    fn accumulator_produces_the_canonical_blocks() {
        let xs: Vec<f32> = (0..77).map(|i| (i as f32 * 0.37).sin().abs() * 3.0).collect();
        for (a, b) in [(0, 77), (3, 50), (13, 14), (16, 64)] {
            let got: Vec<Block> = acc_range(&xs, a, b, 0, 1).iter().map(|x| x.0).collect();
            assert_eq!(got, canonical_blocks(a as u64, b as u64));
        }
    }

    /// Any partition of [0, spp), merged in any order, gives the single render's bits.
    #[test]
    fn merge_of_any_partition_is_bit_identical() {
        let mut rng = crate::sampling::chi2::TestRng::new(4);
        for spp in [1usize, 7, 64, 100, 257, 1000] {
            let xs: Vec<f32> = (0..spp).map(|_| rng.next_f32().powi(3) * 10.0).collect();
            let bl = (spp as u32 / 32).max(1).ilog2();
            // With and without replicate sums (any partition: the split need not be at rounds).
            let reps = if spp % 2 == 0 { REPLICATES } else { 1 };
            let single = partial_r(&xs, 0, spp, bl, reps).finish();
            for _ in 0..20 {
                let mut cuts: Vec<usize> =
                    (0..rng.next_u64() % 6).map(|_| (rng.next_u64() as usize) % (spp + 1)).collect();
                cuts.push(0);
                cuts.push(spp);
                cuts.sort();
                let mut parts: Vec<Partial> = cuts.windows(2).map(|c| partial_r(&xs, c[0], c[1], bl, reps)).collect();
                // Shuffle.
                for i in (1..parts.len()).rev() {
                    parts.swap(i, rng.next_u64() as usize % (i + 1));
                }
                // Merge some pairs first (a part may be a merge of others), then the rest.
                if parts.len() >= 3 {
                    let (a, b) = (parts.remove(0), parts.remove(0));
                    if a.end == b.start || b.end == a.start {
                        parts.push(Partial::merge(vec![a, b]).unwrap());
                    } else {
                        parts.push(a);
                        parts.push(b);
                    }
                }
                let merged = Partial::merge(parts).unwrap();
                assert!(merged.is_complete());
                assert_eq!(merged.finish().pixels, single.pixels, "spp {spp} cuts {cuts:?}");
            }
        }
    }

    #[test]
    fn merge_refuses_overlaps_and_gaps() {
        let xs = [1.0f32; 16];
        let e = Partial::merge(vec![partial(&xs, 0, 8), partial(&xs, 6, 16)]).unwrap_err();
        assert_eq!(e, MergeError::Overlap { a: (0, 8), b: (6, 16) });
        let e = Partial::merge(vec![partial(&xs, 9, 16), partial(&xs, 0, 8)]).unwrap_err();
        assert_eq!(e, MergeError::Gap { from: 8, to: 9 });
    }

    #[test]
    fn sample_variance_when_batches_are_single_samples() {
        let xs = [1.0f32, 2.0, 4.0, 8.0, 3.0];
        let p = partial(&xs, 0, 5).finish().pixels[0];
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / 5.0;
        let var = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / 4.0;
        assert!((p.rgb[0] as f64 - mean).abs() < 1e-6);
        assert!((p.stderr[0] as f64 - (var / 5.0).sqrt()).abs() < 1e-6);
        assert!((p.stderr[1] as f64 - 2.0 * (var / 5.0).sqrt()).abs() < 1e-6);
        assert_eq!(p.stderr[2], 0.0, "a constant channel has exactly zero error");
        assert!((p.mask - 0.6).abs() < 1e-6);
        assert_eq!(p.normal, [0.0, 0.0, 1.0]);
    }

    /// One sample has no spread: the error is unknown (+inf), never the 0 of an exact pixel, in the
    /// error bar and the pixel's own value alike; two equal samples are an exact 0.
    #[test]
    fn one_sample_has_no_error_estimate() {
        let p = partial(&[2.0], 0, 1).finish().pixels[0];
        assert_eq!((p.stderr, p.stderr_own), ([f32::INFINITY; 3], [f32::INFINITY; 3]));
        let p = partial(&[2.0, 2.0], 0, 2).finish().pixels[0];
        assert_eq!(p.stderr[0], 0.0);
    }

    #[test]
    fn batch_means_match_the_two_pass_formula() {
        let mut rng = crate::sampling::chi2::TestRng::new(8);
        let spp = 200usize; // B = 4 (50 batches), no tail
        let xs: Vec<f32> = (0..spp).map(|_| rng.next_f32()).collect();
        let p = partial_b(&xs, 0, spp, 2).finish().pixels[0];
        let bs: Vec<f64> = xs.chunks(4).map(|c| c.iter().map(|&x| x as f64).sum::<f64>() / 4.0).collect();
        let k = bs.len() as f64;
        let m = bs.iter().sum::<f64>() / k;
        let se = (bs.iter().map(|b| (b - m).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt();
        assert!((p.stderr[0] as f64 - se).abs() < 1e-6 * se, "{} vs {se}", p.stderr[0]);
    }

    /// One rare heavy sample (or one rare miss) among many comparable ones is flagged; uniform noise is not.
    #[test]
    fn one_dominant_batch_is_flagged() {
        let mut xs = vec![1.0f32; 256];
        assert!(!partial(&xs, 0, 256).finish().pixels[0].unreliable, "constant");
        xs[77] = 300.0;
        assert!(partial(&xs, 0, 256).finish().pixels[0].unreliable, "one sun hit");
        xs[77] = 0.0;
        assert!(partial(&xs, 0, 256).finish().pixels[0].unreliable, "one sun miss");
        let mut rng = crate::sampling::chi2::TestRng::new(3);
        let flagged = (0..200)
            .filter(|_| {
                let xs: Vec<f32> = (0..256).map(|_| rng.next_f32()).collect();
                partial(&xs, 0, 256).finish().pixels[0].unreliable
            })
            .count();
        assert_eq!(flagged, 0);
    }

    /// Pooling raises the error bars within [`POOL_TRIGGER_RADIUS`] of a flag to the window's pooled
    /// error and leaves every other pixel (and any film without a flag) bit for bit; with
    /// `everywhere` (too few batches for the flag) every pixel is bounded. `stderr_own` never changes.
    #[test]
    fn pooling_bounds_the_neighbourhood_of_a_flag_only() {
        let mut film = Film::new(9, 5);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            p.rgb = [2.0, 1.0, 0.0];
            p.stderr_own = [0.01 * (1 + i % 3) as f32, 0.0, 0.0];
            p.stderr = [7.0; 3]; // overwritten from stderr_own
        }
        pool_heavy_tails(&mut film, false);
        assert!(film.pixels.iter().all(|p| p.stderr == p.stderr_own), "no flag: own σ");
        assert_eq!(film.pooled_count(), 0);
        // A flagged pixel at (1, 1) whose own σ saw the rare event.
        let f = 9 + 1;
        film.pixels[f].unreliable = true;
        film.pixels[f].stderr_own = [0.9, 0.3, 0.0];
        let own = film.clone();
        // The expected bound of (r, c) over its clipped 3 × 3 window, from the own values.
        let bound = |r: u32, c: u32, ch: usize| {
            let (mut var, mut n) = (0.0f64, 0.0);
            for rr in r.saturating_sub(1)..(r + 2).min(5) {
                for cc in c.saturating_sub(1)..(c + 2).min(9) {
                    var += (own.get(rr, cc).stderr_own[ch] as f64).powi(2);
                    n += 1.0;
                }
            }
            own.get(r, c).stderr_own[ch].max((var / n).sqrt() as f32)
        };
        for everywhere in [false, true] {
            pool_heavy_tails(&mut film, everywhere);
            let pooled = film.clone();
            pool_heavy_tails(&mut film, everywhere);
            assert_eq!(film.pixels, pooled.pixels, "idempotent");
            let mut raised = 0;
            for r in 0..5 {
                for c in 0..9 {
                    let (p, o) = (film.get(r, c), own.get(r, c));
                    assert_eq!((p.stderr_own, p.rgb), (o.stderr_own, o.rgb));
                    raised += (p.stderr != p.stderr_own) as usize;
                    if !everywhere && (r > 3 || c > 3) {
                        assert_eq!(p.stderr, o.stderr_own, "({r}, {c}) is farther than 2 from the flag");
                        continue;
                    }
                    for ch in 0..3 {
                        assert_eq!(p.stderr[ch], bound(r, c, ch), "({r}, {c}) channel {ch}");
                    }
                    assert_eq!(p.stderr[2], 0.0, "a noise-free channel keeps σ = 0");
                }
            }
            assert_eq!(film.pooled_count(), raised);
            assert!(raised > 0);
        }
        // The flag's neighbours now carry its rare event: (1, 2) is next to it.
        assert!(film.get(1, 2).stderr[0] > 10.0 * own.get(1, 2).stderr_own[0]);
    }

    /// Below [`UNRELIABLE_MIN_BATCHES`] batches every pixel is bounded; from there on only near a flag.
    #[test]
    fn low_batch_counts_bound_every_pixel() {
        let xs: Vec<f32> = (0..16).map(|i| (i % 5) as f32).collect();
        assert!(partial(&xs[..15], 0, 15).low_batch_count());
        assert!(!partial(&xs, 0, 16).low_batch_count());
        assert!(partial_b(&xs, 0, 16, 1).low_batch_count(), "8 batches of 2");
    }

    /// A tail shorter than a batch counts in the mean but not in the batch-means error.
    #[test]
    fn batches_with_a_tail() {
        let xs: Vec<f32> = (0..70).map(|i| (i % 7) as f32).collect();
        let p = partial_b(&xs, 0, 70, 3).finish().pixels[0];
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / 70.0;
        assert!((p.rgb[0] as f64 - mean).abs() < 1e-6);
        let bs: Vec<f64> = xs[..64].chunks(8).map(|c| c.iter().map(|&x| x as f64).sum::<f64>() / 8.0).collect();
        let m = bs.iter().sum::<f64>() / 8.0;
        let se = (bs.iter().map(|b| (b - m).powi(2)).sum::<f64>() / 7.0 / 8.0).sqrt();
        assert!((p.stderr[0] as f64 - se).abs() < 1e-6 * se.max(1e-9));
    }

    /// With replicates, the error is the spread of the R replicate means of the full rounds
    /// (sample i in replicate i mod R), √(Σ_r (m_r − m)² / (R (R − 1))), the mean of every sample
    /// (a tail shorter than a round counts in the mean only); below one round it is the sample
    /// standard error; a constant pixel has exactly zero error.
    #[test]
    fn replicate_estimator_matches_the_two_pass_formula() {
        let mut rng = crate::sampling::chi2::TestRng::new(12);
        let r = REPLICATES as usize;
        for spp in [r, 4 * r, 4 * r + 5, 100 * r] {
            let xs: Vec<f32> = (0..spp).map(|_| rng.next_f32().powi(2) * 3.0).collect();
            let p = partial_r(&xs, 0, spp, 0, REPLICATES).finish_own().pixels[0];
            let q = spp / r;
            let means: Vec<f64> =
                (0..r).map(|k| (0..q).map(|j| xs[j * r + k] as f64).sum::<f64>() / q as f64).collect();
            let m = means.iter().sum::<f64>() / r as f64;
            let se = (means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (r * (r - 1)) as f64).sqrt();
            assert!((p.stderr_own[0] as f64 - se).abs() < 1e-6 * se, "{spp}: {} vs {se}", p.stderr_own[0]);
            assert!((p.stderr_own[1] as f64 - 2.0 * se).abs() < 2e-6 * se);
            assert_eq!(p.stderr_own[2], 0.0, "a constant channel has exactly zero error");
            let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / spp as f64;
            assert!((p.rgb[0] as f64 - mean).abs() < 1e-6);
        }
        // Below one round: the sample standard error (each sample its own replicate).
        let xs = [1.0f32, 2.0, 4.0, 8.0, 3.0];
        let a = partial_r(&xs, 0, 5, 0, REPLICATES).finish_own().pixels[0];
        let b = partial_b(&xs, 0, 5, 0).finish_own().pixels[0];
        assert_eq!(a.stderr_own, b.stderr_own);
        // Values stratified within each replicate (replicate k's points alternate about k's mean):
        // the samples spread widely, the replicate means do not.
        let xs: Vec<f32> =
            (0..64 * r).map(|i| (i % r) as f32 * 0.01 + if (i / r).is_multiple_of(2) { 5.0 } else { -5.0 }).collect();
        let p = partial_r(&xs, 0, xs.len(), 0, REPLICATES).finish_own().pixels[0];
        let own = partial_b(&xs, 0, xs.len(), 0).finish_own().pixels[0];
        assert!(p.stderr_own[0] < 0.1 * own.stderr_own[0], "{} vs {}", p.stderr_own[0], own.stderr_own[0]);
    }
}
