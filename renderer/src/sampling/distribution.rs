//! Discrete and piecewise-constant 1D/2D distributions (for environment-map importance sampling),
//! named as pbrt-v4's `PiecewiseConstant1D/2D`.
//!
//! - [`PiecewiseConstant1D`]: a non-negative function tabulated on `n` equal cells of [0, 1],
//!   sampled by inverting its CDF, either as a cell index (`sample_discrete`, probability mass
//!   `f_i / Σ f`) or as a continuous point (`sample_continuous`, density `f_i / ∫f` with
//!   ∫f = Σ f / n).
//! - [`PiecewiseConstant2D`]: a function on an `nu × nv` grid of [0, 1]² (row-major, `v` the row),
//!   sampled as marginal in `v` (the row integrals) times the conditional in `u` of the chosen row.
//!   Its density with respect to the unit square is `f(u, v) / ∫∫f`.
//!
//! **Inversion in O(1) expected time, monotone in u.** The CDF is searched from a guide table
//! (the "cutpoint" method of Chen & Asau 1974; Devroye, *Non-Uniform Random Variate Generation*,
//! §III.2.4): guide\[j\] is the cell holding u = j/n, and the search for u starts at
//! guide\[⌊u n⌋\] and walks forward. With n guide entries for n cells the expected number of steps
//! is at most 1 + n/n = 2 whatever the function, and the answer is exactly the cell a binary
//! search finds. Unlike an alias table, the map u ↦ x stays monotone, so the stratification of
//! the sampler's points (Sobol (0, m, 2)-nets) carries over to the sampled directions.
//!
//! **Layout.** Each 1D CDF entry is stored beside its guide entry ([`CdfEntry`], 8 bytes). The 2D
//! distribution keeps all its conditional rows in one flat row-major array of [`CellEntry`], one
//! aligned 32-byte entry per cell holding cdf\[i\], cdf\[i + 1\] and a caller's payload (the
//! environment map keeps its texel there: radiance and density), and the rows' guide tables apart,
//! 2 bytes a cell (4 past 65,536 columns). A sample then reads a guide entry, at a uniformly random
//! column but in a table small enough to stay cached, and the line of the answer, which holds both
//! CDF values of the cell and its payload, so looking the sampled texel up afterwards costs no
//! further cache miss. A caller that knows `u` early can `prefetch` the line where the walk starts.
//!
//! Cells of zero weight are never chosen (the search skips zero-width CDF steps), so a density of 0
//! really means "never sampled". An all-zero function gives a distribution with integral 0: it
//! samples uniformly but reports pdf 0, and callers (lights) treat integral 0 as "cannot sample".
//! CDFs are accumulated in f64 and stored in f32 (rounding is monotone, so they stay sorted).

use crate::math::Vec2;
use crate::simd::{Float, Isa, Mask};
use rayon::prelude::*;

/// Largest f32 below 1: random numbers are clamped to it so `u = 1` cannot select past the end.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// One CDF value and one guide entry (8 bytes: a cache line holds 8 of them).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub struct CdfEntry {
    /// cdf[i]: the probability of cells 0..i (cdf[0] = 0, cdf[n] = 1).
    cdf: f32,
    /// guide[i]: the cell holding u = i/n (unused in entry n).
    guide: u32,
}

/// One cell of a 2D distribution's conditional row: its CDF interval and a payload `P` the caller
/// stores beside them (see the module's "Layout"). 32 bytes, aligned, so an entry never straddles
/// a cache line; a payload of up to 24 bytes fits.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct CellEntry<P> {
    /// cdf[i]: the probability of the row's cells 0..i.
    cdf: f32,
    /// cdf[i + 1] (1 in the row's last cell).
    cdf_next: f32,
    payload: P,
}

/// The guide tables of a 2D distribution's rows, row-major: guide\[i\] of a row is the cell holding
/// u = i/n. Apart from the cells, and as narrow as the row allows (2 bytes a cell up to 65,536
/// columns), so that the first read of a light sample, at a uniformly random column, comes from a
/// table a sixteenth of the cells' size (1 MB for a 1024 × 512 map, which an L2 cache holds).
#[derive(Clone, Debug)]
enum Guides {
    U16(Vec<u16>),
    U32(Vec<u32>),
}

impl Guides {
    /// Entry `index` (row-major).
    #[inline(always)]
    fn get(&self, index: usize) -> usize {
        match self {
            Guides::U16(g) => g[index] as usize,
            Guides::U32(g) => g[index] as usize,
        }
    }
}

