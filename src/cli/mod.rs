//! The command line: one file per subcommand.

pub mod analyze;
pub mod args;
pub mod bench;
pub mod compare;
pub mod factor;
pub mod flags;
pub mod header;
pub mod invert;
pub mod merge;
pub mod outputs;
pub mod passes;
pub mod png;
pub mod render;
pub mod rounds;
pub mod separate;
pub mod sh;
pub mod slurm;
pub mod verify;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

pub type Error = analysis::Error;

#[derive(Parser, Debug)]
#[command(name = "reflect", version, about = "Path tracer and verifier of the frequency-space theory of reflection")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (TOML) to OpenEXR.
    Render(render::RenderArgs),
    /// Spherical-harmonic tools: project environments, transfer coefficients.
    #[command(subcommand)]
    Sh(sh::ShCommand),
    /// Project renders (EXR) into SH and compare with the lighting.
    Analyze(analyze::AnalyzeArgs),
    /// Inverse rendering: recover the lighting (eq. 17) or the BRDF (eq. 16) from renders of a sphere.
    #[command(subcommand)]
    Invert(invert::InvertCommand),
    /// Render, analyse and check the paper's claims; report with error bars.
    Verify(verify::VerifyArgs),
    /// Merge partial renders (shards) into the image a single render writes, bit for bit.
    Merge(merge::MergeArgs),
    /// Run renders on a Slurm cluster (a job array of shards and a merge job).
    #[command(subcommand)]
    Slurm(slurm::SlurmCommand),
    /// Is image A image B up to their noise? Exit 0: they agree, 1: they differ, 2: bad input.
    Compare(compare::CompareArgs),
    /// Tone-mapped sRGB PNG preview of an image (not an analysis input).
    Png(png::PngArgs),
    /// Benchmark: time to a target error on the paper's scenes, per phase, beside peers if installed.
    Bench(bench::BenchArgs),
}

pub fn run(cli: Cli) -> Result<ExitCode, Error> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Sh(c) => sh::run(c),
        Command::Analyze(a) => analyze::run(a),
        Command::Invert(c) => invert::run(c),
        Command::Verify(a) => verify::run(a),
        Command::Png(a) => png::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Slurm(c) => slurm::run(c),
        Command::Bench(a) => bench::run(a),
    }
}

/// Prints a report's warnings on stderr, one `warning: …` line each: the one place every analysis
/// command says them (the text report on stdout does not repeat them; `--json` keeps its
/// `warnings` array).
pub fn print_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// A path in this process's scratch folder for a CLI module's unit tests (created on demand).
#[cfg(test)]
pub fn test_path(module: &str, name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("reflect-cli-{module}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}
