//! The scenes the checks render, built as values of the scene-file types (docs/src/conventions.md §6, `vocab`)
//! from a [`Spec`] (one constructor per common shape: [`Spec::probe`], and the BRDF tables
//! [`lambert`], [`mirror`], [`phong`], [`torrance_sparrow`], [`beckmann`], [`mix`]), and the call
//! that renders one. Every scene uses the `independent` sampler, whose per-pixel standard error is an
//! honest estimate of the pixel's Monte Carlo error (the Sobol sampler's is conservative), and
//! `max_depth = 1`: one convex object under distant light needs a single surface vertex.

use super::Ctx;
use renderer::film::Film;
use renderer::render::{RenderOptions, render};
use renderer::scene::Scene;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use vocab::scene::{
    BrdfSection, CameraSection, Color, LightingSection, MixLayer, ObjectSection, RenderSection, SceneFile,
    TextureSection,
};
use vocab::{Distribution, FresnelKind, Horizon, Mapping, Sampler};

/// The Grace Cathedral probe (angular map, 1000 × 1000) in the run's data folder (see [`super::data`]).
pub fn grace_path(ctx: &Ctx) -> PathBuf {
    ctx.data.join(super::data::GRACE_FILE)
}

/// Camera of a scene.
#[derive(Clone, Debug)]
pub enum Camera {
    /// `normal-probe` at exitance angles θ_o and azimuth φ_o (degrees), W = 2H.
    Probe { theta_o_deg: f64, phi_o_deg: f64 },
    /// `orthographic` looking from `from` at the origin.
    Ortho { from: [f64; 3], up: [f64; 3], extent: f64 },
}

/// Distant lighting of a scene.
#[derive(Clone, Debug)]
pub enum Lighting {
    /// Grey SH lighting, coefficients in index order k.
    Sh(Vec<f64>),
    Directional {
        direction: [f64; 3],
        irradiance: f64,
    },
    Uniform(f64),
    /// Axially symmetric about `axis`, `[θ_deg, value]` rows.
    Axial {
        axis: [f64; 3],
        profile: Vec<[f64; 2]>,
    },
    /// The Grace probe with a scale.
    Grace(f64),
    /// The Grace probe with a scale, rotated by `rotate_deg` (about x, then y, then z; docs/src/conventions.md §6).
    GraceRotated {
        scale: f64,
        rotate_deg: [f64; 3],
    },
}

/// The object.
#[derive(Clone, Debug)]
pub enum Shape {
    Sphere,
    /// The unit sphere with a grey albedo texture T(n) given by SH coefficients (index order k).
    TexturedSphere(Vec<f64>),
    /// A mesh file (absolute path).
    Mesh(String),
}

/// One render request.
#[derive(Clone, Debug)]
pub struct Spec {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    pub camera: Camera,
    pub lighting: Lighting,
    pub shape: Shape,
    /// The BRDF table (built with [`lambert`], [`phong`], … below).
    pub brdf: BrdfSection,
}

/// An f64 as the f32 the scene holds: `as`, the conversion serde applies to a TOML float, so a
/// scene built here is the scene its TOML text (`{x:?}`) would parse to, bit for bit.
fn f(x: f64) -> f32 {
    x as f32
}

fn f3(v: [f64; 3]) -> [f32; 3] {
    v.map(f)
}

fn grey(x: f64) -> Color {
    Color::Grey(f(x))
}

/// `lambert` with a grey albedo.
pub fn lambert(albedo: f64) -> BrdfSection {
    BrdfSection::Lambert { albedo: grey(albedo) }
}

/// `mirror` with a grey k_r.
pub fn mirror(kr: f64) -> BrdfSection {
    BrdfSection::Mirror { kr: grey(kr) }
}

/// `phong` (eq. 40) with a grey k_s, exponent `s`.
pub fn phong(ks: f64, s: f64, horizon: Horizon) -> BrdfSection {
    BrdfSection::Phong { ks: grey(ks), s: f(s), horizon }
}

/// `torrance-sparrow` (eq. 48) with a grey k_s, roughness `sigma` (radians).
pub fn torrance_sparrow(ks: f64, sigma: f64, horizon: Horizon) -> BrdfSection {
    BrdfSection::TorranceSparrow { ks: grey(ks), sigma: f(sigma), horizon }
}

/// `microfacet` with a Beckmann D of roughness `alpha` and no Fresnel term.
pub fn beckmann(alpha: f64) -> BrdfSection {
    BrdfSection::Microfacet {
        distribution: Distribution::Beckmann,
        alpha: f(alpha),
        fresnel: FresnelKind::None,
        f0: None,
        eta: None,
        k: None,
    }
}