/// Builds the n + 1 entries of `func` (already sanitized, n ≥ 1) and returns Σ f (f64).
fn build_entries(func: &[f32], out: &mut [CdfEntry]) -> f64 {
    let n = func.len();
    debug_assert_eq!(out.len(), n + 1);
    let total: f64 = func.iter().map(|&v| v as f64).sum();
    out[0].cdf = 0.0;
    if total > 0.0 {
        let mut acc = 0.0f64;
        for (e, &v) in out[1..].iter_mut().zip(func) {
            acc += v as f64;
            e.cdf = (acc / total) as f32;
        }
    } else {
        // Nothing to importance-sample: a uniform CDF keeps `sample_*` well defined.
        for (i, e) in out[1..].iter_mut().enumerate() {
            e.cdf = (i + 1) as f32 / n as f32;
        }
    }
    out[n].cdf = 1.0;
    let mut i = 0usize;
    for j in 0..n {
        let u = j as f32 / n as f32;
        while i + 1 < n && out[i + 1].cdf <= u {
            i += 1;
        }
        out[j].guide = i as u32;
    }
    total
}

/// Sanitized copy: negative or NaN values are 0.
#[inline]
fn sanitize(v: f32) -> f32 {
    if v.is_finite() && v > 0.0 { v } else { 0.0 }
}

/// `⌊x⌋` as an index below `n`: `(x as usize).min(n - 1)` (0 for NaN and x < 0), for tables of
/// fewer than 2³² entries. Converted through u32, which x86-64 does in 8 instructions where a
/// saturating f32 → usize conversion takes 16: the same index for every x.
#[inline(always)]
pub(crate) fn index_below(x: f32, n: usize) -> usize {
    debug_assert!(n > 0 && n <= u32::MAX as usize);
    ((x as u32) as usize).min(n - 1)
}

/// `n as f32` for a table length n < 2³² (through u32: a u64 → f32 conversion is a dozen
/// x86-64 instructions, a u32 → f32 one or two; the same value).
#[inline(always)]
pub(crate) fn len_f32(n: usize) -> f32 {
    debug_assert!(n <= u32::MAX as usize);
    n as u32 as f32
}

/// Cell i with cdf[i] ≤ u < cdf[i+1] (zero-width cells are skipped), u ∈ [0, 1).
#[inline(always)]
fn find(entries: &[CdfEntry], u: f32) -> usize {
    // The last i < n with cdf[i] ≤ u (cdf[0] = 0 ≤ u): start from the guide entry of
    // ⌊u·n⌋/n ≤ u, which is never past the answer, and walk forward.
    let n = entries.len() - 1;
    let mut i = entries[index_below(u * len_f32(n), n)].guide as usize;
    while i + 1 < n && entries[i + 1].cdf <= u {
        i += 1;
    }
    i
}

/// (cell, `u` remapped to [0, 1) within the cell) for u ∈ [0, 1].
#[inline(always)]
fn sample_entries(entries: &[CdfEntry], u: f32) -> (usize, f32) {
    let u = u.clamp(0.0, ONE_MINUS_EPSILON);
    let i = find(entries, u);
    let (c0, c1) = (entries[i].cdf, entries[i + 1].cdf);
    let width = c1 - c0;
    let remapped = if width > 0.0 { ((u - c0) / width).clamp(0.0, ONE_MINUS_EPSILON) } else { 0.0 };
    (i, remapped)
}

/// The continuous point of cell `i` of `n` at offset `du` ∈ [0, 1).
#[inline(always)]
fn continuous(i: usize, du: f32, n: usize) -> f32 {
    ((len_f32(i) + du) / len_f32(n)).min(ONE_MINUS_EPSILON)
}

#[derive(Clone, Debug)]
pub struct PiecewiseConstant1D {
    /// The tabulated function (non-negative; negative or NaN inputs are stored as 0).
    func: Vec<f32>,
    /// n + 1 entries: the CDF and the guide table.
    entries: Vec<CdfEntry>,
    /// ∫₀¹ f(x) dx = Σ f_i / n.
    func_int: f64,
}

impl PiecewiseConstant1D {
    /// Tabulates `f` on `f.len()` equal cells of [0, 1]. An empty slice is treated as one cell of 0.
    pub fn new(f: &[f32]) -> Self {
        let func: Vec<f32> = if f.is_empty() { vec![0.0] } else { f.iter().map(|&v| sanitize(v)).collect() };
        let n = func.len();
        let mut entries = vec![CdfEntry::default(); n + 1];
        let total = build_entries(&func, &mut entries);
        PiecewiseConstant1D { func, entries, func_int: total / n as f64 }
    }

    /// Number of cells.
    #[inline]
    pub fn count(&self) -> usize {
        self.func.len()
    }

    /// ∫₀¹ f (0 when the function is identically zero).
    #[inline]
    pub fn integral(&self) -> f64 {
        self.func_int
    }

    /// The tabulated value of cell `i`.
    #[inline]
    pub fn func(&self, i: usize) -> f32 {
        self.func[i]
    }

    /// The CDF at the cell boundaries (n + 1 entries).
    pub fn cdf(&self) -> Vec<f32> {
        self.entries.iter().map(|e| e.cdf).collect()
    }

