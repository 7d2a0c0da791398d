//! Drawings of slices in Graphviz DOT, as the paper draws its Mission
//! Dependency Graphs: the slice's own nodes filled in its drone's colour,
//! the remote ends of bridges dashed in the peer's colour.

use std::fmt::Write;

use eamos_lang::hir::DroneId;
use eamos_petri::export::owner_colour;
use eamos_petri::net::Owner;

use crate::slice::{Slice, GCS};

/// The fill colour of a drone or of the ground station: the palette of
/// petri's DOT export, so that a slice and the whole net agree.
pub fn colour_of(slice: &Slice, name: &str) -> &'static str {
    let owner = match slice.drones.iter().position(|d| d == name) {
        Some(i) if name != GCS => Owner::Drone(DroneId(i as u16)),
        _ => Owner::Gcs,
    };
    owner_colour(owner)
}

fn esc(s: &str) -> String {
    s.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// The slice as a DOT digraph.
pub fn to_dot(slice: &Slice) -> String {
    let mine = colour_of(slice, &slice.drone);
    let mut out = String::new();
    let _ = writeln!(out, "digraph \"net-{}\" {{", esc(&slice.drone));
    let _ = writeln!(
        out,
        "  label=\"{}: slice of {}\";\n  labelloc=t;\n  rankdir=TB;\n  node [fontname=\"Helvetica\", fontsize=10, style=filled, fillcolor=\"{mine}\"];\n  edge [fontname=\"Helvetica\", fontsize=9];",
        esc(&slice.mission),
        esc(&slice.drone)
    );
    for (i, p) in slice.places.iter().enumerate() {
        let marked = slice.initial_marking.contains(&(i as u32));
        let shape = if slice.final_place == Some(i as u32) {
            "doublecircle"
        } else {
            "circle"
        };
        let label = if marked {
            format!("{}\\n●", esc(&p.label))
        } else {
            esc(&p.label)
        };
        let _ = writeln!(
            out,
            "  p{i} [shape={shape}, label=\"{label}\", tooltip=\"{}\"];",
            esc(&p.id)
        );
    }
    for (i, t) in slice.transitions.iter().enumerate() {
        let tr = &t.transition;
        let _ = writeln!(
            out,
            "  t{i} [shape=box, label=\"{}\", tooltip=\"{}\"];",
            esc(&tr.label),
            esc(&tr.id)
        );
        for &p in &t.consume {
            let _ = writeln!(out, "  p{p} -> t{i};");
        }
        for &p in &t.read {
            let _ = writeln!(out, "  p{p} -> t{i} [style=dotted, arrowhead=odot];");
        }
        for pr in &t.produce {
            let _ = writeln!(out, "  t{i} -> p{};", pr.place);
        }
    }
    for b in &slice.bridges_out {
        let c = colour_of(slice, &b.to);
        let _ = writeln!(
            out,
            "  out{id} [shape=circle, style=\"dashed,filled\", fillcolor=\"{c}\", label=\"{}\\nbridge {id}\"];\n  t{} -> out{id} [style=dashed, color=\"#555555\"];",
            esc(&b.to),
            b.transition,
            id = b.id
        );
    }
    for b in &slice.bridges_in {
        let c = colour_of(slice, &b.from);
        let _ = writeln!(
            out,
            "  in{id} [shape=box, style=\"dashed,filled\", fillcolor=\"{c}\", label=\"{}\\nbridge {id}\"];\n  in{id} -> p{} [style=dashed, color=\"#555555\"];",
            esc(&b.from),
            b.inbox,
            id = b.id
        );
    }
    out.push_str("}\n");
    out
}
