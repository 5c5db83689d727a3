//! `reflect.analyze` and `reflect.invert.*`: the reports of `reflect analyze` and `reflect invert
//! lighting | brdf | separate | factor`, computed by the commands' own library functions on
//! arguments parsed by the CLI's own parser, so the options, their defaults, their checks and the
//! numbers are those of the command line (and a flag added there is one here too). Images given
//! as arrays are written by the Python side as the EXR files the commands read
//! ([`write_image`], [`header_attributes`]).

use crate::convert::{IntoPy, to_python};
use analysis::Error;
use analysis::image::{Image, write_exr};
use clap::Parser;
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use reflect::cli::invert::InvertCommand;
use reflect::cli::{Cli, Command};
use std::collections::BTreeMap;
use std::path::PathBuf;
use vocab::scene::SceneFile;

fn json<T: serde::Serialize>(r: Result<T, Error>) -> Result<serde_json::Value, Error> {
    serde_json::to_value(r?).map_err(|e| Error::new(format!("JSON output: {e}")))
}

/// `report(argv)`: parses `reflect ARGV…` with the CLI's parser and runs `analyze` or one of the
/// `invert` subcommands, returning the document its `--json` prints (through `serde_json`, so
/// exactly that document: non-finite numbers are null there and here). The GIL is released while
/// the command runs.
#[pyfunction]
pub fn report<'py>(py: Python<'py>, argv: Vec<String>) -> PyResult<Bound<'py, PyAny>> {
    let cli = Cli::try_parse_from(std::iter::once("reflect".to_string()).chain(argv)).map_err(|e| {
        // One line, as the binary prints it (src/main.rs): clap's message up to its usage block,
        // continuation lines joined on (without the "error: " every Python message goes without).
        let text = e.render().to_string();
        let msg: Vec<&str> = text
            .lines()
            .map(str::trim)
            .skip_while(|l| l.is_empty())
            .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
            .collect();
        PyValueError::new_err(msg.join(" ").trim_start_matches("error: ").to_string())
    })?;
    // A panic (a bug) becomes RuntimeError here, as in a render, rather than pyo3's PanicException.
    let run = || match cli.command {
        Command::Analyze(a) => json(reflect::cli::analyze::analyze(&a)),
        Command::Invert(InvertCommand::Lighting(a)) => json(reflect::cli::invert::invert_lighting_report(&a)),
        Command::Invert(InvertCommand::Brdf(a)) => json(reflect::cli::invert::invert_brdf_report(&a)),
        Command::Invert(InvertCommand::Separate(a)) => json(reflect::cli::separate::separate_report(&a)),
        Command::Invert(InvertCommand::Factor(a)) => json(reflect::cli::factor::factor_report(&a)),
        _ => Err(Error::new("only analyze and invert lighting|brdf|separate|factor return a report here")),
    };
    let doc = py
        .detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)))
        .map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("the command panicked (a bug in reflect)"))?
        .py()?;
    to_python(py, &doc)
}

/// `write_image(path, channels, attributes)`: writes an OpenEXR file (32-bit float) with the
/// given (H, W) float32 channels by name and string attributes, as `reflect render` writes its
/// layers and header; the inverse of `read_image`.
#[pyfunction]
pub fn write_image(
    py: Python<'_>,
    path: PathBuf,
    channels: BTreeMap<String, PyReadonlyArray2<'_, f32>>,
    attributes: BTreeMap<String, String>,
) -> PyResult<()> {
    let mut img = Image { attributes, ..Default::default() };
    let mut shape = None;
    for (name, a) in &channels {
        let a = a.as_array();
        let (h, w) = a.dim();
        if *shape.get_or_insert((h, w)) != (h, w) {
            return Err(PyValueError::new_err(format!(
                "channel {name} has shape ({h}, {w}), the others {:?}",
                shape.unwrap_or_default()
            )));
        }
        if let Some(((r, c), v)) = a.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(PyValueError::new_err(format!("channel {name}: non-finite value {v} at row {r}, column {c}")));
        }
        img.channels.insert(name.clone(), a.iter().copied().collect());
    }
    let (h, w) = shape.ok_or_else(|| PyValueError::new_err("an image needs at least one channel"))?;
    (img.height, img.width) = (h, w);
    py.detach(|| write_exr(&path, &img)).py()
}

/// `header_attributes(scene)` → the `reflect:camera`, `reflect:lighting` and `reflect:objects`
/// attributes a render of `scene` (a dict with `camera`, `lighting` and `objects` tables in the
/// scene vocabulary) carries in its header: the same serde types as a scene file (unknown keys and
/// bad values are errors, defaults filled in, numbers as the renderer holds them).
#[pyfunction]
pub fn header_attributes(scene: &Bound<'_, PyAny>) -> PyResult<BTreeMap<String, String>> {
    let file: SceneFile = pythonize::depythonize(scene)
        .map_err(|e| PyValueError::new_err(format!("scene: {}", e.to_string().replace('\n', " "))))?;
    let keep = [vocab::header::CAMERA, vocab::header::LIGHTING, vocab::header::OBJECTS];
    Ok(vocab::header::attributes(&file, renderer::output::INTEGRATOR)
        .into_iter()
        .filter(|(k, _)| keep.contains(&k.as_str()))
        .collect())
}

/// `lighting_toml(table)` → a scene file holding only this `[lighting]` table (the scene
/// vocabulary, checked with its serde types), for a command's `--lighting`, which reads only that
/// table of a `.toml` file.
#[pyfunction]
pub fn lighting_toml(table: &Bound<'_, PyAny>) -> PyResult<String> {
    #[derive(serde::Serialize)]
    struct OnlyLighting {
        lighting: vocab::LightingSection,
    }
    let lighting: vocab::LightingSection = pythonize::depythonize(table)
        .map_err(|e| PyValueError::new_err(format!("lighting: {}", e.to_string().replace('\n', " "))))?;
    toml::to_string(&OnlyLighting { lighting }).map_err(|e| PyValueError::new_err(format!("lighting: {e}")))
}
