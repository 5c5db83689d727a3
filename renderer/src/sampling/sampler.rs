//! Counter-based samplers: every number is a pure function of (seed, pixel, sample index,
//! dimension), so an image is bit-identical whatever the number of threads or the tile order
//! (docs/src/conventions.md §5).
//!
//! - `Independent`: a 64-bit hash of the four counters.
//! - `Sobol`: [`REPLICATES`] independent replicates of padded Owen-scrambled Sobol points (Burley
//!   2020, "Practical Hash-based Owen Scrambling"), interleaved: sample i of a pixel is point
//!   j = ⌊i / R⌋ of replicate r = i mod R. Each replicate has its own scrambles (its keys are hashed
//!   from the pixel's and r), so the R replicate means of a pixel are independent and their spread is
//!   an unbiased estimate of the error of the pixel mean (randomised QMC, Owen 1997; the film's
//!   replicate estimator, `crate::film`). Within a replicate, each pair of dimensions uses the first
//!   two Sobol dimensions, Owen-scrambled with its own hash-derived seed, and the point index j is
//!   itself shuffled per pixel, replicate and dimension pair so that pairs are decorrelated. Any
//!   power-of-two prefix of a replicate's points is a (0, m, 2)-net in every pair of dimensions, and
//!   any prefix of R·k samples of a pixel holds k points of every replicate.

use crate::math::Vec2;

/// The sample generator (`render.sampler`), defined in `vocab`.
pub use vocab::Sampler as SamplerKind;

/// Dimensions whose scrambling keys a [`Sampler`] keeps across the samples of one pixel (a path of
/// depth k draws 5k + 2 dimensions: the camera's 2, then 2 + 1 + 2 per vertex).
const KEYS: usize = 16;

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

/// Mixed into the pixel key to derive a replicate's key (keeps them apart from the draws' keys).
const REPLICATE_SALT: u64 = 0x5EED_0F5C_4A3B_1E00;

#[derive(Clone, Debug)]
pub struct Sampler {
    kind: SamplerKind,
    seed: u64,
    pixel_key: u64,
    /// The replicate of the current sample (always 0 for `Independent`).
    replicate: u32,
    /// The point index within the replicate (the sample index for `Independent`).
    index: u32,
    /// `index.reverse_bits()`: every Sobol draw of the sample Owen-scrambles the index from its
    /// reversed bits, and x86 has no bit-reversal instruction (~16 instructions each), so it is
    /// reversed once per sample, not once per draw. A memo: changes no number.
    index_reversed: u32,
    dim: u32,
    /// The pixel of the last `start`: the cached keys below belong to it.
    pixel: Option<u64>,
    /// Bit r set: `replicate_keys[r]` holds replicate r's key of the current pixel.
    have_replicate: u32,
    replicate_keys: [u64; REPLICATES as usize],
    /// Bit d of `have_1d[r]` set: `keys_1d[r][d]` (resp. `keys_2d[r][d]`) holds the key of a 1D (2D)
    /// draw at dimension d of replicate r. The keys depend on (seed, pixel, replicate, dimension)
    /// only, so the samples of a replicate of a pixel share them; this is a memo and changes no number.
    have_1d: [u32; REPLICATES as usize],
    have_2d: [u32; REPLICATES as usize],
    keys_1d: [[u64; KEYS]; REPLICATES as usize],
    /// (key, mix64(key)) of a 2D draw.
    keys_2d: [[(u64, u64); KEYS]; REPLICATES as usize],
    /// Bit d set: `pre_2d[d]` holds this sample's 2D draw at dimension d, drawn ahead with the other
    /// samples of its batch ([`Sampler::draw_ahead`], [`Sampler::use_ahead`]); cleared by `start`.
    have_pre: u32,
    pre_2d: [Vec2; PRE_DIMS],
}

/// The 2D draws of a sample's first vertex, drawn ahead for a batch of [`LANES`] samples: the
/// camera's (dimension 0) and the first vertex's light (2) and BRDF (5) draws (dimension 4 is the
/// lobe choice, 1D). `[dimension][coordinate][lane]`.
pub type Ahead = [[[f32; LANES]; 2]; 3];

/// The dimensions of [`Ahead`].
const AHEAD_DIMS: [u32; 3] = [0, 2, 5];

