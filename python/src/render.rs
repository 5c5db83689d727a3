//! `reflect.render` and `reflect.load_scene`: scenes from a path, TOML text or a dict, rendered
//! exactly as `reflect render` renders them (same parsing, same overrides, same render loop, same
//! EXR), with the GIL released and Ctrl-C honoured while the render runs.

use crate::convert::input_error;
use crate::convert::{IntoPy, to_python};
use analysis::Error;
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use renderer::film::{Film, Pixel};
use renderer::progressive::{
    Checkpoint, DEFAULT_CHECKPOINT_EVERY, Event, Finished, MIN_TARGET_SPP, NoEstimate, Outcome, ProgressiveError,
    ProgressiveOptions, Stop, render_progressive,
};
use renderer::render::RenderStats;
use renderer::scene::{Scene, SceneFile};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// A scene description with where its relative paths are resolved from.
struct Source {
    file: SceneFile,
    /// Folder that relative data paths (envmaps, meshes) are resolved against.
    base: PathBuf,
    /// The scene file, when there is one (named in errors, as the CLI does).
    path: Option<PathBuf>,
}

fn read_text(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|e| Error::file(path, format!("cannot read scene file: {e}")))
}

/// Parses the scene given as `kind` = "path" | "toml" | "dict" (the Python side has decided which).
fn source(kind: &str, value: &Bound<'_, PyAny>, base: Option<PathBuf>) -> PyResult<Source> {
    let cwd = || std::env::current_dir().unwrap_or_default();
    match kind {
        "path" => {
            let path: PathBuf = value.extract()?;
            let text = read_text(&path).py()?;
            let file = SceneFile::parse(&text).map_err(|m| Error::file(&path, m)).py()?;
            let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
            Ok(Source { file, base, path: Some(path) })
        }
        "toml" => {
            let text: String = value.extract()?;
            let file = SceneFile::parse(&text).map_err(|m| Error::new(format!("scene TOML: {m}"))).py()?;
            Ok(Source { file, base: base.unwrap_or_else(cwd), path: None })
        }
        "dict" => {
            // The same serde types as the TOML file: unknown keys are errors here too.
            let file: SceneFile = pythonize::depythonize(value)
                .map_err(|e| input_error(format!("scene dict: {}", e.to_string().replace('\n', " "))))?;
            Ok(Source { file, base: base.unwrap_or_else(cwd), path: None })
        }
        other => Err(input_error(format!("unknown scene kind '{other}'"))),
    }
}

/// `load_scene(kind, value, base)` → `(table, base, path)`: the scene as a dict of its TOML
/// tables (only what the source gives; defaults are filled in at render time), after checking
/// that it parses with the scene types.
#[pyfunction]
#[pyo3(signature = (kind, value, base=None))]
pub fn load_scene<'py>(
    py: Python<'py>,
    kind: &str,
    value: &Bound<'py, PyAny>,
    base: Option<PathBuf>,
) -> PyResult<(Bound<'py, PyAny>, PathBuf, Option<PathBuf>)> {
    let src = source(kind, value, base)?;
    let table = match kind {
        "dict" => value.clone(),
        _ => {
            // The user's own values (not the f32-rounded parsed ones) as a TOML table.
            let text = match &src.path {
                Some(p) => read_text(p).py()?,
                None => value.extract::<String>()?,
            };
            let t: toml::Table =
                toml::from_str(&text).map_err(|e| input_error(format!("scene TOML: {}", e.message())))?;
            to_python(py, &t)?
        }
    };
    Ok((table, src.base, src.path))
}

/// The CLI's overrides (`--spp`, `--seed`, `--sampler`, `--size`), applied the same way.
fn apply_overrides(
    file: &mut SceneFile,
    spp: Option<u32>,
    seed: Option<u64>,
    size: Option<(u32, u32)>,
    sampler: Option<&str>,
) -> PyResult<()> {
    if let Some(s) = spp {
        file.render.spp = s;
    }
    if let Some(s) = seed {
        file.render.seed = s;
    }
    if let Some(s) = sampler {
        // The closed set's own parse (vocab): the message lists the names, as a scene file's does.
        file.render.sampler = s.parse().map_err(|e: Error| input_error(format!("render.sampler: {e}")))?;
    }
    if let Some((w, h)) = size {
        file.render.width = w;
        file.render.height = h;
    }
    Ok(())
}

