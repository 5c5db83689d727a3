//! Counter-based samplers: every number is a pure function of (seed, pixel, sample index,
//! dimension), so an image is bit-identical whatever the number of threads or the tile order
//! (docs/src/conventions.md §5).
//!
//! - `Independent`: a 64-bit hash of the four counters.
//! - `Sobol`: [`REPLICATES`] independent replicates of padded Owen-scrambled Sobol points (Burley
//!   2020, "Practical Hash-based Owen Scrambling"), interleaved: sample i of a pixel is point
//!   j = ⌊i / R⌋ of replicate r = i mod R. Each replicate has its own scrambles (its seeds are
//!   hashed from the pixel's key of the dimension and r), so the R replicate means of a pixel are
//!   independent and their spread is an unbiased estimate of the error of the pixel mean
//!   (randomised QMC, Owen 1997; the film's replicate estimator, `crate::film`). Within a
//!   replicate, each pair of dimensions uses the first two Sobol dimensions, Owen-scrambled with its
//!   own hash-derived seeds, and the point index j is itself Owen-scrambled (shuffled) per pixel,
//!   replicate and dimension pair so that pairs are decorrelated. Any power-of-two prefix of a
//!   replicate's points is a (0, m, 2)-net in every pair of dimensions, and any prefix of R·k
//!   samples of a pixel holds k points of every replicate.
//! - `SobolSingle` (`sobol-single`): one Owen-scrambled Sobol sequence per pixel, no replicates:
//!   sample i of a pixel is point i of the one sequence, built as one replicate of `Sobol` is (it
//!   is replicate 0's: sample i has the numbers of `Sobol`'s sample R·i, for i < 2^32 / R). Any
//!   power-of-two prefix of a pixel's samples is a (0, m, 2)-net in every pair of dimensions, so
//!   at n spp its error is that of one net of n points rather than the mean of R nets of n / R
//!   points (lower; guide, "Error bars"). With no replicates its error bar is the film's batch
//!   estimator over single samples, which treats the correlated points as independent and
//!   over-estimates the error (conservative). Dimensions of different draws are padded, as in
//!   any padded sampler (Mitsuba's `ldsampler` too): within a pixel their pair is a random
//!   permutation of strata, not a net; across pixels it is uniform.
//!
//! # Draws in lanes
//!
//! The batched integrator traces `N` consecutive samples of one pixel together, and every live
//! path of a batch is at the same vertex, so it wants the same dimension of every lane at once:
//! [`SampleLanes::draw_2d`] and [`SampleLanes::draw_1d`] give it, written once over the lane types
//! ([`U32`], [`Float`]) for every `N`; the one-sample [`Sampler`] is the same code at `N = 1`. A
//! draw hashes the pixel's key with the dimension once for all lanes (64-bit, scalar), and then
//! runs in u32 lanes only: each lane's three scrambling seeds are a 32-bit hash (`hash32`) of
//! that key's parts and the lane's replicate, the Laine–Karras permutations and bit reversals are
//! u32 operations, and the second Sobol dimension is the bit-parallel form of its generator matrix
//! (`sobol1_reversed`). No per-lane key cache and no table gathers are needed: the seeds cost
//! less to compute in lanes than to look up.

// Lane loops index every operand by the lane: the form LLVM vectorizes.
#![allow(clippy::needless_range_loop)]

use crate::math::Vec2;
use crate::simd::{Float, Isa, Sse2, U32};

/// The sample generator (`render.sampler`), defined in `vocab`.
pub use vocab::Sampler as SamplerKind;

/// R, the number of independent replicates (independent scrambles) of the Sobol sampler: sample i
/// of a pixel belongs to replicate i mod R (docs/src/conventions.md §5).
///
/// The error bar of a pixel is the spread of its R replicate means, an estimate with R − 1 degrees
/// of freedom: with R = 16, σ̂ is within ≈ 18 % (1/√(2(R−1))) of σ, z = (x − μ)/σ̂ follows Student's t
/// with 15 degrees of freedom (|z| < 3 for 99.1 % of pixels rather than the normal 99.73 %), and a
/// render reaches the film's 16 batches for the reliability flag at the same spp as the independent
/// sampler. A larger R would tighten σ̂ but leave fewer points in each replicate, and a replicate's
/// points are where the QMC gain comes from (at n spp each replicate is a net of n / R points; the
/// variance cost against one sequence of n points is measured in the guide, "Error bars").
pub const REPLICATES: u32 = vocab::closed::SOBOL_REPLICATES;
// The lanes split an index into replicate and point with a mask and a shift.
const _: () = assert!(REPLICATES.is_power_of_two());

