//! Errors and values across the boundary.

use analysis::Error;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// An exception of the package's own (`reflect._errors`: `InputError` ⊂ `ValueError`, `FileError` ⊂
/// `OSError`, `MissingFileError` ⊂ `FileNotFoundError`, all ⊂ `reflect.Error`) with `message`; the
/// built-in `ValueError` if the package's module cannot be imported (the native module used alone).
pub fn our_error(class: &str, message: String) -> PyErr {
    Python::attach(|py| {
        let made =
            py.import("reflect._errors").and_then(|m| m.getattr(class)).and_then(|t| t.call1((message.clone(),)));
        match made {
            Ok(e) => PyErr::from_value(e),
            Err(_) => PyValueError::new_err(message),
        }
    })
}

/// `reflect.InputError` (a `ValueError`) with `message`: a bad argument, named by its keyword.
pub fn input_error(message: impl Into<String>) -> PyErr {
    our_error("InputError", message.into())
}

/// The one-line message as a Python exception: `reflect.MissingFileError` (a `FileNotFoundError`) when
/// the error names a file that does not exist, else `reflect.InputError` (a `ValueError`).
pub fn py_err(e: Error) -> PyErr {
    let missing = e.path.as_ref().is_some_and(|p| !p.as_os_str().is_empty() && !p.exists());
    if missing { our_error("MissingFileError", e.to_string()) } else { our_error("InputError", e.to_string()) }
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

/// Runs `work` on another thread while this one waits without the GIL, taking the GIL back every
/// 50 ms to run Python's signal handlers: when one raises (Ctrl-C: `KeyboardInterrupt`), `cancel`
/// is set, `work` is expected to stop soon (it polls the flag), and once it has returned the
/// exception is raised. A panic in `work` becomes `RuntimeError`; nothing unwinds into Python.
pub fn interruptibly<T: Send>(
    py: Python<'_>,
    cancel: &std::sync::atomic::AtomicBool,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    use std::sync::mpsc;
    let (tx, rx) = mpsc::channel::<()>();
    // (A Receiver is not Sync; the wait below runs without the GIL, which asks for a Sync borrow.)
    let rx = std::sync::Mutex::new(rx);
    std::thread::scope(|s| {
        let worker = s.spawn(move || {
            let r = work();
            let _ = tx.send(());
            r
        });
        let mut interrupted: Option<PyErr> = None;
        loop {
            let waited = py.detach(|| match rx.lock() {
                Ok(r) => r.recv_timeout(std::time::Duration::from_millis(50)),
                Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
            });
            match waited {
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if interrupted.is_none()
                        && let Err(e) = py.check_signals()
                    {
                        cancel.store(true, std::sync::atomic::Ordering::Relaxed);
                        interrupted = Some(e);
                    }
                }
                _ => break,
            }
        }
        let result = py.detach(|| worker.join());
        if let Some(e) = interrupted {
            return Err(e);
        }
        result.map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("a worker thread panicked (a bug in reflect)"))
    })
}
