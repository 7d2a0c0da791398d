//! Graphviz DOT, drawn as the paper draws its mission graphs: every node
//! filled with its owner's colour, places as circles, transitions as boxes
//! labelled with the action or structure they stand for, read arcs dashed.
//! Initially marked places carry a token (a dot). A legend names the owners.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::{guard_text, owner_colour, owner_label};
use crate::net::{ArcKind, ColourOp, Net, Node, Owner};

/// The net as a DOT digraph, top to bottom.
pub fn to_dot(net: &Net) -> String {
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "digraph {} {{", quote(&net.name));
    let _ = writeln!(w, "  rankdir=TB;");
    let _ = writeln!(
        w,
        "  node [fontname=\"Helvetica\", fontsize=10, style=filled];"
    );
    let _ = writeln!(
        w,
        "  edge [arrowsize=0.7, fontname=\"Helvetica\", fontsize=9];"
    );
    let marked: BTreeSet<_> = net.initial_marking.iter().copied().collect();
    let mut owners = BTreeSet::new();
    for n in net.graph.node_indices() {
        match &net.graph[n] {
            Node::Place(p) => {
                owners.insert(p.owner);
                let token = if marked.contains(&n) { "●" } else { "" };
                let peripheries = if n == net.final_place { 2 } else { 1 };
                let _ = writeln!(
                    w,
                    "  {} [shape=circle, width=0.35, fixedsize=true, peripheries={peripheries}, \
                     fillcolor=\"{}\", label={}, xlabel={}, tooltip={}];",
                    quote(&p.id),
                    owner_colour(p.owner),
                    quote(token),
                    quote(&p.label),
                    quote(&format!("{} ({})", p.label, owner_label(net, p.owner)))
                );
            }
            Node::Transition(t) => {
                owners.insert(t.owner);
                let mut label = t.label.to_string();
                if let Some(g) = guard_text(net, t) {
                    if !label.contains(&g) {
                        label.push_str(&format!("\n[{g}]"));
                    }
                }
                if let Some(d) = t.delay {
                    label.push_str(&format!("\n({d} s)"));
                }
                let _ = writeln!(
                    w,
                    "  {} [shape=box, height=0.3, fillcolor=\"{}\", label={}, tooltip={}];",
                    quote(&t.id),
                    owner_colour(t.owner),
                    quote(&label),
                    quote(&format!("{} ({})", t.id, owner_label(net, t.owner)))
                );
            }
        }
    }
    for (from, to, arc) in net.arcs() {
        let mut attrs = Vec::new();
        if arc.kind == ArcKind::Read {
            attrs.push("style=dashed".to_string());
            attrs.push("arrowhead=none".to_string());
        }
        if arc.weight > 1 {
            attrs.push(format!("label=\"{}\"", arc.weight));
        }
        match arc.colour {
            ColourOp::Next => attrs.push("label=\"+1\"".into()),
            ColourOp::Enter => attrs.push("label=\"push\"".into()),
            ColourOp::Leave => attrs.push("label=\"pop\"".into()),
            _ => {}
        }
        let attrs = if attrs.is_empty() {
            String::new()
        } else {
            format!(" [{}]", attrs.join(", "))
        };
        let _ = writeln!(
            w,
            "  {} -> {}{attrs};",
            quote(net.id(from)),
            quote(net.id(to))
        );
    }
    let _ = writeln!(w, "  subgraph cluster_legend {{");
    let _ = writeln!(
        w,
        "    label=\"owners\"; fontname=\"Helvetica\"; fontsize=10;"
    );
    for (i, o) in owners.iter().enumerate() {
        let _ = writeln!(
            w,
            "    \"legend {i}\" [shape=box, fillcolor=\"{}\", label={}];",
            owner_colour(*o),
            quote(&legend(net, *o))
        );
    }
    let _ = writeln!(w, "  }}");
    let _ = writeln!(w, "}}");
    out
}

fn legend(net: &Net, o: Owner) -> String {
    match o {
        Owner::Unassigned => "placed by the slicer".into(),
        _ => owner_label(net, o),
    }
}

/// A DOT string literal: quotes and backslashes escaped, line breaks as
/// centred line breaks (`\n`).
fn quote(s: &str) -> String {
    let mut q = String::with_capacity(s.len() + 2);
    q.push('"');
    for c in s.chars() {
        match c {
            '"' => q.push_str("\\\""),
            '\\' => q.push_str("\\\\"),
            '\n' => q.push_str("\\n"),
            '\r' => {}
            c => q.push(c),
        }
    }
    q.push('"');
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dot_string_escapes_quotes_backslashes_and_line_breaks() {
        assert_eq!(quote("a \"b\" \\ c\nd"), "\"a \\\"b\\\" \\\\ c\\nd\"");
    }
}
