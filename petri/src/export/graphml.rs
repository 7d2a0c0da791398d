//! GraphML, for graph editors (yEd, Gephi, Cytoscape). Every node and edge
//! carries plain data keys (label, owner, fill colour, shape, ...) that any
//! GraphML reader shows, and yEd's graphics extension so that yEd draws the
//! net as the paper does: owner colours, circles for places, boxes for
//! transitions, dashed read arcs.

use std::fmt::Write as _;

use super::{
    colour_op_name, guard_text, owner_colour, owner_label, place_kind_name, transition_kind_name,
    xml,
};
use crate::net::{ArcKind, Net, Node};

const KEYS: &[(&str, &str, &str)] = &[
    ("label", "node", "label"),
    ("node", "node", "node"),
    ("kind", "node", "kind"),
    ("owner", "node", "owner"),
    ("fill", "node", "fill"),
    ("shape", "node", "shape"),
    ("guard", "node", "guard"),
    ("marked", "node", "marked"),
    ("span", "node", "span"),
    ("arc", "edge", "arc"),
    ("weight", "edge", "weight"),
    ("colour", "edge", "colour"),
    ("style", "edge", "style"),
];

/// The net as a GraphML document.
pub fn to_graphml(net: &Net) -> String {
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>");
    let _ = writeln!(
        w,
        "<graphml xmlns=\"http://graphml.graphdrawing.org/xmlns\" \
         xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" \
         xmlns:y=\"http://www.yworks.com/xml/graphml\" \
         xsi:schemaLocation=\"http://graphml.graphdrawing.org/xmlns \
         http://www.yworks.com/xml/schema/graphml/1.1/ygraphml.xsd\">"
    );
    for (id, domain, name) in KEYS {
        let ty = if *id == "weight" { "int" } else { "string" };
        let _ = writeln!(
            w,
            "  <key id=\"{id}\" for=\"{domain}\" attr.name=\"{name}\" attr.type=\"{ty}\"/>"
        );
    }
    let _ = writeln!(
        w,
        "  <key id=\"ng\" for=\"node\" yfiles.type=\"nodegraphics\"/>"
    );
    let _ = writeln!(
        w,
        "  <key id=\"eg\" for=\"edge\" yfiles.type=\"edgegraphics\"/>"
    );
    let _ = writeln!(
        w,
        "  <graph id=\"{}\" edgedefault=\"directed\">",
        xml(&net.name)
    );
    for n in net.graph.node_indices() {
        let (id, label, node, kind, owner, shape, guard, span) = match &net.graph[n] {
            Node::Place(p) => (
                &p.id,
                p.label.clone(),
                "place",
                place_kind_name(&p.kind),
                p.owner,
                "ellipse",
                None,
                p.span,
            ),
            Node::Transition(t) => (
                &t.id,
                t.label.clone(),
                "transition",
                transition_kind_name(&t.kind),
                t.owner,
                "rectangle",
                guard_text(net, t),
                Some(t.span),
            ),
        };
        let fill = owner_colour(owner);
        let _ = writeln!(w, "    <node id=\"{}\">", xml(id));
        data(w, "label", &label);
        data(w, "node", node);
        data(w, "kind", kind);
        data(w, "owner", &owner_label(net, owner));
        data(w, "fill", fill);
        data(w, "shape", shape);
        if let Some(g) = &guard {
            data(w, "guard", g);
        }
        if net.initial_marking.contains(&n) {
            data(w, "marked", "true");
        }
        if let Some(s) = span {
            data(w, "span", &format!("{}..{}", s.start, s.end));
        }
        let (width, height) = if node == "place" {
            (30, 30)
        } else {
            (40 + 6 * label.chars().count().min(60), 30)
        };
        let _ = writeln!(
            w,
            "      <data key=\"ng\"><y:ShapeNode><y:Geometry width=\"{width}\" height=\"{height}\"/>\
             <y:Fill color=\"{}\" transparent=\"false\"/><y:BorderStyle color=\"#000000\" type=\"line\" width=\"1.0\"/>\
             <y:NodeLabel>{}</y:NodeLabel><y:Shape type=\"{shape}\"/></y:ShapeNode></data>",
            fill.to_uppercase(),
            xml(&label)
        );
        let _ = writeln!(w, "    </node>");
    }
    for e in net.graph.edge_indices() {
        let Some((from, to)) = net.graph.edge_endpoints(e) else {
            continue;
        };
        let arc = net.graph[e];
        let (kind, style) = match arc.kind {
            ArcKind::Consume => ("consume", "line"),
            ArcKind::Produce => ("produce", "line"),
            ArcKind::Read => ("read", "dashed"),
        };
        let _ = writeln!(
            w,
            "    <edge id=\"e{}\" source=\"{}\" target=\"{}\">",
            e.index(),
            xml(net.id(from)),
            xml(net.id(to))
        );
        data(w, "arc", kind);
        data(w, "weight", &arc.weight.to_string());
        data(w, "colour", colour_op_name(arc.colour));
        data(w, "style", if style == "line" { "solid" } else { "dashed" });
        let arrow = if arc.kind == ArcKind::Read {
            "none"
        } else {
            "standard"
        };
        let _ = writeln!(
            w,
            "      <data key=\"eg\"><y:PolyLineEdge><y:LineStyle color=\"#000000\" type=\"{style}\" width=\"1.0\"/>\
             <y:Arrows source=\"none\" target=\"{arrow}\"/></y:PolyLineEdge></data>"
        );
        let _ = writeln!(w, "    </edge>");
    }
    let _ = writeln!(w, "  </graph>");
    let _ = writeln!(w, "</graphml>");
    out
}

fn data(w: &mut String, key: &str, value: &str) {
    let _ = writeln!(w, "      <data key=\"{key}\">{}</data>", xml(value));
}
