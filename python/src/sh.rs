//! `reflect.sh`: projection of environments, evaluation, transfer coefficients and rotation, on
//! NumPy arrays (guide sections "Environment maps and `rotate_deg`", "Spherical harmonics: the
//! terms the commands print", "BRDFs"). The Python side (`reflect/sh.py`) shapes the arrays;
//! these functions take and return C-contiguous float64 arrays.

use crate::convert::IntoPy;
use analysis::Error;
use analysis::image::{RgbImage, read_rgb};
use analysis::projection::{Mapping, project_envmap};
use analysis::sh::rotation::{Rotation, rotate_coefficients};
use analysis::sh::{Reconstructor, lmax_of};
use analysis::transfer::TransferModel;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use reflect::cli::sh::check_lmax;
use std::path::PathBuf;

fn coeffs_array(c: Vec<[f64; 3]>) -> Array2<f64> {
    let n = c.len();
    Array2::from_shape_vec((n, 3), c.into_iter().flatten().collect()).expect("n × 3")
}

fn project(img: RgbImage, mapping: Option<&str>, lmax: usize) -> Result<Array2<f64>, Error> {
    check_lmax(lmax)?;
    let mapping = match mapping {
        Some(m) => Mapping::parse(m)?,
        // (Mapping::infer's refusal names the CLI's flag: this one is said in this API's terms.)
        None => Mapping::infer(img.width, img.height).map_err(|_| {
            Error::new(format!(
                "cannot infer the mapping of a {}×{} map (W = H is angular, W = 2H lat-long): pass mapping=",
                img.width, img.height
            ))
        })?,
    };
    Ok(coeffs_array(project_envmap(&img, mapping, lmax)?))
}

/// L_lm of an environment map file (`.exr` or `.hdr`), ((L+1)², 3).
#[pyfunction]
#[pyo3(signature = (path, mapping, lmax))]
pub fn sh_project_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    mapping: Option<String>,
    lmax: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let c = py
        .detach(|| {
            let img = read_rgb(&path)?;
            project(img, mapping.as_deref(), lmax).map_err(|e| e.in_file(&path))
        })
        .py()?;
    Ok(c.into_pyarray(py))
}

/// L_lm of an (H, W, 3) float32 array of linear radiance, ((L+1)², 3).
#[pyfunction]
#[pyo3(signature = (env, mapping, lmax))]
pub fn sh_project_array<'py>(
    py: Python<'py>,
    env: PyReadonlyArray3<'py, f32>,
    mapping: Option<String>,
    lmax: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let a = env.as_array();
    let (h, w, ch) = a.dim();
    if ch != 3 || h == 0 || w == 0 {
        return Err(py_value(format!("environment array must have shape (H, W, 3), got ({h}, {w}, {ch})")));
    }
    // The same check as for files (analysis::image): no NaN or infinite radiance reaches the projection.
    if let Some(((r, c, _), v)) = a.indexed_iter().find(|(_, v)| !v.is_finite()) {
        return Err(py_value(format!("environment array: non-finite value {v} at row {r}, column {c}")));
    }
    let pixels: Vec<[f32; 3]> =
        a.outer_iter().flat_map(|row| row.outer_iter().map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>()).collect();
    let img = RgbImage { width: w, height: h, pixels };
    let c = py.detach(|| project(img, mapping.as_deref(), lmax)).py()?;
    Ok(c.into_pyarray(py))
}

fn py_value(m: String) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(m)
}

fn lmax_of_len(n: usize) -> PyResult<usize> {
    lmax_of(n).ok_or_else(|| py_value(format!("{n} coefficients is not (lmax+1)² for any lmax")))
}

/// f(ω) = Σ_k c_k Y_k(ω) at each row of `directions` (N, 3), normalized here; → (N, 3).
#[pyfunction]
pub fn sh_evaluate<'py>(
    py: Python<'py>,
    coeffs: PyReadonlyArray2<'py, f64>,
    directions: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let c = coeffs.as_array();
    if c.ncols() != 3 {
        return Err(py_value(format!("coefficients must have shape ((lmax+1)², 3), got {:?}", c.dim())));
    }
    let lmax = lmax_of_len(c.nrows())?;
    let c: Vec<[f64; 3]> = c.outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let d = directions.as_array();
    if d.ncols() != 3 {
        return Err(py_value(format!("directions must have shape (N, 3), got {:?}", d.dim())));
    }
    let mut dirs = Vec::with_capacity(d.nrows());
    for (i, r) in d.outer_iter().enumerate() {
        let n = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return Err(py_value(format!(
                "direction {i} ({}, {}, {}) is not a finite non-zero vector",
                r[0], r[1], r[2]
            )));
        }
        dirs.push([r[0] / n, r[1] / n, r[2] / n]);
    }
    let out = py.detach(|| {
        let mut rec = Reconstructor::new(lmax);
        coeffs_array(dirs.iter().map(|&d| rec.eval(&c, d)).collect())
    });
    Ok(out.into_pyarray(py))
}

