//! `reflect.analyze` and `reflect.invert.lighting | brdf | separate`: the analysis library's own
//! functions ([`analysis::analyze`], [`analysis::invert`], [`analysis::separate`]) called on images
//! held in memory: files read as the CLI reads them ([`reflect::images`]), renders as the image
//! their saved file holds ([`renderer::render_file::film_image`]), arrays as the layers and header
//! attributes the Python side built. No file is written and no command line is built; the
//! arguments arrive checked and typed by the Python side (`reflect/_analysis.py`), which names its
//! keywords in every message it raises.
//!
//! Each function returns its report object (`reflect._analysis.AnalyzeReport`, …) built from the
//! document `--json` prints (through `serde_json`, so non-finite numbers are null there and here)
//! and the `note: …` lines the CLI prints on stderr. The analysis runs on a thread of its own
//! without the GIL while the calling thread runs Python's signal handlers ([`detached`]): Ctrl-C
//! raises `KeyboardInterrupt` at once. A panic becomes `RuntimeError`.

use crate::convert::{input_error, py_err, to_python};
use crate::render::RenderResult;
use analysis::image::{Image, RgbImage};
use analysis::lighting::Lighting;
use analysis::observation::{BrdfValues, CameraValues, Given, LightingInput, Observation, Spelling};
use analysis::projection::{Mapping, Param};
use analysis::transfer::ParamValue;
use numpy::{PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use vocab::scene::SceneFile;

/// One image argument: a file's path, a render, or the layers and header of an array.
pub(crate) enum Input {
    File(PathBuf),
    Memory(Image),
}

/// The image arguments of a call, in order (`names`: each one's name in reports and messages).
pub(crate) fn inputs(images: &[Bound<'_, PyAny>]) -> PyResult<Vec<Input>> {
    let mut out = Vec::with_capacity(images.len());
    for img in images {
        if let Ok(r) = img.cast::<RenderResult>() {
            out.push(Input::Memory(r.get().image()));
        } else if let Ok(p) = img.extract::<PathBuf>() {
            out.push(Input::File(p));
        } else {
            let channels: BTreeMap<String, PyReadonlyArray2<'_, f32>> = img.get_item("channels")?.extract()?;
            let attributes: BTreeMap<String, String> = img.get_item("attributes")?.extract()?;
            let mut image = Image { attributes, ..Default::default() };
            for (name, a) in &channels {
                let a = a.as_array();
                (image.height, image.width) = a.dim();
                image.channels.insert(name.clone(), a.iter().copied().collect());
            }
            out.push(Input::Memory(image));
        }
    }
    Ok(out)
}

/// How images are described besides their headers (the CLI's view flags, in Python's terms).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct View {
    /// The sidecar scene of files (`scene=` beside files).
    pub(crate) scene: Option<PathBuf>,
    center: Option<[f64; 3]>,
    radius: Option<f64>,
    layer: Option<String>,
    pixel_filter: Option<String>,
}

/// Reads and describes the images (as the CLI's `load`): files read with their radiance layer,
/// error bars bounded near flagged pixels, everything described and made ready by
/// [`analysis::observation::observe`]. `what` is the command's verb for refusals.
pub(crate) fn load(
    inputs: Vec<Input>,
    names: &[PathBuf],
    view: &View,
    what: &str,
    probe_only: bool,
) -> Result<(Vec<Image>, Observation, Vec<String>), analysis::Error> {
    let files: Vec<PathBuf> =
        inputs.iter().filter_map(|i| if let Input::File(p) = i { Some(p.clone()) } else { None }).collect();
    let (read, mut notes) = reflect::images::read(&files, view.layer.as_deref())?;
    let mut read = read.into_iter();
    let mut images = Vec::with_capacity(inputs.len());
    for (input, name) in inputs.into_iter().zip(names) {
        images.push(match input {
            Input::File(_) => read.next().unwrap_or_default(),
            Input::Memory(img) => {
                let (img, note) = img.select_layer(view.layer.as_deref()).map_err(|e| e.in_file(name))?;
                notes.extend(note.map(|n| format!("note: {}: {n}", name.display())));
                img
            }
        });
    }
    let stderr_notes = reflect::images::bound_flagged(&mut images, names);
    let scene: Option<(PathBuf, SceneFile)> =
        view.scene.as_ref().map(|p| reflect::images::read_scene(p).map(|s| (p.clone(), s))).transpose()?;
    let cameras = vec![CameraValues::default(); images.len()];
    let given = Given {
        scene: scene.as_ref().map(|(p, s)| (p.as_path(), s)),
        cameras: &cameras,
        center: view.center,
        radius: view.radius,
        probe_only,
        what,
        spelling: Spelling::Keywords,
    };
    let filter = pixel_filter(view)?;
    let mut d = analysis::observation::observe(&mut images, names, &given, view.layer.as_deref(), filter)?;
    notes.append(&mut d.notes);
    d.stderr_notes = stderr_notes;
    Ok((images, d, notes))
}

fn pixel_filter(view: &View) -> Result<Option<analysis::noise::PixelFilter>, analysis::Error> {
    view.pixel_filter
        .as_deref()
        .map(|s| s.parse().map_err(|e: String| analysis::Error::new(format!("pixel_filter=: {e}"))))
        .transpose()
}

/// A closed set's member by name, an unknown name named with its keyword.
fn parse<T: std::str::FromStr<Err = vocab::Error>>(keyword: &str, v: Option<String>) -> PyResult<Option<T>> {
    v.map(|s| s.parse::<T>().map_err(|e| input_error(format!("{keyword}=: {}", e.message)))).transpose()
}

/// The lighting argument: a file path, a `[lighting]` table (dict), SH coefficients ((L+1)², 3)
/// or an environment map (H, W, 3) projected here to the order the fits read (`lmax` + 2 and the
/// truncation sequence's), with `mapping`.
fn lighting_input(
    v: Option<&Bound<'_, PyAny>>,
    mapping: Option<Mapping>,
    lmax: usize,
) -> PyResult<Option<LightingInput>> {
    let Some(v) = v else { return Ok(None) };
    if let Ok(p) = v.extract::<PathBuf>() {
        return Ok(Some(LightingInput::File(p)));
    }
    if v.is_instance_of::<pyo3::types::PyDict>() {
        let section: vocab::LightingSection = pythonize::depythonize(v)
            .map_err(|e| input_error(format!("lighting=: {}", e.to_string().replace('\n', " "))))?;
        let cwd = std::env::current_dir().ok();
        let lighting =
            Lighting::from_section(&section, cwd.as_deref()).map_err(|e| input_error(format!("lighting=: {e}")))?;
        return Ok(Some(LightingInput::Value { lighting, name: "<lighting dict>".into() }));
    }
    if let Ok(c) = v.extract::<PyReadonlyArray2<'_, f64>>() {
        let coefficients: Vec<[f64; 3]> = c.as_array().outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
        return Ok(Some(LightingInput::Value {
            lighting: Lighting::Sh { coefficients },
            name: "<lighting coefficients>".into(),
        }));
    }
    let a: PyReadonlyArray3<'_, f32> = v.extract()?;
    let a = a.as_array();
    let (h, w, _) = a.dim();
    let pixels: Vec<[f32; 3]> =
        a.outer_iter().flat_map(|row| row.outer_iter().map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>()).collect();
    let img = RgbImage { width: w, height: h, pixels };
    let mapping = match mapping {
        Some(m) => m,
        // (Mapping::infer's refusal names the CLI's flag: this one is said in this API's terms.)
        None => Mapping::infer(w, h).map_err(|_| {
            input_error(format!(
                "lighting= (map array): cannot infer the mapping of a {w}×{h} map (W = H is angular, W = 2H lat-long): \
                 pass mapping="
            ))
        })?,
    };
    let coefficients = analysis::projection::project_envmap(&img, mapping, analysis::truncation::truncation_lmax(lmax))
        .map_err(|e| input_error(format!("lighting= (map array): {}", e.message)))?;
    Ok(Some(LightingInput::Value { lighting: Lighting::Sh { coefficients }, name: "<lighting map>".into() }))
}

