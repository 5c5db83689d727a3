//! Factoring a sphere's reflected light field into lighting and BRDF, up to the global scale
//! P = ∫ L dω (eq. 18; sec. 3.1, eq. 23), as parameters → report: the light field is assembled from
//! `normal-probe` images ([`factor_images`]) or from views a front-end renders on demand
//! ([`factor_rendered`]), then factored by [`crate::inverse::factorization`] (whose module doc has the
//! derivation and the quadrature), and reported per order ([`InvertFactorReport`]).
//!
//! The light field B(n; θ'_o, φ'_o) is sampled by one `normal-probe` image per node of a product rule
//! over the outgoing hemisphere ([`hemisphere_nodes`]: n_μ Gauss–Legendre nodes in μ = cos θ'_o times
//! n_φ azimuths φ'_o = 360° k / n_φ), all on one W × H lat-long grid of normals, at pixel centres
//! (a jittered render holds pixel averages and is refused). A view at θ_o = 0, if given, adds the
//! normal-exitance filter Λ_l ρ̂_l / Λ_0 ρ̂_0 (eq. 16). One channel is factored per call: a coloured
//! light field factors per channel.

mod error;
mod report;

pub use error::Error;
pub use report::{
    AlbedoRing, FactorInput, FactorNodesReport, InvertFactorReport, NodeReport, NormalFilter, OrderReport, RenderCount,
    SourceReport, toml_float,
};

use crate::image::Image;
use crate::inverse::factorization::{
    Factorization, LightField, NODE_TOL_DEG, NormalRule, check_nodes, directional_lighting, filter_from_lighting,
    hemisphere_nodes, match_nodes, node_degrees, project,
};
use crate::observation::Camera;
use crate::projection::latlong_max_order;
use crate::projection::resolution::{LATLONG_RULE, check_latlong};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use vocab::scene::{CameraSection, SceneFile};

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// What a factorization is asked for.
#[derive(Clone, Copy, Debug)]
pub struct FactorParams {
    /// Highest SH order of the factored lighting and BRDF (the grid must carry it,
    /// [`check_latlong`]).
    pub lmax: usize,
    /// The channel factored: 0, 1, 2 for R, G, B.
    pub channel: usize,
    /// The quadrature over the lat-long grid of normals.
    pub rule: NormalRule,
    /// Noise amplification 1/g_l above which an order is ill-conditioned (finite, ≥ 1).
    pub max_amplification: f64,
    /// The node rule n_μ × n_φ; `None` (images only): inferred from the images' angles.
    pub nodes: Option<(usize, usize)>,
}

/// One `normal-probe` image of the light field: the file it was read from (named in errors and the
/// report), its pixels and its observed camera ([`crate::observation`]).
#[derive(Clone, Copy, Debug)]
pub struct ProbeImage<'a> {
    pub path: &'a Path,
    pub image: &'a Image,
    pub camera: &'a Camera,
}

/// One view rendered by a front-end for [`factor_rendered`]: per pixel of the W × H grid (row-major),
/// the radiance of the factored channel and its standard error (+∞ where the render has none).
#[derive(Clone, Debug, Default)]
pub struct RenderedView {
    pub radiance: Vec<f64>,
    pub stderr: Vec<f64>,
}

/// Checks the parameters that do not depend on the images.
pub fn validate(params: &FactorParams) -> Result<(), Error> {
    if !(params.max_amplification.is_finite() && params.max_amplification >= 1.0) {
        return Err(Error::MaxAmplification(params.max_amplification));
    }
    if params.channel > 2 {
        return Err(Error::Channel(params.channel));
    }
    if let Some((n_mu, n_phi)) = params.nodes {
        check_nodes(n_mu, n_phi)?;
    }
    Ok(())
}

/// The nodes of an n_μ × n_φ rule, to render one view at each (errors: a rule [`check_nodes`] refuses).
pub fn nodes_report(n_mu: usize, n_phi: usize) -> Result<FactorNodesReport, Error> {
    check_nodes(n_mu, n_phi)?;
    let outgoing = hemisphere_nodes(n_mu, n_phi)?
        .iter()
        .map(|n| {
            let (theta_o_deg, phi_o_deg) = node_degrees(n);
            NodeReport { theta_o_deg, phi_o_deg, weight: n.weight }
        })
        .collect();
    Ok(FactorNodesReport { command: "invert factor --print-nodes".into(), nodes: [n_mu, n_phi], outgoing })
}

