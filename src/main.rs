//! `reflect`: render, analyse and verify (see README.md and the guide in docs/).

use clap::Parser;
use reflect::cli;
use std::process::ExitCode;

fn main() -> ExitCode {
    restore_default_sigpipe();
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

/// Restores the default action of SIGPIPE (terminate quietly), as every Unix filter has it: the
/// Rust runtime ignores SIGPIPE, so a write to a closed pipe (`reflect sh project … | head -1`)
/// returns EPIPE and `println!` panics with a message. With the default action the process ends
/// silently at the first write after the reader has gone, like `cat` or `yes`.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any other thread exists; `signal` with
    // `SIG_DFL` only changes the disposition of one signal.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
