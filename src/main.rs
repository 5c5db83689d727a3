//! `reflect`: render, analyse and verify (see README.md).

mod cli;
mod verify;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            // One line naming the file and the problem; exit status 2 (bad input).
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