    /// Draws a cell index with probability f_i / Σ f. Returns (index, probability mass, `u`
    /// remapped to [0, 1) within the chosen cell, reusable as a fresh uniform number).
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let (i, remapped) = sample_entries(&self.entries, u);
        (i, self.pmf(i), remapped)
    }

    /// Probability mass of cell `i` (0 when the function is identically zero).
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        if self.func_int > 0.0 { (self.func[i] as f64 / (self.func_int * self.func.len() as f64)) as f32 } else { 0.0 }
    }

    /// Draws x ∈ [0, 1) with density f(x)/∫f. Returns (x, density, cell index).
    #[inline]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let (i, du) = sample_entries(&self.entries, u);
        (continuous(i, du, self.func.len()), self.pdf_cell(i), i)
    }

    /// Density f_i/∫f of cell `i` with respect to x ∈ [0, 1].
    #[inline]
    pub fn pdf_cell(&self, i: usize) -> f32 {
        if self.func_int > 0.0 { (self.func[i] as f64 / self.func_int) as f32 } else { 0.0 }
    }

    /// Density at x ∈ [0, 1] (0 outside).
    #[inline]
    pub fn pdf(&self, x: f32) -> f32 {
        if !(0.0..=1.0).contains(&x) {
            return 0.0;
        }
        let i = ((x * self.func.len() as f32) as usize).min(self.func.len() - 1);
        self.pdf_cell(i)
    }
}

/// A piecewise-constant density on [0, 1]², `nu` cells along u (columns) and `nv` along v (rows),
/// with a payload `P` per cell stored in the cell's sampling entry (`()` when none is needed).
#[derive(Clone, Debug)]
pub struct PiecewiseConstant2D<P = ()> {
    /// The conditional CDF and payload of every cell, row-major (`iv * nu + iu`).
    conditional: Vec<CellEntry<P>>,
    /// The conditional rows' guide tables, row-major.
    guides: Guides,
    /// The sanitized function, row-major.
    func: Vec<f32>,
    /// Distribution of the rows, by their integrals ∫ f(u, v) du.
    marginal: PiecewiseConstant1D,
    nu: usize,
    nv: usize,
}

impl PiecewiseConstant2D {
    /// `func` is row-major: `func[iv * nu + iu]`, `nu * nv` values; no payload.
    ///
    /// # Panics
    /// When `func.len() != nu * nv` or a dimension is 0 (a programming error, never user data).
    pub fn new(func: &[f32], nu: usize, nv: usize) -> Self {
        Self::build(func, nu, nv)
    }
}

impl<P: Copy + Default + Send + Sync> PiecewiseConstant2D<P> {
    /// As [`PiecewiseConstant2D::new`], with payloads of type `P`, all `P::default()` until
    /// [`set_payloads`](Self::set_payloads).
    ///
    /// # Panics
    /// When `func.len() != nu * nv` or a dimension is 0 (a programming error, never user data).
    pub fn build(func: &[f32], nu: usize, nv: usize) -> Self {
        const { assert!(std::mem::size_of::<CellEntry<P>>() == 32, "a cell entry is one 32-byte slot") };
        assert!(nu > 0 && nv > 0 && func.len() == nu * nv, "PiecewiseConstant2D: {} values for {nu}×{nv}", func.len());
        let func: Vec<f32> = func.par_iter().map(|&v| sanitize(v)).collect();
        let mut conditional = vec![CellEntry::<P>::default(); nu * nv];
        let mut guides = vec![0u32; nu * nv];
        // Rows are independent: build them in parallel (each writes its own slice: deterministic),
        // through the 1D entries (n + 1 of them) so that the CDF values are those of a 1D row.
        let row_integrals: Vec<f32> = conditional
            .par_chunks_exact_mut(nu)
            .zip(guides.par_chunks_exact_mut(nu))
            .zip(func.par_chunks_exact(nu))
            .map_init(
                || vec![CdfEntry::default(); nu + 1],
                |entries, ((cells, guide), f)| {
                    let total = build_entries(f, entries);
                    for (i, (c, g)) in cells.iter_mut().zip(guide).enumerate() {
                        (c.cdf, c.cdf_next, *g) = (entries[i].cdf, entries[i + 1].cdf, entries[i].guide);
                    }
                    (total / nu as f64) as f32
                },
            )
            .collect();
        let marginal = PiecewiseConstant1D::new(&row_integrals);
        // Every guide entry is a column index below nu.
        let guides = if nu <= 1 << 16 {
            Guides::U16(guides.par_iter().map(|&g| g as u16).collect())
        } else {
            Guides::U32(guides)
        };
        PiecewiseConstant2D { conditional, guides, func, marginal, nu, nv }
    }

