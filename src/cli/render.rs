//! `reflect render`. STUB.
use super::Error;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct RenderArgs {}

pub fn run(_a: RenderArgs) -> Result<ExitCode, Error> {
    Ok(ExitCode::SUCCESS)
}