/// The explicit BRDF (`brdf=`, `s=`, `sigma=`, `brdf_params=`, `albedo=`).
fn brdf_values(
    brdf: Option<String>,
    params: Vec<(String, Bound<'_, PyAny>)>,
    albedo: Option<[f64; 3]>,
) -> PyResult<BrdfValues> {
    let params = params
        .into_iter()
        .map(|(k, v)| {
            let value = match v.extract::<f64>() {
                Ok(x) => ParamValue::Number(x),
                Err(_) => v
                    .extract::<String>()?
                    .parse()
                    .map_err(|e: analysis::Error| input_error(format!("brdf_params['{k}']: {}", e.message)))?,
            };
            Ok((k, value))
        })
        .collect::<PyResult<_>>()?;
    Ok(BrdfValues { kind: parse("brdf", brdf)?, params, albedo, spelling: Spelling::Keywords })
}

/// Runs `work` on a thread of its own while the calling thread waits without the GIL, taking it
/// back every 50 ms to run Python's signal handlers. When one raises (Ctrl-C: `KeyboardInterrupt`),
/// `cancel` (if any) is set and the exception is raised at once: work that polls the flag (a
/// light field's renders) stops within one tile; an analysis, which has no cancellation points,
/// runs to its end on its thread and its result is dropped. A panic (a bug) becomes `RuntimeError`.
pub(crate) fn detached<T: Send + 'static>(
    py: Python<'_>,
    cancel: Option<Arc<AtomicBool>>,
    work: impl FnOnce() -> Result<T, analysis::Error> + Send + 'static,
) -> PyResult<T> {
    use std::sync::mpsc;
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
        let _ = tx.send(r);
    });
    // (A Receiver is not Sync; the wait below runs without the GIL, which asks for a Sync borrow.)
    let rx = std::sync::Mutex::new(rx);
    loop {
        let waited = py.detach(|| match rx.lock() {
            Ok(r) => r.recv_timeout(std::time::Duration::from_millis(50)),
            Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
        });
        match waited {
            Ok(Ok(r)) => return r.map_err(py_err),
            Ok(Err(_)) | Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(pyo3::exceptions::PyRuntimeError::new_err("the analysis panicked (a bug in reflect)"));
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    if let Some(c) = &cancel {
                        c.store(true, Ordering::Relaxed);
                    }
                    return Err(e);
                }
            }
        }
    }
}

