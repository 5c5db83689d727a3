//! `reflect invert separate`: diffuse + specular separation (sec. 3.5, ref. [17]).
//! NOT BUILT YET: the subcommand is wired but refuses to run (exit 2).

use super::Error;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct SeparateArgs {
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_a: &SeparateArgs) -> Result<ExitCode, Error> {
    Err(Error::new("reflect invert separate is not built yet"))
}
