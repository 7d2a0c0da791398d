//! A directory of slices written by `eamos build --out DIR`, and a drone's
//! agent flying its own from there (`eamos run --slices DIR --drone D`).
//!
//! Why: a drone's agent that reads the mission compiles and slices the
//! whole of it, every drone's part, to keep its own. For a fleet of 250
//! drones on one computer that is 250 compilations of a 250-drone mission
//! before anything flies. Compiled once, the slices are read in
//! milliseconds, as `eamos agent` gets its slice from `eamos deploy`.
//!
//! The directory says which mission it holds (`slices.json`: the mission's
//! name, its net's hash, its drones). An agent recomputes the identity from
//! those and the fleet file it is given, and flies only a slice that
//! carries that identity: slices built for another fleet file would
//! otherwise wait forever for a ground station that speaks another
//! identity.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use eamos_fleet::identity::{fleet_version, MissionId};
use eamos_fleet::Fleet;
use eamos_slicer::Slice;

/// The file that names the mission of a slices directory.
pub const MANIFEST: &str = "slices.json";

#[derive(Debug, Serialize, Deserialize)]
pub struct Manifest {
    pub mission: String,
    /// The net's hash ([`eamos_slicer::net_id`]): with the fleet's digest,
    /// the mission identity.
    pub net: String,
    pub drones: Vec<String>,
    /// The identity the slices carry, for people reading the file.
    pub identity: String,
}

/// Writes the manifest of `slices` into `dir`; the path written.
pub fn write_manifest(dir: &Path, manifest: &Manifest) -> Result<PathBuf, String> {
    let path = dir.join(MANIFEST);
    let text = serde_json::to_string_pretty(manifest).expect("a manifest always serialises");
    std::fs::write(&path, text + "\n")
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}

/// `drone`'s slice in `dir`, with the fleet it flies with (`fleet`'s file,
/// or the default fleet): an error naming the file when the directory has
/// no such slice, or when its slices were built for another fleet file.
pub fn read(dir: &Path, drone: &str, fleet: Option<&Path>) -> Result<(Slice, Fleet), String> {
    let path = dir.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|e| {
        format!(
            "cannot read {}: {e} (write the slices with `eamos build MISSION --out {}`)",
            path.display(),
            dir.display()
        )
    })?;
    let manifest: Manifest = serde_json::from_str(&text).map_err(|e| {
        format!(
            "{}:{}:{}: not a slices manifest: {e}",
            path.display(),
            e.line(),
            e.column()
        )
    })?;
    if !manifest.drones.iter().any(|d| d == drone) {
        return Err(format!(
            "`{drone}` is not a drone of {} (its drones: {})",
            manifest.mission,
            manifest.drones.join(", ")
        ));
    }
    let fleet = Fleet::load_or_default(fleet, &manifest.mission, &manifest.drones)
        .map_err(|e| e.to_string())?;
    let file = dir.join(format!("slice-{drone}.bin"));
    let bytes = std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let slice = Slice::from_bytes(&bytes).map_err(|e| format!("{}: {e}", file.display()))?;
    let expected = MissionId::new(&manifest.mission, &manifest.net, &fleet_version(&fleet));
    if slice.drone != drone {
        return Err(format!(
            "{} is the slice of {}, not of {drone}",
            file.display(),
            slice.drone
        ));
    }
    if slice.mission_id != expected.as_str() {
        let flown = if fleet.digest.is_empty() {
            "the default fleet (no --fleet)"
        } else {
            "the fleet file given"
        };
        return Err(format!(
            "{} was not built for {flown}: it carries the identity {}, this fleet's is {expected}; \
             build the slices again with that fleet (`eamos build MISSION --fleet FLEET.toml --out {}`)",
            file.display(),
            slice.mission_id,
            dir.display()
        ));
    }
    Ok((slice, fleet))
}