    /// Stores `payloads[iv * nu + iu]` beside cell (iu, iv). No effect on sampling.
    ///
    /// # Panics
    /// When `payloads.len() != nu * nv`.
    pub fn set_payloads(&mut self, payloads: &[P]) {
        assert_eq!(payloads.len(), self.conditional.len(), "PiecewiseConstant2D: one payload per cell");
        self.conditional.par_iter_mut().zip(payloads.par_iter()).for_each(|(c, p)| c.payload = *p);
        // The table is complete now, and a light sample and a BRDF direction's lookup read it at
        // random: in huge pages where the kernel gives them.
        crate::memory::advise_huge_pages(&self.conditional);
    }

    /// The payload of cell `index = iv * nu + iu`.
    #[inline(always)]
    pub fn payload(&self, index: usize) -> &P {
        &self.conditional[index].payload
    }

    /// (nu, nv).
    #[inline]
    pub fn size(&self) -> (usize, usize) {
        (self.nu, self.nv)
    }

    /// ∫∫ f du dv over the unit square (0 when f ≡ 0: then nothing can be sampled).
    #[inline]
    pub fn integral(&self) -> f64 {
        self.marginal.integral()
    }

    #[inline(always)]
    fn row(&self, iv: usize) -> &[CellEntry<P>] {
        &self.conditional[iv * self.nu..(iv + 1) * self.nu]
    }

    /// Draws (u, v) ∈ [0, 1)² with density f/∫∫f. Returns the point and its cell (column, row),
    /// without reading the density (callers that recompute it from the point save a cache miss).
    /// The one-lane [`PiecewiseConstant2D::sample_points`].
    #[inline(always)]
    pub fn sample_point_cell(&self, u: Vec2) -> (Vec2, (usize, usize)) {
        let ([pu, pv], iu, iv) = self.sample_points([Float::<1>::splat(u.x), Float::splat(u.y)], Mask::ALL);
        (Vec2::new(pu.lane(0), pv.lane(0)), (iu[0], iv[0]))
    }

    /// [`PiecewiseConstant2D::sample_point_cell`] of each lane `k` with `want[k]`: the points
    /// (u, v), their columns and their rows (the other lanes' are unspecified). The clamps, the
    /// guide indices, the remaps into the cells (two divisions) and the continuous points (two
    /// more) run over all lanes, in SIMD registers inside the x86-64-v3 copy of the render's tile
    /// loop; the cutpoint walks (whose lengths depend on the table) and their loads run lane by lane.
    #[inline(always)]
    pub fn sample_points<const N: usize, S: Isa>(
        &self,
        u: [Float<N, S>; 2],
        want: Mask<N, S>,
    ) -> ([Float<N, S>; 2], [usize; N], [usize; N]) {
        let marginal = &self.marginal.entries;
        let nm = marginal.len() - 1;
        // The marginal (rows): `sample_entries` split at its walk.
        let uy = u[1].clamp(0.0, ONE_MINUS_EPSILON);
        let guide = (uy * len_f32(nm)).index_below(nm);
        let (mut iv, mut c0, mut c1) = ([0usize; N], Float::<N, S>::ZERO, Float::<N, S>::ZERO);
        for k in 0..N {
            if want.lane(k) {
                let mut i = marginal[guide[k] as usize].guide as usize;
                while i + 1 < nm && marginal[i + 1].cdf <= uy.0[k] {
                    i += 1;
                }
                (iv[k], c0.0[k], c1.0[k]) = (i, marginal[i].cdf, marginal[i + 1].cdf);
            }
        }
        let width = c1 - c0;
        let dv = width.gt(Float::ZERO).select(((uy - c0) / width).clamp(0.0, ONE_MINUS_EPSILON), Float::ZERO);
        let ux = u[0].clamp(0.0, ONE_MINUS_EPSILON);
        let guide = (ux * len_f32(self.nu)).index_below(self.nu);
        // The row's cell the same way (the entries of a row hold cdf[i + 1] in entry i).
        let mut iu = [0usize; N];
        for k in 0..N {
            if want.lane(k) {
                let row = self.row(iv[k]);
                let n = row.len();
                let mut i = self.guides.get(iv[k] * self.nu + guide[k] as usize);
                while i + 1 < n && row[i].cdf_next <= ux.0[k] {
                    i += 1;
                }
                (iu[k], c0.0[k], c1.0[k]) = (i, row[i].cdf, row[i].cdf_next);
            }
        }
        let width = c1 - c0;
        let du = width.gt(Float::ZERO).select(((ux - c0) / width).clamp(0.0, ONE_MINUS_EPSILON), Float::ZERO);
        // `continuous` of each lane's cell and offset.
        let (mut fu, mut fv) = (Float::<N, S>::ZERO, Float::<N, S>::ZERO);
        for k in 0..N {
            (fu.0[k], fv.0[k]) = (len_f32(iu[k]), len_f32(iv[k]));
        }
        let pu = ((fu + du) / len_f32(self.nu)).min(Float::splat(ONE_MINUS_EPSILON));
        let pv = ((fv + dv) / len_f32(self.nv)).min(Float::splat(ONE_MINUS_EPSILON));
        ([pu, pv], iu, iv)
    }

