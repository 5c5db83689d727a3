//! Integrators: estimators of the radiance arriving at the camera for one primary sample.
//!
//! [`path`] is the unidirectional path tracer with next-event estimation and MIS, batched over the
//! samples of a pixel; `reference` (tests only) is its one-sample-at-a-time oracle. For one convex
//! object under distant light and `max_depth = 1` it estimates exactly the reflection integral of
//! eq. 1, B = ∫ L(ω_i) ρ̂(ω_i, ω_o) dω_i.

pub mod path;
#[cfg(test)]
mod reference;

pub use path::{PathTracer, SampleResult};