/// Dimensions below which [`Sampler`] can hold draws made ahead.
const PRE_DIMS: usize = 6;

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

/// Laine–Karras style hash that only lets bits influence more significant ones (when applied to
/// bit-reversed values it becomes a nested uniform, i.e. Owen, scramble).
#[inline(always)]
fn lk_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// (The sampler scrambles from a memoized reversed index, `owen_scramble_reversed`; this is the
/// definition its tests check against.)
#[cfg(test)]
#[inline(always)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    lk_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// Owen scramble of a value given bit-reversed: `owen_scramble(x, seed)` for x = reverse(r).
#[inline(always)]
fn owen_scramble_reversed(r: u32, seed: u32) -> u32 {
    lk_permutation(r, seed).reverse_bits()
}

/// Second Sobol dimension (primitive polynomial x + 1), bit-reversed: the XOR of the (reversed)
/// generator-matrix columns of the set bits of `i`. Kept reversed because Owen scrambling works on
/// reversed bits. (The definition the tests check the sampler's [`index_and_sobol1`] against.)
#[cfg(test)]
fn sobol1_reversed(i: u32) -> u32 {
    let cols = sobol1_columns();
    (0..32).filter(|&b| i & (1 << b) != 0).fold(0, |r, b| r ^ cols[b]).reverse_bits()
}

/// (i, `sobol1_reversed(i)`) of i = reverse(l), as the high and low halves of a u64: a 2D draw's
/// scrambled index comes out of its Laine–Karras hash bit-reversed (l), and both the index itself
/// (the first coordinate's scramble) and the second Sobol dimension of it are GF(2)-linear in the
/// bits of l, so four byte-indexed table reads give both, without the bit reversal of l (x86-64
/// has no bit-reverse instruction: ~16 instructions) and without a separate table walk for the
/// second dimension. Shuffled indices use all 32 bits, so a bit loop would run 32 times.
#[inline(always)]
fn index_and_sobol1(l: u32) -> u64 {
    SOBOL1_TABLES[0][(l & 0xff) as usize]
        ^ SOBOL1_TABLES[1][((l >> 8) & 0xff) as usize]
        ^ SOBOL1_TABLES[2][((l >> 16) & 0xff) as usize]
        ^ SOBOL1_TABLES[3][(l >> 24) as usize]
}

/// Column k of the generator matrix: v_0 = 2^31, v_{k+1} = v_k ^ (v_k >> 1).
const fn sobol1_columns() -> [u32; 32] {
    let mut v = [0u32; 32];
    let mut c = 1u32 << 31;
    let mut k = 0;
    while k < 32 {
        v[k] = c;
        c ^= c >> 1;
        k += 1;
    }
    v
}

