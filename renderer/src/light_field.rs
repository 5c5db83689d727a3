//! The reflected light field of a sphere, rendered view by view: a scene whose first object is a
//! sphere, re-rendered with a `normal-probe` camera (docs/src/conventions.md §6) at any outgoing
//! direction (θ_o, φ_o), at pixel centres (no jitter), so that each view samples
//! B(n; θ_o, φ_o) on the lat-long grid of normals. [`factor_scene`] renders the nodes of an
//! outgoing rule with it and factors the light field (`analysis::factor::factor_rendered`): the one
//! scene mode that `reflect invert factor --scene` and Python's `reflect.invert.factor(scene=…)` call.

use crate::camera::{Camera, NormalProbe};
use crate::film::Film;
use crate::render::{RenderOptions, render};
use crate::scene::Scene;
use crate::{Error, Result};
use analysis::factor::{FactorInput, FactorParams, InvertFactorReport, RenderedView};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use vocab::scene::{CameraSection, ObjectSection, SceneFile};

/// A scene prepared for its light-field views (see the module docs).
pub struct LightFieldViews {
    scene: Scene,
    /// Set from another thread to stop the views being rendered (see [`LightFieldViews::render`]).
    cancel: Option<Arc<AtomicBool>>,
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
        Ok(LightFieldViews { scene, sphere, cancel: None })
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
        let (film, stats) = render(&self.scene, &RenderOptions { progress: false, cancel: self.cancel.clone() });
        if stats.cancelled {
            return Err(Error::new(CANCELLED));
        }
        Ok(film)
    }

    /// Renders stop within one tile once `cancel` is set ([`RenderOptions::cancel`]); a view so
    /// stopped is the error [`CANCELLED`].
    pub fn set_cancel(&mut self, cancel: Arc<AtomicBool>) {
        self.cancel = Some(cancel);
    }
}

/// The message of a view whose render was cancelled ([`LightFieldViews::set_cancel`]).
pub const CANCELLED: &str = "cancelled";

/// `reflect invert factor --scene`: the light field of the scene file `path` rendered in memory on a
/// `width` × `height` lat-long grid of normals at every node of `params.nodes` (required) and at
/// θ_o = 0, then factored ([`analysis::factor::factor_rendered`], eq. 18, 23) in channel
/// `params.channel`. `grid` names the size parameter in the front-end's terms (`--size`, `size=`)
/// for a grid too coarse for `params.lmax`, checked before the scene is read. `cancel`, when set
/// from another thread, stops the render within one tile (the error's message is [`CANCELLED`]).
/// Errors: the parameters, an unreadable scene (named), `objects[0]` not a sphere.
pub fn factor_scene(
    params: &FactorParams,
    path: &Path,
    (width, height): (u32, u32),
    grid: &str,
    cancel: Option<Arc<AtomicBool>>,
) -> std::result::Result<InvertFactorReport, Error> {
    analysis::factor::validate(params)?;
    analysis::projection::resolution::check_latlong(
        params.lmax,
        width as usize,
        height as usize,
        &format!("normal-probe grid ({grid})"),
    )?;
    let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read scene file: {e}")))?;
    let file = SceneFile::parse(&text).map_err(|m| Error::file(path, m))?;
    let input = FactorInput::Scene {
        scene: path.display().to_string(),
        size: [width, height],
        spp: file.render.spp,
        sampler: file.render.sampler,
        max_depth: file.render.max_depth,
        objects: file.objects.len(),
    };
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut views = LightFieldViews::new(file, &base, width, height).map_err(|e| e.in_file(path))?;
    if let Some(c) = &cancel {
        views.set_cancel(c.clone());
    }
    let ch = params.channel;
    let render = |t: f64, p: f64| -> std::result::Result<RenderedView, analysis::factor::Error> {
        if cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed)) {
            return Err(Error::new(CANCELLED).into());
        }
        let film = views.render(t, p)?;
        Ok(RenderedView {
            radiance: film.pixels.iter().map(|px| px.rgb[ch] as f64).collect(),
            stderr: film.pixels.iter().map(|px| px.stderr[ch] as f64).collect(),
        })
    };
    Ok(analysis::factor::factor_rendered(params, path, (width as usize, height as usize), input, render)?)
}
