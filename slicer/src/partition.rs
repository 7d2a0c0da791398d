//! Who runs what: units, the bridge-count model and the owner search.
//!
//! A *unit* is a place together with every transition that consumes or reads
//! it, closed transitively (two places consumed by one transition are in one
//! unit). A unit lives on one owner, which is what keeps every consume and
//! read arc local. Units that contain a node the compiler gave an owner to
//! (an action, a guarded transition, the ground station's start) are fixed;
//! the others are free and placed here.
//!
//! The cost of an assignment is the number of bridges the slicer would emit
//! for it, after bundling (see [`plan_bundles`]), so the search optimises
//! exactly what it reports.

use std::collections::BTreeMap;

use eamos_petri::net::{ArcKind, Net, Node, NodeId, Owner};
use petgraph::graph::EdgeIndex;
use petgraph::visit::EdgeRef;
use petgraph::Direction;

use crate::error::SliceError;

/// The places-with-their-consumers units of a net.
pub(crate) struct Units {
    /// Unit of every node, by node index.
    pub unit_of: Vec<usize>,
    pub units: Vec<Unit>,
}

pub(crate) struct Unit {
    pub nodes: Vec<NodeId>,
    /// The owner the compiler imposed on one of its nodes, if any.
    pub fixed: Option<Owner>,
    /// Units that one arc connects to this one.
    pub neighbours: Vec<usize>,
    /// Where the tie-break prefers this unit to live (see [`preferred`]).
    pub hint: Hint,
}

/// How a free unit sits between fixed ones: a fork hangs off the one unit
/// that feeds it, a join feeds the one unit that follows it. On a cost tie
/// the paper's convention decides: a fork lives with its predecessor, a join
/// with its successor, so that no drone relays what it does not need.
#[derive(Clone, Copy)]
pub(crate) enum Hint {
    None,
    /// Single producer side: prefer the owner of this unit.
    Upstream(usize),
    /// Single consumer side: prefer the owner of this unit.
    Downstream(usize),
}

fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

