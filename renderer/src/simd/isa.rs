//! [`Isa`]: the instruction set the lane types' operations are written in, a type parameter of
//! [`super::Float`], [`super::Mask`], [`super::U32`] and everything built of them.
//!
//! The same kernel source is compiled once per instruction-set copy of the render's tile loop
//! (`render::render_tile`); the copy chooses the `Isa` its lanes run in. [`Sse2`] (the default,
//! and the only one outside the tile loop's AVX2 copies) does an 8-lane operation as two 128-bit
//! halves; `Avx2` does it in one 256-bit register. Both apply the same IEEE single-precision
//! operation to every lane, so the lanes' bits do not depend on the `Isa`.

/// An instruction set for the lane types' operations (sealed: [`Sse2`] and `Avx2`).
pub trait Isa:
    Copy + Clone + Default + std::fmt::Debug + PartialEq + Eq + Send + Sync + 'static + sealed::Sealed
{
    /// Whether 8-lane operations use 256-bit AVX and AVX2 instructions. True only for `Avx2`,
    /// which only code compiled with those features instantiates.
    const AVX2: bool;
}

/// x86-64's baseline: 128-bit SSE and SSE2 (and plain scalar code on other architectures). The
/// default `Isa` of every lane type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sse2;

/// 256-bit AVX and AVX2 for 8-lane operations.
///
/// Crate-private, and named only in the tile-loop copies compiled with AVX2
/// (`render::render_tile_x86_64_v3` and `_v4`), which the dispatcher calls only on CPUs that have
/// the features, and in tests behind a run-time check of AVX2: an operation on `Avx2` lanes
/// executes AVX2 instructions, so creating such lanes anywhere else could execute them on a CPU
/// without AVX2.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Avx2;

impl Isa for Sse2 {
    const AVX2: bool = false;
}

impl Isa for Avx2 {
    const AVX2: bool = true;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::Sse2 {}
    impl Sealed for super::Avx2 {}
}