/// A progressive-render error in this API's terms (its keywords: `target_rel_error=`, `checkpoint=`).
fn progressive_error(e: ProgressiveError) -> PyErr {
    match e {
        ProgressiveError::InvalidOption { name: "threads", .. } => input_error("threads= must be at least 1"),
        ProgressiveError::InvalidOption { name, value } => {
            input_error(format!("{name}= must be a positive number, got {value}"))
        }
        ProgressiveError::CheckpointMismatch { path, mismatch } => input_error(format!(
            "{}: is a checkpoint of {}; remove it or pass another checkpoint=",
            path.display(),
            mismatch.what()
        )),
        ProgressiveError::File(e) => crate::convert::py_err(e),
        ProgressiveError::Threads { .. } => crate::convert::our_error("Error", e.to_string()),
        other => input_error(other.to_string()),
    }
}

/// The options of `reflect.render` beyond the scene's `[render]` table.
pub struct Passes {
    pub threads: Option<usize>,
    pub progress: bool,
    pub target_rel_error: Option<f64>,
    pub time_limit: Option<f64>,
    pub checkpoint: Option<PathBuf>,
    pub checkpoint_every: Option<f64>,
}

/// How a render in passes went, for the result's metadata.
struct Run {
    film: Film,
    stats: RenderStats,
    passes: u32,
    stop: Stop,
    rel_error: Option<Result<f64, NoEstimate>>,
}

/// Renders through `renderer::progressive` on another thread while this one, without the GIL, waits
/// for it; Ctrl-C (KeyboardInterrupt) sets the cancel flag and the render stops at its next tile
/// ([`crate::convert::interruptibly`]); with a checkpoint, the last finished pass is saved to it.
/// A render to a target error or a time limit is labelled with the spp it reached (`scene` is updated).
fn render_passes(py: Python<'_>, scene: &mut Scene, p: &Passes) -> PyResult<Run> {
    let cancel = Arc::new(AtomicBool::new(false));
    let progressive = p.target_rel_error.is_some() || p.time_limit.is_some();
    let opts = ProgressiveOptions {
        range: None,
        target_rel_error: p.target_rel_error,
        time_limit: p.time_limit.map(|t| Duration::from_secs_f64(t.max(0.0))),
        checkpoint: p.checkpoint.as_ref().map(|path| Checkpoint {
            path: path.clone(),
            every: p.checkpoint_every.map_or(DEFAULT_CHECKPOINT_EVERY, |t| Duration::from_secs_f64(t.max(0.0))),
            attributes: renderer::output::header_attributes(scene),
        }),
        initial: None,
        threads: p.threads,
        progress_bar: p.progress,
        estimate_each_pass: p.progress && progressive,
        cancel: Some(cancel.clone()),
    };
    let progress = p.progress;
    let target = p.target_rel_error;
    let shared: &Scene = scene;
    let outcome = crate::convert::interruptibly(py, &cancel, || {
        render_progressive(shared, &opts, &mut |e| {
            if !progress {
                return;
            }
            match e {
                Event::Resumed { path, at, .. } => eprintln!("resuming from {} at sample {at}", path.display()),
                Event::Pass(r) if progressive => {
                    let err = match r.rel_error {
                        Some(Ok(e)) => format!("95th-percentile relative stderr {:.4} %", 100.0 * e),
                        Some(Err(why)) => format!("no error estimate: {why}"),
                        None => format!("error checked from {MIN_TARGET_SPP} spp on"),
                    };
                    let target = target.map(|x| format!(" (target {:.4} %)", 100.0 * x)).unwrap_or_default();
                    eprintln!("pass {}: {} of at most {} spp, {err}{target}", r.pass, r.end, r.cap);
                }
                Event::Pass(_) => {}
            }
        })
    })?
    .map_err(progressive_error)?;
    match outcome {
        Outcome::Cancelled { .. } => Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("render cancelled")),
        Outcome::Done(Finished { mut state, stats, passes, stop, rel_error }) => {
            if let Some(ck) = &p.checkpoint {
                // The render is complete: the checkpoint has served (as `reflect render` removes it).
                let _ = std::fs::remove_file(ck);
            }
            if progressive {
                let n = state.end as u32;
                state.spp = n;
                scene.settings.spp = n;
                scene.description.render.spp = n;
            }
            Ok(Run { film: state.finish(), stats, passes, stop, rel_error })
        }
    }
}