/// Entry x of table `byte`: (i, `sobol1_reversed(i)`) for i = reverse(x << 8·byte), the part of
/// [`index_and_sobol1`] that byte of l contributes.
const fn sobol1_tables() -> [[u64; 256]; 4] {
    let cols = sobol1_columns();
    let mut t = [[0u64; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut x = 0;
        while x < 256 {
            let i = ((x as u32) << (8 * byte)).reverse_bits();
            let mut r = 0u32;
            let mut b = 0;
            while b < 32 {
                if i & (1 << b) != 0 {
                    r ^= cols[b];
                }
                b += 1;
            }
            t[byte][x] = (i as u64) << 32 | r.reverse_bits() as u64;
            x += 1;
        }
        byte += 1;
    }
    t
}

static SOBOL1_TABLES: [[u64; 256]; 4] = sobol1_tables();

impl Sampler {
    pub fn new(kind: SamplerKind, seed: u64) -> Self {
        Sampler {
            kind,
            seed,
            pixel_key: 0,
            replicate: 0,
            index: 0,
            index_reversed: 0,
            dim: 0,
            pixel: None,
            have_replicate: 0,
            replicate_keys: [0; REPLICATES as usize],
            have_1d: [0; REPLICATES as usize],
            have_2d: [0; REPLICATES as usize],
            keys_1d: [[0; KEYS]; REPLICATES as usize],
            keys_2d: [[(0, 0); KEYS]; REPLICATES as usize],
            have_pre: 0,
            pre_2d: [Vec2::ZERO; PRE_DIMS],
        }
    }

    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    /// The replicate of sample `index` of a pixel (0 for `Independent`) and the point index within it.
    #[inline(always)]
    pub fn replicate_of(kind: SamplerKind, index: u32) -> (u32, u32) {
        match kind {
            SamplerKind::Independent => (0, index),
            SamplerKind::Sobol => (index % REPLICATES, index / REPLICATES),
        }
    }

    /// The number of independent replicates whose means give a pixel's error bar: [`REPLICATES`]
    /// for `Sobol`, 1 for `Independent` (its samples are independent: the film's sample estimator).
    pub fn replicates(kind: SamplerKind) -> u32 {
        match kind {
            SamplerKind::Independent => 1,
            SamplerKind::Sobol => REPLICATES,
        }
    }

    /// Positions the sampler at sample `index` of pixel `pixel` (any unique pixel id, e.g.
    /// row·width + column), dimension 0.
    #[inline]
    pub fn start(&mut self, pixel: u64, index: u32) {
        if self.pixel != Some(pixel) {
            self.pixel = Some(pixel);
            self.pixel_key = hash2(self.seed, pixel);
            self.have_replicate = 0;
            self.have_1d = [0; REPLICATES as usize];
            self.have_2d = [0; REPLICATES as usize];
        }
        let (r, j) = Self::replicate_of(self.kind, index);
        self.replicate = r;
        self.index = j;
        self.index_reversed = j.reverse_bits();
        self.dim = 0;
        self.have_pre = 0;
    }

    /// Replicate r's key of the current pixel: the pixel's key itself for `Independent` (whose
    /// numbers are those of a hash of the sample index), a hash of it and r for `Sobol`.
    #[inline(always)]
    fn replicate_key(&mut self, r: u32) -> u64 {
        if self.kind == SamplerKind::Independent {
            return self.pixel_key;
        }
        if self.have_replicate & (1 << r) == 0 {
            self.replicate_keys[r as usize] = hash2(self.pixel_key, REPLICATE_SALT ^ r as u64);
            self.have_replicate |= 1 << r;
        }
        self.replicate_keys[r as usize]
    }

    /// The key of a 1D draw at dimension `d` of replicate `r` of the current pixel (memoized below `KEYS`).
    #[inline(always)]
    fn key_1d(&mut self, r: u32, d: u32) -> u64 {
        let (i, ri) = (d as usize, r as usize);
        if i < KEYS && self.have_1d[ri] & (1 << d) != 0 {
            return self.keys_1d[ri][i];
        }
        let key = hash2(self.replicate_key(r), d as u64);
        if i < KEYS {
            self.keys_1d[ri][i] = key;
            self.have_1d[ri] |= 1 << d;
        }
        key
    }

    /// (key, mix64(key)) of a 2D draw at dimension `d` of replicate `r` of the current pixel
    /// (memoized below `KEYS`).
    #[inline(always)]
    fn key_2d(&mut self, r: u32, d: u32) -> (u64, u64) {
        let (i, ri) = (d as usize, r as usize);
        if i < KEYS && self.have_2d[ri] & (1 << d) != 0 {
            return self.keys_2d[ri][i];
        }
        let key = hash2(self.replicate_key(r), d as u64 | (1 << 40));
        let k = (key, mix64(key));
        if i < KEYS {
            self.keys_2d[ri][i] = k;
            self.have_2d[ri] |= 1 << d;
        }
        k
    }

    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let d = self.dim;
        self.dim += 1;
        let key = self.key_1d(self.replicate, d);
        match self.kind {
            SamplerKind::Independent => to_unit_f32((hash2(key, self.index as u64) >> 32) as u32),
            SamplerKind::Sobol => {
                // First Sobol dimension (van der Corput) is reverse(i): scramble it reversed.
                // `owen_scramble(self.index, key as u32)`, from the memoized reversed index.
                let i = owen_scramble_reversed(self.index_reversed, key as u32);
                to_unit_f32(owen_scramble_reversed(i, (key >> 32) as u32))
            }
        }
    }

    /// Moves past one dimension without drawing it: the numbers after it are those that follow a
    /// `next_1d()` (a caller that would discard the number saves computing it).
    #[inline]
    pub fn skip_1d(&mut self) {
        self.dim += 1;
    }

    // Always inlined: out of line it ran as compiled for the baseline even when called from the
    // x86-64-v3 copy of the tile loop (34 instructions a sample on bench-beckmann-grace).
    #[inline(always)]
    pub fn next_2d(&mut self) -> Vec2 {
        let d = self.dim;
        self.dim += 2;
        // Only the first PRE_DIMS dimensions can be drawn ahead; a deeper dimension (a long path) must not
        // alias a low bit of `have_pre` (d = 66 read bit 2 and indexed past `pre_2d`).
        if (d as usize) < PRE_DIMS && self.have_pre & (1 << d) != 0 {
            return self.pre_2d[d as usize];
        }
        let (key, k2) = self.key_2d(self.replicate, d);
        match self.kind {
            SamplerKind::Independent => {
                let h = hash2(key, self.index as u64);
                Vec2::new(to_unit_f32(h as u32), to_unit_f32((h >> 32) as u32))
            }
            SamplerKind::Sobol => {
                // i = `owen_scramble(self.index, key as u32)` from the memoized reversed index,
                // read with sobol1_reversed(i) from the tables instead of reversing l.
                let l = lk_permutation(self.index_reversed, key as u32);
                let both = index_and_sobol1(l);
                let (i, s1) = ((both >> 32) as u32, both as u32);
                // `owen_scramble_reversed` of both coordinates, their two bit reversals done as
                // one of a u64 (x in the high half comes out in the low half): the same bits.
                let x = lk_permutation(i, (key >> 32) as u32) as u64;
                let y = lk_permutation(s1, k2 as u32) as u64;
                let r = (x << 32 | y).reverse_bits();
                Vec2::new(to_unit_f32(r as u32), to_unit_f32((r >> 32) as u32))
            }
        }
    }
}