impl Units {
    pub fn of(net: &Net) -> Result<Units, SliceError> {
        let n = net.graph.node_count();
        let mut parent: Vec<usize> = (0..n).collect();
        for e in net.graph.edge_references() {
            if e.weight().weight != 1 {
                return Err(SliceError::ArcWeight {
                    from: node_id(net, e.source()),
                    to: node_id(net, e.target()),
                    weight: e.weight().weight,
                });
            }
            if matches!(e.weight().kind, ArcKind::Consume | ArcKind::Read) {
                let a = find(&mut parent, e.source().index());
                let b = find(&mut parent, e.target().index());
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut index = vec![usize::MAX; n];
        let mut units: Vec<Unit> = Vec::new();
        let mut unit_of = vec![0; n];
        for (i, slot) in unit_of.iter_mut().enumerate() {
            let r = find(&mut parent, i);
            if index[r] == usize::MAX {
                index[r] = units.len();
                units.push(Unit {
                    nodes: Vec::new(),
                    fixed: None,
                    neighbours: Vec::new(),
                    hint: Hint::None,
                });
            }
            *slot = index[r];
            units[index[r]].nodes.push(NodeId::new(i));
        }
        for unit in &mut units {
            let mut owners: Vec<Owner> = unit
                .nodes
                .iter()
                .map(|&v| net.owner(v))
                .filter(|o| *o != Owner::Unassigned)
                .collect();
            owners.sort();
            owners.dedup();
            match owners.len() {
                0 => {}
                1 => unit.fixed = Some(owners[0]),
                _ => {
                    return Err(conflict(net, &unit.nodes, owners));
                }
            }
        }
        for e in net.graph.edge_references() {
            let (a, b) = (unit_of[e.source().index()], unit_of[e.target().index()]);
            if a != b {
                units[a].neighbours.push(b);
                units[b].neighbours.push(a);
            }
        }
        for u in &mut units {
            u.neighbours.sort_unstable();
            u.neighbours.dedup();
        }
        let mut result = Units { unit_of, units };
        for u in 0..result.units.len() {
            result.units[u].hint = result.hint(net, u);
        }
        Ok(result)
    }

    /// Arcs entering and leaving a unit from other units.
    fn boundary(&self, net: &Net, u: usize) -> (Vec<usize>, Vec<usize>) {
        let mut ins = Vec::new();
        let mut outs = Vec::new();
        for &v in &self.units[u].nodes {
            for e in net.graph.edges_directed(v, Direction::Incoming) {
                let w = self.unit_of[e.source().index()];
                if w != u {
                    ins.push(w);
                }
            }
            for e in net.graph.edges_directed(v, Direction::Outgoing) {
                let w = self.unit_of[e.target().index()];
                if w != u {
                    outs.push(w);
                }
            }
        }
        (ins, outs)
    }

    fn hint(&self, net: &Net, u: usize) -> Hint {
        if self.units[u].fixed.is_some() {
            return Hint::None;
        }
        let (ins, outs) = self.boundary(net, u);
        let fixed = |w: usize| self.units[w].fixed.is_some();
        if ins.len() == 1 && outs.len() != 1 && fixed(ins[0]) {
            Hint::Upstream(ins[0])
        } else if outs.len() == 1 && ins.len() != 1 && fixed(outs[0]) {
            Hint::Downstream(outs[0])
        } else if ins.len() == 1 && fixed(ins[0]) {
            Hint::Upstream(ins[0])
        } else if outs.len() == 1 && fixed(outs[0]) {
            Hint::Downstream(outs[0])
        } else {
            Hint::None
        }
    }
}

fn conflict(net: &Net, nodes: &[NodeId], owners: Vec<Owner>) -> SliceError {
    // Name the place whose consumers disagree: that is what a person fixes.
    let place = nodes
        .iter()
        .copied()
        .filter(|&v| net.is_place(v))
        .find(|&p| {
            let mut os: Vec<Owner> = std::iter::once(net.owner(p))
                .chain(net.consumers(p).map(|(t, _)| net.owner(t)))
                .filter(|o| *o != Owner::Unassigned)
                .collect();
            os.sort();
            os.dedup();
            os.len() > 1
        })
        .or_else(|| nodes.iter().copied().find(|&v| net.is_place(v)))
        .unwrap_or(nodes[0]);
    SliceError::OwnerConflict {
        place: node_id(net, place),
        owners: owners
            .iter()
            .map(|&o| net.owner_name(o).to_string())
            .collect(),
        span: match &net.graph[place] {
            Node::Place(p) => p.span,
            Node::Transition(t) => Some(t.span),
        },
    }
}

pub(crate) fn node_id(net: &Net, v: NodeId) -> String {
    match &net.graph[v] {
        Node::Place(p) => p.id.clone(),
        Node::Transition(t) => t.id.clone(),
    }
}

/// A group of crossing arcs that the slicer sends as one bridge.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Bundle {
    /// One arc, sent as it is: the remote place is the inbox.
    Direct { arc: EdgeIndex },
    /// Several arcs of one transition into places of one remote owner: one
    /// token crosses, a local fork there fans it out (the paper's fork
    /// proxy).
    FanOut {
        transition: NodeId,
        to: Owner,
        arcs: Vec<EdgeIndex>,
    },
    /// Inputs of one join whose producers all live on one remote owner: they
    /// are joined there first and one token crosses.
    PreJoin {
        join: NodeId,
        from: Owner,
        places: Vec<NodeId>,
    },
    /// Several producers on one remote owner feeding one place (the merge
    /// after a condition, say): they merge there and one token crosses.
    Forward {
        place: NodeId,
        from: Owner,
        arcs: Vec<EdgeIndex>,
    },
}

/// Facts about the net that the bundle planner asks again and again.
pub(crate) struct Facts {
    pub marked: Vec<bool>,
    /// For every place: its depth (length of its tokens' colour).
    pub depth: Vec<u8>,
}

impl Facts {
    pub fn of(net: &Net) -> Facts {
        let n = net.graph.node_count();
        let mut marked = vec![false; n];
        for &p in &net.initial_marking {
            marked[p.index()] = true;
        }
        let depth = net
            .graph
            .node_indices()
            .map(|v| net.place(v).map_or(0, |p| p.depth))
            .collect();
        Facts { marked, depth }
    }
}

/// Whether `p` may be joined on its producers' owner before its only
/// consumer `join` takes it: nobody else looks at `p`, it is not marked at
/// the start, and all its producers share one owner other than `join`'s.
fn prejoinable(
    net: &Net,
    facts: &Facts,
    owner: &[Owner],
    p: NodeId,
    join: NodeId,
) -> Option<Owner> {
    if facts.marked[p.index()] {
        return None;
    }
    let mut consumers = net.consumers(p);
    match (consumers.next(), consumers.next()) {
        (Some((t, ArcKind::Consume)), None) if t == join => {}
        _ => return None,
    }
    let mut from = None;
    for s in net.producers(p) {
        let o = owner[s.index()];
        if from.is_some_and(|f| f != o) {
            return None;
        }
        from = Some(o);
    }
    from.filter(|&f| f != owner[join.index()])
}

/// Groups the arcs that cross owners into bridges. Every crossing arc ends
/// up in exactly one bundle; the number of bundles is the number of bridges.
///
/// Greedy, in a fixed order so that the result is deterministic: fan-outs
/// first (largest first), then pre-joins, then forwards, then single arcs.
pub(crate) fn plan_bundles(net: &Net, facts: &Facts, owner: &[Owner]) -> Vec<Bundle> {
    let crossing: Vec<EdgeIndex> = net
        .graph
        .edge_references()
        .filter(|e| {
            e.weight().kind == ArcKind::Produce
                && owner[e.source().index()] != owner[e.target().index()]
        })
        .map(|e| e.id())
        .collect();
    if crossing.is_empty() {
        return Vec::new();
    }
    let mut covered = vec![false; net.graph.edge_count()];
    let mut is_crossing = vec![false; net.graph.edge_count()];
    for &e in &crossing {
        is_crossing[e.index()] = true;
    }
    let mut bundles = Vec::new();

    // Fan-outs: arcs of one transition to one remote owner.
    let mut fanouts: BTreeMap<(NodeId, Owner), Vec<EdgeIndex>> = BTreeMap::new();
    for &e in &crossing {
        let (t, p) = net.graph.edge_endpoints(e).expect("edge exists");
        fanouts.entry((t, owner[p.index()])).or_default().push(e);
    }
    let mut fanouts: Vec<_> = fanouts.into_iter().filter(|(_, a)| a.len() >= 2).collect();
    fanouts.sort_by(|a, b| b.1.len().cmp(&a.1.len()).then(a.0.cmp(&b.0)));
    for ((transition, to), arcs) in fanouts {
        for e in &arcs {
            covered[e.index()] = true;
        }
        bundles.push(Bundle::FanOut {
            transition,
            to,
            arcs,
        });
    }

    // Pre-joins: the consumer's eligible input places, grouped by the owner
    // of their producers. Every producer arc into a chosen place must still
    // be free: a place's tokens go through the pre-join or not at all.
    let mut joins: Vec<NodeId> = crossing
        .iter()
        .filter_map(|&e| {
            let (_, p) = net.graph.edge_endpoints(e)?;
            let mut c = net.consumers(p);
            match (c.next(), c.next()) {
                (Some((t, ArcKind::Consume)), None) => Some(t),
                _ => None,
            }
        })
        .collect();
    joins.sort_unstable();
    joins.dedup();
    let mut prejoins = Vec::new();
    for join in joins {
        let inputs: Vec<NodeId> = net.preset(join).collect();
        let depth = inputs.first().map(|p| facts.depth[p.index()]);
        if inputs.iter().any(|p| Some(facts.depth[p.index()]) != depth)
            || net.read_set(join).next().is_some()
        {
            continue;
        }
        let mut by_owner: BTreeMap<Owner, Vec<NodeId>> = BTreeMap::new();
        for &p in &inputs {
            if let Some(from) = prejoinable(net, facts, owner, p, join) {
                let free = net
                    .graph
                    .edges_directed(p, Direction::Incoming)
                    .all(|e| is_crossing[e.id().index()] && !covered[e.id().index()]);
                if free {
                    by_owner.entry(from).or_default().push(p);
                }
            }
        }
        for (from, places) in by_owner {
            let arcs: usize = places.iter().map(|&p| net.producers(p).count()).sum();
            if arcs >= 2 {
                prejoins.push((arcs, join, from, places));
            }
        }
    }
    prejoins.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    for (_, join, from, places) in prejoins {
        let arcs: Vec<EdgeIndex> = places
            .iter()
            .flat_map(|&p| {
                net.graph
                    .edges_directed(p, Direction::Incoming)
                    .map(|e| e.id())
            })
            .collect();
        if arcs.iter().any(|e| covered[e.index()]) {
            continue;
        }
        for e in &arcs {
            covered[e.index()] = true;
        }
        bundles.push(Bundle::PreJoin { join, from, places });
    }

    // Forwards: free arcs into one place from one remote owner.
    let mut forwards: BTreeMap<(NodeId, Owner), Vec<EdgeIndex>> = BTreeMap::new();
    for &e in &crossing {
        if covered[e.index()] {
            continue;
        }
        let (t, p) = net.graph.edge_endpoints(e).expect("edge exists");
        forwards.entry((p, owner[t.index()])).or_default().push(e);
    }
    for ((place, from), arcs) in forwards {
        if arcs.len() >= 2 {
            for e in &arcs {
                covered[e.index()] = true;
            }
            bundles.push(Bundle::Forward { place, from, arcs });
        }
    }

    for &e in &crossing {
        if !covered[e.index()] {
            bundles.push(Bundle::Direct { arc: e });
        }
    }
    bundles
}

/// An owner for every unit, chosen to keep the bridge count low.
pub(crate) struct Assignment {
    pub unit_owner: Vec<Owner>,
}

impl Assignment {
    pub fn node_owners(&self, units: &Units) -> Vec<Owner> {
        units.unit_of.iter().map(|&u| self.unit_owner[u]).collect()
    }
}

/// Passes of improvement before the search stops even if it could go on;
/// each pass that changes nothing ends it earlier.
const MAX_PASSES: usize = 12;
/// Free units moved together as one chain at most.
const MAX_CHAIN: usize = 16;

/// Places every free unit: first next to the fixed units it touches most,
/// then by local search over single units and chains of free units, moving
/// only when the bridge count drops (or, at an equal count, when the move
/// follows the fork-with-predecessor, join-with-successor convention).
pub(crate) fn assign(net: &Net, units: &Units, facts: &Facts, owners: &[Owner]) -> Assignment {
    let nu = units.units.len();
    let mut unit_owner: Vec<Option<Owner>> = units.units.iter().map(|u| u.fixed).collect();

    // Seed: spread owners from fixed units to free neighbours, the owner
    // with the most arcs into the unit first, the smaller owner on a tie.
    loop {
        let mut changed = false;
        for u in 0..nu {
            if unit_owner[u].is_some() {
                continue;
            }
            let mut score: BTreeMap<Owner, usize> = BTreeMap::new();
            for &v in &units.units[u].nodes {
                for e in net.graph.edges_directed(v, Direction::Incoming) {
                    if let Some(o) = unit_owner[units.unit_of[e.source().index()]] {
                        if units.unit_of[e.source().index()] != u {
                            *score.entry(o).or_default() += 1;
                        }
                    }
                }
                for e in net.graph.edges_directed(v, Direction::Outgoing) {
                    if let Some(o) = unit_owner[units.unit_of[e.target().index()]] {
                        if units.unit_of[e.target().index()] != u {
                            *score.entry(o).or_default() += 1;
                        }
                    }
                }
            }
            if let Some((&o, _)) = score.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))) {
                unit_owner[u] = Some(o);
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let default = owners.first().copied().unwrap_or(Owner::Gcs);
    let mut unit_owner: Vec<Owner> = unit_owner
        .into_iter()
        .map(|o| o.unwrap_or(default))
        .collect();

    let free: Vec<usize> = (0..nu)
        .filter(|&u| units.units[u].fixed.is_none())
        .collect();
    if free.is_empty() {
        return Assignment { unit_owner };
    }
    let cost_of = |unit_owner: &[Owner]| -> usize {
        let owner: Vec<Owner> = units.unit_of.iter().map(|&u| unit_owner[u]).collect();
        plan_bundles(net, facts, &owner).len()
    };
    let rank = |unit_owner: &[Owner], u: usize, o: Owner| -> u8 {
        match units.units[u].hint {
            Hint::Upstream(w) | Hint::Downstream(w) if unit_owner[w] == o => 0,
            Hint::None => 0,
            _ => 1,
        }
    };

    let mut cost = cost_of(&unit_owner);
    for _ in 0..MAX_PASSES {
        let mut improved = false;
        for &u in &free {
            // The unit alone, then the chain of free units around it that
            // share its owner (a join and the fork after it move together).
            let chain = chain_of(units, &unit_owner, u);
            let groups = if chain.len() > 1 {
                vec![vec![u], chain]
            } else {
                vec![chain]
            };
            for group in groups {
                let current = unit_owner[u];
                let mut candidates: Vec<Owner> = group
                    .iter()
                    .flat_map(|&g| units.units[g].neighbours.iter().map(|&w| unit_owner[w]))
                    .filter(|&o| o != current)
                    .collect();
                candidates.sort();
                candidates.dedup();
                let mut best = (cost, rank(&unit_owner, u, current), current);
                for o in candidates {
                    for &g in &group {
                        unit_owner[g] = o;
                    }
                    let c = (cost_of(&unit_owner), rank(&unit_owner, u, o), o);
                    if (c.0, c.1) < (best.0, best.1) {
                        best = c;
                    }
                    for &g in &group {
                        unit_owner[g] = current;
                    }
                }
                if best.2 != current {
                    for &g in &group {
                        unit_owner[g] = best.2;
                    }
                    cost = best.0;
                    improved = true;
                }
            }
        }
        if !improved {
            break;
        }
    }
    Assignment { unit_owner }
}

/// The free units reachable from `u` through free units of the same owner.
fn chain_of(units: &Units, unit_owner: &[Owner], u: usize) -> Vec<usize> {
    let mut seen = vec![u];
    let mut i = 0;
    while i < seen.len() && seen.len() < MAX_CHAIN {
        let w = seen[i];
        for &x in &units.units[w].neighbours {
            if units.units[x].fixed.is_none()
                && unit_owner[x] == unit_owner[u]
                && !seen.contains(&x)
                && seen.len() < MAX_CHAIN
            {
                seen.push(x);
            }
        }
        i += 1;
    }
    seen.sort_unstable();
    seen
}