/// `render(kind, value, base, spp, seed, size, threads, sampler, progress, target_rel_error, time_limit,
/// checkpoint, checkpoint_every)`: see `reflect.render`.
#[pyfunction]
#[pyo3(signature = (kind, value, base=None, spp=None, seed=None, size=None, threads=None, sampler=None, progress=false,
    target_rel_error=None, time_limit=None, checkpoint=None, checkpoint_every=None))]
#[allow(clippy::too_many_arguments)]
pub fn render(
    py: Python<'_>,
    kind: &str,
    value: &Bound<'_, PyAny>,
    base: Option<PathBuf>,
    spp: Option<u32>,
    seed: Option<u64>,
    size: Option<(u32, u32)>,
    threads: Option<usize>,
    sampler: Option<String>,
    progress: bool,
    target_rel_error: Option<f64>,
    time_limit: Option<f64>,
    checkpoint: Option<PathBuf>,
    checkpoint_every: Option<f64>,
) -> PyResult<RenderResult> {
    let Source { mut file, base, path } = source(kind, value, base)?;
    apply_overrides(&mut file, spp, seed, size, sampler.as_deref())?;
    let mut scene = py
        .detach(|| {
            Scene::build(file, &base).map_err(|e| match &path {
                Some(p) => e.in_file(p),
                None => e,
            })
        })
        .py()?;
    scene.path = path;
    let passes = Passes { threads, progress, target_rel_error, time_limit, checkpoint, checkpoint_every };
    // The most spp allowed, before a render to a target labels the scene with the spp it reached.
    let spp_cap = scene.settings.spp;
    let run = render_passes(py, &mut scene, &passes)?;
    let result = RenderResult::new(py, &scene, run.film, &run.stats)?;
    let d = result.stats.bind(py);
    d.set_item("passes", run.passes)?;
    d.set_item("stopped_by", run.stop.name())?;
    // As `reflect render --json`'s `progressive.spp_cap` and `progressive.target_reached`.
    d.set_item("spp_cap", spp_cap)?;
    d.set_item("target_reached", target_rel_error.map(|_| run.stop == Stop::Target))?;
    d.set_item("target_rel_error", target_rel_error)?;
    d.set_item("time_limit", time_limit)?;
    d.set_item("rel_error_p95", run.rel_error.and_then(|e| e.ok()))?;
    d.set_item("rel_error_unknown", run.rel_error.and_then(|e| e.err()).map(|w| w.why()))?;
    Ok(result)
}

/// A finished render: the AOVs of guide "Output images" as NumPy arrays, and the film to save.
/// Background pixels (`mask` 0) show the environment with `stderr` 0: average over the object,
/// `image.stderr[image.mask > 0].mean()`, not over the whole image.
#[pyclass(module = "reflect._reflect", frozen)]
pub struct RenderResult {
    /// Linear RGB radiance, float32 (H, W, 3), row 0 at the top.
    #[pyo3(get)]
    rgb: Py<PyArray3<f32>>,
    /// Standard error of each pixel mean, float32 (H, W, 3); +inf at 1 spp (no estimate); 0 on the
    /// background (`mask` 0): select the object (`stderr[mask > 0]`) before averaging.
    #[pyo3(get)]
    stderr: Py<PyArray3<f32>>,
    /// The pixel's own standard error before the bound near flagged pixels (the `stderr_own`
    /// layer), float32 (H, W, 3).
    #[pyo3(get)]
    stderr_own: Py<PyArray3<f32>>,
    /// World-space normal of the first hit (0 on a miss), float32 (H, W, 3).
    #[pyo3(get)]
    normal: Py<PyArray3<f32>>,
    /// Fraction of each pixel's samples that hit an object, float32 (H, W): `mask > 0` selects the
    /// object's pixels.
    #[pyo3(get)]
    mask: Py<PyArray2<f32>>,
    /// The `stderr_flag.Y` layer as bool (H, W): True where the pixel's error bar cannot be trusted
    /// (one rare sample dominates its variance).
    #[pyo3(get)]
    stderr_flag: Py<PyArray2<bool>>,
    /// Throughput and settings of the render.
    #[pyo3(get)]
    stats: Py<PyDict>,
    film: Film,
    attributes: Vec<(String, String)>,
    spp: u32,
    seed: u64,
    sampler: String,
    seconds: f64,
}

