//! What the commands that fly a mission (`run`, `deploy`, `abort`) read
//! first, the same way each time: the mission checked, compiled and sliced,
//! the fleet file loaded, and the slices bound to the identity of both, so
//! that every peer and every command agrees on which mission it is.

use std::path::Path;
use std::process::ExitCode;

use eamos_exec::fleet::Fleet;
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
    let name = mission.display().to_string();
    let text = std::fs::read_to_string(mission)
        .map_err(|e| bad_input(&format!("cannot read {name}: {e}")))?;
    let source = SourceFile::new(name.clone(), text);
    let profiles = eamos_profile::builtin();
    let compiled = eamos_lang::compile(&source, &profiles).map_err(|diags| {
        let style = Style { width: 100, colour };
        eprint!("{}", eamos_lang::render_all(&diags, &source, style));
        ExitCode::from(2)
    })?;
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    let mut slices = eamos_slicer::slice(&net)
        .map_err(|e| bad_input(&format!("{name}: cannot slice the mission: {e}")))?;
    let fleet = match fleet {
        Some(path) => Fleet::load(path, &slices.mission, &net.drones)
            .map_err(|e| bad_input(&e.to_string()))?,
        None => Fleet::default(),
    };
    // Peers built from another mission or fleet file refuse this one.
    eamos_exec::identity::bind(&mut slices, &fleet);
    Ok(Mission {
        source,
        profiles,
        net,
        slices,
        fleet,
    })
}
