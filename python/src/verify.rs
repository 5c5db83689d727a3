//! `reflect.verify`: the checks of `reflect verify`, returning the document of `verify --json`.

use crate::convert::{IntoPy, to_python};
use analysis::Error;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use reflect::verify::{CHECKS, Ctx, Entry, data, report, run_entry};
use std::path::PathBuf;

/// The checks `verify --list` prints: (name, equations).
#[pyfunction]
pub fn verify_checks() -> Vec<(&'static str, &'static str)> {
    CHECKS.iter().map(|e| (e.name, e.equation)).collect()
}

/// `verify(quick, checks, seed, data, out, threads)` → the `verify --json` document. `out` is the
/// report folder (report.md/html/json and plots), written only when given; the checks' scratch
/// files then go there too, else into a temporary folder removed afterwards.
#[pyfunction]
#[pyo3(signature = (quick=true, checks=None, seed=None, data=None, out=None, threads=None))]
pub fn verify<'py>(
    py: Python<'py>,
    quick: bool,
    checks: Option<Vec<String>>,
    seed: Option<u64>,
    data: Option<PathBuf>,
    out: Option<PathBuf>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    let selected: Vec<&Entry> = match &checks {
        None => CHECKS.iter().collect(),
        Some(names) => names
            .iter()
            .map(|name| {
                CHECKS.iter().find(|e| e.name == name.as_str()).ok_or_else(|| {
                    Error::new(format!(
                        "unknown check '{name}'; known: {}",
                        CHECKS.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
                    ))
                })
            })
            .collect::<Result<_, _>>()
            .py()?,
    };
    // As the CLI looks (--data, $REFLECT_DATA, ../shared/data from the current directory); the
    // interpreter's path says nothing about a checkout, so it is not a place here.
    let env = std::env::var_os(data::ENV).map(PathBuf::from);
    let cwd = std::env::current_dir().ok();
    let data =
        data::find(&data::places(data.as_deref(), env.as_deref(), cwd.as_deref(), None)).map_err(Error::new).py()?;
    let scratch = match &out {
        Some(o) => {
            std::fs::create_dir_all(o)
                .map_err(|e| Error::file(o, format!("cannot create the report folder: {e}")))
                .py()?;
            None
        }
        None => Some(TempDir::new().py()?),
    };
    let dir = out.clone().unwrap_or_else(|| scratch.as_ref().map(|t| t.0.clone()).unwrap_or_default());
    let seed = seed.unwrap_or(1); // the CLI's default --seed
    // The checks run one after another on a worker thread; Ctrl-C (KeyboardInterrupt) sets
    // `cancel`: the running check's render stops at its next tile (the check's arithmetic on
    // finished renders is not interrupted) and no further check starts.
    let cancel = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let ctx = Ctx { quick, wrong: false, seed, out: dir, verbose: false, data, cancel: Some(cancel.clone()) };
    let (doc, results) = crate::convert::interruptibly(py, &cancel, || {
        let t = std::time::Instant::now();
        let results = reflect::cli::render::with_threads(threads, || {
            let mut done = Vec::with_capacity(selected.len());
            for e in &selected {
                if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                    break;
                }
                done.push(run_entry(&ctx, e));
            }
            done
        })?;
        let seconds = t.elapsed().as_secs_f64();
        if results.len() == selected.len()
            && let Some(o) = &out
        {
            report::write_folder(o, &results, quick, seconds).map_err(|m| Error::file(o, m))?;
        }
        Ok::<_, Error>((report::json(&results, quick, seconds), results.len()))
    })?
    .py()?;
    if results != selected.len() {
        return Err(PyRuntimeError::new_err("verify: a check went missing (a bug in reflect)"));
    }
    drop(scratch);
    to_python(py, &doc)
}

/// A folder under the system's temporary folder, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Result<TempDir, Error> {
        use std::sync::atomic::{AtomicU64, Ordering};
        static N: AtomicU64 = AtomicU64::new(0);
        let d = std::env::temp_dir().join(format!(
            "reflect-python-verify-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&d).map_err(|e| Error::file(&d, format!("cannot create a scratch folder: {e}")))?;
        Ok(TempDir(d))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