/// Λ_l ρ̂_l, l = 0 … lmax, for unit albedo / k_s, and the paper's approximation where it has one.
#[pyfunction]
#[pyo3(signature = (brdf, lmax, s=None, sigma=None, theta_o_deg=None))]
#[allow(clippy::type_complexity)]
pub fn sh_transfer<'py>(
    py: Python<'py>,
    brdf: &str,
    lmax: usize,
    s: Option<f64>,
    sigma: Option<f64>,
    theta_o_deg: Option<f64>,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Option<(String, Bound<'py, PyArray1<f64>>)>)> {
    check_lmax(lmax).py()?;
    // The CLI's parse and mapping: the closed set's message for an unknown name, then the one
    // BRDF → transfer-model mapping of `analysis`.
    let kind: vocab::BrdfKind = brdf.parse().py()?;
    let model = TransferModel::from_params(kind, s, sigma, theta_o_deg).py()?;
    let (f, approx) = py.detach(|| (model.lambda_rho(lmax), model.approximation(lmax)));
    Ok((Array1::from(f).into_pyarray(py), approx.map(|(name, v)| (name.to_string(), Array1::from(v).into_pyarray(py)))))
}

/// Coefficients of f_R(ω) = f(Rᵀω) for a 3 × 3 rotation matrix R (orthonormal, det +1).
#[pyfunction]
pub fn sh_rotate<'py>(
    py: Python<'py>,
    coeffs: PyReadonlyArray2<'py, f64>,
    rotation: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let c = coeffs.as_array();
    if c.ncols() != 3 {
        return Err(py_value(format!("coefficients must have shape ((lmax+1)², 3), got {:?}", c.dim())));
    }
    lmax_of_len(c.nrows())?;
    let r = rotation.as_array();
    if r.dim() != (3, 3) {
        return Err(py_value(format!("rotation must be a 3 × 3 matrix, got shape {:?}", r.dim())));
    }
    let m = [[r[[0, 0]], r[[0, 1]], r[[0, 2]]], [r[[1, 0]], r[[1, 1]], r[[1, 2]]], [r[[2, 0]], r[[2, 1]], r[[2, 2]]]];
    // RᵀR = I and det R = +1, to 1e-6: anything else is not a rotation of directions.
    let mut worst: f64 = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            let dot: f64 = (0..3).map(|k| m[k][i] * m[k][j]).sum();
            worst = worst.max((dot - if i == j { 1.0 } else { 0.0 }).abs());
        }
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if !(worst < 1e-6 && (det - 1.0).abs() < 1e-6) {
        return Err(py_value(format!("rotation is not a rotation matrix (|RᵀR − I| = {worst:.2e}, det = {det:.6})")));
    }
    let c: Vec<[f64; 3]> = c.outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
    let out = py.detach(|| coeffs_array(rotate_coefficients(&c, &Rotation(m))));
    Ok(out.into_pyarray(py))
}

/// `read_image(path)` → (channels, attributes): every channel of an `.exr`/`.hdr` file as an
/// (H, W) float32 array by name (`R`, `G`, `B`, `normal.X`, `mask.Y`, `stderr.R`, …), and the
/// header's string attributes (`reflect:camera`, `reflect:scene`, …).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn read_image<'py>(
    py: Python<'py>,
    path: PathBuf,
) -> PyResult<(Bound<'py, pyo3::types::PyDict>, std::collections::BTreeMap<String, String>)> {
    let img = py.detach(|| renderer::render_file::read_image(&path)).py()?;
    let channels = pyo3::types::PyDict::new(py);
    let (h, w) = (img.height, img.width);
    for (name, v) in img.channels {
        let a = Array2::from_shape_vec((h, w), v).map_err(|e| py_value(format!("{}: {e}", path.display())))?;
        channels.set_item(name, a.into_pyarray(py))?;
    }
    Ok((channels, img.attributes))
}
