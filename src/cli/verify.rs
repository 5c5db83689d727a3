//! `reflect verify [--quick] [--check NAME] [--json] [--verbose] [--out DIR] [--data DIR] [--seed N] [--threads N]`
//!
//! Renders, projects into SH and compares with the paper's analytic predictions (issue 4); see
//! `src/verify/`. Prints a table on stdout (or, with `--json`, the JSON document of docs/src/conventions.md §7
//! on stdout and the table on stderr), progress on stderr (a progress bar on a terminal, else one
//! line per finished check; `--verbose`: a line per render too), and writes `report.md`,
//! `report.html`, `report.json`, SVG plots and PNG pictures of the renders into `--out` (default `out/verify/`). Exit status 1 when a check
//! fails, 2 for bad input (an unknown check name, an unwritable folder, no data folder: see
//! `crate::verify::data`).

use super::Error;
use super::outputs::{Files, Format};
use crate::verify::{self, CHECKS, Ctx, report};
use std::io::{IsTerminal, Write};
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
    /// Print a line per render and per check stage (default: a progress bar on a terminal, else one
    /// line per finished check).
    #[arg(long, short)]
    pub verbose: bool,
    /// Testing aid: compare every check with a deliberately wrong prediction (each must then fail).
    #[arg(long, hide = true)]
    pub wrong_prediction: bool,
    /// Testing aid: after the run, run the checks again against deliberately wrong predictions on
    /// the same renders (kept in memory, not rendered again) and write that run's JSON document to
    /// FILE; the exit status and the report are the first run's.
    #[arg(long, hide = true, value_name = "FILE")]
    pub then_wrong_prediction: Option<PathBuf>,
}

pub fn run(a: VerifyArgs) -> Result<ExitCode, Error> {
    if a.list {
        // Names padded to the longest, so the equations line up whatever a new check is called.
        let w = CHECKS.iter().map(|e| e.name.chars().count()).max().unwrap_or(0);
        for e in CHECKS {
            println!("{:<w$} {}", e.name, e.equation);
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
    let mut files = Files::new()
        .input("the probe", data.join(verify::data::GRACE_FILE))
        .output("the report (--out)", a.out.join("report.md"), Format::Markdown)
        .output("the report (--out)", a.out.join("report.html"), Format::Html)
        .output("the report (--out)", a.out.join("report.json"), Format::Json);
    if let Some(f) = &a.then_wrong_prediction {
        files = files.output("--then-wrong-prediction", f, Format::Json);
    }
    files.check()?;
    std::fs::create_dir_all(&a.out)
        .map_err(|e| Error::file(&a.out, format!("cannot create the report folder: {e}")))?;
    let ctx = Ctx {
        quick: a.quick,
        wrong: a.wrong_prediction,
        seed: a.seed,
        out: a.out.clone(),
        verbose: a.verbose,
        data,
        cancel: None,
    };
    if a.then_wrong_prediction.is_some() {
        verify::scenes::keep_renders();
    }
    let t = std::time::Instant::now();
    // On a terminal (and without --verbose) a progress bar naming the running check; otherwise one
    // line per finished check on stderr (and, with --verbose, a line when each starts).
    let bar = if !a.verbose && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(selected.len() as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} checks, {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(b)
    } else {
        None
    };
    let checks = super::render::with_threads(a.threads, || {
        selected
            .iter()
            .map(|e| {
                match &bar {
                    Some(b) => b.set_message(format!("{} ({})", e.name, e.equation)),
                    None if a.verbose => {
                        eprintln!("[{:6.1} s] {} ({}) …", t.elapsed().as_secs_f64(), e.name, e.equation)
                    }
                    None => {}
                }
                let c = verify::run_entry(&ctx, e);
                match &bar {
                    Some(b) => b.inc(1),
                    None => eprintln!(
                        "[{:6.1} s] {} {} ({:.1} s){}",
                        t.elapsed().as_secs_f64(),
                        e.name,
                        if c.passed() { "PASS" } else { "FAIL" },
                        c.seconds,
                        c.error.as_ref().map(|m| format!(": {m}")).unwrap_or_default()
                    ),
                }
                c
            })
            .collect::<Vec<_>>()
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let seconds = t.elapsed().as_secs_f64();
    let doc = report::Report::new(&checks, a.quick, seconds);
    if a.json {
        eprint!("{doc}");
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{}", serde_json::to_string_pretty(&doc).unwrap_or_default());
    } else {
        print!("{doc}");
    }
    report::write_folder(&a.out, &checks, a.quick, seconds).map_err(|m| Error::file(&a.out, m))?;
    if let Some(file) = &a.then_wrong_prediction {
        let wrong_ctx = Ctx { wrong: true, ..ctx.clone() };
        let t2 = std::time::Instant::now();
        let wrong = super::render::with_threads(a.threads, || {
            selected
                .iter()
                .map(|e| {
                    let c = verify::run_entry(&wrong_ctx, e);
                    eprintln!(
                        "[{:6.1} s] wrong prediction: {} {} ({:.1} s)",
                        t2.elapsed().as_secs_f64(),
                        e.name,
                        if c.passed() { "PASS" } else { "FAIL" },
                        c.seconds
                    );
                    c
                })
                .collect::<Vec<_>>()
        })?;
        let doc = report::json(&wrong, a.quick, t2.elapsed().as_secs_f64());
        std::fs::write(file, serde_json::to_string_pretty(&doc).unwrap_or_default())
            .map_err(|e| Error::file(file, e.to_string()))?;
    }
    eprintln!("report: {} (wall time {seconds:.1} s)", a.out.join("report.html").display());
    Ok(if checks.iter().all(|c| c.passed()) { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
