//! `reflect verify [--quick] [--check NAME] [--json] [--out DIR] [--data DIR] [--seed N] [--threads N]`
//!
//! Renders, projects into SH and compares with the paper's analytic predictions (issue 4); see
//! `src/verify/`. Prints a table on stdout (or, with `--json`, the JSON document of CONVENTIONS §7
//! on stdout and the table on stderr), progress on stderr, and writes `report.md`, `report.html`,
//! `report.json` and SVG plots into `--out` (default `out/verify/`). Exit status 1 when a check
//! fails, 2 for bad input (an unknown check name, an unwritable folder, no data folder: see
//! `crate::verify::data`).

use super::Error;
use crate::verify::{self, CHECKS, Ctx, report};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone)]
pub struct VerifyArgs {
    /// Reduced resolution and samples: every check in < 60 s on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Run only this check (see --list).
    #[arg(long)]
    pub check: Option<String>,
    /// List the checks and exit.
    #[arg(long)]
    pub list: bool,
    /// Print the JSON document on stdout (the table then goes to stderr).
    #[arg(long)]
    pub json: bool,
    /// Report folder.
    #[arg(long, default_value = "out/verify")]
    pub out: PathBuf,
    /// Base random seed of the renders.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Data folder holding grace_probe.hdr [default: $REFLECT_DATA, else ../shared/data from the
    /// current directory, else from the executable's checkout].
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Worker threads [default: all cores].
    #[arg(long, value_parser = super::render::parse_threads)]
    pub threads: Option<usize>,
    /// Testing aid: compare every check with a deliberately wrong prediction (each must then fail).
    #[arg(long, hide = true)]
    pub wrong_prediction: bool,
}

pub fn run(a: VerifyArgs) -> Result<ExitCode, Error> {
    if a.list {
        for e in CHECKS {
            println!("{:<17} {}", e.name, e.equation);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let selected: Vec<&verify::Entry> = match &a.check {
        Some(name) => {
            let e = CHECKS.iter().find(|e| e.name == name.as_str()).ok_or_else(|| {
                Error::new(format!(
                    "unknown check '{name}'; known: {}",
                    CHECKS.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
                ))
            })?;
            vec![e]
        }
        None => CHECKS.iter().collect(),
    };
    // Before any output: a missing probe is bad input (exit 2, one line naming every place looked at).
    let data = verify::data::resolve(a.data.as_deref()).map_err(Error::new)?;
    std::fs::create_dir_all(&a.out)
        .map_err(|e| Error::file(&a.out, format!("cannot create the report folder: {e}")))?;
    let ctx = Ctx { quick: a.quick, wrong: a.wrong_prediction, seed: a.seed, out: a.out.clone(), verbose: true, data };
    let t = std::time::Instant::now();
    let checks = super::render::with_threads(a.threads, || {
        selected
            .iter()
            .map(|e| {
                eprintln!("[{:6.1} s] {} ({}) …", t.elapsed().as_secs_f64(), e.name, e.equation);
                let c = verify::run_entry(&ctx, e);
                eprintln!(
                    "[{:6.1} s] {} {} ({:.1} s){}",
                    t.elapsed().as_secs_f64(),
                    e.name,
                    if c.passed() { "PASS" } else { "FAIL" },
                    c.seconds,
                    c.error.as_ref().map(|m| format!(": {m}")).unwrap_or_default()
                );
                c
            })
            .collect::<Vec<_>>()
    })?;
    let seconds = t.elapsed().as_secs_f64();
    let table = report::table(&checks);
    if a.json {
        eprint!("{table}");
        let doc = report::json(&checks, a.quick, seconds);
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{}", serde_json::to_string_pretty(&doc).unwrap_or_default());
    } else {
        print!("{table}");
    }
    report::write_folder(&a.out, &checks, a.quick, seconds).map_err(|m| Error::file(&a.out, m))?;
    eprintln!("report: {} (wall time {seconds:.1} s)", a.out.join("report.html").display());
    Ok(if checks.iter().all(|c| c.passed()) { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
