//! `pyramid design`.
use std::process::ExitCode;

/// Arguments of `pyramid design`.
#[derive(clap::Args)]
pub struct Args {}

/// Runs `pyramid design`.
pub fn run(_args: &Args) -> ExitCode {
    ExitCode::SUCCESS
}
