//! Projection into spherical harmonics: of environment maps ([`envmap`]), of any function of
//! direction ([`function`]), of `normal-probe` renders ([`normal_probe`]) and of orthographic
//! images of a sphere by weighted least squares ([`orthographic`]), with the camera of an image's
//! OpenEXR matrices ([`exr_camera`]); the highest order each input carries ([`resolution`]).

pub mod envmap;
pub mod exr_camera;
pub mod function;
pub mod normal_probe;
pub mod orthographic;
pub mod resolution;

pub use envmap::{Mapping, project_envmap, project_latlong};
pub use exr_camera::{ExrCamera, camera_of_matrices, mirror_columns};
pub use function::{project_function, project_function_scalar};
pub use normal_probe::{normal_probe_outgoing, probe_samples, project_normal_probe};
pub use orthographic::{
    Fit, OrthoCamera, OrthoView, Param, Sample, Sphere, fit_orthographic, ortho_sample_pixels, ortho_samples,
    stderr_estimate,
};
pub use resolution::{check_latlong, check_order, latlong_max_order};
