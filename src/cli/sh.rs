//! `reflect sh …`. STUB.
use super::Error;
use std::process::ExitCode;

#[derive(clap::Subcommand, Debug)]
pub enum ShCommand {
    /// Project an environment map into SH.
    Project,
}

pub fn run(_c: ShCommand) -> Result<ExitCode, Error> {
    Ok(ExitCode::SUCCESS)
}
