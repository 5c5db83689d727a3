//! `reflect bench [--quick] [--scenes A,B] [--peers auto|none|mitsuba] [--json] [--out DIR]`: parses
//! the flags into [`crate::bench::BenchParams`], runs [`crate::bench::run`] and prints its report
//! (a table on stdout, or with `--json` the JSON document on stdout and the table on stderr; the
//! JSON is also written to `DIR/bench.json`).

use super::Error;
use super::outputs::{Files, Format};
use crate::bench::{self, BenchParams, peers::PeerChoice, suite};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// The quick suite (lambert-grace, beckmann-grace, mesh-sky; 2 seeds; a smaller reference):
    /// under 5 minutes on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Scenes to run, comma-separated (default: the whole suite, or the quick set); --list names them.
    #[arg(long, value_name = "A,B")]
    pub scenes: Option<String>,
    /// List the suite's scenes and exit.
    #[arg(long)]
    pub list: bool,
    /// The RMS relative error whose time is measured.
    #[arg(long, default_value_t = 0.01, value_name = "X")]
    pub target_rel_error: f64,
    /// Seeds per series [default: 2 with --quick, else 3].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=32))]
    pub seeds: Option<u32>,
    /// Image side in pixels.
    #[arg(long, default_value_t = 128, value_name = "N", value_parser = clap::value_parser!(u32).range(16..=2048))]
    pub size: u32,
    /// Worker threads of every render, ours and the peers'.
    #[arg(long, value_parser = super::render::parse_threads)]
    pub threads: Option<usize>,
    /// Peers in the same run: auto (Mitsuba 3 when its Python package imports), none, mitsuba (required).
    #[arg(long, default_value = "auto", value_parser = ["auto", "none", "mitsuba"])]
    pub peers: String,
    /// The Python that runs the peers.
    #[arg(long, default_value = "python3", value_name = "PATH")]
    pub python: PathBuf,
    /// Work folder: references (kept and reused), scene files, bench.json.
    #[arg(long, default_value = "out/bench", value_name = "DIR")]
    pub out: PathBuf,
    /// Data folder holding the maps [default: as `reflect verify --data`].
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Print the JSON document on stdout (the table then goes to stderr).
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: BenchArgs) -> Result<ExitCode, Error> {
    if a.list {
        for s in suite::SUITE {
            println!("{:<24} {}{}", s.name, if s.quick { "quick " } else { "" }, s.mitsuba.map_or("", |_| "mitsuba"));
        }
        return Ok(ExitCode::SUCCESS);
    }
    if !(a.target_rel_error > 0.0 && a.target_rel_error < 1.0) {
        return Err(Error::new(format!("--target-rel-error must be in (0, 1), got {}", a.target_rel_error)));
    }
    let scenes = suite::select(a.scenes.as_deref(), a.quick).map_err(Error::new)?;
    let data = crate::verify::data::resolve(a.data.as_deref()).map_err(Error::new)?;
    let json_out = a.out.join("bench.json");
    Files::new().output("the report (--out)", &json_out, Format::Json).check()?;
    let exe = std::env::current_exe().map_err(|e| Error::new(format!("cannot find this executable: {e}")))?;
    let threads = a.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let peers = match a.peers.as_str() {
        "none" => PeerChoice::None,
        "mitsuba" => PeerChoice::Mitsuba { python: a.python.clone() },
        _ => PeerChoice::Auto { python: a.python.clone() },
    };
    let params = BenchParams {
        scenes,
        size: a.size,
        target: a.target_rel_error,
        seeds: a.seeds.unwrap_or(if a.quick { 2 } else { 3 }),
        ladder: if a.quick { vec![16, 64, 256, 1024] } else { vec![16, 64, 256, 1024, 4096] },
        reference_spp: if a.quick { 4096 } else { 65536 },
        threads,
        work: a.out.clone(),
        data,
        exe,
        peers,
    };
    let report = bench::run(&params, |line| eprintln!("{line}")).map_err(|e| Error::new(e.to_string()))?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| Error::new(format!("JSON: {e}")))?;
    std::fs::write(&json_out, &json).map_err(|e| Error::file(&json_out, e.to_string()))?;
    if a.json {
        eprintln!("{report}");
        println!("{json}");
    } else {
        println!("{report}");
    }
    Ok(ExitCode::SUCCESS)
}
