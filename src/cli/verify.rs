//! `reflect verify`. STUB: renders the default scene until the verifier exists.
use super::Error;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct VerifyArgs {}

pub fn run(_a: VerifyArgs) -> Result<ExitCode, Error> {
    super::render::run(super::render::RenderArgs::default())
}
