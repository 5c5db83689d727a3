//! `reflect analyze`. STUB.
use super::Error;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct AnalyzeArgs {}

pub fn run(_a: AnalyzeArgs) -> Result<ExitCode, Error> {
    Ok(ExitCode::SUCCESS)
}
