//! From an assignment to slices: apply the bundles to the net (new fan-out,
//! pre-join and forward nodes), then cut the result along owners.

use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufWriter, Write as _};

use eamos_lang::hir::DroneId;
use eamos_petri::net::{
    Arc, ArcKind, ColourOp, Net, Node, NodeId, Owner, Place, PlaceKind, Transition, TransitionKind,
};
use petgraph::graph::DiGraph;
use petgraph::visit::EdgeRef;
use petgraph::Direction;
use sha2::{Digest, Sha256};

use crate::end::End;
use crate::error::SliceError;
use crate::partition::{assign, node_id, plan_bundles, Bundle, Facts, Units};
use crate::slice::{BridgeIn, BridgeOut, Produce, Slice, SliceTransition, GCS};
use crate::work::Work;

/// The slices of one mission, the ground station's first, then one per
/// drone in the order the mission declares them.
#[derive(Debug, Clone)]
pub struct Slices {
    pub mission: String,
    /// The mission identity every slice carries (see [`slice_as`]).
    pub mission_id: String,
    pub slices: Vec<Slice>,
    /// The mission's drones, in the order it declares them.
    pub drones: Vec<String>,
    /// Each drone's capability profile, in the same order.
    pub profiles: Vec<String>,
}

impl Slices {
    /// The slice run by this drone (or by [`GCS`]).
    pub fn get(&self, drone: &str) -> Option<&Slice> {
        self.slices.iter().find(|s| s.drone == drone)
    }

    /// All bridges of the mission.
    pub fn bridge_count(&self) -> usize {
        self.slices.iter().map(|s| s.bridges_out.len()).sum()
    }
}

/// The name an owner goes by in slices and ids.
pub(crate) fn owner_name(net: &Net, o: Owner) -> String {
    match o {
        Owner::Drone(d) => net.drones[d.0 as usize].clone(),
        _ => GCS.to_string(),
    }
}

/// A hash of the mission's net. It is not the mission identity (which
/// also covers the fleet, see `eamos_fleet::identity`), only one input of
/// it; [`slice`] names slices by it when no identity is given.
pub fn net_id(net: &Net) -> String {
    // The compact form, streamed through a small buffer: a stress mission's
    // net is megabytes of it, and field-sized writes into the hash cost more
    // than the copy. SHA-256 rather than the SHA3 of the slice files: the
    // ground station that compiles has it in hardware (x86 SHA extensions,
    // ARMv8 crypto), and SHA3 in software was a tenth of a whole compile.
    let mut hasher = Sha256::new();
    let mut buffered = BufWriter::with_capacity(1 << 16, &mut hasher);
    postcard::to_io(net, &mut buffered).expect("a net always serialises");
    buffered.flush().expect("a hash takes every byte");
    drop(buffered);
    hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// A net to slice, lent or handed over. A net handed over is freed once
/// distributed, before the cut: a compile's peak then holds two of the
/// net, the distributed net and the slices, not all three (on the stress
/// mission, 3 of 10 MB). Lend it where the caller still needs it.
pub enum Handed<'a> {
    Lent(&'a Net),
    Given(Net),
}

impl<'a> From<&'a Net> for Handed<'a> {
    fn from(net: &'a Net) -> Self {
        Self::Lent(net)
    }
}

impl From<Net> for Handed<'_> {
    fn from(net: Net) -> Self {
        Self::Given(net)
    }
}

impl Handed<'_> {
    fn net(&self) -> &Net {
        match self {
            Self::Lent(net) => net,
            Self::Given(net) => net,
        }
    }
}

