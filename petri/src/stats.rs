//! The size of a net per owner: what each drone will have to run, what the
//! ground station runs, and what the slicer has yet to place.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::net::{Net, Node, Owner};

/// Places, transitions and arcs of one owner (or of the whole net).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counts {
    /// `Drone1`, `GCS`, `unassigned` or `total`.
    pub owner: String,
    pub places: usize,
    pub transitions: usize,
    /// Arcs counted with the owner of their transition end: the owner that
    /// fires them.
    pub arcs: usize,
    /// Of those, read (test) arcs.
    pub read_arcs: usize,
}

/// The size of a net, owner by owner: drones in declaration order, then the
/// ground station, then unassigned nodes; owners with nothing are left out.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetStats {
    pub mission: String,
    pub owners: Vec<Counts>,
    pub total: Counts,
    /// Arcs between a place and a transition of two different assigned
    /// owners: each becomes a message between them.
    pub cross_owner_arcs: usize,
}

pub fn stats(net: &Net) -> NetStats {
    let mut by: BTreeMap<Owner, Counts> = BTreeMap::new();
    let mut total = Counts {
        owner: "total".into(),
        ..Counts::default()
    };
    for n in net.graph.node_indices() {
        let c = by.entry(net.owner(n)).or_default();
        match &net.graph[n] {
            Node::Place(_) => {
                c.places += 1;
                total.places += 1;
            }
            Node::Transition(_) => {
                c.transitions += 1;
                total.transitions += 1;
            }
        }
    }
    let mut cross = 0;
    for (from, to, arc) in net.arcs() {
        let t = if net.is_place(from) { to } else { from };
        let p = if net.is_place(from) { from } else { to };
        let c = by.entry(net.owner(t)).or_default();
        c.arcs += 1;
        total.arcs += 1;
        if arc.kind == crate::net::ArcKind::Read {
            c.read_arcs += 1;
            total.read_arcs += 1;
        }
        let (a, b) = (net.owner(t), net.owner(p));
        if a != b && a != Owner::Unassigned && b != Owner::Unassigned {
            cross += 1;
        }
    }
    // Drones first (Owner orders Gcs < Drone < Unassigned).
    let mut owners: Vec<(Owner, Counts)> = by.into_iter().collect();
    owners.sort_by_key(|(o, _)| match o {
        Owner::Drone(d) => (0, d.0),
        Owner::Gcs => (1, 0),
        Owner::Unassigned => (2, 0),
    });
    let owners = owners
        .into_iter()
        .map(|(o, mut c)| {
            c.owner = super::export::owner_label(net, o);
            c
        })
        .collect();
    NetStats {
        mission: net.name.clone(),
        owners,
        total,
        cross_owner_arcs: cross,
    }
}

impl fmt::Display for NetStats {
    /// A table a person reads in a terminal.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let width = self
            .owners
            .iter()
            .map(|c| c.owner.chars().count())
            .chain([5, "owner".len()])
            .max()
            .unwrap_or(5);
        writeln!(f, "net of mission {}", self.mission)?;
        writeln!(
            f,
            "{:<width$}  {:>6}  {:>11}  {:>5}  {:>9}",
            "owner", "places", "transitions", "arcs", "read arcs"
        )?;
        let row = |f: &mut fmt::Formatter<'_>, c: &Counts| {
            writeln!(
                f,
                "{:<width$}  {:>6}  {:>11}  {:>5}  {:>9}",
                c.owner, c.places, c.transitions, c.arcs, c.read_arcs
            )
        };
        for c in &self.owners {
            row(f, c)?;
        }
        row(f, &self.total)?;
        writeln!(
            f,
            "arcs between two owners (messages): {}",
            self.cross_owner_arcs
        )
    }
}
