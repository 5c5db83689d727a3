//! `reflect.invert.factor`, still through the command line: `factor_report(argv)` parses
//! `reflect invert factor ARGV…` with the CLI's parser and runs the command's code, returning the
//! document its `--json` prints. Factorization has not moved into `analysis` yet (its
//! scene-rendering path needs the renderer); once it has, this becomes a call like
//! [`crate::commands`]' and goes away.

use crate::convert::{IntoPy, to_python};
use analysis::Error;
use clap::Parser;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use reflect::cli::invert::InvertCommand;
use reflect::cli::{Cli, Command};

/// `factor_report(argv)` → the `--json` document of `reflect invert factor ARGV…`. The GIL is
/// released while the command runs.
#[pyfunction]
pub fn factor_report<'py>(py: Python<'py>, argv: Vec<String>) -> PyResult<Bound<'py, PyAny>> {
    let args = ["reflect", "invert", "factor"].into_iter().map(String::from).chain(argv);
    let cli = Cli::try_parse_from(args).map_err(|e| {
        // One line, as the binary prints it (src/main.rs): clap's message up to its usage block.
        let text = e.render().to_string();
        let msg: Vec<&str> = text
            .lines()
            .map(str::trim)
            .skip_while(|l| l.is_empty())
            .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
            .collect();
        PyValueError::new_err(msg.join(" ").trim_start_matches("error: ").to_string())
    })?;
    let Command::Invert(InvertCommand::Factor(a)) = cli.command else {
        return Err(PyValueError::new_err("not an invert factor command"));
    };
    let run = || {
        reflect::cli::factor::factor_report(&a)
            .and_then(|r| serde_json::to_value(r).map_err(|e| Error::new(format!("JSON output: {e}"))))
    };
    let doc = py
        .detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)))
        .map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("the command panicked (a bug in reflect)"))?
        .py()?;
    to_python(py, &doc)
}