/// Slices a mission net: one slice for the ground station and one per
/// drone, named by the net's hash ([`net_id`]): for tools and tests that
/// have no fleet. A mission to fly is cut with [`slice_as`] under its
/// identity.
///
/// The hash and the partition do not depend on each other, and only the
/// cut needs the hash: it is computed on a second thread while the net is
/// partitioned (a tenth of the stress mission's compile taken off its
/// critical path), or in turn where no thread can be started.
pub fn slice<'a>(net: impl Into<Handed<'a>>) -> Result<Slices, SliceError> {
    let net = net.into();
    let (distributed, id) = std::thread::scope(|scope| {
        let net = net.net();
        let hashing = std::thread::Builder::new()
            .name("net-id".into())
            .spawn_scoped(scope, || net_id(net));
        let distributed = distribute(net);
        let id = match hashing {
            Ok(h) => h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)),
            Err(_) => net_id(net),
        };
        distributed.map(|d| (d, id))
    })?;
    drop(net);
    Ok(cut_slices(&distributed, id))
}

/// Slices a mission net under the mission identity `identity`, which every
/// slice carries from birth.
pub fn slice_as<'a>(net: impl Into<Handed<'a>>, identity: &str) -> Result<Slices, SliceError> {
    let net = net.into();
    let distributed = distribute(net.net())?;
    drop(net);
    Ok(cut_slices(&distributed, identity.to_string()))
}

/// Slices a mission net as [`slice`] does, and gives the distributed net
/// beside the slices: the mission net after bundling, every node owned,
/// whose cut along owners ([`cut_along_owners`]) gives the slices and whose
/// arcs between owners are exactly the bridges. For drawings and checks of
/// the slicer: [`slice`] frees the distributed net once it is cut.
pub fn slice_distributed(net: &Net) -> Result<(Slices, Net), SliceError> {
    let distributed = distribute(net)?;
    let slices = cut_slices(&distributed, net_id(net));
    Ok((slices, distributed))
}

/// The slices cut from a distributed net under `identity`.
fn cut_slices(distributed: &Net, identity: String) -> Slices {
    Slices {
        mission: distributed.name.clone(),
        slices: cut_along_owners(distributed, &identity),
        mission_id: identity,
        drones: distributed.drones.clone(),
        profiles: distributed.profiles.clone(),
    }
}

/// The distributed net: `net` partitioned among its owners, bundled, every
/// node owned.
fn distribute(net: &Net) -> Result<Net, SliceError> {
    if let Some(name) = net.drones.iter().find(|d| *d == GCS) {
        return Err(SliceError::ReservedName(name.clone()));
    }
    if !net.profiles.is_empty() && net.profiles.len() != net.drones.len() {
        return Err(SliceError::Profiles {
            drones: net.drones.len(),
            profiles: net.profiles.len(),
        });
    }
    for v in net.graph.node_indices() {
        if let Owner::Drone(d) = net.owner(v) {
            if d.0 as usize >= net.drones.len() {
                return Err(SliceError::UnknownDrone {
                    node: node_id(net, v),
                    index: d.0,
                    drones: net.drones.len(),
                });
            }
        }
    }
    // The end tree is nobody's (see `end.rs`): partition the net without
    // its arcs, so that its inputs stay wherever their producers are.
    let end = End::of(net);
    let work = Work::new(net, end.as_ref().map_or(&[], |e| &e.region));
    let units = Units::of(work)?;
    let facts = Facts::of(net);
    let owners: Vec<Owner> = std::iter::once(Owner::Gcs)
        .chain((0..net.drones.len()).map(|d| Owner::Drone(DroneId(d as u16))))
        .collect();
    let assignment = assign(work, &units, &facts, &owners);
    let owner = assignment.node_owners(&units);
    let bundles = plan_bundles(work, &facts, &owner);
    // The partition's working state is dropped before the distributed net
    // is built, whose memory it becomes (a megabyte on the stress mission).
    drop((units, facts, assignment));
    Ok(apply_bundles(work, &owner, &bundles, end.as_ref()))
}

/// The slices of a net whose nodes all have their owner (the distributed
/// net of [`slice_distributed`]): every arc between two owners becomes a
/// bridge. Cutting the distributed net again gives the same slices; the
/// mutation tests cut a net with nodes moved to other owners, to see that a
/// wrong slicing is told apart from a right one.
pub fn cut_along_owners(distributed: &Net, identity: &str) -> Vec<Slice> {
    let owners: Vec<Owner> = std::iter::once(Owner::Gcs)
        .chain((0..distributed.drones.len()).map(|d| Owner::Drone(DroneId(d as u16))))
        .collect();
    let ends = end_owners(distributed);
    cut_all(distributed, &owners, identity, &ends)
}