/// Lanes of a batch: the samples of one pixel the batched integrator
/// ([`crate::integrator::PathTracer::li_lanes`]) traces together, stage by stage, one per SIMD lane
/// of AVX2's 256-bit registers where a stage runs in them.
pub const LANES: usize = 8;

/// Where one sample of the current pixel stands in its sequence (its index and next dimension).
/// The batched integrator keeps one per lane and moves the sampler between them
/// ([`Sampler::cursor`], [`Sampler::resume`]), so that the lanes of a pixel share the pixel's
/// memoized scrambling keys and each lane draws exactly the numbers it would alone.
#[derive(Clone, Copy, Debug)]
pub struct SampleCursor {
    replicate: u32,
    index: u32,
    index_reversed: u32,
    dim: u32,
}

impl Sampler {
    /// The current sample's position (see [`SampleCursor`]).
    #[inline(always)]
    pub fn cursor(&self) -> SampleCursor {
        SampleCursor {
            replicate: self.replicate,
            index: self.index,
            index_reversed: self.index_reversed,
            dim: self.dim,
        }
    }

    /// Continues the sample of `c`, taken by [`Sampler::cursor`] since the last `start` at another
    /// pixel: the next draws are those that sample would have made next (the same bits). Draws made
    /// ahead ([`Sampler::use_ahead`]) are not part of a cursor: they are forgotten, and computed
    /// again where reached (the same bits) unless `use_ahead` gives them back.
    #[inline(always)]
    pub fn resume(&mut self, c: &SampleCursor) {
        self.replicate = c.replicate;
        self.index = c.index;
        self.index_reversed = c.index_reversed;
        self.dim = c.dim;
        self.have_pre = 0;
    }
}

