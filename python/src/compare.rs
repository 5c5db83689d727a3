//! `reflect.compare`: [`analysis::compare::compare`] on images given as paths or NumPy arrays (no
//! temporary file), returning the CLI's `--json` document as a dict.

use crate::convert::to_python;
use analysis::compare::{CompareError, CompareParams};
use analysis::image::Image;
use numpy::{PyReadonlyArray2, PyReadonlyArray3};
use pyo3::exceptions::{PyFileNotFoundError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The Python name of input `i` (0 = `a`, 1 = `b`, then `seeds[k]`).
fn input_name(i: usize) -> String {
    match i {
        0 => "a".into(),
        1 => "b".into(),
        k => format!("seeds[{}]", k - 2),
    }
}

/// An image from a dict of arrays: `rgb` (H, W, 3) float32, optional `stderr` and `stderr_own` (H, W, 3),
/// `stderr_flag` and `mask` (H, W) float32, `spp` (int: the error layer's samples) and `sampler`
/// (`"independent"`, the default, `"sobol"` or `"sobol-single"`), which give the error layer's degrees of freedom.
fn image_of_dict(d: &Bound<'_, PyDict>, name: &str) -> PyResult<Image> {
    let bad = |m: String| PyValueError::new_err(format!("{name}: {m}"));
    let rgb: PyReadonlyArray3<f32> = d
        .get_item("rgb")?
        .ok_or_else(|| bad("no 'rgb' array".into()))?
        .extract()
        .map_err(|_| bad("'rgb' must be a float32 array of shape (H, W, 3)".into()))?;
    let sh = rgb.as_array().shape().to_vec();
    if sh[2] != 3 || sh[0] == 0 || sh[1] == 0 {
        return Err(bad(format!("'rgb' has shape {sh:?}; expected (H, W, 3) with H, W > 0")));
    }
    let (h, w) = (sh[0], sh[1]);
    let mut img = Image { width: w, height: h, ..Default::default() };
    let planes = |a: &PyReadonlyArray3<f32>, prefix: &str, img: &mut Image| -> PyResult<()> {
        let v = a.as_array();
        if v.shape() != [h, w, 3] {
            return Err(bad(format!("'{prefix}' has shape {:?}; expected ({h}, {w}, 3)", v.shape())));
        }
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            let plane: Vec<f32> = (0..h * w).map(|i| v[[i / w, i % w, c]]).collect();
            if plane.iter().any(|x| x.is_nan() || (prefix == "rgb" && !x.is_finite())) {
                return Err(bad(format!("'{prefix}' holds NaN or infinite values")));
            }
            let key = if prefix == "rgb" { n.to_string() } else { format!("{prefix}.{n}") };
            img.channels.insert(key, plane);
        }
        Ok(())
    };
    planes(&rgb, "rgb", &mut img)?;
    if let Some(s) = d.get_item("stderr")?.filter(|s| !s.is_none()) {
        let s: PyReadonlyArray3<f32> =
            s.extract().map_err(|_| bad("'stderr' must be a float32 array of shape (H, W, 3)".into()))?;
        planes(&s, "stderr", &mut img)?;
    }
    if let Some(s) = d.get_item("stderr_own")?.filter(|s| !s.is_none()) {
        let s: PyReadonlyArray3<f32> =
            s.extract().map_err(|_| bad("'stderr_own' must be a float32 array of shape (H, W, 3)".into()))?;
        planes(&s, "stderr_own", &mut img)?;
    }
    for (key, channel) in [("stderr_flag", "stderr_flag.Y"), ("mask", "mask.Y")] {
        if let Some(m) = d.get_item(key)?.filter(|s| !s.is_none()) {
            let m: PyReadonlyArray2<f32> =
                m.extract().map_err(|_| bad(format!("'{key}' must be a float32 array of shape (H, W)")))?;
            let v = m.as_array();
            if v.shape() != [h, w] {
                return Err(bad(format!("'{key}' has shape {:?}; expected ({h}, {w})", v.shape())));
            }
            img.channels.insert(channel.into(), v.iter().copied().collect());
        }
    }
    let sampler = match d.get_item("sampler")?.filter(|s| !s.is_none()) {
        Some(s) => {
            let s: String = s.extract().map_err(|_| bad("'sampler' must be a string".into()))?;
            s.parse::<vocab::Sampler>().map_err(|e| bad(e.to_string()))?
        }
        // An error bar from another renderer is its samples' standard error (spp − 1 degrees of
        // freedom), as the independent sampler's.
        None => vocab::Sampler::Independent,
    };
    if let Some(spp) = d.get_item("spp")?.filter(|s| !s.is_none()) {
        let spp: u32 = spp.extract().map_err(|_| bad("'spp' must be a whole number".into()))?;
        img.attributes.insert(
            vocab::header::RENDER.into(),
            serde_json::json!({ "width": w, "height": h, "spp": spp, "sampler": sampler }).to_string(),
        );
    }
    Ok(img)
}