fn layer<'py, const N: usize>(
    py: Python<'py>,
    film: &Film,
    f: impl Fn(&Pixel) -> [f32; N],
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let v: Vec<f32> = film.pixels.iter().flat_map(f).collect();
    Ok(PyArray1::from_vec(py, v))
}

impl RenderResult {
    /// The image a reader of the file [`RenderResult::save`] writes gets: its layers and header.
    pub fn image(&self) -> analysis::image::Image {
        renderer::render_file::film_image(&self.film, &self.attributes)
    }

    fn new(py: Python<'_>, scene: &Scene, film: Film, stats: &RenderStats) -> PyResult<Self> {
        let (h, w) = (film.height as usize, film.width as usize);
        let rgb3 = |f: fn(&Pixel) -> [f32; 3]| -> PyResult<Py<PyArray3<f32>>> {
            Ok(layer(py, &film, f)?.reshape([h, w, 3])?.unbind())
        };
        let rgb = rgb3(|p| p.rgb)?;
        let stderr = rgb3(|p| p.stderr)?;
        let stderr_own = rgb3(|p| p.stderr_own)?;
        let normal = rgb3(|p| p.normal)?;
        let mask = layer(py, &film, |p| [p.mask])?.reshape([h, w])?.unbind();
        let flags: Vec<bool> = film.pixels.iter().map(|p| p.unreliable).collect();
        let stderr_flag = PyArray1::from_vec(py, flags).reshape([h, w])?.unbind();
        let s = &scene.settings;
        let d = PyDict::new(py);
        d.set_item("wall_seconds", stats.wall.as_secs_f64())?;
        d.set_item("samples", stats.samples)?;
        d.set_item("rays", stats.rays)?;
        d.set_item("threads", stats.threads)?;
        d.set_item("samples_per_sec", stats.samples_per_sec())?;
        d.set_item("rays_per_sec", stats.rays_per_sec())?;
        d.set_item("width", s.width)?;
        d.set_item("height", s.height)?;
        d.set_item("spp", s.spp)?;
        d.set_item("seed", s.seed)?;
        d.set_item("max_depth", s.max_depth)?;
        d.set_item("sampler", scene.description.render.sampler.name())?;
        let attributes = renderer::output::header_attributes(scene);
        Ok(RenderResult {
            rgb,
            stderr,
            stderr_own,
            normal,
            mask,
            stderr_flag,
            stats: d.unbind(),
            film,
            attributes,
            spp: s.spp,
            seed: s.seed,
            sampler: scene.description.render.sampler.name().to_string(),
            seconds: stats.wall.as_secs_f64(),
        })
    }
}

#[pymethods]
impl RenderResult {
    /// Writes the render as the CLI does: 32-bit float OpenEXR with the layers of guide "Output images"
    /// and the scene in the header, atomically.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        if path.extension().and_then(|e| e.to_str()).map(|e| e.eq_ignore_ascii_case("exr")) != Some(true) {
            return Err(input_error(Error::file(&path, "output file must end in .exr").to_string()));
        }
        py.detach(|| renderer::output::write_exr(&path, &self.film, &self.attributes))
            .map_err(|e| crate::convert::our_error("FileError", e.to_string()))
    }

    /// Samples per pixel of the image (with `target_rel_error=` / `time_limit=`: the spp reached).
    #[getter]
    fn spp(&self) -> u32 {
        self.spp
    }

    /// The seed of the render.
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }

    /// The sampler's name ("sobol", "independent", "sobol-single").
    #[getter]
    fn sampler(&self) -> &str {
        &self.sampler
    }

    /// The render loop's time, seconds (loading the scene not included).
    #[getter]
    fn seconds(&self) -> f64 {
        self.seconds
    }

    fn __repr__(&self) -> String {
        format!("<reflect.RenderResult {}×{}>", self.film.width, self.film.height)
    }
}
