//! `eamos build MISSION`: compile a mission.

use std::path::PathBuf;
use std::process::ExitCode;

/// Compile a mission and print a summary of it.
#[derive(clap::Args)]
pub struct Args {
    /// The mission file (Go syntax).
    pub mission: PathBuf,
}

pub fn run(_args: Args) -> ExitCode {
    eprintln!("eamos build: not implemented yet");
    ExitCode::from(2)
}