fn max_input_depth(work: Work, t: NodeId) -> u8 {
    work.preset(t)
        .chain(work.read_set(t))
        .filter_map(|p| work.net.place(p).map(|p| p.depth))
        .max()
        .unwrap_or(0)
}

/// Rewrites the net so that every bundle becomes one crossing arc, and the
/// end tree (if any) becomes one end per owner joined by a transition that
/// belongs to no one (see `end.rs`).
fn apply_bundles(work: Work, owner: &[Owner], bundles: &[Bundle], end: Option<&End>) -> Net {
    let net = work.net;
    // Sized for what the bundles and the end add (two nodes and at most
    // one arc more per target each), so that the vectors never double.
    let added: usize = bundles
        .iter()
        .map(|b| match b {
            Bundle::Direct { .. } => 0,
            Bundle::FanOut { arcs, .. } | Bundle::Forward { arcs, .. } => arcs.len(),
            Bundle::PreJoin { places, .. } => places.len(),
        })
        .sum();
    let ends = end.map_or(0, |e| e.inputs.len());
    let mut graph: DiGraph<Node, Arc> = DiGraph::with_capacity(
        net.graph.node_count() + 2 * bundles.len() + 2 * ends,
        net.graph.edge_count() + 2 * bundles.len() + added + 3 * ends,
    );
    // New index of every node of `net`; the end tree's inner nodes go.
    let mut map: Vec<Option<NodeId>> = vec![None; net.graph.node_count()];
    for v in net.graph.node_indices() {
        let virtual_end = end.is_some_and(|e| v == e.finish || v == net.final_place);
        if end.is_some_and(|e| e.region[v.index()]) && !virtual_end {
            continue;
        }
        let o = if virtual_end {
            Owner::Unassigned
        } else {
            owner[v.index()]
        };
        let mut node = net.graph[v].clone();
        match &mut node {
            Node::Place(p) => p.owner = o,
            Node::Transition(t) => t.owner = o,
        }
        map[v.index()] = Some(graph.add_node(node));
    }
    let at = |v: NodeId| map[v.index()].expect("bundles touch no node of the end tree");
    let mut skip = vec![false; net.graph.edge_count()];
    let mut extra: Vec<(NodeId, NodeId, ArcKind, ColourOp)> = Vec::new();
    let name = |o: Owner| owner_name(net, o);
    for b in bundles {
        match b {
            Bundle::Direct { .. } => {}
            Bundle::FanOut {
                transition,
                to,
                arcs,
            } => {
                let t = net
                    .transition(*transition)
                    .expect("fan-out from a transition");
                let targets: Vec<(NodeId, ColourOp)> = arcs
                    .iter()
                    .map(|&e| {
                        skip[e.index()] = true;
                        (
                            net.graph.edge_endpoints(e).expect("edge").1,
                            net.graph[e].colour,
                        )
                    })
                    .collect();
                let same = targets.iter().all(|&(_, c)| c == targets[0].1);
                let (send, depth) = if same {
                    let d = net.place(targets[0].0).map_or(0, |p| p.depth);
                    (targets[0].1, d)
                } else {
                    (ColourOp::Keep, max_input_depth(work, *transition))
                };
                let inbox = graph.add_node(Node::Place(Place {
                    id: format!("{}.out.{}.p", t.id, name(*to)).into(),
                    label: format!("from {}", t.label).into(),
                    kind: PlaceKind::Control,
                    owner: *to,
                    span: Some(t.span),
                    depth,
                }));
                let proxy = graph.add_node(Node::Transition(Transition {
                    id: format!("{}.out.{}", t.id, name(*to)).into(),
                    label: format!("fan-out of {}", t.label).into(),
                    kind: TransitionKind::Fork,
                    owner: *to,
                    span: t.span,
                    guard: None,
                    delay: None,
                }));
                extra.push((at(*transition), inbox, ArcKind::Produce, send));
                extra.push((inbox, proxy, ArcKind::Consume, ColourOp::Keep));
                for (p, c) in targets {
                    let local = if same { ColourOp::Keep } else { c };
                    extra.push((proxy, at(p), ArcKind::Produce, local));
                }
            }
            Bundle::PreJoin { join, from, places } => {
                let j = net.transition(*join).expect("pre-join before a transition");
                let depth = net.place(places[0]).map_or(0, |p| p.depth);
                for &p in places {
                    if let Node::Place(place) = &mut graph[at(p)] {
                        place.owner = *from;
                    }
                    for e in work.connecting(p, *join) {
                        skip[e.id().index()] = true;
                    }
                }
                let pre = graph.add_node(Node::Transition(Transition {
                    id: format!("{}.in.{}", j.id, name(*from)).into(),
                    label: format!("join on {} before {}", name(*from), j.label).into(),
                    kind: TransitionKind::Join,
                    owner: *from,
                    span: j.span,
                    guard: None,
                    delay: None,
                }));
                let inbox = graph.add_node(Node::Place(Place {
                    id: format!("{}.in.{}.p", j.id, name(*from)).into(),
                    label: format!("joined on {}", name(*from)).into(),
                    kind: PlaceKind::Control,
                    owner: owner[join.index()],
                    span: Some(j.span),
                    depth,
                }));
                for &p in places {
                    extra.push((at(p), pre, ArcKind::Consume, ColourOp::Keep));
                }
                extra.push((pre, inbox, ArcKind::Produce, ColourOp::Keep));
                extra.push((inbox, at(*join), ArcKind::Consume, ColourOp::Keep));
            }
            Bundle::Forward { place, from, arcs } => {
                let p = net.place(*place).expect("forward into a place");
                let first = net.graph.edge_endpoints(arcs[0]).expect("edge").0;
                let span = net.transition(first).map(|t| t.span).unwrap_or_default();
                let local = graph.add_node(Node::Place(Place {
                    id: format!("{}.fwd.{}.p", p.id, name(*from)).into(),
                    label: format!("{} on {}", p.label, name(*from)).into(),
                    kind: PlaceKind::Control,
                    owner: *from,
                    span: p.span,
                    depth: p.depth,
                }));
                let fwd = graph.add_node(Node::Transition(Transition {
                    id: format!("{}.fwd.{}", p.id, name(*from)).into(),
                    label: format!("forward to {}", p.label).into(),
                    kind: TransitionKind::Silent,
                    owner: *from,
                    span,
                    guard: None,
                    delay: None,
                }));
                for &e in arcs {
                    skip[e.index()] = true;
                    let s = net.graph.edge_endpoints(e).expect("edge").0;
                    extra.push((at(s), local, ArcKind::Produce, net.graph[e].colour));
                }
                extra.push((local, fwd, ArcKind::Consume, ColourOp::Keep));
                extra.push((fwd, at(*place), ArcKind::Produce, ColourOp::Keep));
            }
        }
    }
    for e in work.arcs() {
        if !skip[e.id().index()] {
            graph.add_edge(at(e.source()), at(e.target()), *e.weight());
        }
    }
    let arc = |kind, colour| Arc {
        kind,
        weight: 1,
        colour,
    };
    for (a, b, kind, colour) in extra {
        graph.add_edge(a, b, arc(kind, colour));
    }
    if let Some(end) = end {
        let finish = net.transition(end.finish).expect("finish is a transition");
        let span = finish.span;
        let mut by_owner: BTreeMap<Owner, Vec<NodeId>> = BTreeMap::new();
        for &p in &end.inputs {
            by_owner.entry(owner[p.index()]).or_default().push(p);
        }
        for (o, inputs) in by_owner {
            let who = name(o);
            let place = graph.add_node(Node::Place(Place {
                id: format!("final.{who}").into(),
                label: format!("end of the mission on {who}").into(),
                kind: PlaceKind::Final,
                owner: o,
                span: Some(span),
                depth: 0,
            }));
            let t = graph.add_node(Node::Transition(Transition {
                id: format!("end.{who}").into(),
                label: format!("{} on {who}", finish.label).into(),
                kind: TransitionKind::Finish,
                owner: o,
                span,
                guard: None,
                delay: None,
            }));
            for p in inputs {
                graph.add_edge(at(p), t, arc(ArcKind::Consume, ColourOp::Keep));
            }
            graph.add_edge(t, place, arc(ArcKind::Produce, ColourOp::Keep));
            graph.add_edge(place, at(end.finish), arc(ArcKind::Consume, ColourOp::Keep));
        }
        graph.add_edge(
            at(end.finish),
            at(net.final_place),
            arc(ArcKind::Produce, ColourOp::Keep),
        );
    }
    Net {
        name: net.name.clone(),
        graph,
        drones: net.drones.clone(),
        profiles: net.profiles.clone(),
        initial_marking: net.initial_marking.iter().map(|&p| at(p)).collect(),
        initial_place: at(net.initial_place),
        final_place: at(net.final_place),
    }
}

