//! `eamos check FILE`: prove a mission safe to start before anything flies.
//!
//! A `.go` file is compiled (front end, then net compiler) and its net
//! checked against the built-in profiles; a `.pnml` file is read as a plain
//! P/T net, so the checker can be compared with other Petri net tools.
//! Exit status: 0 nothing found and every property decided, 1 findings,
//! 2 bad input, 3 nothing found but some property undecided (the
//! exploration stopped at its memory bound).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use eamos_lang::{SourceFile, Style};
use eamos_verify::{Goal, Options, Report};
use serde_json::json;

/// Prove a mission (or a PNML net) free of deadlocks, endless waits, drone
/// conflicts and dead code, before anything flies.
#[derive(clap::Args)]
pub struct Args {
    /// The mission (`.go`) or a P/T net (`.pnml`).
    pub file: PathBuf,
    /// Print the report as JSON (schema `eamos-check/1`) on standard output.
    #[arg(long)]
    pub json: bool,
    /// Stop exploring past this many megabytes, with partial verdicts.
    #[arg(long, value_name = "MB", default_value_t = 4096)]
    pub max_memory: u64,
    /// Explore every interleaving instead of using stubborn sets (slower;
    /// for comparison with other tools).
    #[arg(long)]
    pub no_reduction: bool,
    /// The fleet file: the drones' homes and the airspace (fence, ceiling,
    /// floor, separation) the spatial properties are checked against.
    /// Without one: the homes `eamos run` uses, no fence, no ceiling.
    #[arg(long, value_name = "FLEET")]
    pub fleet: Option<PathBuf>,
    /// Draw the plan view of the spatial findings (homes, fence, the legs
    /// involved, the points of closest approach) to this SVG file.
    #[arg(long, value_name = "FILE")]
    pub svg: Option<PathBuf>,
    /// Leave out the spatial properties (separation, airspace, flight
    /// state): the logic alone, as before a fleet is known, or to time
    /// what they cost.
    #[arg(long)]
    pub no_spatial: bool,
    /// Decide only this property, as model checkers are asked one query:
    /// `deadlock` searches depth-first and stops at the first deadlock.
    #[arg(long, value_enum, value_name = "PROPERTY")]
    pub only: Option<Only>,
    /// With `--only deadlock`: search breadth-first, so that the
    /// counterexample is a shortest one (slower on large nets).
    #[arg(long, requires = "only")]
    pub shortest: bool,
}

/// The properties that can be asked alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Only {
    /// Can the net reach a dead marking (before the mission's end)?
    Deadlock,
}

pub fn run(args: Args) -> ExitCode {
    let name = args.file.display().to_string();
    let bytes = match std::fs::read(&args.file) {
        Ok(b) => b,
        Err(e) => {
            return bad_input(
                &args,
                json!({"file": name, "message": format!("cannot read the file: {e}")}),
                &format!("error: cannot read {name}: {e}"),
            )
        }
    };
    let mut options = Options {
        reduction: !args.no_reduction,
        max_memory_mb: args.max_memory,
        progress: if args.json {
            None
        } else {
            eamos_verify::terminal_progress()
        },
        spatial: !args.no_spatial && args.only.is_none(),
        goal: match args.only {
            None => Goal::All,
            Some(Only::Deadlock) => Goal::Deadlock {
                shortest: args.shortest,
            },
        },
        ..Options::default()
    };
    let style = Style {
        width: 100,
        colour: !args.json && std::io::stderr().is_terminal(),
    };
    let source = match eamos_lang::decode(name.clone(), bytes) {
        Ok(source) => source,
        Err((source, diags)) => {
            let records: Vec<_> = diags.iter().map(|d| d.record(&source)).collect();
            return bad_input(
                &args,
                json!({"file": name, "message": "the file is not valid UTF-8", "diagnostics": records}),
                eamos_lang::render_all(&diags, &source, style).trim_end(),
            );
        }
    };
    let report = if is_pnml(&args.file, &source.text) {
        match eamos_verify::pnml::parse(&name, &source.text) {
            Ok(net) => eamos_verify::check_pnml(&net, &options),
            Err(e) => {
                return bad_input(
                    &args,
                    json!({"file": e.file, "line": e.line, "col": e.col, "message": e.message}),
                    &format!("error: {e}"),
                )
            }
        }
    } else {
        let profiles = eamos_profile::builtin();
        match eamos_lang::compile(&source, &profiles) {
            Ok(compiled) => {
                if !compiled.warnings.is_empty() && !args.json {
                    eprint!(
                        "{}",
                        eamos_lang::render_all(&compiled.warnings, &source, style)
                    );
                }
                let net = eamos_petri::compile(&compiled.mission, &profiles);
                // The checker reads the net: the checked mission is freed
                // before it runs, not held through it, and so is what the
                // front end and the net compiler ran.
                drop(compiled);
                eamos_trim::after_phase();
                let fleet = match &args.fleet {
                    Some(path) => match eamos_fleet::Fleet::load(path, &net.name, &net.drones) {
                        Ok(f) => f,
                        Err(e) => {
                            return bad_input(
                                &args,
                                json!({"file": path.display().to_string(), "message": e.to_string()}),
                                &format!("error: {e}"),
                            )
                        }
                    },
                    None => eamos_fleet::Fleet::default(),
                };
                let space = super::mission::space(&fleet, &net.drones);
                options.space = Some(space.clone());
                let report = eamos_verify::check_net(&net, &profiles, Some(&source.text), &options);
                if let Some(svg) = &args.svg {
                    let drawing = super::plan::svg(&report, &space, &net.drones);
                    if let Err(e) = std::fs::write(svg, drawing) {
                        return bad_input(
                            &args,
                            json!({"file": svg.display().to_string(), "message": format!("cannot write the plan view: {e}")}),
                            &format!("error: cannot write {}: {e}", svg.display()),
                        );
                    }
                }
                report
            }
            Err(diags) => {
                let records: Vec<_> = diags.iter().map(|d| d.record(&source)).collect();
                return bad_input(
                    &args,
                    json!({"file": name, "message": "the mission does not compile", "diagnostics": records}),
                    eamos_lang::render_all(&diags, &source, style).trim_end(),
                );
            }
        }
    };
    print_report(&args, &report, &source);
    if report.found_something() {
        ExitCode::from(1)
    } else if report.undecided().next().is_some() {
        ExitCode::from(3)
    } else {
        ExitCode::SUCCESS
    }
}

fn is_pnml(path: &Path, text: &str) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pnml") || e.eq_ignore_ascii_case("xml"))
        || text.trim_start().starts_with("<?xml")
}

fn print_report(args: &Args, report: &Report, source: &SourceFile) {
    if args.json {
        let j = report.to_json(source);
        println!(
            "{}",
            serde_json::to_string_pretty(&j).unwrap_or_else(|_| j.to_string())
        );
    } else {
        let colour = std::io::stdout().is_terminal() && std::env::var_os("NO_COLOR").is_none();
        print!("{}", report.render(source, colour));
    }
}

/// Bad input: an error on standard error (and, with `--json`, an error
/// object on standard output), exit status 2.
fn bad_input(args: &Args, error: serde_json::Value, text: &str) -> ExitCode {
    if args.json {
        println!(
            "{}",
            json!({"schema": "eamos-check/1", "file": args.file.display().to_string(), "error": error})
        );
    }
    eprintln!("{text}");
    ExitCode::from(2)
}
