//! What the commands that fly a mission (`run`, `deploy`, `abort`) read
//! first, the same way each time: the mission checked, compiled and sliced,
//! the fleet file loaded, and the slices bound to the identity of both, so
//! that every peer and every command agrees on which mission it is.

use std::path::Path;
use std::process::ExitCode;

use eamos_fleet::Fleet;
use eamos_lang::{SourceFile, Style};
use eamos_petri::net::Net;
use eamos_profile::ProfileTable;
use eamos_slicer::Slices;

pub struct Mission {
    pub source: SourceFile,
    pub profiles: ProfileTable,
    pub net: Net,
    /// Bound to the identity of mission and fleet.
    pub slices: Slices,
    pub fleet: Fleet,
}

/// The command's exit status for bad input, after saying what was wrong.
pub fn bad_input(message: &str) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(2)
}

/// Reads `mission` and `fleet` (the default fleet without one); on bad input
/// prints the diagnostics (coloured if `colour`) and returns exit status 2.
pub fn load(mission: &Path, fleet: Option<&Path>, colour: bool) -> Result<Mission, ExitCode> {
    cut(read(mission, fleet, colour)?)
}

/// A mission compiled to its net, with its fleet, not yet sliced.
struct Read {
    name: String,
    source: SourceFile,
    profiles: ProfileTable,
    net: Net,
    fleet: Fleet,
}

fn read(mission: &Path, fleet: Option<&Path>, colour: bool) -> Result<Read, ExitCode> {
    let name = mission.display().to_string();
    let bytes =
        std::fs::read(mission).map_err(|e| bad_input(&format!("cannot read {name}: {e}")))?;
    let style = Style { width: 100, colour };
    let report = |source: &SourceFile, diags: &[eamos_lang::Diagnostic]| {
        eprint!("{}", eamos_lang::render_all(diags, source, style));
        ExitCode::from(2)
    };
    let source = eamos_lang::decode(name.clone(), bytes)
        .map_err(|(source, diags)| report(&source, &diags))?;
    let profiles = eamos_profile::builtin();
    let compiled =
        eamos_lang::compile(&source, &profiles).map_err(|diags| report(&source, &diags))?;
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    // The checked mission is the net's now: freed before anything else
    // runs on the net, as `eamos build` does.
    drop(compiled);
    let fleet = Fleet::load_or_default(fleet, &net.name, &net.drones)
        .map_err(|e| bad_input(&e.to_string()))?;
    Ok(Read {
        name,
        source,
        profiles,
        net,
        fleet,
    })
}

/// Cuts the slices under the identity of the net and the fleet: peers
/// built from another mission or fleet file refuse these slices.
fn cut(read: Read) -> Result<Mission, ExitCode> {
    let Read {
        name,
        source,
        profiles,
        net,
        fleet,
    } = read;
    let slices = eamos_fleet::identity::slice(&net, &fleet)
        .map_err(|e| bad_input(&format!("{name}: cannot slice the mission: {e}")))?;
    Ok(Mission {
        source,
        profiles,
        net,
        slices,
        fleet,
    })
}

/// Where the fleet flies, as the checker needs it: every drone's home (the
/// fleet file's, or the default row) and the airspace.
pub fn space(fleet: &Fleet, drones: &[String]) -> eamos_verify::Space {
    eamos_verify::Space {
        homes: fleet.homes(drones),
        airspace: fleet.airspace().clone(),
    }
}

/// [`load`] with [`preflight`] between the compile and the cut: what `run`
/// and `deploy` read before they fly anything. The check runs before the
/// slices exist, so that its memory and theirs are not held at once (a
/// ground station of 250 drones peaked at the check, with every drone's
/// slice beside it). Between the phases, what the one before freed and
/// the code it ran go back to the system (see
/// [`eamos_trim::after_phase`]): the ground station of 250
/// drones compiles, checks and cuts in 17.4-17.9 MiB instead of
/// 19.8-20.6.
pub fn load_to_fly(
    mission: &Path,
    fleet: Option<&Path>,
    colour: bool,
    allow_findings: bool,
) -> Result<Mission, ExitCode> {
    let read = read(mission, fleet, colour)?;
    eamos_trim::after_phase();
    preflight(&read, allow_findings, colour)?;
    eamos_trim::after_phase();
    cut(read)
}

/// Checks the mission with its fleet before it flies. An error finding
/// (a deadlock, two drones that can meet, a leg out of the airspace, a
/// motion before take-off...) stops it, unless the user said
/// `--allow-findings`; either way the findings are printed first.
fn preflight(m: &Read, allow_findings: bool, colour: bool) -> Result<(), ExitCode> {
    let options = eamos_verify::Options {
        space: Some(space(&m.fleet, &m.net.drones)),
        ..eamos_verify::Options::default()
    };
    let report = eamos_verify::check_net(&m.net, &m.profiles, Some(&m.source.text), &options);
    let errors = report.findings.iter().filter(|f| f.kind.is_error()).count();
    if report.findings.is_empty() {
        return Ok(());
    }
    eprint!("{}", report.render(&m.source, colour));
    if errors == 0 {
        return Ok(());
    }
    if allow_findings {
        eprintln!(
            "warning: flying with {errors} error finding(s) of `eamos check`, as --allow-findings says"
        );
        Ok(())
    } else {
        eprintln!(
            "error: `eamos check` found {errors} error(s) in this mission: not flying it (fix them, or fly anyway with --allow-findings)"
        );
        Err(ExitCode::from(1))
    }
}
