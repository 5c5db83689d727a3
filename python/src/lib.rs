//! The native half of the Python package `reflect` (module `reflect._reflect`).
//!
//! Thin bindings over the workspace's libraries: [`renderer`] for rendering, [`analysis`] for the
//! SH tools and the analyses (`analyze`, `invert`: parameters → reports on images in memory), and
//! the root crate's image reading (`reflect::images`) and verifier (`reflect::verify`), so
//! Python gets the same numbers, the same files and the same one-line errors as the CLI. The
//! public API, with argument handling and documentation, is the Python package beside this crate
//! (`python/reflect/`); its stub `reflect/_reflect.pyi` documents this module.
//!
//! Errors: every [`analysis::Error`] becomes the package's `reflect.InputError` (a `ValueError`) with
//! its one-line message, or `reflect.MissingFileError` (a `FileNotFoundError`) when the file it names
//! does not exist (`reflect/_errors.py`). A panic in a render thread becomes
//! `RuntimeError`; nothing unwinds into Python.

mod commands;
mod compare;
mod convert;
mod factor;
mod objects;
mod render;
mod sh;
mod verify;

use pyo3::prelude::*;

#[pymodule]
#[pyo3(name = "_reflect")]
fn reflect_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<render::RenderResult>()?;
    m.add_class::<objects::NativeBrdf>()?;
    m.add_class::<objects::NativeLight>()?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(sh::sh_project_file, m)?)?;
    m.add_function(wrap_pyfunction!(sh::sh_project_array, m)?)?;
    m.add_function(wrap_pyfunction!(sh::sh_evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(sh::sh_transfer, m)?)?;
    m.add_function(wrap_pyfunction!(sh::sh_rotate, m)?)?;
    m.add_function(wrap_pyfunction!(sh::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(commands::analyze, m)?)?;
    m.add_function(wrap_pyfunction!(commands::invert_lighting, m)?)?;
    m.add_function(wrap_pyfunction!(commands::invert_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(commands::invert_separate, m)?)?;
    m.add_function(wrap_pyfunction!(factor::invert_factor, m)?)?;
    m.add_function(wrap_pyfunction!(factor::invert_factor_scene, m)?)?;
    m.add_function(wrap_pyfunction!(commands::write_image, m)?)?;
    m.add_function(wrap_pyfunction!(commands::header_attributes, m)?)?;
    m.add_function(wrap_pyfunction!(compare::compare, m)?)?;
    m.add_function(wrap_pyfunction!(verify::verify, m)?)?;
    m.add_function(wrap_pyfunction!(verify::verify_checks, m)?)?;
    Ok(())
}