/// Multiplies a replicate number into the input of its seeds' hash (Knuth's golden-ratio constant:
/// the 16 replicates give 16 inputs far apart in every bit).
const REPLICATE_MIX: u32 = 0x9E37_79B9;

/// Tags the key of a 2D draw's dimension (a 1D draw's is the plain dimension): the two never share keys.
const TAG_2D: u64 = 1 << 40;

/// A strong 64-bit mixer (the SplitMix64 / Stafford "mix13" finalizer).
#[inline(always)]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[inline(always)]
fn hash2(a: u64, b: u64) -> u64 {
    mix64(a ^ mix64(b.wrapping_add(0x9E37_79B9_7F4A_7C15)))
}

#[inline(always)]
fn to_unit_f32(x: u32) -> f32 {
    // 24 high bits: exactly representable, strictly below 1.
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A 32-bit bijective mixer (Wellons's "lowbias32", 2018): a lane's scrambling seed from its
/// dimension key and replicate. u32 multiplications only, so it runs in SIMD lanes.
#[inline(always)]
fn hash32<const N: usize, S: Isa>(x: U32<N, S>) -> U32<N, S> {
    let x = x ^ x.shift_right(16);
    let x = x.wrapping_mul(0x7feb_352d);
    let x = x ^ x.shift_right(15);
    let x = x.wrapping_mul(0x846c_a68b);
    x ^ x.shift_right(16)
}

/// Laine–Karras style hash that only lets bits influence more significant ones (when applied to
/// bit-reversed values it becomes a nested uniform, i.e. Owen, scramble).
#[inline(always)]
fn lk_permutation<const N: usize, S: Isa>(x: U32<N, S>, seed: U32<N, S>) -> U32<N, S> {
    let mut x = x.wrapping_add(seed);
    x = x ^ x.wrapping_mul(0x6c50_b47c);
    x = x ^ x.wrapping_mul(0xb82f_1e52);
    x = x ^ x.wrapping_mul(0xc7af_e638);
    x ^ x.wrapping_mul(0x8d22_f6e6)
}

/// Owen scramble of x (a point of the van der Corput sequence is `reverse(i)`, so this is the
/// scramble of the value `x` read as a binary fraction): the definition the tests check against.
#[cfg(test)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    lk_permutation(U32::<1>::from_array([x.reverse_bits()]), U32::from_array([seed])).0[0].reverse_bits()
}

/// Second Sobol dimension of index `i` (primitive polynomial x + 1), bit-reversed: the XOR of the
/// generator-matrix columns v_k (v_0 = 2^31, v_{k+1} = v_k ^ (v_k >> 1)) of the set bits k of i,
/// reversed. Column k is (1 + D)^k applied to the top bit (D: a shift right by one), so the
/// reversed sum holds the coefficients of Σ_k i_k (1 + t)^k: i's bits as a polynomial, shifted by
/// t → t + 1 (a Taylor shift over GF(2)). Since (1 + t)^(2^m) = 1 + t^(2^m) there, the shift is
/// five steps, each adding every upper half of a block of 2^(m+1) coefficients to its lower half:
/// 10 lane operations instead of a loop over 32 bits or table gathers (a test checks it against the
/// bit loop).
#[inline(always)]
fn sobol1_reversed<const N: usize, S: Isa>(i: U32<N, S>) -> U32<N, S> {
    let mut x = i;
    x = x ^ x.shift_right(1).and(0x5555_5555);
    x = x ^ x.shift_right(2).and(0x3333_3333);
    x = x ^ x.shift_right(4).and(0x0f0f_0f0f);
    x = x ^ x.shift_right(8).and(0x00ff_00ff);
    x ^ x.shift_right(16)
}

/// `N` samples of one pixel, drawn together: lane k is sample `index[k]`. Every draw is a pure
/// function of (seed, pixel, the lane's sample index, dimension), and lane k has the bits a one-lane
/// `SampleLanes` of that sample gives (the same code).
#[derive(Clone, Copy, Debug)]
pub struct SampleLanes<const N: usize, S: Isa = Sse2> {
    kind: SamplerKind,
    /// hash(seed, pixel).
    pixel_key: u64,
    /// The lanes' sample indices within the pixel.
    index: U32<N, S>,
    /// Sobol: each lane's replicate times [`REPLICATE_MIX`], the lane's part of its seeds' hash
    /// (`SobolSingle`: replicate 0).
    replicate_mix: U32<N, S>,
    /// Sobol: each lane's point index within its replicate, bit-reversed (the van der Corput
    /// point of the index, which Owen scrambling works on; `SobolSingle`: the sample index).
    point_reversed: U32<N, S>,
}

impl<const N: usize, S: Isa> SampleLanes<N, S> {
    /// The samples `index` of pixel `pixel` (any unique pixel id, e.g. row·width + column).
    #[inline(always)]
    pub fn new(kind: SamplerKind, seed: u64, pixel: u64, index: U32<N, S>) -> Self {
        // Replicate r = i mod R, point ⌊i / R⌋; one sequence is R = 1 (the Independent sampler
        // reads neither).
        let r = Sampler::replicates(kind);
        SampleLanes {
            kind,
            pixel_key: hash2(seed, pixel),
            index,
            replicate_mix: index.and(r - 1).wrapping_mul(REPLICATE_MIX),
            point_reversed: index.shift_right(r.trailing_zeros()).reverse_bits(),
        }
    }

    /// Each lane's scrambling seed of a draw whose dimension key has the part `key`.
    #[inline(always)]
    fn seeds(&self, key: u32) -> U32<N, S> {
        hash32(U32::splat(key) ^ self.replicate_mix)
    }

    /// The lanes' point indices Owen-scrambled with the seeds of `key` (the index shuffle that
    /// decorrelates the dimensions), not reversed: i of the draw.
    #[inline(always)]
    fn shuffled_index(&self, key: u32) -> U32<N, S> {
        lk_permutation(self.point_reversed, self.seeds(key)).reverse_bits()
    }

    /// The 2D draw of every lane at dimensions `d`, `d + 1`: `[x, y]`, each in [0, 1).
    ///
    /// Sobol: with i the lane's shuffled point index and k the pixel's key of dimension d, x is
    /// the Owen scramble of van der Corput's reverse(i) and y of the second Sobol dimension of i,
    /// each with its own seed (`hash32` of a part of k and the replicate).
    #[inline(always)]
    pub fn draw_2d(&self, d: u32) -> [Float<N, S>; 2] {
        let key = hash2(self.pixel_key, d as u64 | TAG_2D);
        match self.kind {
            SamplerKind::Independent => {
                let (mut x, mut y) = (Float::from_array([0.0; N]), Float::from_array([0.0; N]));
                for k in 0..N {
                    let h = hash2(key, self.index.0[k] as u64);
                    (x.0[k], y.0[k]) = (to_unit_f32(h as u32), to_unit_f32((h >> 32) as u32));
                }
                [x, y]
            }
            SamplerKind::Sobol | SamplerKind::SobolSingle => {
                let i = self.shuffled_index(key as u32);
                let x = lk_permutation(i, self.seeds((key >> 32) as u32)).reverse_bits();
                let y = lk_permutation(sobol1_reversed(i), self.seeds(mix64(key) as u32)).reverse_bits();
                [x.to_unit_f32(), y.to_unit_f32()]
            }
        }
    }

    /// The 1D draw of every lane at dimension `d`, in [0, 1) (Sobol: the Owen-scrambled van der
    /// Corput point of the lane's shuffled index).
    #[inline(always)]
    pub fn draw_1d(&self, d: u32) -> Float<N, S> {
        let key = hash2(self.pixel_key, d as u64);
        match self.kind {
            SamplerKind::Independent => {
                let mut x = Float::from_array([0.0; N]);
                for k in 0..N {
                    x.0[k] = to_unit_f32((hash2(key, self.index.0[k] as u64) >> 32) as u32);
                }
                x
            }
            SamplerKind::Sobol | SamplerKind::SobolSingle => {
                let i = self.shuffled_index(key as u32);
                lk_permutation(i, self.seeds((key >> 32) as u32)).reverse_bits().to_unit_f32()
            }
        }
    }
}

/// One sample's numbers in sequence (dimension 0, 1, 2, …): the one-lane [`SampleLanes`] and a
/// running dimension. The readable one-sample path tracer (the tests' oracle) and the renderer's
/// other one-sample callers draw through it.
#[derive(Clone, Debug)]
pub struct Sampler {
    kind: SamplerKind,
    seed: u64,
    sample: SampleLanes<1>,
    dim: u32,
}

impl Sampler {
    pub fn new(kind: SamplerKind, seed: u64) -> Self {
        Sampler { kind, seed, sample: SampleLanes::new(kind, seed, 0, U32::from_array([0])), dim: 0 }
    }

    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    /// The replicate of sample `index` of a pixel (0 for `Independent` and `SobolSingle`) and the
    /// point index within it.
    #[inline(always)]
    pub fn replicate_of(kind: SamplerKind, index: u32) -> (u32, u32) {
        match kind {
            SamplerKind::Independent | SamplerKind::SobolSingle => (0, index),
            SamplerKind::Sobol => (index % REPLICATES, index / REPLICATES),
        }
    }

    /// The number of independent replicates whose means give a pixel's error bar: [`REPLICATES`]
    /// for `Sobol`, 1 for `Independent` (its samples are independent: the film's sample estimator)
    /// and for `SobolSingle` (one sequence: the same estimator, conservative for its correlated
    /// points).
    #[inline(always)]
    pub fn replicates(kind: SamplerKind) -> u32 {
        match kind {
            SamplerKind::Independent | SamplerKind::SobolSingle => 1,
            SamplerKind::Sobol => REPLICATES,
        }
    }

    /// The samples `first, first + 1, …, first + N − 1` of pixel `pixel` (wrapping in u32), drawn
    /// together ([`SampleLanes`]).
    #[inline(always)]
    pub fn lanes<const N: usize, S: Isa>(&self, pixel: u64, first: u32) -> SampleLanes<N, S> {
        SampleLanes::new(self.kind, self.seed, pixel, U32::ramp(first))
    }

    /// Positions the sampler at sample `index` of pixel `pixel` (any unique pixel id, e.g.
    /// row·width + column), dimension 0.
    #[inline]
    pub fn start(&mut self, pixel: u64, index: u32) {
        self.sample = SampleLanes::new(self.kind, self.seed, pixel, U32::from_array([index]));
        self.dim = 0;
    }

    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let d = self.dim;
        self.dim += 1;
        self.sample.draw_1d(d).0[0]
    }

    /// Moves past one dimension without drawing it: the numbers after it are those that follow a
    /// `next_1d()` (a caller that would discard the number saves computing it).
    #[inline]
    pub fn skip_1d(&mut self) {
        self.dim += 1;
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let d = self.dim;
        self.dim += 2;
        let [x, y] = self.sample.draw_2d(d);
        Vec2::new(x.0[0], y.0[0])
    }
}

