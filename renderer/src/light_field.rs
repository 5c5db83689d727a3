//! The reflected light field of a sphere, rendered view by view: a scene whose first object is a
//! sphere, re-rendered with a `normal-probe` camera (docs/src/conventions.md §6) at any outgoing
//! direction (θ_o, φ_o), at pixel centres (no jitter), so that each view samples
//! B(n; θ_o, φ_o) on the lat-long grid of normals. `reflect invert factor --scene` renders the
//! nodes of its outgoing rule with it (`analysis::factor::factor_rendered`).

use crate::camera::{Camera, NormalProbe};
use crate::film::Film;
use crate::render::{RenderOptions, render};
use crate::scene::Scene;
use crate::{Error, Result};
use std::path::Path;
use vocab::scene::{CameraSection, ObjectSection, SceneFile};

/// A scene prepared for its light-field views (see the module docs).
pub struct LightFieldViews {
    scene: Scene,
    /// Centre and radius of `objects[0]`, the sphere the camera looks at.
    sphere: (glam::Vec3, f32),
}

impl LightFieldViews {
    /// Builds `file` (relative files from `base`) with its camera replaced by a pixel-centre
    /// normal-probe and its image size by `width` × `height` (`[render]` spp, seed, sampler and
    /// max_depth are kept). Errors: `objects[0]` is not a sphere or there is no object, or the
    /// scene does not build.
    pub fn new(mut file: SceneFile, base: &Path, width: u32, height: u32) -> Result<Self> {
        let sphere = match file.objects.first() {
            Some(ObjectSection::Sphere { center, radius, .. }) => (glam::Vec3::from(*center), *radius),
            Some(_) => return Err(Error::new("objects[0] must be a sphere (the normal-probe camera looks at it)")),
            None => return Err(Error::new("the scene has no objects (objects[0] must be a sphere)")),
        };
        file.render.width = width;
        file.render.height = height;
        // Pixel centres (jitter off): the normal quadrature's nodes are the pixel centres.
        file.camera = CameraSection::NormalProbe { theta_o_deg: 0.0, phi_o_deg: 0.0, jitter: false };
        let scene = Scene::build(file, base)?;
        Ok(LightFieldViews { scene, sphere })
    }

    /// The scene as built (its settings: size, spp, sampler, max_depth).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The view at outgoing direction (θ_o, φ_o) in degrees: a film of `width` × `height` pixels
    /// (row-major, lat-long over the normals). Errors: angles the camera refuses.
    pub fn render(&mut self, theta_o_deg: f64, phi_o_deg: f64) -> Result<Film> {
        let (w, h) = (self.scene.settings.width, self.scene.settings.height);
        let cam = NormalProbe::new(theta_o_deg as f32, phi_o_deg as f32, false, self.sphere.0, self.sphere.1, w, h)
            .map_err(Error::new)?;
        self.scene.camera = Camera::NormalProbe(cam);
        Ok(render(&self.scene, &RenderOptions { progress: false, ..Default::default() }).0)
    }
}
