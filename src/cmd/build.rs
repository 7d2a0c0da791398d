//! `eamos build MISSION`: compile a mission and say what it amounts to.
//!
//! Glue only: the front end (`eamos-lang`) checks the mission against the
//! built-in capability profiles and counts it; this prints the result.
//! Exit status: 0 compiled (warnings, if any, on standard error), 2 bad input
//! (an unreadable file or a mission with errors, reported on standard error).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use eamos_fleet::identity::{fleet_version, MissionId};
use eamos_lang::{SourceFile, Style};
use serde_json::json;

/// Compile a mission and print a summary of it: drones and their types, the
/// number of action instances (per drone), block instances (SEQ / PAR),
/// control structures by kind and events, then the size of its Petri net
/// per drone. Errors are reported with file, line and column; the exit
/// status is 2 if there are any.
#[derive(clap::Args)]
pub struct Args {
    /// The mission file (a subset of Go).
    pub mission: PathBuf,
    /// Print the summary, or the diagnostics with their codes and positions,
    /// as JSON on standard output.
    #[arg(long)]
    pub json: bool,
    /// Write the mission's Petri net into DIR as `net.pnml` (PNML P/T net),
    /// `net.dot` (Graphviz) and `net.graphml`, and one slice per drone (and
    /// the ground station) as `slice-<drone>.json`, `slice-<drone>.bin` and
    /// `net-<drone>.dot`, with `slices.json` naming the mission they cut.
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// In `net.pnml`, add a transition `final_loop` on the place `final`, so
    /// that model checkers tell proper termination from a deadlock.
    #[arg(long)]
    pub pnml_final_loop: bool,
    /// The fleet file the slices written with `--out` will fly with: they
    /// carry the identity of the mission and this fleet, as `eamos run
    /// --fleet` computes it, so that `eamos run --slices DIR --drone D
    /// --fleet FLEET.toml` flies them. Without it, the default fleet's.
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: Option<PathBuf>,
}