/// The report object `reflect._analysis.<class>(doc, notes)` of a report.
pub(crate) fn result<'py, R: serde::Serialize>(
    py: Python<'py>,
    class: &str,
    r: &R,
    notes: Vec<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let doc = serde_json::to_value(r).map_err(|e| input_error(format!("JSON output: {e}")))?;
    py.import("reflect._analysis")?.getattr(class)?.call1((to_python(py, &doc)?, notes))
}

pub(crate) fn paths(names: Vec<String>) -> Vec<PathBuf> {
    names.into_iter().map(PathBuf::from).collect()
}

/// `analyze(images, names, view, lmax, …)` → `AnalyzeReport`: [`analysis::analyze::analyze`].
#[pyfunction]
#[pyo3(signature = (images, names, view, *, lmax, lighting=None, mapping=None, param=None, brdf=None, brdf_params=Vec::new(), albedo=None, no_diagnosis=false))]
#[allow(clippy::too_many_arguments)]
pub fn analyze<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    names: Vec<String>,
    view: View,
    lmax: usize,
    lighting: Option<Bound<'py, PyAny>>,
    mapping: Option<String>,
    param: Option<String>,
    brdf: Option<String>,
    brdf_params: Vec<(String, Bound<'py, PyAny>)>,
    albedo: Option<[f64; 3]>,
    no_diagnosis: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let mapping: Option<Mapping> = parse("mapping", mapping)?;
    let params = analysis::analyze::AnalyzeParams {
        lmax,
        lighting: lighting_input(lighting.as_ref(), mapping, lmax)?,
        mapping: mapping.filter(|_| lighting.as_ref().is_some_and(|l| l.extract::<PathBuf>().is_ok())),
        param: match param.as_deref() {
            None => None,
            Some("normal") => Some(Param::Normal),
            Some("reflection") => Some(Param::Reflection),
            Some(p) => return Err(input_error(format!("param= must be \"normal\" or \"reflection\", got {p:?}"))),
        },
        brdf: brdf_values(brdf, brdf_params, albedo)?,
        pixel_filter: pixel_filter(&view).map_err(py_err)?,
        no_diagnosis,
    };
    let inputs = inputs(&images)?;
    let names = paths(names);
    let (r, notes) = detached(py, None, move || {
        params.validate()?;
        let (images, observed, mut notes) = load(inputs, &names, &view, "analysed", false)?;
        let r = analysis::analyze::analyze(&params, images, &names, &observed)?;
        notes.extend(r.notes.iter().cloned());
        Ok((r, notes))
    })?;
    result(py, "AnalyzeReport", &r, notes)
}

