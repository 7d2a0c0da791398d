//! The net as the partition sees it: the mission's net without the arcs of
//! its end tree (see `end.rs`), so that the tree's inputs stay wherever
//! their producers are.
//!
//! A view rather than a copy: the tree is a handful of nodes, and a copy of
//! a stress mission's net without them cost megabytes of memory at the peak
//! of slicing and a clone of every label. Nodes are read from the net as
//! they are; only the walks along arcs leave out those that touch the tree.

use eamos_petri::net::{Arc, ArcKind, Net, NodeId};
use petgraph::graph::EdgeReference;
use petgraph::visit::EdgeRef;
use petgraph::Direction;

#[derive(Clone, Copy)]
pub(crate) struct Work<'a> {
    pub net: &'a Net,
    /// Nodes whose arcs the partition does not see, by node index; empty
    /// when the whole net is partitioned.
    hidden: &'a [bool],
}

impl<'a> Work<'a> {
    /// `net` without the arcs that touch a node of `hidden` (by node index;
    /// an empty slice hides nothing).
    pub fn new(net: &'a Net, hidden: &'a [bool]) -> Work<'a> {
        Work { net, hidden }
    }

    fn sees(&self, v: NodeId) -> bool {
        !self.hidden.get(v.index()).copied().unwrap_or(false)
    }

    fn sees_arc(&self, e: &EdgeReference<'a, Arc>) -> bool {
        self.sees(e.source()) && self.sees(e.target())
    }

    /// Every arc the partition sees.
    pub fn arcs(self) -> impl Iterator<Item = EdgeReference<'a, Arc>> {
        self.net
            .graph
            .edge_references()
            .filter(move |e| self.sees_arc(e))
    }

    /// The arcs into `v`.
    pub fn incoming(self, v: NodeId) -> impl Iterator<Item = EdgeReference<'a, Arc>> {
        self.directed(v, Direction::Incoming)
    }

    /// The arcs out of `v`.
    pub fn outgoing(self, v: NodeId) -> impl Iterator<Item = EdgeReference<'a, Arc>> {
        self.directed(v, Direction::Outgoing)
    }

    fn directed(self, v: NodeId, dir: Direction) -> impl Iterator<Item = EdgeReference<'a, Arc>> {
        let seen = self.sees(v);
        self.net
            .graph
            .edges_directed(v, dir)
            .filter(move |e| seen && self.sees_arc(e))
    }

    /// The arcs from `a` to `b`.
    pub fn connecting(self, a: NodeId, b: NodeId) -> impl Iterator<Item = EdgeReference<'a, Arc>> {
        self.outgoing(a).filter(move |e| e.target() == b)
    }

    /// Places a transition consumes from.
    pub fn preset(self, t: NodeId) -> impl Iterator<Item = NodeId> + 'a {
        self.incoming(t)
            .filter(|e| e.weight().kind == ArcKind::Consume)
            .map(|e| e.source())
    }

    /// Places a transition only reads.
    pub fn read_set(self, t: NodeId) -> impl Iterator<Item = NodeId> + 'a {
        self.incoming(t)
            .filter(|e| e.weight().kind == ArcKind::Read)
            .map(|e| e.source())
    }

    /// Transitions that consume from or read a place.
    pub fn consumers(self, p: NodeId) -> impl Iterator<Item = (NodeId, ArcKind)> + 'a {
        self.outgoing(p).map(|e| (e.target(), e.weight().kind))
    }

    /// Transitions that produce into a place.
    pub fn producers(self, p: NodeId) -> impl Iterator<Item = NodeId> + 'a {
        self.incoming(p).map(|e| e.source())
    }
}
