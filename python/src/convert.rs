//! Errors and values across the boundary.

use analysis::Error;
use pyo3::exceptions::{PyFileNotFoundError, PyValueError};
use pyo3::prelude::*;

/// The CLI's one-line message as a Python exception: `FileNotFoundError` when the error names a
/// file that does not exist (the only kind of bad input that has a more precise built-in class),
/// else `ValueError`.
pub fn py_err(e: Error) -> PyErr {
    let missing = e.path.as_ref().is_some_and(|p| !p.as_os_str().is_empty() && !p.exists());
    if missing { PyFileNotFoundError::new_err(e.to_string()) } else { PyValueError::new_err(e.to_string()) }
}

/// `Result<T, analysis::Error>` → `PyResult<T>`.
pub trait IntoPy<T> {
    fn py(self) -> PyResult<T>;
}

impl<T> IntoPy<T> for Result<T, Error> {
    fn py(self) -> PyResult<T> {
        self.map_err(py_err)
    }
}

/// A `Serialize` value as plain Python objects (dicts, lists, floats, ints, strings, None).
pub fn to_python<'py, T: serde::Serialize>(py: Python<'py>, v: &T) -> PyResult<Bound<'py, PyAny>> {
    pythonize::pythonize(py, v).map_err(|e| PyValueError::new_err(format!("cannot convert a result to Python: {e}")))
}