/// The owners that hold an end of the mission (a final place), in the order
/// of `owners`: the mission has ended when each of them has reached it.
fn end_owners(net: &Net) -> Vec<Owner> {
    let mut ends: Vec<Owner> = net
        .places()
        .filter(|(_, p)| p.kind == PlaceKind::Final && p.owner != Owner::Unassigned)
        .map(|(_, p)| p.owner)
        .collect();
    ends.sort();
    ends.dedup();
    ends
}

/// Every owner's slice. The bridges are numbered once for all, and each
/// slice visits only its own nodes and arcs.
fn cut_all(net: &Net, owners: &[Owner], mission_id: &str, ends: &[Owner]) -> Vec<Slice> {
    let index_of = |o: Owner| owners.iter().position(|&x| x == o);
    let mut nodes: Vec<Vec<NodeId>> = vec![Vec::new(); owners.len()];
    // Index of every node among its owner's places or transitions.
    let mut local = vec![u32::MAX; net.graph.node_count()];
    let mut counts = vec![(0u32, 0u32); owners.len()];
    for v in net.graph.node_indices() {
        if let Some(i) = index_of(net.owner(v)) {
            nodes[i].push(v);
            let count = if net.is_place(v) {
                &mut counts[i].0
            } else {
                &mut counts[i].1
            };
            local[v.index()] = *count;
            *count += 1;
        }
    }
    let mut bridges: Vec<Vec<(u32, petgraph::graph::EdgeIndex)>> = vec![Vec::new(); owners.len()];
    for (id, e) in bridge_order(net).into_iter().enumerate() {
        let (t, p) = net.graph.edge_endpoints(e).expect("edge");
        for o in [net.owner(t), net.owner(p)] {
            if let Some(i) = index_of(o) {
                bridges[i].push((id as u32, e));
            }
        }
    }
    let ends: std::sync::Arc<[String]> = ends.iter().map(|&o| owner_name(net, o)).collect();
    let drones: std::sync::Arc<[String]> = net.drones.as_slice().into();
    owners
        .iter()
        .zip(nodes)
        .zip(bridges)
        .zip(counts)
        .map(|(((&me, nodes), bridges), count)| {
            let part = Cut {
                me,
                mission_id,
                nodes: &nodes,
                local: &local,
                bridges: &bridges,
                ends: &ends,
                drones: &drones,
            };
            cut(net, part, count)
        })
        .collect()
}

