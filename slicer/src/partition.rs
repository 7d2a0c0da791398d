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

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};

use eamos_petri::net::{ArcKind, Net, Node, NodeId, Owner};
use petgraph::graph::EdgeIndex;
use petgraph::visit::EdgeRef;

use crate::error::SliceError;
use crate::work::Work;

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
    pub fn of(work: Work) -> Result<Units, SliceError> {
        let net = work.net;
        let n = net.graph.node_count();
        let mut parent: Vec<usize> = (0..n).collect();
        for e in work.arcs() {
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
                    return Err(conflict(work, &unit.nodes, owners));
                }
            }
        }
        for e in work.arcs() {
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
            result.units[u].hint = result.hint(work, u);
        }
        Ok(result)
    }

    /// Arcs entering and leaving a unit from other units.
    fn boundary(&self, work: Work, u: usize) -> (Vec<usize>, Vec<usize>) {
        let mut ins = Vec::new();
        let mut outs = Vec::new();
        for &v in &self.units[u].nodes {
            for e in work.incoming(v) {
                let w = self.unit_of[e.source().index()];
                if w != u {
                    ins.push(w);
                }
            }
            for e in work.outgoing(v) {
                let w = self.unit_of[e.target().index()];
                if w != u {
                    outs.push(w);
                }
            }
        }
        (ins, outs)
    }

    fn hint(&self, work: Work, u: usize) -> Hint {
        if self.units[u].fixed.is_some() {
            return Hint::None;
        }
        let (ins, outs) = self.boundary(work, u);
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

fn conflict(work: Work, nodes: &[NodeId], owners: Vec<Owner>) -> SliceError {
    let net = work.net;
    // Name the place whose consumers disagree: that is what a person fixes.
    let place = nodes
        .iter()
        .copied()
        .filter(|&v| net.is_place(v))
        .find(|&p| {
            let mut os: Vec<Owner> = std::iter::once(net.owner(p))
                .chain(work.consumers(p).map(|(t, _)| net.owner(t)))
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
        Node::Place(p) => p.id.to_string(),
        Node::Transition(t) => t.id.to_string(),
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
    work: Work,
    facts: &Facts,
    owner: &[Owner],
    p: NodeId,
    join: NodeId,
) -> Option<Owner> {
    if facts.marked[p.index()] {
        return None;
    }
    let mut consumers = work.consumers(p);
    match (consumers.next(), consumers.next()) {
        (Some((t, ArcKind::Consume)), None) if t == join => {}
        _ => return None,
    }
    let mut from = None;
    for s in work.producers(p) {
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
pub(crate) fn plan_bundles(work: Work, facts: &Facts, owner: &[Owner]) -> Vec<Bundle> {
    let net = work.net;
    let crossing: Vec<EdgeIndex> = work
        .arcs()
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
            let mut c = work.consumers(p);
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
        let inputs: Vec<NodeId> = work.preset(join).collect();
        let depth = inputs.first().map(|p| facts.depth[p.index()]);
        if inputs.iter().any(|p| Some(facts.depth[p.index()]) != depth)
            || work.read_set(join).next().is_some()
        {
            continue;
        }
        let mut by_owner: BTreeMap<Owner, Vec<NodeId>> = BTreeMap::new();
        for &p in &inputs {
            if let Some(from) = prejoinable(work, facts, owner, p, join) {
                let free = work
                    .incoming(p)
                    .all(|e| is_crossing[e.id().index()] && !covered[e.id().index()]);
                if free {
                    by_owner.entry(from).or_default().push(p);
                }
            }
        }
        for (from, places) in by_owner {
            let arcs: usize = places.iter().map(|&p| work.producers(p).count()).sum();
            if arcs >= 2 {
                prejoins.push((arcs, join, from, places));
            }
        }
    }
    prejoins.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    for (_, join, from, places) in prejoins {
        let arcs: Vec<EdgeIndex> = places
            .iter()
            .flat_map(|&p| work.incoming(p).map(|e| e.id()))
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

/// The bridge count of [`plan_bundles`], kept as a sum of local terms so
/// that a move is judged by the few terms it can change.
///
/// The greedy plan never has to choose between two bundles of one kind
/// (fan-outs of different transitions, pre-joins of different joins and
/// forwards into different places share no arc), and a later kind only
/// takes arcs an earlier one left. So the number of bundles is
///
/// - per transition `t`: the remote owners that receive two arcs or more
///   from `t` (its fan-outs);
/// - per join `J`: the producer owners whose eligible, uncovered inputs of
///   `J` bring two arcs or more (its pre-joins);
/// - per place `p` outside a pre-join: the remote owners among the
///   producers of its arcs that no fan-out covers (a forward, or one direct
///   arc, each).
///
/// Each term reads the owners of a node's neighbours and of their
/// neighbours, so a move changes only the terms around it (see
/// [`Cost::anchors`]): evaluating it costs what its neighbourhood costs,
/// not what the net costs.
struct Cost {
    /// Produce arcs out of every transition, by target (one entry per arc).
    outs: Csr,
    /// Produce arcs into every place, by source (one entry per arc).
    ins: Csr,
    /// The transition that is a place's only consumer, when it consumes it.
    sole: Vec<u32>,
    /// Consume inputs of every transition whose inputs could be pre-joined
    /// (one depth, no read arc), empty otherwise.
    joinable: Csr,
    marked: Vec<bool>,
    is_place: Vec<bool>,
    /// Owner of every node, kept in step with the search.
    owner: Vec<Owner>,
    /// Scratch: places in a pre-join, during one evaluation.
    prejoined: Vec<bool>,
    /// Scratch: membership stamps for collecting anchors.
    stamp: Vec<u32>,
    epoch: u32,
    /// Scratch: the owners one term counts. The search evaluates these terms
    /// millions of times on a stress mission; a vector each time was a sixth
    /// of the whole compile.
    owners: Vec<Owner>,
    /// Scratch: the pre-join groups of one join.
    groups: Vec<(Owner, usize, u32)>,
}

/// The terms a move of some units can change.
#[derive(Default)]
struct Anchors {
    fanouts: Vec<u32>,
    joins: Vec<u32>,
    places: Vec<u32>,
}

const NONE: u32 = u32::MAX;

/// Adjacency lists of all nodes in two flat arrays (one allocation each,
/// where a list per node would make hundreds of thousands).
struct Csr {
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Csr {
    /// From `(node, item)` pairs; a node's items keep their order.
    fn new(n: usize, mut pairs: Vec<(u32, u32)>) -> Csr {
        pairs.sort_by_key(|&(v, _)| v);
        let mut start = vec![0u32; n + 1];
        for &(v, _) in &pairs {
            start[v as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        Csr {
            start,
            items: pairs.into_iter().map(|(_, x)| x).collect(),
        }
    }

    fn of(&self, v: u32) -> &[u32] {
        &self.items[self.start[v as usize] as usize..self.start[v as usize + 1] as usize]
    }
}

impl Cost {
    fn new(work: Work, facts: &Facts, owner: Vec<Owner>) -> Cost {
        let net = work.net;
        let n = net.graph.node_count();
        let mut outs = Vec::new();
        let mut ins = Vec::new();
        let mut consumers = vec![0u32; n];
        let mut sole = vec![NONE; n];
        for e in work.arcs() {
            let (a, b) = (e.source().index(), e.target().index());
            match e.weight().kind {
                ArcKind::Produce => {
                    outs.push((a as u32, b as u32));
                    ins.push((b as u32, a as u32));
                }
                ArcKind::Consume => {
                    consumers[a] += 1;
                    sole[a] = b as u32;
                }
                ArcKind::Read => consumers[a] += 1,
            }
        }
        for (p, c) in consumers.iter().enumerate() {
            if *c != 1 {
                sole[p] = NONE;
            }
        }
        let mut joinable = Vec::new();
        let mut inputs = Vec::new();
        for t in net.graph.node_indices() {
            if net.is_place(t) || work.read_set(t).next().is_some() {
                continue;
            }
            inputs.clear();
            inputs.extend(work.preset(t).map(|p| p.index() as u32));
            let depth = inputs.first().map(|&p| facts.depth[p as usize]);
            if inputs
                .iter()
                .all(|&p| Some(facts.depth[p as usize]) == depth)
            {
                joinable.extend(inputs.iter().map(|&p| (t.index() as u32, p)));
            }
        }
        Cost {
            outs: Csr::new(n, outs),
            ins: Csr::new(n, ins),
            sole,
            joinable: Csr::new(n, joinable),
            marked: facts.marked.clone(),
            is_place: net.graph.node_indices().map(|v| net.is_place(v)).collect(),
            owner,
            prejoined: vec![false; n],
            stamp: vec![0; n],
            epoch: 0,
            owners: Vec::new(),
            groups: Vec::new(),
        }
    }

    /// Fan-outs of transition `t`.
    fn fanouts(&mut self, t: u32) -> usize {
        let outs = self.outs.of(t);
        // Most transitions have one output: no fan-out without two.
        if outs.len() < 2 {
            return 0;
        }
        let me = self.owner[t as usize];
        let remote = &mut self.owners;
        remote.clear();
        remote.extend(
            outs.iter()
                .map(|&p| self.owner[p as usize])
                .filter(|&o| o != me),
        );
        remote.sort_unstable();
        remote
            .chunk_by(|a, b| a == b)
            .filter(|g| g.len() >= 2)
            .count()
    }

    /// Whether the arc `s -> p` crosses inside a fan-out of `s`.
    fn covered(&self, s: u32, p: u32) -> bool {
        let to = self.owner[p as usize];
        to != self.owner[s as usize]
            && self
                .outs
                .of(s)
                .iter()
                .filter(|&&q| self.owner[q as usize] == to)
                .nth(1)
                .is_some()
    }

    /// The owner a pre-join of `p` would run on, if `p` can be pre-joined
    /// (see `prejoinable`) and none of its arcs is in a fan-out.
    fn prejoin_from(&self, p: u32, join: u32) -> Option<Owner> {
        if self.marked[p as usize] || self.sole[p as usize] != join {
            return None;
        }
        let here = self.owner[p as usize];
        let mut from = None;
        for &s in self.ins.of(p) {
            let o = self.owner[s as usize];
            if from.is_some_and(|f| f != o) || o == here || self.covered(s, p) {
                return None;
            }
            from = Some(o);
        }
        from
    }

    /// Pre-joins of `join`; marks their places in `prejoined` when asked.
    fn prejoins(&mut self, join: u32, mark: bool) -> usize {
        let mut groups = std::mem::take(&mut self.groups);
        groups.clear();
        groups.extend(self.joinable.of(join).iter().filter_map(|&p| {
            self.prejoin_from(p, join)
                .map(|f| (f, self.ins.of(p).len(), p))
        }));
        groups.sort_unstable();
        let mut count = 0;
        for g in groups.chunk_by(|a, b| a.0 == b.0) {
            if g.iter().map(|x| x.1).sum::<usize>() >= 2 {
                count += 1;
                if mark {
                    for x in g {
                        self.prejoined[x.2 as usize] = true;
                    }
                }
            }
        }
        self.groups = groups;
        count
    }

    /// Forwards and direct arcs into place `p`.
    fn arrivals(&mut self, p: u32) -> usize {
        if self.prejoined[p as usize] {
            return 0;
        }
        let here = self.owner[p as usize];
        let ins = self.ins.of(p);
        if let [s] = ins {
            return usize::from(self.owner[*s as usize] != here && !self.covered(*s, p));
        }
        let mut remote = std::mem::take(&mut self.owners);
        remote.clear();
        remote.extend(
            ins.iter()
                .filter(|&&s| self.owner[s as usize] != here && !self.covered(s, p))
                .map(|&s| self.owner[s as usize]),
        );
        remote.sort_unstable();
        remote.dedup();
        let n = remote.len();
        self.owners = remote;
        n
    }

    /// The sum of the terms named by `anchors`.
    fn local(&mut self, a: &Anchors) -> usize {
        let mut total = 0;
        for &t in &a.fanouts {
            total += self.fanouts(t);
        }
        for &j in &a.joins {
            total += self.prejoins(j, true);
        }
        for &p in &a.places {
            total += self.arrivals(p);
        }
        for &j in &a.joins {
            for &p in self.joinable.of(j) {
                self.prejoined[p as usize] = false;
            }
        }
        total
    }

    /// Every term: the bridge count of the current owners.
    fn total(&mut self) -> usize {
        let n = self.owner.len() as u32;
        let all = Anchors {
            fanouts: (0..n).filter(|&v| !self.outs.of(v).is_empty()).collect(),
            joins: (0..n)
                .filter(|&v| !self.joinable.of(v).is_empty())
                .collect(),
            places: (0..n).filter(|&v| !self.ins.of(v).is_empty()).collect(),
        };
        self.local(&all)
    }

    /// The terms that moving `nodes` to another owner can change: fan-outs
    /// of the transitions moved or feeding a place moved (`S`), pre-joins of
    /// the joins moved or consuming what `S` produces, arrivals into what
    /// `S` produces and into those joins' inputs.
    fn anchors(&mut self, nodes: impl Iterator<Item = u32>, a: &mut Anchors) {
        self.epoch += 1;
        let epoch = self.epoch;
        a.fanouts.clear();
        a.joins.clear();
        a.places.clear();
        for v in nodes {
            if self.is_place[v as usize] {
                a.fanouts.extend(self.ins.of(v).iter().copied());
            } else {
                a.joins.push(v);
                a.fanouts.push(v);
            }
        }
        a.fanouts.sort_unstable();
        a.fanouts.dedup();
        for &t in &a.fanouts {
            for &q in self.outs.of(t) {
                if self.stamp[q as usize] != epoch {
                    self.stamp[q as usize] = epoch;
                    a.places.push(q);
                }
                if self.sole[q as usize] != NONE {
                    a.joins.push(self.sole[q as usize]);
                }
            }
        }
        a.joins.retain(|&j| !self.joinable.of(j).is_empty());
        a.joins.sort_unstable();
        a.joins.dedup();
        for &j in &a.joins {
            for &p in self.joinable.of(j) {
                if self.stamp[p as usize] != epoch {
                    self.stamp[p as usize] = epoch;
                    a.places.push(p);
                }
            }
        }
    }
}

/// Places every free unit: first next to the fixed units it touches most,
/// then by local search over single units and chains of free units, moving
/// only when the bridge count drops (or, at an equal count, when the move
/// follows the fork-with-predecessor, join-with-successor convention).
///
/// Linear in the net per pass: the seed visits each unit once per owner it
/// hears of, and a move is judged by the bridges around it ([`Cost`]).
pub(crate) fn assign(work: Work, units: &Units, facts: &Facts, owners: &[Owner]) -> Assignment {
    let nu = units.units.len();
    let mut unit_owner = seed(work, units);
    let default = owners.first().copied().unwrap_or(Owner::Gcs);
    let mut unit_owner: Vec<Owner> = unit_owner.drain(..).map(|o| o.unwrap_or(default)).collect();

    let free: Vec<usize> = (0..nu)
        .filter(|&u| units.units[u].fixed.is_none())
        .collect();
    if free.is_empty() {
        return Assignment { unit_owner };
    }
    let rank = |unit_owner: &[Owner], u: usize, o: Owner| -> u8 {
        match units.units[u].hint {
            Hint::Upstream(w) | Hint::Downstream(w) if unit_owner[w] == o => 0,
            Hint::None => 0,
            _ => 1,
        }
    };
    let owner_of_nodes = units.unit_of.iter().map(|&u| unit_owner[u]).collect();
    let mut model = Cost::new(work, facts, owner_of_nodes);
    let mut cost = model.total();
    let set = |model: &mut Cost, group: &[usize], o: Owner| {
        for &g in group {
            for &v in &units.units[g].nodes {
                model.owner[v.index()] = o;
            }
        }
    };
    // The first pass visits every free unit; later ones only those near a
    // unit that moved (their moves are judged by owners within a few arcs).
    let mut todo = free;
    let mut dirty = vec![false; nu];
    let mut anchors = Anchors::default();
    for _ in 0..MAX_PASSES {
        let mut improved = false;
        let mut moved: Vec<usize> = Vec::new();
        for &u in &todo {
            // The unit alone, then the chain of free units around it that
            // share its owner (a join and the fork after it move together),
            // taken after the unit's own move so that it moves as one.
            for step in 0..2 {
                let group = if step == 0 {
                    vec![u]
                } else {
                    let chain = chain_of(units, &unit_owner, u);
                    if chain.len() <= 1 {
                        break;
                    }
                    chain
                };
                let current = unit_owner[u];
                let mut candidates: Vec<Owner> = group
                    .iter()
                    .flat_map(|&g| units.units[g].neighbours.iter().map(|&w| unit_owner[w]))
                    .filter(|&o| o != current)
                    .collect();
                candidates.sort();
                candidates.dedup();
                if candidates.is_empty() {
                    continue;
                }
                model.anchors(
                    group
                        .iter()
                        .flat_map(|&g| units.units[g].nodes.iter().map(|v| v.index() as u32)),
                    &mut anchors,
                );
                let before = model.local(&anchors);
                let mut best = (cost, rank(&unit_owner, u, current), current);
                for o in candidates {
                    set(&mut model, &group, o);
                    for &g in &group {
                        unit_owner[g] = o;
                    }
                    let after = cost + model.local(&anchors) - before;
                    let c = (after, rank(&unit_owner, u, o), o);
                    if (c.0, c.1) < (best.0, best.1) {
                        best = c;
                    }
                    for &g in &group {
                        unit_owner[g] = current;
                    }
                }
                set(&mut model, &group, best.2);
                if best.2 != current {
                    for &g in &group {
                        unit_owner[g] = best.2;
                    }
                    cost = best.0;
                    improved = true;
                    moved.extend_from_slice(&group);
                }
            }
        }
        if !improved {
            break;
        }
        // Units within two hops of a move, in index order.
        let mut next = Vec::new();
        for &m in &moved {
            for &w in std::iter::once(&m).chain(&units.units[m].neighbours) {
                for &x in std::iter::once(&w).chain(&units.units[w].neighbours) {
                    if units.units[x].fixed.is_none() && !dirty[x] {
                        dirty[x] = true;
                        next.push(x);
                    }
                }
            }
        }
        for &x in &next {
            dirty[x] = false;
        }
        next.sort_unstable();
        todo = next;
    }
    debug_assert_eq!(
        cost,
        plan_bundles(
            work,
            facts,
            &Assignment {
                unit_owner: unit_owner.clone()
            }
            .node_owners(units)
        )
        .len(),
        "the incremental bridge count drifted from the plan"
    );
    Assignment { unit_owner }
}

/// Spreads owners from the fixed units to free neighbours, the owner with
/// the most arcs into the unit first, the smaller owner on a tie. Sweeps
/// the units in index order, a unit seeing the owners given earlier in the
/// same sweep; only units next to a newly placed one are visited again.
fn seed(work: Work, units: &Units) -> Vec<Option<Owner>> {
    let mut unit_owner: Vec<Option<Owner>> = units.units.iter().map(|u| u.fixed).collect();
    let nu = units.units.len();
    // Units to visit in this sweep (at or after the current index) and in
    // the next one, as min-heaps.
    let mut this: BinaryHeap<Reverse<usize>> = BinaryHeap::new();
    let mut next: BinaryHeap<Reverse<usize>> = BinaryHeap::new();
    let mut queued = vec![false; nu];
    for u in 0..nu {
        if unit_owner[u].is_none()
            && units.units[u]
                .neighbours
                .iter()
                .any(|&w| unit_owner[w].is_some())
        {
            queued[u] = true;
            this.push(Reverse(u));
        }
    }
    loop {
        while let Some(Reverse(u)) = this.pop() {
            queued[u] = false;
            if unit_owner[u].is_some() {
                continue;
            }
            let mut score: BTreeMap<Owner, usize> = BTreeMap::new();
            for &v in &units.units[u].nodes {
                let arcs = work
                    .incoming(v)
                    .map(|e| e.source())
                    .chain(work.outgoing(v).map(|e| e.target()));
                for w in arcs {
                    let wu = units.unit_of[w.index()];
                    if wu != u {
                        if let Some(o) = unit_owner[wu] {
                            *score.entry(o).or_default() += 1;
                        }
                    }
                }
            }
            let Some((&o, _)) = score.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))) else {
                continue;
            };
            unit_owner[u] = Some(o);
            for &w in &units.units[u].neighbours {
                if unit_owner[w].is_none() && !queued[w] {
                    queued[w] = true;
                    if w > u {
                        this.push(Reverse(w));
                    } else {
                        next.push(Reverse(w));
                    }
                }
            }
        }
        if next.is_empty() {
            break;
        }
        std::mem::swap(&mut this, &mut next);
    }
    unit_owner
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
