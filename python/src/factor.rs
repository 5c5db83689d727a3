//! `reflect.invert.factor`: [`analysis::factor`] called on images held in memory (files read as the
//! CLI reads them, renders, arrays; as [`crate::commands`] does for the other analyses), or on a
//! scene's light field rendered in memory view by view ([`renderer::light_field`]). No file is
//! written and no command line is built; the arguments arrive checked by the Python side
//! (`reflect/_analysis.py`). Each function returns its report object as [`crate::commands`]' do.

use crate::commands::{View, detached, inputs, load, paths, result};
use crate::convert::input_error;
use analysis::factor::{FactorParams, ProbeImage};
use analysis::inverse::factorization::NormalRule;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

fn params(
    lmax: usize,
    nodes: Option<(usize, usize)>,
    channel: usize,
    quadrature: &str,
    max_amplification: f64,
) -> PyResult<FactorParams> {
    let rule = match quadrature {
        "fejer" => NormalRule::Fejer,
        "pixel" => NormalRule::PixelSolidAngle,
        q => return Err(input_error(format!("quadrature= must be \"fejer\" or \"pixel\", got {q:?}"))),
    };
    Ok(FactorParams { lmax, channel, rule, max_amplification, nodes })
}

/// `invert_factor(images, names, view, normal, *, lmax, …)` → `InvertFactorReport`:
/// [`analysis::factor::factor_images`]. `normal`: `(image, name, view)` of the θ_o = 0 view, if any.
#[pyfunction]
#[pyo3(signature = (images, names, view, normal, *, lmax, nodes, channel, quadrature, max_amplification))]
#[allow(clippy::too_many_arguments)]
pub fn invert_factor<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    names: Vec<String>,
    view: View,
    normal: Option<(Bound<'py, PyAny>, String, View)>,
    lmax: usize,
    nodes: Option<(usize, usize)>,
    channel: usize,
    quadrature: &str,
    max_amplification: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let params = params(lmax, nodes, channel, quadrature, max_amplification)?;
    let normal = match normal {
        Some((img, name, v)) => Some((inputs(std::slice::from_ref(&img))?, PathBuf::from(name), v)),
        None => None,
    };
    let inputs = inputs(&images)?;
    let names = paths(names);
    let (r, notes) = detached(py, None, move || {
        analysis::factor::validate(&params)?;
        let (images, observed, mut notes) = load(inputs, &names, &view, "factored", true)?;
        let sidecar = view.scene.as_deref().map(reflect::images::read_scene).transpose()?;
        let normal = match normal {
            None => None,
            Some((input, name, v)) => {
                let (mut imgs, d, n) = load(input, std::slice::from_ref(&name), &v, "factored", true)?;
                notes.extend(n);
                Some((name, imgs.remove(0), d.cameras[0]))
            }
        };
        let views: Vec<ProbeImage<'_>> = names
            .iter()
            .zip(&images)
            .zip(&observed.cameras)
            .map(|((path, image), camera)| ProbeImage { path, image, camera })
            .collect();
        let normal = normal.as_ref().map(|(path, image, camera)| ProbeImage { path, image, camera });
        let r = analysis::factor::factor_images(&params, &views, normal, sidecar.as_ref())?;
        Ok((r, notes))
    })?;
    result(py, "InvertFactorReport", &r, notes)
}

/// `invert_factor_scene(scene, *, lmax, nodes, size, …)` → `InvertFactorReport`: the light field of
/// the scene file rendered at every node and at θ_o = 0 ([`renderer::light_field::factor_scene`], the
/// function `reflect invert factor --scene` calls); Ctrl-C stops the render within one tile.
#[pyfunction]
#[pyo3(signature = (scene, *, lmax, nodes, size, channel, quadrature, max_amplification))]
#[allow(clippy::too_many_arguments)]
pub fn invert_factor_scene<'py>(
    py: Python<'py>,
    scene: PathBuf,
    lmax: usize,
    nodes: (usize, usize),
    size: (u32, u32),
    channel: usize,
    quadrature: &str,
    max_amplification: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let params = params(lmax, Some(nodes), channel, quadrature, max_amplification)?;
    let cancel = Arc::new(AtomicBool::new(false));
    let c = cancel.clone();
    let r = detached(py, Some(cancel), move || {
        renderer::light_field::factor_scene(&params, &scene, size, "size=", Some(c))
    })?;
    result(py, "InvertFactorReport", &r, Vec::new())
}