/// `mix` of (weight, BRDF) layers.
pub fn mix(layers: Vec<(f64, BrdfSection)>) -> BrdfSection {
    BrdfSection::Mix { layers: layers.into_iter().map(|(w, brdf)| MixLayer { weight: f(w), brdf }).collect() }
}

impl Spec {
    pub fn probe(ctx: &Ctx, spp: u32, lighting: Lighting, brdf: BrdfSection) -> Spec {
        let h = ctx.probe_height();
        Spec {
            width: 2 * h,
            height: h,
            spp,
            seed: ctx.seed,
            camera: Camera::Probe { theta_o_deg: 0.0, phi_o_deg: 0.0 },
            lighting,
            shape: Shape::Sphere,
            brdf,
        }
    }

    /// The scene, as a value of the scene-file types (so a renamed field is a compile error here).
    pub fn scene(&self, ctx: &Ctx) -> SceneFile {
        let render = RenderSection {
            width: self.width,
            height: self.height,
            spp: self.spp,
            seed: self.seed,
            max_depth: 1,
            sampler: Sampler::Independent,
        };
        let camera = match &self.camera {
            Camera::Probe { theta_o_deg, phi_o_deg } => {
                CameraSection::NormalProbe { theta_o_deg: f(*theta_o_deg), phi_o_deg: f(*phi_o_deg), jitter: false }
            }
            Camera::Ortho { from, up, extent } => {
                CameraSection::Orthographic { from: f3(*from), to: [0.0; 3], up: f3(*up), extent: f(*extent) }
            }
        };
        let grey3 = |v: f64| [f(v); 3];
        let grace = |scale: f64, rotate_deg: [f64; 3]| LightingSection::Envmap {
            file: grace_path(ctx).display().to_string(),
            mapping: Some(Mapping::Angular),
            scale: f(scale),
            rotate_deg: f3(rotate_deg),
            layer: None,
        };
        let lighting = match &self.lighting {
            Lighting::Sh(c) => LightingSection::Sh { coefficients: c.iter().map(|&v| grey3(v)).collect() },
            Lighting::Directional { direction, irradiance } => {
                LightingSection::Directional { direction: f3(*direction), irradiance: grey(*irradiance) }
            }
            Lighting::Uniform(r) => LightingSection::Uniform { radiance: grey(*r) },
            Lighting::Axial { axis, profile } => LightingSection::Axial {
                axis: f3(*axis),
                profile: profile.iter().map(|&[t, v]| [f(t), f(v), f(v), f(v)]).collect(),
            },
            Lighting::Grace(scale) => grace(*scale, [0.0; 3]),
            Lighting::GraceRotated { scale, rotate_deg } => grace(*scale, *rotate_deg),
        };
        let brdf = self.brdf.clone();
        let sphere = |texture| ObjectSection::Sphere { center: [0.0; 3], radius: 1.0, texture, brdf: brdf.clone() };
        let object = match &self.shape {
            Shape::Sphere => sphere(None),
            Shape::TexturedSphere(t) => {
                sphere(Some(TextureSection::Sh { coefficients: t.iter().map(|&v| grey3(v)).collect() }))
            }
            Shape::Mesh(file) => ObjectSection::Mesh {
                file: file.clone(),
                smooth: true,
                translate: [0.0; 3],
                scale: 1.0,
                rotate_deg: [0.0; 3],
                texture: None,
                brdf,
            },
        };
        SceneFile { render, camera, lighting, objects: vec![object] }
    }
}

/// Pixels flagged `stderr_flag.Y` = 1 ([`Film::unreliable_count`]) and pixels whose `stderr` the
/// renderer's bound raised above their own σ ([`Film::pooled_count`]), summed over
/// every film [`render_spec`] returned in this process. [`super::run_entry`] reads them before and
/// after a check (checks run one after another) to state them in the check's report.
static STDERR_FLAGGED: AtomicUsize = AtomicUsize::new(0);
static STDERR_POOLED: AtomicUsize = AtomicUsize::new(0);

/// The running totals (flagged, pooled) of `STDERR_FLAGGED` and `STDERR_POOLED`.
pub fn stderr_flag_totals() -> (usize, usize) {
    (STDERR_FLAGGED.load(Ordering::Relaxed), STDERR_POOLED.load(Ordering::Relaxed))
}

/// Adds a rendered film's flagged and pooled pixels to the running totals ([`stderr_flag_totals`]).
pub fn count_stderr_flags(film: &Film) {
    STDERR_FLAGGED.fetch_add(film.unreliable_count(), Ordering::Relaxed);
    STDERR_POOLED.fetch_add(film.pooled_count(), Ordering::Relaxed);
}

/// Films kept by [`render_spec`] while [`keep_renders`] is on, keyed by the spec's full description
/// (size, spp, seed, camera, lighting, shape, BRDF): rendering is deterministic in those, so a kept
/// film is bit for bit what rendering the spec again would give.
static KEPT: Mutex<Option<HashMap<String, Film>>> = Mutex::new(None);

