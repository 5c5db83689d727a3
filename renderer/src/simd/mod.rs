//! The kernel's lane types: `N` samples computed by one body of code, for every `N` and every
//! instruction set.
//!
//! [`Float<N, S>`] and [`Mask<N, S>`] are `N` f32 lanes and `N` boolean lanes; [`Float3<N, S>`] is
//! `N` three-vectors; [`U32<N, S>`] is `N` u32 lanes (the sampler's integers). `S` is the
//! [`Isa`] their operations are written in: [`Sse2`] (the default) or, inside the render's tile
//! loop compiled for x86-64-v3 or v4, `Avx2`, which does 8 lanes in one 256-bit register (VEX or
//! EVEX encoded) where `Sse2` does two 128-bit halves. A function written over them (a BRDF's
//! sample, eval and pdf) is the same code at `N = 1` (the one-sample callers and the tests'
//! reference integrator) and at `N = 8` (the batched integrator's lanes), in either `Isa`: lane k
//! of the result has the bits of the one-lane call on lane k's inputs, since every operation is
//! the IEEE f32 operation applied lane by lane.
//!
//! Own code rather than a crate: `wide`'s `f32x8` fixes its instruction set when the crate is
//! compiled (two SSE halves in this project's baseline build, whose AVX2 copy of the tile loop is
//! chosen at run time), has no one-lane instance of the same type, and no gathers; `pulp` chooses
//! at run time but only inside its own dispatch closure, around which the integrator is not built.
//! An `Isa` type parameter lets one source be compiled into each copy with that copy's registers.

pub mod fast;
pub mod float;
pub mod frame;
pub mod isa;
pub mod uint;
pub mod vec3;

pub use float::{Float, Mask};
pub use frame::Frames;
pub(crate) use isa::Avx2;
pub use isa::{Isa, Sse2};
pub use uint::U32;
pub use vec3::Float3;
