//! The missions and slices the probes read, written once per report, and
//! what the table says about them.

use std::path::{Path, PathBuf};

use eamos_lang::SourceFile;

use crate::workload::{self, MissionSpec, SMALL, STRESS, STRESS_WITHOUT_CHOICES};

/// The files the probes read, and what the table says about them.
pub struct Facts {
    pub small: MissionFacts,
    pub stress: MissionFacts,
    /// The stress mission without choices (only checked).
    pub without_choices: PathBuf,
}

pub struct MissionFacts {
    pub spec: MissionSpec,
    pub mission: PathBuf,
    pub slice: PathBuf,
    /// The largest drone slice: its drone, places, transitions, bytes.
    pub drone: String,
    pub places: usize,
    pub transitions: usize,
    pub bytes: usize,
    pub meg_nodes: usize,
}

/// Writes the two paper missions and their largest drone slices.
pub fn prepare(dir: &Path) -> Result<Facts, String> {
    let files = dir.join("files");
    std::fs::create_dir_all(&files)
        .map_err(|e| format!("cannot create {}: {e}", files.display()))?;
    let profiles = eamos_profile::builtin();
    let one = |spec: MissionSpec| -> Result<MissionFacts, String> {
        let text = spec.text();
        let mission = files.join(spec.file_name());
        std::fs::write(&mission, &text)
            .map_err(|e| format!("cannot write {}: {e}", mission.display()))?;
        let source = SourceFile::new(mission.display().to_string(), text);
        let compiled = workload::compile(&source, &profiles)?;
        let meg_nodes = eamos_gen::meg::nodes(&workload::front_end(&source, &profiles)?);
        let largest = workload::largest_drone_slice(&compiled.slices);
        let bytes = largest.to_bytes();
        let slice = files.join(format!(
            "{}-{}.slice",
            spec.file_name().trim_end_matches(".go"),
            largest.drone
        ));
        std::fs::write(&slice, &bytes)
            .map_err(|e| format!("cannot write {}: {e}", slice.display()))?;
        Ok(MissionFacts {
            spec,
            mission,
            slice,
            drone: largest.drone.clone(),
            places: largest.places.len(),
            transitions: largest.transitions.len(),
            bytes: bytes.len(),
            meg_nodes,
        })
    };
    let without_choices = files.join(STRESS_WITHOUT_CHOICES.file_name());
    std::fs::write(&without_choices, STRESS_WITHOUT_CHOICES.text())
        .map_err(|e| format!("cannot write {}: {e}", without_choices.display()))?;
    Ok(Facts {
        small: one(SMALL)?,
        stress: one(STRESS)?,
        without_choices,
    })
}

pub fn path_str(p: &Path) -> Result<&str, String> {
    p.to_str()
        .ok_or_else(|| format!("{} is not valid UTF-8", p.display()))
}
