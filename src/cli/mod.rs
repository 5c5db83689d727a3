//! The command line: one file per subcommand.

pub mod analyze;
pub mod args;
pub mod factor;
pub mod flags;
pub mod header;
pub mod invert;
pub mod merge;
pub mod passes;
pub mod pixels;
pub mod png;
pub mod render;
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
    /// Tone-mapped sRGB PNG preview of an image (not an analysis input).
    Png(png::PngArgs),
}

pub fn run(cli: Cli) -> Result<ExitCode, Error> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Sh(c) => sh::run(c),
        Command::Analyze(a) => analyze::run(a),
        Command::Invert(c) => invert::run(c),
        Command::Verify(a) => verify::run(a),
        Command::Png(a) => png::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Slurm(c) => slurm::run(c),
    }
}

/// A path in this process's scratch folder for a CLI module's unit tests (created on demand).
#[cfg(test)]
pub fn test_path(module: &str, name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("reflect-cli-{module}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}