impl Sampler {
    /// The next 2D draw of `LANES` samples of the current pixel at once, in structure-of-arrays
    /// form `[x; LANES], [y; LANES]`: lane k is the draw [`Sampler::next_2d`] gives after
    /// `start(pixel, index[k])` at the current dimension (the same bits; a test compares them).
    /// The lanes' scrambling keys are their replicates' keys of the pixel (memoized), so what remains
    /// per lane is integer arithmetic (Laine–Karras hashes, four table reads, a bit reversal) written
    /// as lane loops that the x86-64-v3 copy of the tile loop can run in AVX2 registers. Advances the
    /// dimension by 2, like `next_2d`.
    #[inline(always)]
    pub fn next_2d_lanes(&mut self, index: &[u32; LANES]) -> ([f32; LANES], [f32; LANES]) {
        let d = self.dim;
        self.dim += 2;
        let mut xs = [0.0; LANES];
        let mut ys = [0.0; LANES];
        match self.kind {
            SamplerKind::Independent => {
                let (key, _) = self.key_2d(0, d);
                for k in 0..LANES {
                    let h = hash2(key, index[k] as u64);
                    xs[k] = to_unit_f32(h as u32);
                    ys[k] = to_unit_f32((h >> 32) as u32);
                }
            }
            SamplerKind::Sobol => {
                let mut keys = [(0u64, 0u64); LANES];
                let mut reversed = [0u32; LANES];
                for k in 0..LANES {
                    let (r, j) = Self::replicate_of(self.kind, index[k]);
                    keys[k] = self.key_2d(r, d);
                    reversed[k] = j.reverse_bits();
                }
                let mut both = [0u64; LANES];
                for k in 0..LANES {
                    both[k] = index_and_sobol1(lk_permutation(reversed[k], keys[k].0 as u32));
                }
                for k in 0..LANES {
                    let (i, s1) = ((both[k] >> 32) as u32, both[k] as u32);
                    let x = lk_permutation(i, (keys[k].0 >> 32) as u32) as u64;
                    let y = lk_permutation(s1, keys[k].1 as u32) as u64;
                    let r = (x << 32 | y).reverse_bits();
                    xs[k] = to_unit_f32(r as u32);
                    ys[k] = to_unit_f32((r >> 32) as u32);
                }
            }
        }
        (xs, ys)
    }

    /// The draws of [`Ahead`] for the samples `index` of pixel `pixel`, all lanes at once
    /// ([`Sampler::next_2d_lanes`]). Leaves the sampler at sample `index[0]`; hand each lane's draws
    /// to its sample with [`Sampler::use_ahead`] after its `start`.
    #[inline(always)]
    pub fn draw_ahead(&mut self, pixel: u64, index: &[u32; LANES]) -> Ahead {
        // Loops, not closures: a closure is a function of its own, compiled for the baseline even
        // when it is called from the x86-64-v3 copy of the tile loop, and LLVM left these out of line.
        self.start(pixel, index[0]);
        let mut ahead = [[[0.0; LANES]; 2]; 3];
        for (j, &d) in AHEAD_DIMS.iter().enumerate() {
            self.dim = d;
            let (x, y) = self.next_2d_lanes(index);
            ahead[j] = [x, y];
        }
        ahead
    }

