//! BRDF and light objects over NumPy batches: the renderer's own `eval`, `sample` and `pdf`
//! (`renderer::brdf::Bxdf`, `renderer::light::DistantLight`), built from the scene files' tables
//! (docs/src/conventions.md §4, §6) so a Python object is exactly what a scene of that table renders.
//!
//! Arrays arrive checked and shaped by `reflect/brdf.py` and `reflect/light.py`: C-contiguous float32,
//! N×3 directions (unit vectors) and N×2 (or N) uniform numbers; results are float32 like the
//! renderer's arithmetic. The GIL is released over each batch.

use crate::convert::{IntoPy, input_error};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use renderer::brdf::{Brdf, Bxdf, build_brdf};
use renderer::light::envmap::Table;
use renderer::light::{DistantLight, Light};
use renderer::math::{Vec2, Vec3};
use vocab::scene::{BrdfSection, LightingSection};

type Out<'py> = Bound<'py, PyAny>;

fn vec3s(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<Vec3>> {
    let s = a.as_slice().map_err(|_| input_error(format!("{name}= must be a contiguous array")))?;
    if a.shape()[1] != 3 {
        return Err(input_error(format!("{name}= must have shape (N, 3), got {:?}", a.shape())));
    }
    Ok(s.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
}

fn vec2s(name: &str, a: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<Vec2>> {
    let s = a.as_slice().map_err(|_| input_error(format!("{name}= must be a contiguous array")))?;
    if a.shape()[1] != 2 {
        return Err(input_error(format!("{name}= must have shape (N, 2), got {:?}", a.shape())));
    }
    Ok(s.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect())
}

fn rows3<'py>(py: Python<'py>, v: &[Vec3]) -> PyResult<Out<'py>> {
    let flat: Vec<f32> = v.iter().flat_map(|x| x.to_array()).collect();
    Ok(PyArray1::from_vec(py, flat).reshape([v.len(), 3])?.into_any())
}

fn same_len(a: usize, b: usize, names: (&str, &str)) -> PyResult<()> {
    if a == b { Ok(()) } else { Err(input_error(format!("{}= has {a} rows and {}= {b}", names.0, names.1))) }
}

/// A BRDF of docs/src/conventions.md §4 (`reflect.brdf.*` build it from its scene-file table).
#[pyclass(module = "reflect._reflect", frozen, name = "NativeBrdf")]
pub struct NativeBrdf {
    brdf: Brdf,
}

#[pymethods]
impl NativeBrdf {
    /// From a scene file's `brdf` table (a dict with `type`); errors name the key.
    #[new]
    fn new(table: &Bound<'_, PyAny>) -> PyResult<Self> {
        let section: BrdfSection = pythonize::depythonize(table)
            .map_err(|e| input_error(format!("brdf: {}", e.to_string().replace('\n', " "))))?;
        let brdf = build_brdf(&section).map_err(|m| input_error(format!("brdf: {m}")))?;
        Ok(NativeBrdf { brdf })
    }

    /// ρ̂(ω_o, ω_i) = BRDF · cos θ_i for each row: (N, 3) float32.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray2<'py, f32>,
        wo: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Out<'py>> {
        let (wi, wo) = (vec3s("wi", &wi)?, vec3s("wo", &wo)?);
        same_len(wi.len(), wo.len(), ("wi", "wo"))?;
        let v: Vec<Vec3> = py.detach(|| wi.iter().zip(&wo).map(|(i, o)| self.brdf.eval(*o, *i)).collect());
        rows3(py, &v)
    }

    /// The solid-angle density with which `sample` draws ω_i given ω_o: (N,) float32.
    fn pdf<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray2<'py, f32>,
        wo: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Out<'py>> {
        let (wi, wo) = (vec3s("wi", &wi)?, vec3s("wo", &wo)?);
        same_len(wi.len(), wo.len(), ("wi", "wo"))?;
        let v: Vec<f32> = py.detach(|| wi.iter().zip(&wo).map(|(i, o)| self.brdf.pdf(*o, *i)).collect());
        Ok(PyArray1::from_vec(py, v).into_any())
    }

    /// Draws ω_i for each row: (wi (N, 3), weight = ρ̂/pdf (N, 3), pdf (N,), delta (N,) bool); a row
    /// that draws nothing has zeros (and delta False).
    fn sample<'py>(
        &self,
        py: Python<'py>,
        wo: PyReadonlyArray2<'py, f32>,
        u: PyReadonlyArray2<'py, f32>,
        u_lobe: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<(Out<'py>, Out<'py>, Out<'py>, Out<'py>)> {
        let (wo, u) = (vec3s("wo", &wo)?, vec2s("u", &u)?);
        let ul = u_lobe.as_slice().map_err(|_| input_error("u_lobe= must be a contiguous array"))?.to_vec();
        same_len(wo.len(), u.len(), ("wo", "u"))?;
        same_len(wo.len(), ul.len(), ("wo", "u_lobe"))?;
        let drawn: Vec<_> =
            py.detach(|| wo.iter().zip(&u).zip(&ul).map(|((o, u), l)| self.brdf.sample(*o, *l, *u)).collect());
        let wi: Vec<Vec3> = drawn.iter().map(|s| s.map_or(Vec3::ZERO, |s| s.wi)).collect();
        let weight: Vec<Vec3> = drawn.iter().map(|s| s.map_or(Vec3::ZERO, |s| s.weight)).collect();
        let pdf: Vec<f32> = drawn.iter().map(|s| s.map_or(0.0, |s| s.pdf)).collect();
        let delta: Vec<bool> = drawn.iter().map(|s| s.is_some_and(|s| s.delta)).collect();
        Ok((
            rows3(py, &wi)?,
            rows3(py, &weight)?,
            PyArray1::from_vec(py, pdf).into_any(),
            PyArray1::from_vec(py, delta).into_any(),
        ))
    }
}