/// `invert_lighting(images, names, view, lmax, …)` → `InvertLightingReport`: [`analysis::invert::lighting()`].
#[pyfunction]
#[pyo3(signature = (images, names, view, *, lmax, brdf=None, brdf_params=Vec::new(), albedo=None, max_amplification=analysis::inverse::lighting::DEFAULT_MAX_AMPLIFICATION, discrepancy=false))]
#[allow(clippy::too_many_arguments)]
pub fn invert_lighting<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    names: Vec<String>,
    view: View,
    lmax: usize,
    brdf: Option<String>,
    brdf_params: Vec<(String, Bound<'py, PyAny>)>,
    albedo: Option<[f64; 3]>,
    max_amplification: f64,
    discrepancy: bool,
) -> PyResult<Bound<'py, PyAny>> {
    use analysis::inverse::lighting::Rule;
    let params = analysis::invert::LightingParams {
        lmax,
        brdf: brdf_values(brdf, brdf_params, albedo)?,
        max_amplification,
        rule: if discrepancy { Rule::Discrepancy } else { Rule::Gcv },
        map: None,
        pixel_filter: pixel_filter(&view).map_err(py_err)?,
    };
    let inputs = inputs(&images)?;
    let names = paths(names);
    let (r, notes) = detached(py, None, move || {
        analysis::invert::lighting::validate(&params)?;
        let (images, observed, mut notes) = load(inputs, &names, &view, "inverted", false)?;
        let r = analysis::invert::lighting(&params, images, &names, &observed)?;
        notes.extend(r.notes.iter().cloned());
        Ok((r, notes))
    })?;
    result(py, "InvertLightingReport", &r, notes)
}

/// `invert_brdf(images, names, view, model, lmax, …)` → `InvertBrdfReport`: [`analysis::invert::brdf()`].
#[pyfunction]
#[pyo3(signature = (images, names, view, *, model, lmax, lighting=None, mapping=None, distribution=None, min=None, max=None))]
#[allow(clippy::too_many_arguments)]
pub fn invert_brdf<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    names: Vec<String>,
    view: View,
    model: &str,
    lmax: usize,
    lighting: Option<Bound<'py, PyAny>>,
    mapping: Option<String>,
    distribution: Option<String>,
    min: Option<f64>,
    max: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    use analysis::invert::FitModel;
    let mapping: Option<Mapping> = parse("mapping", mapping)?;
    let model = match model {
        "phong" => FitModel::Phong,
        "torrance-sparrow" => FitModel::TorranceSparrow,
        "microfacet" => FitModel::Microfacet { distribution: parse("distribution", distribution)?.unwrap_or_default() },
        m => {
            return Err(input_error(format!(
                "model= must be \"phong\", \"torrance-sparrow\" or \"microfacet\", got {m:?}"
            )));
        }
    };
    let params = analysis::invert::BrdfParams {
        lmax,
        lighting: lighting_input(lighting.as_ref(), mapping, lmax)?,
        mapping: mapping.filter(|_| lighting.as_ref().is_some_and(|l| l.extract::<PathBuf>().is_ok())),
        model,
        min,
        max,
        pixel_filter: pixel_filter(&view).map_err(py_err)?,
    };
    let inputs = inputs(&images)?;
    let names = paths(names);
    let (r, notes) = detached(py, None, move || {
        analysis::invert::brdf::validate(&params)?;
        let (images, observed, mut notes) = load(inputs, &names, &view, "inverted", false)?;
        let r = analysis::invert::brdf(&params, images, &names, &observed)?;
        notes.extend(r.notes.iter().cloned());
        Ok((r, notes))
    })?;
    result(py, "InvertBrdfReport", &r, notes)
}