/// `compare(images, alpha, block, exclude_edges, layer, object_only)`: `images` is [a, b, seeds…], each a path
/// or a dict of arrays (see `image_of_dict`). Returns the `--json` document as a dict.
#[pyfunction]
#[pyo3(signature = (images, alpha, block, exclude_edges, layer=None, object_only=false))]
pub fn compare<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    alpha: f64,
    block: usize,
    exclude_edges: usize,
    layer: Option<String>,
    object_only: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let mut imgs = Vec::with_capacity(images.len());
    let mut paths: Vec<Option<PathBuf>> = Vec::with_capacity(images.len());
    for (i, x) in images.iter().enumerate() {
        if let Ok(d) = x.cast::<PyDict>() {
            let mut img = image_of_dict(d, &input_name(i))?;
            // As for a file: flagged pixels compared with the error bars near them bounded (when
            // the dict carries `stderr_own`, as a RenderResult does).
            reflect::images::bound_near_flags(&mut img);
            imgs.push(img);
            paths.push(None);
            continue;
        }
        let p: PathBuf = x.extract().map_err(|_| {
            PyValueError::new_err(format!("{}: expected a path, an array or a RenderResult", input_name(i)))
        })?;
        let read = || -> Result<Image, analysis::Error> {
            let (img, _notes) = renderer::render_file::read_image_notes(&p)?;
            let mut img = img.select_layer(layer.as_deref()).map_err(|e| e.in_file(&p))?.0;
            // pbrt-v4's image axes brought to ours, as the CLI does.
            reflect::cli::compare::to_our_image_axes(&mut img);
            // As `reflect compare`: flagged pixels are compared with the error bars near them
            // bounded.
            reflect::images::bound_near_flags(&mut img);
            Ok(img)
        };
        match py.detach(read) {
            Ok(img) => imgs.push(img),
            Err(e) if !p.exists() => return Err(PyFileNotFoundError::new_err(e.to_string())),
            Err(e) => return Err(PyValueError::new_err(e.to_string())),
        }
        paths.push(Some(p));
    }
    if imgs.len() < 2 {
        return Err(PyValueError::new_err("compare needs a and b"));
    }
    let params = CompareParams { alpha, block, exclude_edges, object_only, b_systematic: None };
    let report =
        py.detach(|| analysis::compare::compare(&imgs[0], &imgs[1..], &params)).map_err(|e: CompareError| {
            let name = |i: usize| paths[i].as_ref().map_or_else(|| input_name(i), |p| p.display().to_string());
            let mut msg = e.to_string();
            for i in (0..imgs.len()).rev() {
                msg = msg.replace(&format!("input {i}"), &name(i));
            }
            match e.input() {
                Some(i) => PyValueError::new_err(format!("{}: {msg}", name(i))),
                None => PyValueError::new_err(msg),
            }
        })?;
    to_python(py, &report)
}
