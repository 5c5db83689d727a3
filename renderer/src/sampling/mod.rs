//! Random numbers and the warps, distributions and tests built on them.

pub mod chi2;
pub mod distribution;
pub mod sampler;
pub mod warp;

pub use sampler::{LANES, SampleLanes, Sampler, SamplerKind};