/// What both modes hand to the report: the sampled light field and the optional normal view.
struct Measured {
    lf: LightField,
    nodes: (usize, usize),
    /// B_lm at θ_o = 0 (l ≤ lmax), if a normal view was given or rendered.
    normal_b: Option<Vec<f64>>,
    /// Largest per-pixel standard error of the factored channel over all images (if recorded).
    max_stderr: Option<f64>,
    input: FactorInput,
    renders: Option<(usize, f64)>,
}

/// The factorization of the light field that `images` sample, one per node of the outgoing rule
/// (`params.nodes`, or inferred from the set, which must be exactly that rule: every node once,
/// within [`NODE_TOL_DEG`]), with `normal` the optional view at θ_o = 0. `sidecar` is the scene the
/// images are renders of, if a front-end was told one: a `jitter = true` normal-probe camera there
/// (for an image without a camera header of its own) is refused as in the header.
///
/// Errors, naming the file: a camera that is not a pixel-centre normal-probe, images of different
/// grids or scenes (their `reflect:lighting` / `reflect:objects` headers), a missing channel or a bad
/// `stderr` layer, a grid that cannot carry `params.lmax`, a set that is not the node rule.
pub fn factor_images(
    params: &FactorParams,
    images: &[ProbeImage<'_>],
    normal: Option<ProbeImage<'_>>,
    sidecar: Option<&SceneFile>,
) -> Result<InvertFactorReport, Error> {
    validate(params)?;
    let (lmax, ch) = (params.lmax, params.channel);
    let mut angles = Vec::with_capacity(images.len());
    let mut data = Vec::with_capacity(images.len());
    let mut size: Option<(usize, usize, &Path)> = None;
    let mut max_se: Option<f64> = None;
    let mut first_scene: Option<([Option<String>; 2], &Path)> = None;
    for v in images {
        let p = v.path;
        let (t, ph) = probe_angles(v, sidecar)?;
        if t.abs() <= NODE_TOL_DEG {
            return Err(Error::NormalViewAsNode.in_file(p));
        }
        match size {
            None => size = Some((v.image.width, v.image.height, p)),
            Some((w, h, first)) if (w, h) != (v.image.width, v.image.height) => {
                return Err(Error::GridDiffers {
                    width: v.image.width,
                    height: v.image.height,
                    first: first.to_path_buf(),
                    first_width: w,
                    first_height: h,
                }
                .in_file(p));
            }
            _ => {}
        }
        match &first_scene {
            None => first_scene = Some((scene_of(v.image), p)),
            Some((s0, p0)) => same_scene(s0, p0, v.image, p)?,
        }
        let (values, se) = channel_of(v.image, ch, p)?;
        if let Some(s) = se {
            max_se = Some(max_se.map_or(s, |m: f64| m.max(s)));
        }
        angles.push((t, ph));
        // f32 storage: half the memory of the f64 channel while waiting for the node inference.
        data.push(values.into_iter().map(|x| x as f32).collect::<Vec<f32>>());
    }
    let Some((w, h, first)) = size else { return Err(Error::NoImages) };
    check_latlong(lmax, w, h, "normal-probe grid").map_err(|e| Error::from(e).in_file(first))?;
    let names: Vec<String> = images.iter().map(|v| v.path.display().to_string()).collect();
    let (nodes_n, nodes, idx) = match_nodes(&angles, &names, params.nodes)?;
    let mut lf = LightField::new(w, h, params.rule)?;
    for ((values, &j), v) in data.iter().zip(&idx).zip(images) {
        let values: Vec<f64> = values.iter().map(|x| *x as f64).collect();
        lf.add(nodes[j], &values).map_err(|e| Error::from(e).in_file(v.path))?;
    }
    let normal_b = match normal {
        None => None,
        Some(v) => {
            let p = v.path;
            let (t, _) = probe_angles(&v, sidecar)?;
            if let Some((s0, p0)) = &first_scene {
                same_scene(s0, p0, v.image, p)?;
            }
            if t.abs() > NODE_TOL_DEG {
                return Err(Error::NormalViewExitance(t).in_file(p));
            }
            check_latlong(lmax, v.image.width, v.image.height, "normal-probe image")
                .map_err(|e| Error::from(e).in_file(p))?;
            let (values, se) = channel_of(v.image, ch, p)?;
            if let Some(s) = se {
                max_se = Some(max_se.map_or(s, |m: f64| m.max(s)));
            }
            Some(project(&values, v.image.width, v.image.height, params.rule, lmax).map_err(|e| e.in_file(p))?)
        }
    };
    let m = Measured {
        lf,
        nodes: nodes_n,
        normal_b,
        max_stderr: max_se,
        input: FactorInput::Images { images: names, normal: normal.map(|v| v.path.display().to_string()) },
        renders: None,
    };
    let f = m.lf.factorize(lmax, params.max_amplification)?;
    Ok(report(params, &m, &f, "images"))
}

/// The factorization of a light field rendered on demand: `render(θ_o°, φ_o°)` returns the view of
/// the sphere at that outgoing direction on the `width` × `height` grid, called once per node of the
/// n_μ × n_φ rule `params.nodes` (required) and once at θ_o = 0 for the normal-exitance filter.
/// `scene` names the scene in errors; `input` is what the report says the light field came from
/// (with `objects` > 1 the report warns that only the first object is factored). Errors of `render`
/// are passed on; the report carries the render count and wall time.
pub fn factor_rendered(
    params: &FactorParams,
    scene: &Path,
    (width, height): (usize, usize),
    input: FactorInput,
    mut render: impl FnMut(f64, f64) -> Result<RenderedView, Error>,
) -> Result<InvertFactorReport, Error> {
    validate(params)?;
    let lmax = params.lmax;
    let (n_mu, n_phi) =
        params.nodes.ok_or(Error::Vocab(vocab::Error::new("a rendered light field needs its node rule")))?;
    check_latlong(lmax, width, height, "normal-probe grid (--size)")?;
    let mut view = |t: f64, p: f64| -> Result<(Vec<f64>, f64), Error> {
        let v = render(t, p).map_err(|e| e.in_file(scene))?;
        if v.radiance.len() != width * height || v.stderr.len() != width * height {
            let what = crate::inverse::factorization::fmt_node(t, p);
            return Err(Error::RenderSize { what, got: v.radiance.len(), width, height }.in_file(scene));
        }
        let se = v.stderr.iter().fold(0.0f64, |m, s| m.max(*s));
        Ok((v.radiance, se))
    };
    let t0 = std::time::Instant::now();
    let mut lf = LightField::new(width, height, params.rule)?;
    let mut max_se = 0.0f64;
    let nodes = hemisphere_nodes(n_mu, n_phi)?;
    for node in &nodes {
        let (t, p) = node_degrees(node);
        let (v, se) = view(t, p)?;
        max_se = max_se.max(se);
        lf.add(*node, &v).map_err(|e| Error::from(e).in_file(scene))?;
    }
    let (v0, se0) = view(0.0, 0.0)?;
    max_se = max_se.max(se0);
    let normal_b = project(&v0, width, height, params.rule, lmax)?;
    let secs = t0.elapsed().as_secs_f64();
    let m = Measured {
        lf,
        nodes: (n_mu, n_phi),
        normal_b: Some(normal_b),
        // +inf: renders of 1 spp, which have no error estimate.
        max_stderr: Some(max_se).filter(|s| s.is_finite()),
        input,
        renders: Some((nodes.len() + 1, secs)),
    };
    let f = m.lf.factorize(lmax, params.max_amplification)?;
    Ok(report(params, &m, &f, "scene"))
}

/// (θ_o°, φ_o°) of an image's observed camera, checked to be a pixel-centre normal-probe: a
/// `jitter = true` camera in its header, or in the sidecar scene for an image without one, is refused.
fn probe_angles(v: &ProbeImage<'_>, sidecar: Option<&SceneFile>) -> Result<(f64, f64), Error> {
    let header = vocab::header::Header::read(&v.image.attributes).map_err(|e| e.in_file(v.path))?.camera;
    let jittered = |c: Option<&CameraSection>| matches!(c, Some(CameraSection::NormalProbe { jitter: true, .. }));
    if jittered(header.as_ref()) || (header.is_none() && jittered(sidecar.map(|s| &s.camera))) {
        return Err(Error::Jittered.in_file(v.path));
    }
    match *v.camera {
        Camera::NormalProbe { theta_o_deg, phi_o_deg } => Ok((theta_o_deg, phi_o_deg)),
        Camera::Ortho(_) => Err(Error::NotProbe.in_file(v.path)),
    }
}

/// The factored channel of an image as f64, and its largest standard error (if the layer exists).
fn channel_of(img: &Image, ch: usize, p: &Path) -> Result<(Vec<f64>, Option<f64>), Error> {
    let name = CHANNELS[ch];
    let v = img.channel(name).ok_or_else(|| Error::NoChannel(name).in_file(p))?;
    // The layer is only reported here, but it is validated as everywhere (finite, ≥ 0, not all zero).
    let layer = img.stderr_layer().map_err(|e| Error::from(e).in_file(p))?;
    let se = layer.map(|s| s.pixels.iter().fold(0.0f64, |m, x| m.max(x[ch] as f64)));
    Ok((v.iter().map(|x| *x as f64).collect(), se))
}

const SCENE_KEYS: [&str; 2] = ["reflect:lighting", "reflect:objects"];

/// The headers that identify the scene of a render (absent when not written by reflect).
fn scene_of(img: &Image) -> [Option<String>; 2] {
    SCENE_KEYS.map(|k| img.attributes.get(k).cloned())
}

/// All renders must be of one scene: the lighting and objects headers agree with the first image's.
fn same_scene(first: &[Option<String>; 2], first_path: &Path, img: &Image, p: &Path) -> Result<(), Error> {
    let s = scene_of(img);
    match (0..2).find(|&k| first[k] != s[k]) {
        Some(k) => Err(Error::SceneDiffers { key: SCENE_KEYS[k], first: PathBuf::from(first_path) }.in_file(p)),
        None => Ok(()),
    }
}

fn ratios(x: &[Option<f64>]) -> Vec<Option<f64>> {
    let x0 = x.first().copied().flatten();
    x.iter().map(|v| Some((*v)? / x0?).filter(|r| r.is_finite())).collect()
}

fn report(params: &FactorParams, m: &Measured, f: &Factorization, mode: &str) -> InvertFactorReport {
    let lmax = params.lmax;
    let kr = f.brdf_ratios();
    let orders = f
        .orders
        .iter()
        .map(|o| OrderReport {
            l: o.l,
            kappa: o.kappa,
            kappa_ratio: Some(kr[o.l]).filter(|r| r.is_finite()),
            gain: o.gain,
            amplification: (o.gain > 0.0).then(|| 1.0 / o.gain),
            status: o.status.name().into(),
        })
        .collect();
    let source = f.source_direction().map(|s| {
        let [x, y, z] = s.direction;
        SourceReport {
            direction: s.direction,
            theta_deg: z.clamp(-1.0, 1.0).acos().to_degrees(),
            phi_deg: y.atan2(x).to_degrees(),
            directionality: s.directionality,
        }
    });
    let albedo_profile =
        m.lf.albedo_profile().iter().map(|(t, v)| AlbedoRing { theta_o_deg: t.to_degrees(), p_albedo: *v }).collect();
    let filter = m.normal_b.as_ref().map(|b| NormalFilter {
        factored_lighting: ratios(&filter_from_lighting(b, &f.lighting, lmax)),
        directional_source: f.source_direction().map(|s| {
            let y: Vec<Option<f64>> = directional_lighting(s.direction, lmax).into_iter().map(Some).collect();
            ratios(&filter_from_lighting(b, &y, lmax))
        }),
    });
    let (w, h) = (m.lf.width, m.lf.height);
    let mut warnings = Vec::new();
    if let FactorInput::Scene { objects, .. } = &m.input
        && *objects > 1
    {
        warnings
            .push("only objects[0] is factored; the other objects may shadow it or appear in its reflections".into());
    }
    InvertFactorReport {
        command: "invert factor".into(),
        mode: mode.into(),
        input: m.input.clone(),
        nodes: [m.nodes.0, m.nodes.1],
        grid: [w, h],
        rule: match params.rule {
            NormalRule::Fejer => "fejer",
            NormalRule::PixelSolidAngle => "pixel",
        }
        .into(),
        channel: CHANNELS[params.channel].to_string(),
        lmax,
        lmax_carried: latlong_max_order(w, h),
        lmax_carried_rule: LATLONG_RULE.into(),
        max_amplification: params.max_amplification,
        renders: m.renders.map(|(count, wall_seconds)| RenderCount { count, wall_seconds }),
        max_stderr: m.max_stderr,
        orders,
        lighting: f.lighting.clone(),
        gauge_l00: 1.0 / (4.0 * PI).sqrt(),
        source,
        source_note: "direction of the order-1 lighting (L_11, L_1-1, L_10)/|.|; meaningful only for a single \
                      directional source, whose directionality |L_1|/sqrt(3/4pi) is 1"
            .into(),
        albedo_profile,
        filter,
        warnings,
    }
}