    /// Gives the current sample (just `start`ed at `index[lane]` of the pixel of `ahead`) its draws
    /// made ahead: `next_2d` at those dimensions returns them (the same bits it would compute).
    #[inline(always)]
    pub fn use_ahead(&mut self, ahead: &Ahead, lane: usize) {
        for (j, &d) in AHEAD_DIMS.iter().enumerate() {
            self.pre_2d[d as usize] = Vec2::new(ahead[j][0][lane], ahead[j][1][lane]);
            self.have_pre |= 1 << d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Not a check: a workload for counting instructions (run under callgrind, guide "Performance notes and
    /// their history", round seven): 2^16 batches of `LANES` 2D Sobol draws through `next_2d_lanes` in a function
    /// compiled for x86-64-v3, and the same draws one by one through `next_2d`.
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
        fn lanes_v3(s: &mut Sampler) -> f32 {
            lanes_body(s)
        }
        #[inline(never)]
        fn lanes_base(s: &mut Sampler) -> f32 {
            lanes_body(s)
        }
        #[inline(always)]
        fn lanes_body(s: &mut Sampler) -> f32 {
            let mut acc = 0.0;
            s.start(1, 0);
            for b in 0..(1u32 << 16) {
                let r: [u32; LANES] = std::array::from_fn(|k| b * LANES as u32 + k as u32);
                s.dim = 2;
                let (xs, _) = s.next_2d_lanes(&r);
                acc += xs.iter().sum::<f32>();
            }
            acc
        }
        let mut s = Sampler::new(SamplerKind::Sobol, 3);
        let a = scalar(&mut s);
        let b = lanes_base(&mut s);
        #[cfg(target_arch = "x86_64")]
        if crate::render::has_x86_64_v3() {
            // SAFETY: every feature of lanes_v3 was detected.
            let c = unsafe { lanes_v3(&mut s) };
            assert_eq!(b, c);
        }
        assert!(a.is_finite() && b.is_finite());
    }

    /// Draws made ahead for a batch are the draws each sample makes alone: a path of several
    /// vertices (1D and 2D draws mixed, the lobe choice skipped or drawn) gives the same numbers
    /// with and without `use_ahead`.
    #[test]
    fn draws_ahead_are_the_sample_draws() {
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let (mut a, mut b) = (Sampler::new(kind, 4), Sampler::new(kind, 4));
            for pixel in [3u64, 1 << 35] {
                for first in [0u32, 64, u32::MAX - 7] {
                    let index: [u32; LANES] = std::array::from_fn(|k| first.wrapping_add(k as u32));
                    let ahead = a.draw_ahead(pixel, &index);
                    for (k, &i) in index.iter().enumerate() {
                        // The path tracer's layout (camera 2D, then per vertex 2D, lobe 1D or
                        // skipped, 2D, and a roulette 1D), and a layout that meets the dimensions
                        // drawn ahead with 1D draws and at odd offsets.
                        for ops in ["22s2122s21", "21222s2112"] {
                            a.start(pixel, i);
                            a.use_ahead(&ahead, k);
                            b.start(pixel, i);
                            let (mut got, mut want) = (Vec::new(), Vec::new());
                            for op in ops.chars() {
                                match op {
                                    '1' => {
                                        got.push(a.next_1d().to_bits());
                                        want.push(b.next_1d().to_bits());
                                    }
                                    's' => {
                                        a.skip_1d();
                                        b.skip_1d();
                                    }
                                    _ => {
                                        let (u, v) = (a.next_2d(), b.next_2d());
                                        got.extend([u.x.to_bits(), u.y.to_bits()]);
                                        want.extend([v.x.to_bits(), v.y.to_bits()]);
                                    }
                                }
                            }
                            assert_eq!(got, want, "{kind:?} pixel {pixel} index {i} ops {ops}");
                        }
                    }
                }
            }
        }
    }

    /// `next_2d_lanes` gives every lane the bits of `next_2d` at that lane's sample index, for both
    /// samplers, at several dimensions and pixels, with indices in and out of order.
    #[test]
    fn lanes_equal_the_scalar_draws() {
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let (mut batch, mut one) = (Sampler::new(kind, 3), Sampler::new(kind, 3));
            for pixel in [0u64, 77, 1 << 33] {
                for first in [0u32, 8, 1000, u32::MAX - 7] {
                    let index: [u32; LANES] = std::array::from_fn(|k| first.wrapping_add((k as u32 * 5) % 8));
                    batch.start(pixel, 0);
                    for d in [0u32, 2, 5, 30] {
                        batch.dim = d;
                        let (xs, ys) = batch.next_2d_lanes(&index);
                        for k in 0..LANES {
                            one.start(pixel, index[k]);
                            one.dim = d;
                            let v = one.next_2d();
                            assert_eq!((xs[k].to_bits(), ys[k].to_bits()), (v.x.to_bits(), v.y.to_bits()));
                        }
                    }
                }
            }
        }
    }

    /// The per-pixel key memo changes no number: pixels interleaved (the memo must follow the
    /// pixel), paths of different lengths and 1D/2D mixes past the memo's `KEYS` dimensions, each
    /// draw compared with a fresh sampler's (which computes every key).
    /// A 2D Sobol draw is the pair of `owen_scramble_reversed`s it is defined as (the two bit
    /// reversals are done as one of a u64), bit for bit.
    #[test]
    fn sobol_2d_equals_its_definition() {
        let mut s = Sampler::new(SamplerKind::Sobol, 11);
        for pixel in [0u64, 5, 1 << 40] {
            for index in (0..4096u32).chain([u32::MAX - 1, u32::MAX]) {
                s.start(pixel, index);
                for d in [0u32, 2, 4, 40] {
                    s.dim = d;
                    let got = s.next_2d();
                    let rkey = hash2(hash2(11, pixel), REPLICATE_SALT ^ (index % REPLICATES) as u64);
                    let key = hash2(rkey, d as u64 | (1 << 40));
                    let i = owen_scramble(index / REPLICATES, key as u32);
                    let want = Vec2::new(
                        to_unit_f32(owen_scramble_reversed(i, (key >> 32) as u32)),
                        to_unit_f32(owen_scramble_reversed(sobol1_reversed(i), mix64(key) as u32)),
                    );
                    assert_eq!((got.x.to_bits(), got.y.to_bits()), (want.x.to_bits(), want.y.to_bits()));
                }
            }
        }
    }