/// A distant light of docs/src/conventions.md §6 (`reflect.light.*` build it from its `[lighting]`
/// table).
#[pyclass(module = "reflect._reflect", frozen, name = "NativeLight")]
pub struct NativeLight {
    light: Light,
}

#[pymethods]
impl NativeLight {
    /// From a scene file's `[lighting]` table (a dict with `type`), data files relative to `base`.
    /// An environment map samples by luminance unless `compensated` (the renderer's table, which
    /// only MIS with samples covering every direction makes unbiased; `light::envmap::Table`).
    #[new]
    #[pyo3(signature = (table, base, compensated = false))]
    fn new(py: Python<'_>, table: &Bound<'_, PyAny>, base: std::path::PathBuf, compensated: bool) -> PyResult<Self> {
        let mut section: LightingSection = pythonize::depythonize(table)
            .map_err(|e| input_error(format!("lighting: {}", e.to_string().replace('\n', " "))))?;
        let light = py
            .detach(|| {
                renderer::scene::build::build_light(&mut section, &base, &mut Default::default()).map(|l| match l {
                    Light::Envmap(e) if !compensated => Light::Envmap(e.with_table(Table::Luminance)),
                    l => l,
                })
            })
            .py()?;
        Ok(NativeLight { light })
    }

    /// Radiance L(ω) arriving from each world direction: (N, 3) float32 (0 for a directional light).
    fn eval<'py>(&self, py: Python<'py>, direction: PyReadonlyArray2<'py, f32>) -> PyResult<Out<'py>> {
        let d = vec3s("direction", &direction)?;
        let v: Vec<Vec3> = py.detach(|| d.iter().map(|w| self.light.eval(*w)).collect());
        rows3(py, &v)
    }

    /// The solid-angle density with which `sample` draws each direction: (N,) float32.
    fn pdf<'py>(&self, py: Python<'py>, direction: PyReadonlyArray2<'py, f32>) -> PyResult<Out<'py>> {
        let d = vec3s("direction", &direction)?;
        let v: Vec<f32> = py.detach(|| d.iter().map(|w| self.light.pdf(*w)).collect());
        Ok(PyArray1::from_vec(py, v).into_any())
    }

    /// Draws a direction per row of `u`: (direction (N, 3), value = L/pdf (N, 3), pdf (N,), delta (N,)
    /// bool); zeros where nothing is drawn.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        u: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<(Out<'py>, Out<'py>, Out<'py>, Out<'py>)> {
        let u = vec2s("u", &u)?;
        let drawn: Vec<_> = py.detach(|| u.iter().map(|u| self.light.sample(*u)).collect());
        let wi: Vec<Vec3> = drawn.iter().map(|s| s.map_or(Vec3::ZERO, |s| s.wi)).collect();
        let value: Vec<Vec3> = drawn.iter().map(|s| s.map_or(Vec3::ZERO, |s| s.value)).collect();
        let pdf: Vec<f32> = drawn.iter().map(|s| s.map_or(0.0, |s| s.pdf)).collect();
        let delta: Vec<bool> = drawn.iter().map(|s| s.is_some_and(|s| s.delta)).collect();
        Ok((
            rows3(py, &wi)?,
            rows3(py, &value)?,
            PyArray1::from_vec(py, pdf).into_any(),
            PyArray1::from_vec(py, delta).into_any(),
        ))
    }
}