    /// Draws (u, v) ∈ [0, 1)² with density f/∫∫f. Returns the point, its density with respect to
    /// the unit square (0 if f ≡ 0) and its cell (column, row).
    #[inline]
    pub fn sample_continuous_cell(&self, u: Vec2) -> (Vec2, f32, (usize, usize)) {
        let (p, (iu, iv)) = self.sample_point_cell(u);
        (p, self.pdf_index(iu, iv), (iu, iv))
    }

    /// Draws (u, v) ∈ [0, 1)² with density f/∫∫f. Returns the point and its density with respect to
    /// the unit square (0 if f ≡ 0).
    #[inline]
    pub fn sample_continuous(&self, u: Vec2) -> (Vec2, f32) {
        let (p, pdf, _) = self.sample_continuous_cell(u);
        (p, pdf)
    }

    /// A hint that `sample_continuous(u)` follows soon: reads the guide entry of the row it will
    /// search (the marginal and the guide tables are small and stay cached) and starts loading the
    /// cell where its walk starts. No effect on results.
    #[inline(always)]
    pub fn prefetch(&self, u: Vec2) {
        // The row of `sample_entries(marginal, u.y)`, without its remapped u (a division).
        let iv = find(&self.marginal.entries, u.y.clamp(0.0, ONE_MINUS_EPSILON));
        let uu = u.x.clamp(0.0, ONE_MINUS_EPSILON);
        let k = index_below(uu * len_f32(self.nu), self.nu);
        // The guide entry is small and usually cached: read it, and start loading the cell where
        // the walk starts (the answer itself, or its neighbour, in most samples).
        let start = self.guides.get(iv * self.nu + k);
        crate::math::prefetch_read(&self.conditional[iv * self.nu + start]);
    }

    /// Density of cell (column `iu`, row `iv`) with respect to the unit square.
    #[inline]
    pub fn pdf_index(&self, iu: usize, iv: usize) -> f32 {
        let total = self.marginal.integral();
        if total > 0.0 { (self.func[iv * self.nu + iu] as f64 / total) as f32 } else { 0.0 }
    }

