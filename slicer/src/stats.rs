//! Per-drone figures of a slicing, the columns of the paper's Table 7.

use serde::{Deserialize, Serialize};

use crate::distribute::Slices;
use crate::slice::Slice;

/// Figures of one slice.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SliceStats {
    pub drone: String,
    pub places: usize,
    pub transitions: usize,
    /// Arcs between this slice's own nodes (consume, read and produce).
    pub internal_arcs: usize,
    pub bridges_in: usize,
    pub bridges_out: usize,
    /// Size of the binary slice file in bytes.
    pub binary_bytes: usize,
    /// Size of the JSON slice file in bytes.
    pub json_bytes: usize,
}

/// Figures of every slice of a mission.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Statistics {
    pub mission: String,
    pub mission_id: String,
    /// All bridges of the mission (each counted once).
    pub bridges: usize,
    pub slices: Vec<SliceStats>,
}

impl SliceStats {
    pub fn of(slice: &Slice) -> SliceStats {
        SliceStats {
            drone: slice.drone.clone(),
            places: slice.places.len(),
            transitions: slice.transitions.len(),
            internal_arcs: slice.internal_arcs(),
            bridges_in: slice.bridges_in.len(),
            bridges_out: slice.bridges_out.len(),
            binary_bytes: slice.to_bytes().len(),
            json_bytes: slice.to_json().len(),
        }
    }
}

impl Statistics {
    pub fn of(slices: &Slices) -> Statistics {
        Statistics {
            mission: slices.mission.clone(),
            mission_id: slices.mission_id.clone(),
            bridges: slices.bridge_count(),
            slices: slices.slices.iter().map(SliceStats::of).collect(),
        }
    }

    /// A plain-text table, one row per slice.
    pub fn table(&self) -> String {
        let head = [
            "slice",
            "places",
            "transitions",
            "internal arcs",
            "bridges in",
            "bridges out",
            "binary bytes",
            "json bytes",
        ];
        let rows: Vec<[String; 8]> = self
            .slices
            .iter()
            .map(|s| {
                [
                    s.drone.clone(),
                    s.places.to_string(),
                    s.transitions.to_string(),
                    s.internal_arcs.to_string(),
                    s.bridges_in.to_string(),
                    s.bridges_out.to_string(),
                    s.binary_bytes.to_string(),
                    s.json_bytes.to_string(),
                ]
            })
            .collect();
        let mut width: Vec<usize> = head.iter().map(|h| h.len()).collect();
        for r in &rows {
            for (w, c) in width.iter_mut().zip(r) {
                *w = (*w).max(c.len());
            }
        }
        let line = |cells: Vec<&str>| {
            let mut s = String::new();
            for (i, (c, w)) in cells.iter().zip(&width).enumerate() {
                if i == 0 {
                    s.push_str(&format!("{c:<w$}"));
                } else {
                    s.push_str(&format!("  {c:>w$}"));
                }
            }
            s.trim_end().to_string() + "\n"
        };
        let mut out = line(head.to_vec());
        for r in &rows {
            out.push_str(&line(r.iter().map(String::as_str).collect()));
        }
        out.push_str(&format!("{} bridges in all\n", self.bridges));
        out
    }
}
