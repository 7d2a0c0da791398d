//! Which `RepeatFor` loops the checker may explore without counting their
//! rounds.
//!
//! A counted loop multiplies every state inside it by its count, and across
//! drones those products multiply: a generated 16-drone mission of 20,000
//! nodes has 3.6 million markings counted and 100,000 uncounted. Counting
//! matters only where something outside the loop can tell the rounds
//! apart. Where nothing can, the loop is *folded*: its round and end steps
//! become a free choice, as a `RepeatWhile`'s are, and it gets no counter.
//!
//! A loop is folded only when its body is *closed*: the places its first
//! step marks, and everything that follows from them up to the loop's head,
//! are fed by no step outside the body and read or taken by none (so no
//! `Signal` leaves it and no `Await` waits on the outside), and none is
//! marked at the start or is the mission's end. Then, with a count of at
//! least one:
//! * every marking the counted net reaches, without its counter, the
//!   folded net reaches too (a counted run is a folded run);
//! * a dead marking of the counted net is dead in the folded net (the
//!   loop's head always has one of its two steps enabled in either);
//! * conversely a run of the folded net becomes a counted run by taking out
//!   the rounds past the count and adding the missing ones (a round touches
//!   nothing outside the body, so it commutes with every other step), as
//!   long as a round can come to its end, which the folded net shows when
//!   the end stays reachable from everywhere in it.
//!
//! So deadlock-freedom, the end's reachability, every action's liveness,
//! the absence of drone conflicts and of near legs carry over from the
//! folded net to the mission when all of them hold there. The check uses
//! the folded net first and, on anything else than a clean proof, checks
//! the counted net again, whose counterexamples replay in the token game
//! as they are (see [`crate::check_net`]).

use std::collections::HashSet;

use crate::report::{Property, PropertyResult, Report, Verdict};

use eamos_petri::net::{Net, NodeId};
use petgraph::visit::EdgeRef;
use petgraph::Direction::{Incoming, Outgoing};

/// Whether the loop whose head is `head`, whose rounds start with
/// `round`, has a closed body (see the module's doc).
pub(crate) fn closed_body(net: &Net, head: NodeId, round: NodeId) -> bool {
    let marked: HashSet<NodeId> = net.initial_marking.iter().copied().collect();
    let mut places: HashSet<NodeId> = HashSet::new();
    let mut steps: HashSet<NodeId> = HashSet::new();
    let mut queue: Vec<NodeId> = Vec::new();
    let enter = |p: NodeId, places: &mut HashSet<NodeId>, queue: &mut Vec<NodeId>| {
        if p != head && places.insert(p) {
            queue.push(p);
        }
    };
    for e in net.graph.edges_directed(round, Outgoing) {
        enter(e.target(), &mut places, &mut queue);
    }
    // Everything that follows from the round's first places, up to the
    // head; a body that leaks reaches the end, where the search stops.
    while let Some(p) = queue.pop() {
        if p == net.final_place || marked.contains(&p) {
            return false;
        }
        for e in net.graph.edges_directed(p, Outgoing) {
            let t = e.target();
            if t == round || !steps.insert(t) {
                continue;
            }
            for out in net.graph.edges_directed(t, Outgoing) {
                enter(out.target(), &mut places, &mut queue);
            }
        }
    }
    let inside = |p: NodeId| places.contains(&p);
    let fed_inside = |p: &NodeId| {
        net.graph
            .edges_directed(*p, Incoming)
            .all(|e| e.source() == round || steps.contains(&e.source()))
    };
    let reads_inside = |t: &NodeId| {
        net.graph
            .edges_directed(*t, Incoming)
            .all(|e| inside(e.source()))
    };
    places.iter().all(fed_inside) && steps.iter().all(reads_inside)
}

/// Whether a check of the folded net is a proof for the mission: the
/// exploration went to its end, every property it decides holds (the end's
/// reachability among them, which the argument needs, unless only
/// deadlocks were asked), and no finding carries a run of the folded net.
/// Separation may be left undecided: the reasons it can be (legs not
/// known, a drone flying two at once, too many pairs) are the mission's,
/// not the fold's, and the counted net would say the same.
pub(crate) fn proves(report: &Report) -> bool {
    let holds = |r: &PropertyResult| match r.property {
        Property::Deadlock
        | Property::Termination
        | Property::Safety
        | Property::DeadActions
        | Property::Conflicts => matches!(r.verdict, Verdict::Holds | Verdict::NotApplicable(_)),
        Property::Separation => r.verdict != Verdict::Violated,
        Property::Conditions | Property::Airspace | Property::FlightState => true,
    };
    report.stats.complete
        && report.findings.iter().all(|f| f.trace.is_none())
        && report.properties.iter().all(holds)
}

/// Says on the deadlock verdict (which every check answers) that rounds
/// were not counted, and why that is still a proof.
pub(crate) fn note(report: &mut Report, loops: usize) {
    if let Some(r) = report
        .properties
        .iter_mut()
        .find(|r| r.property == Property::Deadlock)
    {
        r.notes.push(format!(
            "{loops} `RepeatFor` loop(s) explored without counting their rounds: \
             nothing outside their bodies can tell one round from another"
        ));
    }
}