/// Lanes of a batch: the samples of one pixel the batched integrator
/// ([`crate::integrator::PathTracer::li_lanes`]) traces together, stage by stage, one per SIMD lane
/// of AVX2's 256-bit registers where a stage runs in them.
pub const LANES: usize = 8;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::chi2_survival;

    /// Not a check: a workload for counting instructions (run under callgrind, guide "Performance notes and
    /// their history"): 2^16 batches of `LANES` 2D Sobol draws through `SampleLanes::draw_2d` in a
    /// function compiled for x86-64-v3 and for the baseline, and the same draws one by one.
    #[test]
    #[ignore]
    fn lanes_instruction_count_workload() {
        #[inline(never)]
        fn scalar(s: &mut Sampler) -> f32 {
            let mut acc = 0.0;
            for b in 0..(1u32 << 16) {
                for k in 0..LANES as u32 {
                    s.start(1, b * LANES as u32 + k);
                    s.dim = 2;
                    acc += s.next_2d().x;
                }
            }
            acc
        }
        #[inline(never)]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,movbe,f16c,popcnt")]
        fn lanes_v3(s: &Sampler) -> f32 {
            lanes_body(s)
        }
        #[inline(never)]
        fn lanes_base(s: &Sampler) -> f32 {
            lanes_body(s)
        }
        #[inline(always)]
        fn lanes_body(s: &Sampler) -> f32 {
            let mut acc = 0.0;
            for b in 0..(1u32 << 16) {
                let [xs, _] = s.lanes::<LANES, Sse2>(1, b * LANES as u32).draw_2d(2);
                acc += xs.0.iter().sum::<f32>();
            }
            acc
        }
        let mut s = Sampler::new(SamplerKind::Sobol, 3);
        let a = scalar(&mut s);
        let b = lanes_base(&s);
        #[cfg(target_arch = "x86_64")]
        if crate::render::has_x86_64_v3() {
            // SAFETY: every feature of lanes_v3 was detected.
            let c = unsafe { lanes_v3(&s) };
            assert_eq!(b, c);
        }
        assert!(a.is_finite() && b.is_finite());
    }

    /// Lane k of a batch's draws has the bits of the one-sample sampler at sample `first + k`, for
    /// both samplers, 1D and 2D, at several dimensions, pixels and first indices (one that wraps),
    /// at 8 lanes and at 16.
    #[test]
    fn lanes_equal_the_one_sample_draws() {
        fn check<const N: usize, S: Isa>(kind: SamplerKind) {
            let batch = Sampler::new(kind, 3);
            let mut one = Sampler::new(kind, 3);
            for pixel in [0u64, 77, 1 << 33] {
                for first in [0u32, 8, 13, 1000, u32::MAX - 7] {
                    let lanes = batch.lanes::<N, S>(pixel, first);
                    for d in [0u32, 2, 4, 5, 30] {
                        let [xs, ys] = lanes.draw_2d(d);
                        let us = lanes.draw_1d(d);
                        for k in 0..N {
                            one.start(pixel, first.wrapping_add(k as u32));
                            one.dim = d;
                            let v = one.next_2d();
                            assert_eq!((xs.0[k].to_bits(), ys.0[k].to_bits()), (v.x.to_bits(), v.y.to_bits()));
                            one.dim = d;
                            assert_eq!(us.0[k].to_bits(), one.next_1d().to_bits(), "{kind:?} {pixel} {first} {d}");
                        }
                    }
                }
            }
        }
        for kind in SamplerKind::ALL.iter().copied() {
            check::<8, Sse2>(kind);
            check::<16, Sse2>(kind);
            // The lanes in 256-bit registers (the tile loop's AVX2 copies).
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                check::<8, crate::simd::Avx2>(kind);
            } else {
                eprintln!("{kind:?}: this CPU has no AVX2; the 256-bit lanes are not checked");
            }
        }
    }

    /// The definition of the scrambling seeds, written out one sample at a time: `hash32` (lowbias32)
    /// of a part of the dimension's key and the replicate times `REPLICATE_MIX`.
    fn seed_of(part: u64, index: u32) -> u32 {
        let mut x = part as u32 ^ (index % REPLICATES).wrapping_mul(REPLICATE_MIX);
        x ^= x >> 16;
        x = x.wrapping_mul(0x7feb_352d);
        x ^= x >> 15;
        x = x.wrapping_mul(0x846c_a68b);
        x ^ (x >> 16)
    }

    /// The second Sobol dimension by its definition: the generator-matrix columns of the set bits.
    fn sobol1_by_columns(mut i: u32) -> u32 {
        let (mut v, mut r) = (1u32 << 31, 0u32);
        while i != 0 {
            if i & 1 != 0 {
                r ^= v;
            }
            i >>= 1;
            v ^= v >> 1;
        }
        r
    }

    /// A 2D Sobol draw is the pair of Owen scrambles it is defined as: index i (the point index
    /// within the replicate, Owen-scrambled), then x = scramble(reverse(i)) and y =
    /// scramble(Sobol₁(i)), each with its own seed, bit for bit.
    #[test]
    fn sobol_2d_equals_its_definition() {
        let mut s = Sampler::new(SamplerKind::Sobol, 11);
        for pixel in [0u64, 5, 1 << 40] {
            for index in (0..4096u32).chain([u32::MAX - 1, u32::MAX]) {
                s.start(pixel, index);
                for d in [0u32, 2, 4, 40] {
                    s.dim = d;
                    let got = s.next_2d();
                    let key = hash2(hash2(11, pixel), d as u64 | TAG_2D);
                    let i = owen_scramble(index / REPLICATES, seed_of(key, index));
                    let want = Vec2::new(
                        to_unit_f32(owen_scramble(i.reverse_bits(), seed_of(key >> 32, index))),
                        to_unit_f32(owen_scramble(sobol1_by_columns(i), seed_of(mix64(key), index))),
                    );
                    assert_eq!((got.x.to_bits(), got.y.to_bits()), (want.x.to_bits(), want.y.to_bits()));
                }
            }
        }
    }

    /// A 1D Sobol draw is the nested Owen scramble of the van der Corput point of the shuffled index.
    #[test]
    fn sobol_1d_equals_its_definition() {
        let mut s = Sampler::new(SamplerKind::Sobol, 11);
        for pixel in [0u64, 5, 1 << 40] {
            for index in (0..4096u32).chain([u32::MAX - 1, u32::MAX]) {
                s.start(pixel, index);
                for d in [0u32, 1, 4, 40] {
                    s.dim = d;
                    let got = s.next_1d();
                    let key = hash2(hash2(11, pixel), d as u64);
                    let i = owen_scramble(index / REPLICATES, seed_of(key, index));
                    let want = to_unit_f32(owen_scramble(i.reverse_bits(), seed_of(key >> 32, index)));
                    assert_eq!(got.to_bits(), want.to_bits());
                }
            }
        }
    }

    /// The independent sampler's numbers are the 64-bit hashes they were before the lanes (its
    /// renders keep their bits): hash(hash(hash(seed, pixel), dimension), sample index).
    #[test]
    fn independent_draws_equal_their_definition() {
        let mut s = Sampler::new(SamplerKind::Independent, 9);
        for index in [0u32, 1, 77, u32::MAX] {
            s.start(4, index);
            let key = hash2(hash2(9, 4), TAG_2D);
            let h = hash2(key, index as u64);
            assert_eq!(s.next_2d(), Vec2::new(to_unit_f32(h as u32), to_unit_f32((h >> 32) as u32)));
            let key = hash2(hash2(9, 4), 2);
            assert_eq!(s.next_1d(), to_unit_f32((hash2(key, index as u64) >> 32) as u32));
        }
    }

    /// Skipping a dimension leaves every later number as it is after drawing it.
    #[test]
    fn skip_1d_keeps_the_later_numbers() {
        for kind in SamplerKind::ALL.iter().copied() {
            let (mut a, mut b) = (Sampler::new(kind, 5), Sampler::new(kind, 5));
            for i in 0..64u32 {
                a.start(9, i);
                b.start(9, i);
                assert_eq!(a.next_2d(), b.next_2d());
                let _ = a.next_1d();
                b.skip_1d();
                assert_eq!(a.next_2d(), b.next_2d(), "{kind:?} {i}");
                assert_eq!(a.next_1d().to_bits(), b.next_1d().to_bits(), "{kind:?} {i}");
            }
        }
    }

    #[test]
    fn deterministic_and_in_range() {
        for kind in SamplerKind::ALL.iter().copied() {
            let mut a = Sampler::new(kind, 42);
            let mut b = Sampler::new(kind, 42);
            for i in 0..100 {
                a.start(17, i);
                b.start(17, i);
                for _ in 0..5 {
                    let (x, y) = (a.next_2d(), b.next_2d());
                    assert_eq!(x, y);
                    assert!(x.x >= 0.0 && x.x < 1.0 && x.y >= 0.0 && x.y < 1.0);
                }
            }
        }
    }

    /// Whether `n` points (a power of two) are a (0, m, 2)-net in base 2, m = log2 n: every
    /// elementary interval of area 1/n (every shape 2^a × 2^(m−a)) holds exactly one point.
    fn is_net(points: &[Vec2]) -> Result<(), (usize, usize)> {
        let n = points.len();
        assert!(n.is_power_of_two());
        for a in 0..=n.trailing_zeros() {
            let shape = (1usize << a, n >> a);
            let mut seen = vec![0u32; n];
            for p in points {
                seen[(p.y * shape.1 as f32) as usize * shape.0 + (p.x * shape.0 as f32) as usize] += 1;
            }
            if !seen.iter().all(|&c| c == 1) {
                return Err(shape);
            }
        }
        Ok(())
    }

    /// A pixel's 2D draws at dimensions `dims` of samples 0 … `count` − 1, drawn in lanes of 8.
    fn draws_2d(s: &Sampler, pixel: u64, count: u32, dims: &[u32]) -> Vec<Vec<Vec2>> {
        let mut out = vec![Vec::with_capacity(count as usize); dims.len()];
        for b in 0..count / LANES as u32 {
            let l = s.lanes::<LANES, Sse2>(pixel, b * LANES as u32);
            for (j, &d) in dims.iter().enumerate() {
                let [x, y] = l.draw_2d(d);
                out[j].extend((0..LANES).map(|k| Vec2::new(x.0[k], y.0[k])));
            }
        }
        out
    }

    /// The dimensions of the net tests: the camera's, the first light's and the first BRDF
    /// sample's 2D draws, and one deep in a path.
    const NET_DIMS: [u32; 4] = [0, 2, 5, 30];

    /// A power-of-two prefix of a replicate's Owen-scrambled Sobol points is a (0,m,2)-net: every
    /// elementary interval of area 1/n holds exactly one point (replicates 0, 7 and R − 1 of two
    /// pixels, prefixes of 64 and 256 points; the points of replicate r are the samples r, r + R,
    /// r + 2R, …), drawn in lanes of 8.
    #[test]
    fn sobol_prefix_is_a_net() {
        let s = Sampler::new(SamplerKind::Sobol, 3);
        for pixel in [5u64, 1 << 30] {
            let draws = draws_2d(&s, pixel, 256 * REPLICATES, &NET_DIMS);
            for r in [0, 7, REPLICATES - 1] {
                for (j, d) in NET_DIMS.into_iter().enumerate() {
                    for n in [64usize, 256] {
                        let pts: Vec<Vec2> = (0..n).map(|i| draws[j][r as usize + REPLICATES as usize * i]).collect();
                        assert_eq!(is_net(&pts), Ok(()), "pixel {pixel} replicate {r} dim {d}, {n} points");
                    }
                }
            }
        }
    }

    /// `sobol-single`: every power-of-two prefix (1 … 1024 samples) of a pixel's samples is a
    /// (0, m, 2)-net in each of the 2D draws, for three pixels and two seeds, drawn in lanes of 8.
    #[test]
    fn sobol_single_prefixes_are_nets() {
        for seed in [3u64, 8] {
            let s = Sampler::new(SamplerKind::SobolSingle, seed);
            for pixel in [0u64, 5, 1 << 30] {
                let draws = draws_2d(&s, pixel, 1024, &NET_DIMS);
                for (j, d) in NET_DIMS.into_iter().enumerate() {
                    for m in 0..=10 {
                        let r = is_net(&draws[j][..1 << m]);
                        assert_eq!(r, Ok(()), "seed {seed} pixel {pixel} dim {d}: first {} samples", 1 << m);
                    }
                }
            }
        }
    }

    /// `sobol-single` is one replicate of `Sobol` (replicate 0): its sample i has the bits of
    /// `Sobol`'s sample R·i, in 1D and 2D draws, at a high index too.
    #[test]
    fn sobol_single_is_replicate_zero() {
        let (mut one, mut rep) = (Sampler::new(SamplerKind::SobolSingle, 4), Sampler::new(SamplerKind::Sobol, 4));
        for i in (0..512u32).chain([(1 << 28) - 1]) {
            one.start(9, i);
            rep.start(9, i * REPLICATES);
            for _ in 0..4 {
                assert_eq!(one.next_2d(), rep.next_2d(), "{i}");
                assert_eq!(one.next_1d().to_bits(), rep.next_1d().to_bits(), "{i}");
            }
        }
        assert_eq!(Sampler::replicates(SamplerKind::SobolSingle), 1);
        assert_eq!(Sampler::replicate_of(SamplerKind::SobolSingle, 37), (0, 37));
    }

    /// χ² of 2D projections: the points of a pixel (all replicates, 4096 samples) binned on a
    /// 16 × 16 grid, for the pairs within a 2D draw (camera, light, BRDF: nets, far more uniform than
    /// random) and pairs across draws and replicates' seeds (the camera's x with the light's x, the
    /// light's y with the BRDF's x, a 1D draw with the BRDF's y, the roulette's 1D with the light's
    /// x), which the index shuffle must leave independent. Each statistic against χ² with 255
    /// degrees of freedom, two-sided at α = 10⁻³ per test, Šidák-corrected over the 3 pixels × 7
    /// pairs (a correlated pair gives p ≈ 0; points more uniform than random give p ≈ 1, which is
    /// asserted only for the nets).
    #[test]
    fn two_d_projections_pass_chi2() {
        let s = Sampler::new(SamplerKind::Sobol, 17);
        let kind = s.kind();
        let n = 4096u32;
        let tests = 3.0 * 7.0;
        let alpha = 1.0 - (1.0f64 - 1e-3).powf(1.0 / tests);
        for pixel in [0u64, 12_345, 1 << 41] {
            // Per sample: camera (0, 1), light (2, 3), lobe 4, BRDF (5, 6), roulette 7.
            let mut pts = vec![[0.0f32; 8]; n as usize];
            for b in 0..n / LANES as u32 {
                let l = s.lanes::<LANES, Sse2>(pixel, b * LANES as u32);
                let ([c0, c1], [l0, l1], lobe, [b0, b1], rr) =
                    (l.draw_2d(0), l.draw_2d(2), l.draw_1d(4), l.draw_2d(5), l.draw_1d(7));
                for k in 0..LANES {
                    let p = &mut pts[(b * LANES as u32) as usize + k];
                    *p = [c0.0[k], c1.0[k], l0.0[k], l1.0[k], lobe.0[k], b0.0[k], b1.0[k], rr.0[k]];
                }
            }
            let chi2 = |a: usize, b: usize| {
                let mut cells = [0u32; 256];
                for p in &pts {
                    cells[(p[b] * 16.0) as usize * 16 + (p[a] * 16.0) as usize] += 1;
                }
                let e = n as f64 / 256.0;
                let stat: f64 = cells.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
                chi2_survival(stat, 255.0)
            };
            for (a, b, net) in
                [(0, 1, true), (2, 3, true), (5, 6, true), (0, 2, false), (3, 5, false), (4, 6, false), (7, 2, false)]
            {
                let p = chi2(a, b);
                assert!(p > alpha / 2.0, "{kind:?} pixel {pixel} dims ({a}, {b}): p = {p}");
                if !net {
                    assert!(
                        p < 1.0 - alpha / 2.0,
                        "{kind:?} pixel {pixel} dims ({a}, {b}): p = {p}, too uniform for independent draws"
                    );
                }
            }
        }
    }

    /// `sobol-single` across pixels: one sample of each of 4096 pixels (sample index 7·pixel mod
    /// 1024, so every index of a 1024-sample render is met), the same 7 pairs as above on a 16 × 16
    /// grid. The pixels' scrambles are independent, so each statistic follows χ² with 255 degrees of
    /// freedom; two-sided at α = 10⁻³ per test, Šidák-corrected over 2 seeds × 7 pairs. (Within one
    /// pixel, pairs of dimensions of different draws are padded, not nets: the coarse cells of both
    /// are functions of the index's low bits, so 4096 points of one pixel fill 16 of the 256 cells,
    /// a random permutation, as in any padded sampler; only across pixels are they uniform.)
    #[test]
    fn sobol_single_across_pixels_passes_chi2() {
        let tests = 2.0 * 7.0;
        let alpha = 1.0 - (1.0f64 - 1e-3).powf(1.0 / tests);
        let n = 4096u64;
        for seed in [17u64, 18] {
            let mut s = Sampler::new(SamplerKind::SobolSingle, seed);
            let pts: Vec<[f32; 8]> = (0..n)
                .map(|pixel| {
                    s.start(pixel, (7 * pixel % 1024) as u32);
                    let (c, l, lobe, b, rr) = (s.next_2d(), s.next_2d(), s.next_1d(), s.next_2d(), s.next_1d());
                    [c.x, c.y, l.x, l.y, lobe, b.x, b.y, rr]
                })
                .collect();
            for (a, b) in [(0, 1), (2, 3), (5, 6), (0, 2), (3, 5), (4, 6), (7, 2)] {
                let mut cells = [0u32; 256];
                for p in &pts {
                    cells[(p[b] * 16.0) as usize * 16 + (p[a] * 16.0) as usize] += 1;
                }
                let e = n as f64 / 256.0;
                let stat: f64 = cells.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
                let p = chi2_survival(stat, 255.0);
                assert!(p > alpha / 2.0 && p < 1.0 - alpha / 2.0, "seed {seed} dims ({a}, {b}): p = {p}");
            }
        }
    }

    /// The replicates of a pixel are independent scrambles: over many pixels, the correlation of
    /// replicate r's and replicate r + 1's mean of a smooth integrand (their first 16 points, the
    /// camera's 2D draw) is zero within its standard error 1/√pixels (k = 4).
    #[test]
    fn replicate_means_are_uncorrelated() {
        let s = Sampler::new(SamplerKind::Sobol, 23);
        let f = |u: f32, v: f32| (u * v * 6.0).sin() as f64;
        let pixels = 4000;
        let (mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0);
        for pixel in 0..pixels {
            let mut m = [0.0f64; REPLICATES as usize];
            for b in 0..(16 * REPLICATES) / LANES as u32 {
                let [x, y] = s.lanes::<LANES, Sse2>(pixel, b * LANES as u32).draw_2d(0);
                for k in 0..LANES {
                    m[((b * LANES as u32) as usize + k) % REPLICATES as usize] += f(x.0[k], y.0[k]) / 16.0;
                }
            }
            for r in 0..REPLICATES as usize {
                let (a, b) = (m[r], m[(r + 1) % REPLICATES as usize]);
                (sx, sy, sxx, syy, sxy) = (sx + a, sy + b, sxx + a * a, syy + b * b, sxy + a * b);
            }
        }
        let n = (pixels * REPLICATES as u64) as f64;
        let cov = sxy / n - sx / n * sy / n;
        let rho = cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt();
        assert!(rho.abs() < 4.0 / n.sqrt(), "correlation of neighbouring replicates {rho}");
    }

    /// The bit-parallel second Sobol dimension equals the column loop.
    #[test]
    fn sobol1_matches_the_bit_loop() {
        let mut rng = crate::sampling::chi2::TestRng::new(9);
        for i in (0..4096).chain((0..4096).map(|_| rng.next_u64() as u32)) {
            assert_eq!(sobol1_reversed(U32::<1>::from_array([i])).0[0].reverse_bits(), sobol1_by_columns(i));
        }
    }

    #[test]
    fn independent_mean_is_half() {
        let mut s = Sampler::new(SamplerKind::Independent, 1);
        let n = 100_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            s.start(i as u64 % 97, i);
            sum += s.next_1d() as f64;
        }
        // σ of the mean = sqrt(1/12 / n) ≈ 9.1e-4; allow 5σ.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt());
    }
}