/// One owner's part of the distributed net, as [`cut`] takes it.
struct Cut<'a> {
    me: Owner,
    mission_id: &'a str,
    nodes: &'a [NodeId],
    /// Index of every node among its owner's places or transitions.
    local: &'a [u32],
    /// The bridges this owner sends or receives, numbered.
    bridges: &'a [(u32, petgraph::graph::EdgeIndex)],
    ends: &'a std::sync::Arc<[String]>,
    /// The mission's drones, one list for every slice.
    drones: &'a std::sync::Arc<[String]>,
}

/// The slice of one owner: its nodes, its internal arcs, and a bridge for
/// every arc between it and another owner. `count` is how many places and
/// transitions it has: the slices live as long as the net, and vectors
/// grown by doubling would keep up to half their room spare at the peak.
fn cut(net: &Net, part: Cut, (place_count, transition_count): (u32, u32)) -> Slice {
    let Cut {
        me,
        mission_id,
        nodes,
        local,
        bridges,
        ends,
        drones,
    } = part;
    let mut places = Vec::with_capacity(place_count as usize);
    let mut transitions = Vec::with_capacity(transition_count as usize);
    for &v in nodes {
        match &net.graph[v] {
            Node::Place(p) => places.push(p.clone()),
            Node::Transition(t) => {
                transitions.push(SliceTransition {
                    transition: t.clone(),
                    consume: Vec::new(),
                    read: Vec::new(),
                    produce: Vec::new(),
                });
            }
        }
    }
    let local = |v: NodeId| local[v.index()];
    let mut bridges_in = Vec::new();
    let mut bridges_out = Vec::new();
    let mut peers = BTreeSet::new();
    for &(id, e) in bridges {
        let (t, p) = net.graph.edge_endpoints(e).expect("edge");
        let (from, to) = (net.owner(t), net.owner(p));
        if from == me {
            peers.insert(owner_name(net, to));
            bridges_out.push(BridgeOut {
                id,
                transition: local(t),
                to: owner_name(net, to),
                colour: net.graph[e].colour,
            });
        } else if to == me {
            peers.insert(owner_name(net, from));
            bridges_in.push(BridgeIn {
                id,
                from: owner_name(net, from),
                inbox: local(p),
            });
        }
    }
    // Internal arcs, in a stable order (by node, then by arc insertion).
    let mut final_place = None;
    for &v in nodes {
        if net.is_place(v) {
            if net.place(v).is_some_and(|p| p.kind == PlaceKind::Final) {
                final_place = Some(local(v));
            }
            continue;
        }
        let st = &mut transitions[local(v) as usize];
        let mut ins: Vec<_> = net.graph.edges_directed(v, Direction::Incoming).collect();
        ins.sort_by_key(|e| e.id());
        for e in ins {
            match e.weight().kind {
                ArcKind::Consume => st.consume.push(local(e.source())),
                ArcKind::Read => st.read.push(local(e.source())),
                ArcKind::Produce => {}
            }
        }
        let mut outs: Vec<_> = net.graph.edges_directed(v, Direction::Outgoing).collect();
        outs.sort_by_key(|e| e.id());
        for e in outs {
            if net.owner(e.target()) == me {
                st.produce.push(Produce {
                    place: local(e.target()),
                    colour: e.weight().colour,
                });
            }
        }
    }
    let mut telemetry = BTreeSet::new();
    for t in &transitions {
        if let Some(g) = &t.transition.guard {
            for d in g.drones() {
                if me != Owner::Drone(d) {
                    telemetry.insert(net.drones[d.0 as usize].clone());
                }
            }
        }
    }
    let initial_marking = net
        .initial_marking
        .iter()
        .filter(|&&p| net.owner(p) == me)
        .map(|&p| local(p))
        .collect();
    Slice {
        mission: net.name.clone(),
        mission_id: mission_id.to_string(),
        drone: owner_name(net, me),
        profile: match me {
            Owner::Drone(d) => net.profiles.get(d.0 as usize).cloned(),
            _ => None,
        },
        drones: drones.clone(),
        places,
        transitions,
        initial_marking,
        final_place,
        ends: ends.clone(),
        bridges_in,
        bridges_out,
        peers: peers.into_iter().collect(),
        telemetry: telemetry.into_iter().collect(),
    }
}

/// Crossing arcs in the order that numbers the bridges: by sending
/// transition, then by receiving place.
fn bridge_order(net: &Net) -> Vec<petgraph::graph::EdgeIndex> {
    let mut arcs: Vec<_> = net
        .graph
        .edge_references()
        .filter(|e| {
            e.weight().kind == ArcKind::Produce && net.owner(e.source()) != net.owner(e.target())
        })
        .map(|e| (e.source(), e.target(), e.id()))
        .collect();
    arcs.sort();
    arcs.into_iter().map(|(_, _, e)| e).collect()
}
