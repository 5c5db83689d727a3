//! `reflect`: render, analyse and verify (see README.md).

use clap::Parser;
use reflect::cli;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = match cli::Cli::try_parse() {
        Ok(a) => a,
        // --help and --version print in full and exit 0.
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => {
            // A usage error is bad input like any other: one line (clap's message up to its usage
            // block, continuation lines such as the missing argument names joined on), pointing at
            // --help instead of the multi-line usage; exit status 2.
            let text = e.render().to_string();
            let msg: Vec<&str> = text
                .lines()
                .map(str::trim)
                .skip_while(|l| l.is_empty())
                .take_while(|l| !l.is_empty() && !l.starts_with("Usage:"))
                .collect();
            eprintln!("{} (see reflect --help)", msg.join(" "));
            return ExitCode::from(2);
        }
    };
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            // One line naming the file and the problem; exit status 2 (bad input).
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
