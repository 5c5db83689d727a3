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
