//! The scenes the checks render, built as TOML text (CONVENTIONS §6) in code, and the call that
//! renders one. Every scene uses the `independent` sampler, whose per-pixel standard error is an
//! honest estimate of the pixel's Monte Carlo error (the Sobol sampler's is conservative), and
//! `max_depth = 1`: one convex object under distant light needs a single surface vertex.

use super::Ctx;
use renderer::film::Film;
use renderer::render::{RenderOptions, render};
use renderer::scene::{Scene, SceneFile};
use std::fmt::Write;
use std::path::{Path, PathBuf};

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
    /// The Grace probe with a scale, rotated by `rotate_deg` (about x, then y, then z; CONVENTIONS §6).
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
    /// Inline TOML table of the BRDF, e.g. `{ type = "lambert", albedo = 1.0 }`.
    pub brdf: String,
}

fn v3(v: [f64; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

impl Spec {
    pub fn probe(ctx: &Ctx, spp: u32, lighting: Lighting, brdf: &str) -> Spec {
        let h = ctx.probe_height();
        Spec {
            width: 2 * h,
            height: h,
            spp,
            seed: ctx.seed,
            camera: Camera::Probe { theta_o_deg: 0.0, phi_o_deg: 0.0 },
            lighting,
            shape: Shape::Sphere,
            brdf: brdf.to_string(),
        }
    }

    /// The scene file text.
    pub fn toml(&self, ctx: &Ctx) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "[render]\nwidth = {}\nheight = {}\nspp = {}\nseed = {}\nmax_depth = 1\nsampler = \"independent\"\n",
            self.width, self.height, self.spp, self.seed
        );
        match &self.camera {
            Camera::Probe { theta_o_deg, phi_o_deg } => {
                let _ = writeln!(
                    s,
                    "[camera]\ntype = \"normal-probe\"\ntheta_o_deg = {theta_o_deg:?}\nphi_o_deg = {phi_o_deg:?}\n"
                );
            }
            Camera::Ortho { from, up, extent } => {
                let _ = writeln!(
                    s,
                    "[camera]\ntype = \"orthographic\"\nfrom = {}\nto = [0.0, 0.0, 0.0]\nup = {}\nextent = {extent:?}\n",
                    v3(*from),
                    v3(*up)
                );
            }
        }
        match &self.lighting {
            Lighting::Sh(c) => {
                let _ = write!(s, "[lighting]\ntype = \"sh\"\ncoefficients = [");
                for (k, v) in c.iter().enumerate() {
                    let _ = write!(s, "{}[{v:?}, {v:?}, {v:?}]", if k > 0 { ", " } else { "" });
                }
                let _ = writeln!(s, "]\n");
            }
            Lighting::Directional { direction, irradiance } => {
                let _ = writeln!(
                    s,
                    "[lighting]\ntype = \"directional\"\ndirection = {}\nirradiance = {irradiance:?}\n",
                    v3(*direction)
                );
            }
            Lighting::Uniform(r) => {
                let _ = writeln!(s, "[lighting]\ntype = \"uniform\"\nradiance = {r:?}\n");
            }
            Lighting::Axial { axis, profile } => {
                let _ = write!(s, "[lighting]\ntype = \"axial\"\naxis = {}\nprofile = [", v3(*axis));
                for (i, [t, v]) in profile.iter().enumerate() {
                    let _ = write!(s, "{}[{t:?}, {v:?}, {v:?}, {v:?}]", if i > 0 { ", " } else { "" });
                }
                let _ = writeln!(s, "]\n");
            }
            Lighting::Grace(scale) => {
                let _ = writeln!(
                    s,
                    "[lighting]\ntype = \"envmap\"\nfile = {:?}\nmapping = \"angular\"\nscale = {scale:?}\n",
                    grace_path(ctx).display().to_string()
                );
            }
            Lighting::GraceRotated { scale, rotate_deg } => {
                let _ = writeln!(
                    s,
                    "[lighting]\ntype = \"envmap\"\nfile = {:?}\nmapping = \"angular\"\nscale = {scale:?}\nrotate_deg = {}\n",
                    grace_path(ctx).display().to_string(),
                    v3(*rotate_deg)
                );
            }
        }
        match &self.shape {
            Shape::Sphere => {
                let _ = writeln!(
                    s,
                    "[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nbrdf = {}",
                    self.brdf
                );
            }
            Shape::TexturedSphere(t) => {
                let _ = write!(
                    s,
                    "[[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nbrdf = {}\ntexture = {{ type = \"sh\", coefficients = [",
                    self.brdf
                );
                for (k, v) in t.iter().enumerate() {
                    let _ = write!(s, "{}[{v:?}, {v:?}, {v:?}]", if k > 0 { ", " } else { "" });
                }
                let _ = writeln!(s, "] }}");
            }
            Shape::Mesh(file) => {
                let _ =
                    writeln!(s, "[[objects]]\nshape = \"mesh\"\nfile = {file:?}\nsmooth = true\nbrdf = {}", self.brdf);
            }
        }
        s
    }
}

/// Renders a spec on the current rayon pool. Errors (a scene the renderer refuses) are returned,
/// and a panic inside the renderer (an unfinished piece) is caught and reported as an error so
/// one broken check does not take the others down.
pub fn render_spec(ctx: &Ctx, spec: &Spec) -> Result<Film, String> {
    let text = spec.toml(ctx);
    let file = SceneFile::parse(&text).map_err(|e| format!("scene rejected: {e}\n{text}"))?;
    let scene = Scene::build(file, Path::new(".")).map_err(|e| format!("scene rejected: {e}"))?;
    let t = std::time::Instant::now();
    let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        render(&scene, &RenderOptions { progress: false, cancel: ctx.cancel.clone() })
    }));
    match out {
        Ok((film, stats)) => {
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
    let text = spec.toml(ctx);
    let file = SceneFile::parse(&text).map_err(|e| format!("scene rejected: {e}\n{text}"))?;
    let scene = Scene::build(file, Path::new(".")).map_err(|e| format!("scene rejected: {e}"))?;
    let film = render_spec(ctx, spec)?;
    renderer::output::write_exr(path, &film, &renderer::output::header_attributes(&scene))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(film)
}