/// Writes the net's exports into `dir` (created if needed); the paths
/// written, or a message naming the path that failed.
fn write_net(
    net: &eamos_petri::Net,
    source: &SourceFile,
    dir: &std::path::Path,
    final_loop: bool,
) -> Result<Vec<PathBuf>, String> {
    use eamos_petri::export::{dot, graphml, pnml};
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let locate = |s: eamos_lang::Span| source.location(s);
    let opts = pnml::PnmlOptions {
        final_loop,
        locate: Some(&locate),
    };
    let files = [
        ("net.pnml", pnml::to_pnml(net, &opts)),
        ("net.dot", dot::to_dot(net)),
        ("net.graphml", graphml::to_graphml(net)),
    ];
    let mut written = Vec::new();
    for (file, text) in files {
        let path = dir.join(file);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

pub fn run(args: Args) -> ExitCode {
    let name = args.mission.display().to_string();
    let bytes = match std::fs::read(&args.mission) {
        Ok(b) => b,
        Err(e) => {
            let message = format!("cannot read {name}: {e}");
            if args.json {
                println!("{}", json!({ "file": name, "error": message }));
            }
            eprintln!("error: {message}");
            return ExitCode::from(2);
        }
    };
    let style = Style {
        width: 100,
        colour: !args.json
            && std::io::stderr().is_terminal()
            && std::env::var_os("NO_COLOR").is_none(),
    };
    let source = match eamos_lang::decode(name, bytes) {
        Ok(source) => source,
        Err((source, diags)) => return bad_mission(&args, &source, &diags, style),
    };
    let profiles = eamos_profile::builtin();
    match eamos_lang::compile(&source, &profiles) {
        Ok(compiled) => {
            let eamos_lang::Compiled { mission, warnings } = compiled;
            let summary = mission.summary();
            // The front end is done: its code and its freed heap go back
            // before the net and the slices take their memory (2.4 MB off
            // the stress mission's peak).
            eamos_trim::after_phase();
            let net = eamos_petri::compile(&mission, &profiles);
            // Nothing below reads the checked mission: freed now, the slicer
            // reuses its memory instead of adding to it.
            drop(mission);
            let net_stats = eamos_petri::stats::stats(&net);
            let fleet =
                eamos_fleet::Fleet::load_or_default(args.fleet.as_deref(), &net.name, &net.drones);
            let fleet = match fleet {
                Ok(fleet) => fleet,
                Err(e) => return failed(&args, &source, &e.to_string()),
            };
            // The net's exports are written before the slicer is handed the
            // net, which it frees once distributed (see `Handed`).
            let written = match &args.out {
                None => Vec::new(),
                Some(dir) => match write_net(&net, &source, dir, args.pnml_final_loop) {
                    Ok(written) => written,
                    Err(message) => return failed(&args, &source, &message),
                },
            };
            let net_id = eamos_slicer::net_id(&net);
            let id = MissionId::new(&net.name, &net_id, &fleet_version(&fleet));
            let slices = match eamos_slicer::slice_as(net, id.as_str()) {
                Ok(slices) => slices,
                Err(e) => {
                    let message = format!("cannot slice the net of {}: {e}", source.name);
                    return failed(&args, &source, &message);
                }
            };
            let slice_stats = eamos_slicer::Statistics::of(&slices);
            let slices_written = match &args.out {
                None => Vec::new(),
                Some(dir) => match write_slices(&slices, &net_id, dir) {
                    Ok(written) => written,
                    Err(message) => return failed(&args, &source, &message),
                },
            };
            if args.json {
                let records: Vec<_> = warnings.iter().map(|d| d.record(&source)).collect();
                println!(
                    "{}",
                    json!({
                        "file": source.name,
                        "summary": summary,
                        "warnings": records,
                        "net": net_stats,
                        "slices": slice_stats,
                        "written": written,
                        "slices_written": slices_written,
                    })
                );
            } else {
                if !warnings.is_empty() {
                    eprint!("{}", eamos_lang::render_all(&warnings, &source, style));
                }
                print!("{summary}");
                print!("\n{net_stats}");
                print!(
                    "\nslices (one per drone, bridges between them):\n{}",
                    slice_stats.table()
                );
                for path in written.iter().chain(&slices_written) {
                    println!("wrote {}", path.display());
                }
            }
            ExitCode::SUCCESS
        }
        Err(diags) => bad_mission(&args, &source, &diags, style),
    }
}

/// Writes each peer's slice into `dir` and the manifest naming the mission
/// they cut; the paths written.
fn write_slices(
    slices: &eamos_slicer::Slices,
    net_id: &str,
    dir: &std::path::Path,
) -> Result<Vec<PathBuf>, String> {
    let files = eamos_slicer::write_dir(slices, dir)
        .map_err(|e| format!("cannot write slices into {}: {e}", dir.display()))?;
    let mut written: Vec<PathBuf> = files
        .into_iter()
        .flat_map(|f| [f.json, f.binary, f.dot])
        .collect();
    written.push(super::slices::write_manifest(
        dir,
        &super::slices::Manifest {
            mission: slices.mission.clone(),
            net: net_id.to_string(),
            drones: slices.drones.clone(),
            identity: slices.mission_id.clone(),
        },
    )?);
    Ok(written)
}

/// A mission compiled that cannot be written or sliced: the message on
/// standard error (and, with `--json`, on standard output), exit status 2.
fn failed(args: &Args, source: &SourceFile, message: &str) -> ExitCode {
    if args.json {
        println!("{}", json!({ "file": source.name, "error": message }));
    }
    eprintln!("error: {message}");
    ExitCode::from(2)
}

/// A mission that does not compile (or cannot even be decoded): its
/// diagnostics on standard error (and, with `--json`, on standard output),
/// exit status 2.
fn bad_mission(
    args: &Args,
    source: &SourceFile,
    diags: &[eamos_lang::Diagnostic],
    style: Style,
) -> ExitCode {
    if args.json {
        let records: Vec<_> = diags.iter().map(|d| d.record(source)).collect();
        println!("{}", json!({ "file": source.name, "diagnostics": records }));
    }
    eprint!("{}", eamos_lang::render_all(diags, source, style));
    ExitCode::from(2)
}
