//! Writing a mission's slices to a directory.

use std::io;
use std::path::{Path, PathBuf};

use crate::distribute::Slices;
use crate::dot::to_dot;

/// The files written for one slice.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    pub drone: String,
    pub json: PathBuf,
    pub binary: PathBuf,
    pub dot: PathBuf,
}

/// Writes `slice-<drone>.json`, `slice-<drone>.bin` and `net-<drone>.dot` for
/// every slice (the ground station's included) into `dir`, which must exist.
pub fn write_dir(slices: &Slices, dir: &Path) -> io::Result<Vec<Written>> {
    let mut out = Vec::new();
    for s in &slices.slices {
        let w = Written {
            drone: s.drone.clone(),
            json: dir.join(format!("slice-{}.json", s.drone)),
            binary: dir.join(format!("slice-{}.bin", s.drone)),
            dot: dir.join(format!("net-{}.dot", s.drone)),
        };
        std::fs::write(&w.json, s.to_json())?;
        std::fs::write(&w.binary, s.to_bytes())?;
        std::fs::write(&w.dot, to_dot(s))?;
        out.push(w);
    }
    Ok(out)
}
