//! `eamos build MISSION`: compile a mission and say what it amounts to.
//!
//! Glue only: the front end (`eamos-lang`) checks the mission against the
//! built-in capability profiles and counts it; this prints the result.
//! Exit status: 0 compiled (warnings, if any, on standard error), 2 bad input
//! (an unreadable file or a mission with errors, reported on standard error).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use eamos_lang::{SourceFile, Style};
use serde_json::json;

/// Compile a mission and print a summary of it: drones and their types, the
/// number of action instances (per drone), block instances (SEQ / PAR),
/// control structures by kind and events. Errors are reported with file,
/// line and column; the exit status is 2 if there are any.
#[derive(clap::Args)]
pub struct Args {
    /// The mission file (a subset of Go).
    pub mission: PathBuf,
    /// Print the summary, or the diagnostics with their codes and positions,
    /// as JSON on standard output.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> ExitCode {
    let name = args.mission.display().to_string();
    let text = match std::fs::read_to_string(&args.mission) {
        Ok(t) => t,
        Err(e) => {
            let message = format!("cannot read {name}: {e}");
            if args.json {
                println!("{}", json!({ "file": name, "error": message }));
            }
            eprintln!("error: {message}");
            return ExitCode::from(2);
        }
    };
    let source = SourceFile::new(name, text);
    let profiles = eamos_mid::profiles::builtin();
    let style = Style {
        width: 100,
        colour: !args.json
            && std::io::stderr().is_terminal()
            && std::env::var_os("NO_COLOR").is_none(),
    };
    match eamos_lang::compile(&source, &profiles) {
        Ok(compiled) => {
            let summary = compiled.mission.summary();
            if args.json {
                let warnings: Vec<_> = compiled
                    .warnings
                    .iter()
                    .map(|d| d.record(&source))
                    .collect();
                println!(
                    "{}",
                    json!({ "file": source.name, "summary": summary, "warnings": warnings })
                );
            } else {
                if !compiled.warnings.is_empty() {
                    eprint!(
                        "{}",
                        eamos_lang::render_all(&compiled.warnings, &source, style)
                    );
                }
                print!("{summary}");
            }
            ExitCode::SUCCESS
        }
        Err(diags) => {
            if args.json {
                let records: Vec<_> = diags.iter().map(|d| d.record(&source)).collect();
                println!("{}", json!({ "file": source.name, "diagnostics": records }));
            }
            eprint!("{}", eamos_lang::render_all(&diags, &source, style));
            ExitCode::from(2)
        }
    }
}