/// `invert_separate(images, names, view, lmax, …)` → `InvertSeparateReport`: [`analysis::separate::separate`].
#[pyfunction]
#[pyo3(signature = (images, names, view, *, lmax, kd=None, ks=None, channel=None, scan=false))]
#[allow(clippy::too_many_arguments)]
pub fn invert_separate<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    names: Vec<String>,
    view: View,
    lmax: usize,
    kd: Option<[f64; 3]>,
    ks: Option<[f64; 3]>,
    channel: Option<usize>,
    scan: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let params =
        analysis::separate::SeparateParams { kd, ks, lmax, channel, scan, map: None, spelling: Spelling::Keywords };
    let inputs = inputs(&images)?;
    let names = paths(names);
    let (r, notes) = detached(py, None, move || {
        analysis::separate::validate(&params, inputs.len())?;
        let (images, observed, notes) = load(inputs, &names, &view, "separated", true)?;
        let r = analysis::separate::separate(&params, &images, &names, &observed)?;
        Ok((r, notes))
    })?;
    result(py, "InvertSeparateReport", &r, notes)
}

/// `header_attributes(scene)` → the `reflect:camera`, `reflect:lighting` and `reflect:objects`
/// attributes a render of `scene` (a dict with `camera`, `lighting` and `objects` tables in the
/// scene vocabulary) carries in its header: the same serde types as a scene file (unknown keys and
/// bad values are errors, defaults filled in, numbers as the renderer holds them).
#[pyfunction]
pub fn header_attributes(scene: &Bound<'_, PyAny>) -> PyResult<BTreeMap<String, String>> {
    let file: SceneFile = pythonize::depythonize(scene)
        .map_err(|e| input_error(format!("scene: {}", e.to_string().replace('\n', " "))))?;
    let keep = [vocab::header::CAMERA, vocab::header::LIGHTING, vocab::header::OBJECTS];
    Ok(vocab::header::attributes(&file, renderer::output::INTEGRATOR)
        .into_iter()
        .filter(|(k, _)| keep.contains(&k.as_str()))
        .collect())
}

/// `write_image(path, channels, attributes)`: writes an OpenEXR file (32-bit float) with the
/// given (H, W) float32 channels by name and string attributes, as `reflect render` writes its
/// layers and header; the inverse of `read_image`.
#[pyfunction]
pub fn write_image(
    py: Python<'_>,
    path: PathBuf,
    channels: BTreeMap<String, PyReadonlyArray2<'_, f32>>,
    attributes: BTreeMap<String, String>,
) -> PyResult<()> {
    let mut img = Image { attributes, ..Default::default() };
    let mut shape = None;
    for (name, a) in &channels {
        let a = a.as_array();
        let (h, w) = a.dim();
        if *shape.get_or_insert((h, w)) != (h, w) {
            return Err(input_error(format!(
                "channel {name} has shape ({h}, {w}), the others {:?}",
                shape.unwrap_or_default()
            )));
        }
        if let Some(((r, c), v)) = a.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(input_error(format!("channel {name}: non-finite value {v} at row {r}, column {c}")));
        }
        img.channels.insert(name.clone(), a.iter().copied().collect());
    }
    let (h, w) = shape.ok_or_else(|| input_error("an image needs at least one channel"))?;
    (img.height, img.width) = (h, w);
    py.detach(|| analysis::image::write_exr(&path, &img)).map_err(py_err)
}