    /// Density at `uv` ∈ [0, 1]² (0 outside).
    #[inline]
    pub fn pdf(&self, uv: Vec2) -> f32 {
        if !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y) {
            return 0.0;
        }
        let iu = index_below(uv.x * len_f32(self.nu), self.nu);
        let iv = index_below(uv.y * len_f32(self.nv), self.nv);
        self.pdf_index(iu, iv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `sample_points` at eight lanes is its one-lane call (`sample_point_cell`) lane by lane, bit
    /// for bit, on a table with zero rows, zero cells and heavy cells, at random numbers and the
    /// ends of [0, 1].
    #[test]
    fn eight_lane_points_are_one_lane_points() {
        let mut rng = crate::sampling::chi2::TestRng::new(17);
        let (nu, nv) = (37, 23);
        let f: Vec<f32> = (0..nu * nv)
            .map(|k| if k % 7 == 0 || (k / nu) % 5 == 2 { 0.0 } else { rng.next_f32().powi(6) * 50.0 })
            .collect();
        let d = PiecewiseConstant2D::new(&f, nu, nv);
        let pick = |rng: &mut crate::sampling::chi2::TestRng| match rng.next_u64() % 8 {
            0 => 0.0,
            1 => 1.0,
            2 => ONE_MINUS_EPSILON,
            _ => rng.next_f32(),
        };
        let mut compared = 0;
        for _ in 0..4000 {
            let mut u = [Float::<8>::ZERO; 2];
            let mut want = [false; 8];
            for (k, w) in want.iter_mut().enumerate() {
                (u[0].0[k], u[1].0[k]) = (pick(&mut rng), pick(&mut rng));
                *w = rng.next_f32() < 0.8;
            }
            let ([pu, pv], iu, iv) = d.sample_points(u, Mask::from_bools(want));
            for k in 0..8 {
                if want[k] {
                    let (p, (c, r)) = d.sample_point_cell(Vec2::new(u[0].0[k], u[1].0[k]));
                    assert_eq!(
                        (pu.0[k].to_bits(), pv.0[k].to_bits(), iu[k], iv[k]),
                        (p.x.to_bits(), p.y.to_bits(), c, r),
                        "u {:?}",
                        (u[0].0[k], u[1].0[k])
                    );
                    compared += 1;
                }
            }
        }
        assert!(compared > 20_000);
    }

    /// The guided search returns exactly the cell of a plain binary search, zero-width cells
    /// included.
    #[test]
    fn guided_search_equals_binary_search() {
        let mut rng = crate::sampling::chi2::TestRng::new(3);
        let f: Vec<f32> = (0..1000).map(|i| if i % 7 == 0 { 0.0 } else { rng.next_f32().powi(8) * 100.0 }).collect();
        let d = PiecewiseConstant1D::new(&f);
        for k in 0..200_000 {
            let u = if k < 1000 { k as f32 / 1000.0 } else { rng.next_f32() };
            let u = u.clamp(0.0, ONE_MINUS_EPSILON);
            let expect = (d.cdf().partition_point(|&c| c <= u)).saturating_sub(1).min(d.count() - 1);
            assert_eq!(find(&d.entries, u), expect, "u = {u}");
        }
    }
    use crate::sampling::chi2::{TestRng, chi2_survival};

    /// Pearson χ² of observed counts against expected counts (cells with expectation 0 must stay
    /// empty). Returns the p-value.
    fn chi2_counts(observed: &[f64], expected: &[f64]) -> f64 {
        let mut stat = 0.0;
        let mut dof = 0usize;
        for (o, e) in observed.iter().zip(expected) {
            if *e == 0.0 {
                assert_eq!(*o, 0.0, "a cell of zero probability was sampled");
                continue;
            }
            assert!(*e >= 5.0, "test design: expected count {e} < 5");
            stat += (o - e).powi(2) / e;
            dof += 1;
        }
        chi2_survival(stat, (dof - 1) as f64)
    }

    // Seven χ² tests below: Šidák-style alpha ≈ 1e-3 / 7.
    const ALPHA: f64 = 1.4e-4;

    #[test]
    fn one_d_pmf_cdf_and_integral() {
        let d = PiecewiseConstant1D::new(&[1.0, 0.0, 3.0, 4.0]);
        assert_eq!(d.count(), 4);
        assert!((d.integral() - 2.0).abs() < 1e-12);
        let expect_cdf = [0.0, 0.125, 0.125, 0.5, 1.0];
        for (c, e) in d.cdf().iter().zip(expect_cdf) {
            assert!((c - e).abs() < 1e-7);
        }
        assert!((d.pmf(3) - 0.5).abs() < 1e-7);
        assert!((d.pdf(0.9) - 2.0).abs() < 1e-6, "density 4/2 in the last cell");
        assert_eq!(d.pdf(0.3), 0.0);
        assert_eq!(d.pdf(1.5), 0.0);
        // Inversion: the continuous sample at u = cdf(x) is x.
        for &x in &[0.05f32, 0.6, 0.99] {
            let i = (x * 4.0) as usize;
            let u = d.cdf()[i] + (x * 4.0 - i as f32) * (d.cdf()[i + 1] - d.cdf()[i]);
            let (xs, pdf, is) = d.sample_continuous(u);
            assert!((xs - x).abs() < 1e-5, "{xs} vs {x}");
            assert_eq!(is, i);
            assert_eq!(pdf, d.pdf_cell(i));
        }
        // u = 1 (or beyond) never runs past the end; u at a zero-width step skips the empty cell.
        assert_eq!(d.sample_discrete(1.0).0, 3);
        assert_eq!(d.sample_discrete(0.125).0, 2);
    }

    #[test]
    fn one_d_all_zero_reports_zero_pdf() {
        let d = PiecewiseConstant1D::new(&[0.0, 0.0, f32::NAN, -1.0]);
        assert_eq!(d.integral(), 0.0);
        let (x, pdf, _) = d.sample_continuous(0.3);
        assert!((0.0..1.0).contains(&x));
        assert_eq!(pdf, 0.0);
        assert_eq!(d.pdf(0.3), 0.0);
        let e = PiecewiseConstant1D::new(&[]);
        assert_eq!(e.count(), 1);
        assert_eq!(e.integral(), 0.0);
    }

    #[test]
    fn one_d_discrete_chi_square() {
        let f: Vec<f32> =
            (0..50).map(|i| if i % 7 == 3 { 0.0 } else { 1.0 + (i as f32 * 0.37).sin().abs() * 5.0 }).collect();
        let d = PiecewiseConstant1D::new(&f);
        let n = 200_000;
        let mut rng = TestRng::new(11);
        let mut obs = vec![0.0; f.len()];
        for _ in 0..n {
            let (i, pmf, r) = d.sample_discrete(rng.next_f32());
            assert!(pmf > 0.0 && (0.0..1.0).contains(&r));
            obs[i] += 1.0;
        }
        let exp: Vec<f64> = (0..f.len()).map(|i| d.pmf(i) as f64 * n as f64).collect();
        let p = chi2_counts(&obs, &exp);
        assert!(p > ALPHA, "p = {p}");
    }

    #[test]
    fn one_d_continuous_chi_square_on_sub_cells() {
        // Bins finer than the cells: within a cell the density must be flat.
        let f = [0.5f32, 2.0, 0.0, 1.0, 4.0];
        let d = PiecewiseConstant1D::new(&f);
        let sub = 8;
        let bins = f.len() * sub;
        let n = 200_000;
        let mut rng = TestRng::new(12);
        let mut obs = vec![0.0; bins];
        for _ in 0..n {
            let (x, pdf, i) = d.sample_continuous(rng.next_f32());
            assert_eq!(pdf, d.pdf(x), "returned density equals pdf(x)");
            assert_eq!(i, (x * f.len() as f32) as usize);
            obs[((x * bins as f32) as usize).min(bins - 1)] += 1.0;
        }
        let exp: Vec<f64> =
            (0..bins).map(|b| d.pdf((b as f32 + 0.5) / bins as f32) as f64 / bins as f64 * n as f64).collect();
        let p = chi2_counts(&obs, &exp);
        assert!(p > ALPHA, "p = {p}");
    }

    #[test]
    fn one_d_wrong_density_is_rejected() {
        // Negative test of the harness: compare draws of a non-uniform f with uniform expectations.
        let d = PiecewiseConstant1D::new(&[1.0, 2.0, 3.0, 4.0]);
        let n = 100_000;
        let mut rng = TestRng::new(13);
        let mut obs = [0.0; 4];
        for _ in 0..n {
            obs[d.sample_discrete(rng.next_f32()).0] += 1.0;
        }
        let p = chi2_counts(&obs, &[n as f64 / 4.0; 4]);
        assert!(p < 1e-6, "p = {p}");
    }

    fn test_grid() -> (Vec<f32>, usize, usize) {
        let (nu, nv) = (12, 7);
        let f = (0..nu * nv)
            .map(|k| {
                let (iu, iv) = (k % nu, k / nu);
                if iv == 2 || (iu + iv) % 5 == 0 {
                    0.0
                } else {
                    0.2 + ((iu as f32 * 0.9).cos() * (iv as f32 * 1.3).sin()).abs() * 3.0
                }
            })
            .collect();
        (f, nu, nv)
    }

    #[test]
    fn two_d_pdf_integrates_to_one_and_matches_function() {
        let (f, nu, nv) = test_grid();
        let d = PiecewiseConstant2D::new(&f, nu, nv);
        let total: f64 = f.iter().map(|&v| v as f64).sum::<f64>() / (nu * nv) as f64;
        assert!((d.integral() - total).abs() < 1e-6 * total);
        let mut int = 0.0;
        for iv in 0..nv {
            for iu in 0..nu {
                let p = d.pdf(Vec2::new((iu as f32 + 0.5) / nu as f32, (iv as f32 + 0.5) / nv as f32));
                assert!((p as f64 - f[iv * nu + iu] as f64 / total).abs() < 1e-5);
                int += p as f64 / (nu * nv) as f64;
            }
        }
        assert!((int - 1.0).abs() < 1e-5, "∫pdf = {int}");
        assert_eq!(d.pdf(Vec2::new(-0.1, 0.5)), 0.0);
    }

    #[test]
    fn two_d_chi_square_on_sub_cells() {
        let (f, nu, nv) = test_grid();
        let d = PiecewiseConstant2D::new(&f, nu, nv);
        let (su, sv) = (2 * nu, 2 * nv); // two bins per cell per axis: flatness within cells too
        let n = 300_000;
        let mut rng = TestRng::new(14);
        let mut obs = vec![0.0; su * sv];
        for _ in 0..n {
            let (p, pdf) = d.sample_continuous(Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!(pdf > 0.0);
            assert_eq!(pdf, d.pdf(p));
            let bu = ((p.x * su as f32) as usize).min(su - 1);
            let bv = ((p.y * sv as f32) as usize).min(sv - 1);
            obs[bv * su + bu] += 1.0;
        }
        let exp: Vec<f64> = (0..su * sv)
            .map(|b| {
                let c = Vec2::new(((b % su) as f32 + 0.5) / su as f32, ((b / su) as f32 + 0.5) / sv as f32);
                d.pdf(c) as f64 / (su * sv) as f64 * n as f64
            })
            .collect();
        let p = chi2_counts(&obs, &exp);
        assert!(p > ALPHA, "p = {p}");
    }

    #[test]
    fn two_d_large_grid_builds() {
        // 1000 × 1000 (the Grace probe size): the integral survives a million f32 cells.
        let (nu, nv) = (1000, 1000);
        let f: Vec<f32> = (0..nu * nv).map(|k| ((k % 977) as f32).sqrt()).collect();
        let t = std::time::Instant::now();
        let d = PiecewiseConstant2D::new(&f, nu, nv);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        // Timing is reported, not asserted (the machine is shared); the result must be usable.
        eprintln!("PiecewiseConstant2D 1000×1000 built in {ms:.1} ms");
        let expect = f.iter().map(|&v| v as f64).sum::<f64>() / (nu * nv) as f64;
        assert!((d.integral() - expect).abs() < 1e-5 * expect);
    }

    /// The packed 2D table draws exactly the points of the textbook construction (a 1D marginal
    /// over row integrals, then a 1D conditional per row), bit for bit: the layout changed, not
    /// what is computed. On a grid of 2-byte guide entries and on one wider than 65,536 columns
    /// (4-byte entries).
    #[test]
    fn two_d_packed_rows_equal_the_composition_of_one_d() {
        for (nu, nv, seed) in [(97, 41, 21), ((1 << 16) + 4, 3, 22)] {
            packed_rows_equal_the_composition_of_one_d(nu, nv, seed);
        }
    }

    fn packed_rows_equal_the_composition_of_one_d(nu: usize, nv: usize, seed: u64) {
        let mut rng = TestRng::new(seed);
        let f: Vec<f32> = (0..nu * nv).map(|k| if k % 11 == 0 { 0.0 } else { rng.next_f32().powi(6) * 50.0 }).collect();
        let d = PiecewiseConstant2D::new(&f, nu, nv);
        assert_eq!(matches!(d.guides, Guides::U32(_)), nu > 1 << 16, "{nu} columns");
        // With a payload in every entry (its own index): the same draws, and each cell's payload.
        let mut dp = PiecewiseConstant2D::<[u32; 5]>::build(&f, nu, nv);
        dp.set_payloads(&(0..nu * nv).map(|k| [k as u32; 5]).collect::<Vec<_>>());
        let rows: Vec<PiecewiseConstant1D> = f.chunks(nu).map(PiecewiseConstant1D::new).collect();
        let marginal = PiecewiseConstant1D::new(&rows.iter().map(|r| r.integral() as f32).collect::<Vec<_>>());
        for _ in 0..100_000 {
            let u = Vec2::new(rng.next_f32(), rng.next_f32());
            let (v, _, iv) = marginal.sample_continuous(u.y);
            let (x, _, iu) = rows[iv].sample_continuous(u.x);
            let (p, pdf, cell) = d.sample_continuous_cell(u);
            assert_eq!((p.x.to_bits(), p.y.to_bits(), cell), (x.to_bits(), v.to_bits(), (iu, iv)));
            assert_eq!(pdf, (rows[iv].func(iu) as f64 / marginal.integral()) as f32);
            let (pp, cp) = dp.sample_point_cell(u);
            assert_eq!((pp.x.to_bits(), pp.y.to_bits(), cp), (x.to_bits(), v.to_bits(), (iu, iv)));
            assert_eq!(*dp.payload(iv * nu + iu), [(iv * nu + iu) as u32; 5]);
        }
    }

    /// χ² of the packed table on a map-like grid: 512 × 256 cells, a dark band, a few very bright
    /// cells (a sun), smooth elsewhere; 2 × 10⁶ draws binned on 64 × 32 bins of 8 × 8 cells, the
    /// expected counts the pdf summed over each bin's cells.
    #[test]
    fn two_d_chi_square_map_like_grid() {
        let (nu, nv) = (512, 256);
        let f: Vec<f32> = (0..nu * nv)
            .map(|k| {
                let (iu, iv) = (k % nu, k / nu);
                if (100..110).contains(&iv) {
                    0.0
                } else if (300..303).contains(&iu) && (40..42).contains(&iv) {
                    5.0e4
                } else {
                    0.1 + ((iu as f32 * 0.05).sin() * (iv as f32 * 0.03).cos()).abs()
                }
            })
            .collect();
        let d = PiecewiseConstant2D::new(&f, nu, nv);
        let (bu, bv) = (nu / 8, nv / 8);
        let n = 2_000_000;
        let mut rng = TestRng::new(22);
        let mut obs = vec![0.0; bu * bv];
        for _ in 0..n {
            // Binned by the point, whose density pdf(uv) is what is claimed. (The returned cell can
            // differ from the point's: (i + du)/n with du just below 1 rounds up to the edge
            // (i + 1)/n in f32, as in pbrt; lights recompute the density from the direction.)
            let (p, _) = d.sample_continuous(Vec2::new(rng.next_f32(), rng.next_f32()));
            let (iu, iv) = (((p.x * nu as f32) as usize).min(nu - 1), ((p.y * nv as f32) as usize).min(nv - 1));
            obs[(iv / 8) * bu + iu / 8] += 1.0;
        }
        let mut exp = vec![0.0; bu * bv];
        for iv in 0..nv {
            for iu in 0..nu {
                exp[(iv / 8) * bu + iu / 8] += d.pdf_index(iu, iv) as f64 / (nu * nv) as f64 * n as f64;
            }
        }
        // Bins with tiny expectation are pooled (the χ² approximation needs ≥ 5 per cell).
        let (mut o2, mut e2, mut orest, mut erest) = (vec![], vec![], 0.0, 0.0);
        for (o, e) in obs.iter().zip(&exp) {
            if *e >= 5.0 {
                o2.push(*o);
                e2.push(*e);
            } else {
                orest += o;
                erest += e;
            }
        }
        if erest >= 5.0 {
            o2.push(orest);
            e2.push(erest);
        }
        let p = chi2_counts(&o2, &e2);
        assert!(p > ALPHA, "p = {p}");
    }
}
