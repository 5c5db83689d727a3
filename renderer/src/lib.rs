//! `renderer`: a CPU Monte Carlo path tracer for convex objects under distant lighting.
//!
//! Layout (one concept per file):
//! - [`math`]: colours, shading frames, spherical coordinates (docs/src/conventions.md §1).
//! - [`sampling`]: counter-based samplers (independent and Owen-scrambled Sobol), warps, discrete
//!   and piecewise-constant distributions, and the chi-square harness that tests every sampler.
//! - [`brdf`]: the paper's BRDFs (mirror, Lambert, Phong, Torrance–Sparrow) and a full microfacet
//!   model, each with `eval` (the transfer function ρ̂ = BRDF·cosθ'_i), `sample` and `pdf`.
//! - [`light`]: distant lights (uniform, directional, axial, SH, environment map), each with
//!   `eval`, `sample` and `pdf`.
//! - [`geometry`]: spheres and triangle meshes (OBJ, glTF) in one BVH.
//! - [`camera`], [`film`], [`integrator`], [`scene`], [`render`]: from a scene file to an image;
//!   [`progressive`]: renders in passes (target error, time limit, checkpoints, shards, continuation);
//!   [`rounds`]: the decisions of a render to a target error in rounds of shards.
//! - [`shard`]: partial renders on disk; [`render_file`]: any file a render leaves (a state too) as its image;
//!   [`light_field`]: a sphere's reflected light field, one normal-probe view per outgoing direction.

pub mod brdf;
pub mod camera;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod light_field;
pub mod math;
pub mod memory;
pub mod noise;
pub mod output;
pub mod progressive;
pub mod render;
pub mod render_file;
pub mod rounds;
pub mod sampling;
pub mod scene;
pub mod shard;
pub mod simd;
pub mod texture;

/// The one user-facing error type of the project (shared with `analysis`): it names the file and
/// the problem on one line.
pub use vocab::Error;
pub type Result<T> = std::result::Result<T, Error>;