    /// A 1D Sobol draw is the nested Owen scramble it is defined as (the index scrambled from its
    /// memoized bit reversal gives the same bits).
    #[test]
    fn sobol_1d_equals_its_definition() {
        let mut s = Sampler::new(SamplerKind::Sobol, 11);
        for pixel in [0u64, 5, 1 << 40] {
            for index in (0..4096u32).chain([u32::MAX - 1, u32::MAX]) {
                s.start(pixel, index);
                for d in [0u32, 1, 4, 40] {
                    s.dim = d;
                    let got = s.next_1d();
                    let rkey = hash2(hash2(11, pixel), REPLICATE_SALT ^ (index % REPLICATES) as u64);
                    let key = hash2(rkey, d as u64);
                    let i = owen_scramble(index / REPLICATES, key as u32);
                    let want = to_unit_f32(owen_scramble_reversed(i, (key >> 32) as u32));
                    assert_eq!(got.to_bits(), want.to_bits());
                }
            }
        }
    }

    /// Skipping a dimension leaves every later number as it is after drawing it.
    #[test]
    fn skip_1d_keeps_the_later_numbers() {
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
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
    fn key_memo_gives_the_numbers_of_a_fresh_sampler() {
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
            let mut s = Sampler::new(kind, 7);
            for i in 0..64u32 {
                for pixel in [3u64, 1 << 33, 3, 90] {
                    s.start(pixel, i);
                    let mut fresh = Sampler::new(kind, 7);
                    fresh.start(pixel, i);
                    // Path lengths 1..=20 draws; the draw kinds depend on the sample too.
                    for k in 0..(1 + (i * 7 + pixel as u32) % 20) {
                        if (k + i) % 3 == 0 {
                            assert_eq!(s.next_1d().to_bits(), fresh.next_1d().to_bits(), "{kind:?} {pixel} {i} {k}");
                        } else {
                            assert_eq!(s.next_2d(), fresh.next_2d(), "{kind:?} {pixel} {i} {k}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn deterministic_and_in_range() {
        for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
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

    /// A power-of-two prefix of a replicate's Owen-scrambled Sobol points is a (0,m,2)-net: every
    /// elementary interval of area 1/N holds exactly one point (replicates 0 and R − 1; the points
    /// of replicate r are the samples r, r + R, r + 2R, …).
    #[test]
    fn sobol_prefix_is_a_net() {
        let mut s = Sampler::new(SamplerKind::Sobol, 3);
        let n = 256usize;
        for (r, shape) in [0, REPLICATES - 1]
            .into_iter()
            .flat_map(|r| [(1usize, 256usize), (16, 16), (256, 1), (4, 64)].map(|sh| (r, sh)))
        {
            let mut seen = vec![0u32; n];
            for i in 0..n as u32 {
                s.start(5, r + REPLICATES * i);
                let _ = s.next_1d();
                let p = s.next_2d();
                let cx = (p.x * shape.0 as f32) as usize;
                let cy = (p.y * shape.1 as f32) as usize;
                seen[cy * shape.0 + cx] += 1;
            }
            assert!(seen.iter().all(|&c| c == 1), "replicate {r}, shape {shape:?}: {seen:?}");
        }
    }

    #[test]
    fn sobol1_tables_match_the_bit_loop() {
        let slow = |mut i: u32| {
            let (mut v, mut r) = (1u32 << 31, 0u32);
            while i != 0 {
                if i & 1 != 0 {
                    r ^= v;
                }
                i >>= 1;
                v ^= v >> 1;
            }
            r
        };
        let mut rng = crate::sampling::chi2::TestRng::new(9);
        for i in (0..4096).chain((0..4096).map(|_| rng.next_u64() as u32)) {
            assert_eq!(sobol1_reversed(i).reverse_bits(), slow(i));
            let l = i.reverse_bits();
            assert_eq!(index_and_sobol1(l), (i as u64) << 32 | sobol1_reversed(i) as u64);
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
