//! The mission graph as the page lays it out: every place and transition
//! of the net with its owner (a drone by index, the ground station, or not
//! yet placed) and the source line the statement that made it starts on.

use eamos_lang::{SourceFile, Span};
use eamos_petri::export::transition_kind_name;
use eamos_petri::net::{ArcKind, Net, Node, Owner};
use serde::Serialize;

use crate::input::line_of;

#[derive(Debug, Clone, Serialize)]
pub struct Graph {
    pub nodes: Vec<GraphNode>,
    pub edges: Vec<GraphEdge>,
}

#[derive(Debug, Clone, Serialize)]
pub struct GraphNode {
    /// The net's id of the place or transition (`p12`, `t7`).
    pub id: String,
    /// `place` or `transition`.
    pub shape: &'static str,
    /// The transition's kind (`action-start`, `fork`, ...); `place` for places.
    pub kind: &'static str,
    pub label: String,
    /// The drone that runs it; `None` for the ground station's nodes and
    /// the plumbing the slicer places.
    pub drone: Option<usize>,
    /// Where in the mission it comes from; `None` for the net's own
    /// `initial` and `final` places and the plumbing without a statement.
    pub line: Option<u32>,
    /// Marked in the initial marking.
    pub marked: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct GraphEdge {
    pub from: String,
    pub to: String,
    /// A read arc: the transition looks at the place without taking it.
    pub read: bool,
}

pub(crate) fn graph(net: &Net, source: &SourceFile) -> Graph {
    let located = |span: Option<Span>| {
        span.filter(|s| !(s.is_empty() && s.start == 0))
            .map(|s| line_of(source, s))
    };
    let drone = |o: Owner| match o {
        Owner::Drone(d) => Some(d.0 as usize),
        _ => None,
    };
    let nodes = net
        .graph
        .node_indices()
        .map(|n| match &net.graph[n] {
            Node::Place(p) => GraphNode {
                id: p.id.to_string(),
                shape: "place",
                kind: "place",
                label: p.label.to_string(),
                drone: drone(p.owner),
                line: located(p.span),
                marked: net.initial_marking.contains(&n),
            },
            Node::Transition(t) => GraphNode {
                id: t.id.to_string(),
                shape: "transition",
                kind: transition_kind_name(&t.kind),
                label: t.label.to_string(),
                drone: drone(t.owner),
                line: located(Some(t.span)),
                marked: false,
            },
        })
        .collect();
    let edges = net
        .arcs()
        .map(|(a, b, arc)| GraphEdge {
            from: net.id(a).to_string(),
            to: net.id(b).to_string(),
            read: arc.kind == ArcKind::Read,
        })
        .collect();
    Graph { nodes, edges }
}
