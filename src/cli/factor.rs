//! `reflect invert factor`: light-field factorization (eq. 18, 23).
//! NOT BUILT YET: the subcommand is wired but refuses to run (exit 2).

use super::Error;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct FactorArgs {
    /// Print one JSON document to stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_a: &FactorArgs) -> Result<ExitCode, Error> {
    Err(Error::new("reflect invert factor is not built yet"))
}
