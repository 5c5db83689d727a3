//! The kernel's lane types: `N` samples computed by one body of code, for every `N`.
//!
//! [`Float<N>`] and [`Mask<N>`] are `N` f32 lanes and `N` boolean lanes; [`Float3<N>`] is `N`
//! three-vectors; [`U32<N>`] is `N` u32 lanes (the sampler's integers). A function written over them (a BRDF's sample, eval and pdf) is the same code at
//! `N = 1` (the one-sample callers and the tests' reference integrator) and at `N = 8` (the
//! batched integrator's lanes): lane k of the result has the bits of the one-lane call on lane
//! k's inputs, since every operation is the IEEE f32 operation applied lane by lane. Inside the
//! render's tile loop compiled for x86-64-v3 or v4 they get VEX or EVEX encodings (in 128-bit halves: [`float`]).
//!
//! Own code rather than a crate: `wide`'s `f32x8` fixes its instruction set when the crate is
//! compiled (two SSE halves in this project's baseline build, whose AVX2 copy of the tile loop is
//! chosen at run time), has no one-lane instance of the same type, and no gathers; `pulp` chooses
//! at run time but only inside its own dispatch closure, around which the integrator is not built.
//! Plain arrays of `N` lanes let LLVM emit the vector instructions of whichever copy inlines them.

pub mod fast;
pub mod float;
pub mod frame;
pub mod uint;
pub mod vec3;

pub use float::{Float, Mask};
pub use frame::Frames;
pub use uint::U32;
pub use vec3::Float3;
