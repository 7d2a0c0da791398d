//! Shared helpers of the slicer's tests: the paper missions, compiled.
#![allow(dead_code)]

use std::path::PathBuf;

use eamos_lang::SourceFile;
use eamos_petri::Net;

/// The built-in profiles.
pub fn profiles() -> eamos_profile::ProfileTable {
    eamos_profile::builtin()
}

/// The directory of the paper's missions, beside the repository.
pub fn paper_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/missions/paper")
}

/// The checked mission of one paper file (`experiment_b` and the like).
pub fn paper_mission(name: &str) -> eamos_lang::hir::Mission {
    let path = paper_dir().join(format!("{name}.go"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let file = SourceFile::new(format!("{name}.go"), text);
    match eamos_lang::compile(&file, &profiles()) {
        Ok(c) => c.mission,
        Err(d) => panic!("{name} does not compile: {d:?}"),
    }
}

/// The net of one paper mission.
pub fn paper_net(name: &str) -> Net {
    eamos_petri::compile(&paper_mission(name), &profiles())
}

pub const PAPER: &[&str] = &[
    "listing01_demo",
    "experiment_a",
    "experiment_b",
    "experiment_c",
    "experiment_d",
];
pub mod gen;