/// From now on [`render_spec`] keeps every film it renders and serves a spec it has rendered before
/// from memory: `reflect verify --then-wrong-prediction` runs every check a second time, against
/// deliberately wrong predictions, on the very renders of the first run (one process instead of two
/// full runs). Off by default (memory grows with every render).
pub fn keep_renders() {
    let mut kept = KEPT.lock().unwrap_or_else(|e| e.into_inner());
    kept.get_or_insert_with(HashMap::new);
}

/// Renders a spec on the current rayon pool. Errors (a scene the renderer refuses) are returned,
/// and a panic inside the renderer (an unfinished piece) is caught and reported as an error so
/// one broken check does not take the others down.
pub fn render_spec(ctx: &Ctx, spec: &Spec) -> Result<Film, String> {
    let key = format!("{spec:?}");
    let kept = KEPT.lock().unwrap_or_else(|e| e.into_inner()).as_ref().and_then(|m| m.get(&key).cloned());
    if let Some(film) = kept {
        count_stderr_flags(&film);
        return Ok(film);
    }
    let film = render_spec_uncached(ctx, spec)?;
    if let Some(m) = KEPT.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
        m.insert(key, film.clone());
    }
    Ok(film)
}

fn render_spec_uncached(ctx: &Ctx, spec: &Spec) -> Result<Film, String> {
    let scene = Scene::build(spec.scene(ctx), Path::new(".")).map_err(|e| format!("scene rejected: {e}"))?;
    let t = std::time::Instant::now();
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        render(&scene, &RenderOptions { progress: false, cancel: ctx.cancel.clone() })
    }));
    match out {
        Ok((mut film, stats)) => {
            // Issue 9: `verify` must not use an error bar its own diagnostic marks as unreliable. At
            // ≥ 16 spp renders write the flagged pixels' own σ (with `stderr_flag.Y`); every check
            // here judges with the renderer's bound near them instead (`pool_heavy_tails`). Flags
            // exist only with ≥ 16 batches, where `finish` applied no bound, so `everywhere` is false
            // and the low-spp bound of other renders is untouched.
            if film.unreliable_count() > 0 {
                renderer::film::pool_heavy_tails(&mut film, false);
            }
            if ctx.verbose {
                eprintln!(
                    "    render {}×{} {} spp: {:.2} s",
                    spec.width,
                    spec.height,
                    spec.spp,
                    t.elapsed().as_secs_f64()
                );
            }
            if stats.cancelled {
                return Err("the run was cancelled".into());
            }
            count_stderr_flags(&film);
            Ok(film)
        }
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "panic".into());
            Err(format!("the renderer panicked: {msg}"))
        }
    }
}

/// A grey SH lighting with energy in every order 1 ≤ l ≤ lmax: deterministic pseudo-random L_lm
/// with Σ_m L_lm² = `per_order²` for each l ≥ 1, and L_00 Y_00 = 0.6 × the worst-case bound
/// |Σ_{l≥1} L_l(ω)| ≤ Σ_l √((2l+1)/4π) · per_order (Cauchy–Schwarz and the addition theorem).
/// The worst case is not reached by random coefficients, so the lighting is positive in practice;
/// the renderer's SH light keeps the sign anyway, so a negative lobe would not bias B.
pub fn sh_lighting(lmax: usize, per_order: f64, seed: u64) -> Vec<f64> {
    let mut rng = renderer::sampling::chi2::TestRng::new(seed ^ 0x5eed_1a57);
    let mut c = vec![0.0; (lmax + 1) * (lmax + 1)];
    let mut bound = 0.0;
    for l in 1..=lmax {
        let ks: Vec<usize> = (l * l..(l + 1) * (l + 1)).collect();
        let raw: Vec<f64> = ks.iter().map(|_| (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5).collect();
        let norm = raw.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-12);
        for (i, &k) in ks.iter().enumerate() {
            c[k] = per_order * raw[i] / norm;
        }
        bound += ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI)).sqrt() * per_order;
    }
    c[0] = (0.6 * bound).max(1.0) / 0.282_094_791_773_878_14;
    c
}

/// Renders a spec like [`render_spec`] and writes it to `path` as `reflect render` does (OpenEXR
/// with the `reflect:` header and the `stderr`, `normal`, `mask` layers), for checks that analyse
/// the file through the same reader as `reflect analyze`.
pub fn render_spec_to_exr(ctx: &Ctx, spec: &Spec, path: &Path) -> Result<Film, String> {
    let scene = Scene::build(spec.scene(ctx), Path::new(".")).map_err(|e| format!("scene rejected: {e}"))?;
    let film = render_spec(ctx, spec)?;
    renderer::output::write_exr(path, &film, &renderer::output::header_attributes(&scene))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(film)
}
