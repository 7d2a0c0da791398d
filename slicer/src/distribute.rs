//! From an assignment to slices: apply the bundles to the net (new fan-out,
//! pre-join and forward nodes), then cut the result along owners.

use std::collections::BTreeSet;

use eamos_lang::hir::DroneId;
use eamos_petri::net::{
    Arc, ArcKind, ColourOp, Net, Node, NodeId, Owner, Place, PlaceKind, Transition, TransitionKind,
};
use petgraph::graph::DiGraph;
use petgraph::visit::EdgeRef;
use petgraph::Direction;
use serde::{Deserialize, Serialize};
use sha3::{Digest, Sha3_256};

use crate::error::SliceError;
use crate::partition::{assign, node_id, plan_bundles, Bundle, Facts, Units};
use crate::slice::{BridgeIn, BridgeOut, Produce, Slice, SliceTransition, GCS};

/// The slices of one mission, the ground station's first, then one per
/// drone in the order the mission declares them.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Slices {
    pub mission: String,
    pub mission_id: String,
    pub slices: Vec<Slice>,
    /// The mission net after bundling, every node owned: cutting it along
    /// owners gives [`Slices::slices`]; its arcs between owners are exactly
    /// the bridges. Kept for drawings and checks.
    pub distributed: Net,
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

/// A hash of the mission's net: two slices belong to one mission exactly
/// when their identities are equal.
pub fn mission_id(net: &Net) -> String {
    let bytes = serde_json::to_vec(net).expect("a net always serialises");
    let digest = Sha3_256::digest(&bytes);
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Slices a mission net: one slice for the ground station and one per drone.
pub fn slice(net: &Net) -> Result<Slices, SliceError> {
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
    let units = Units::of(net)?;
    let facts = Facts::of(net);
    let owners: Vec<Owner> = std::iter::once(Owner::Gcs)
        .chain((0..net.drones.len()).map(|d| Owner::Drone(DroneId(d as u16))))
        .collect();
    let assignment = assign(net, &units, &facts, &owners);
    let owner = assignment.node_owners(&units);
    let bundles = plan_bundles(net, &facts, &owner);
    let distributed = apply_bundles(net, &owner, &bundles);
    let id = mission_id(net);
    let slices = owners.iter().map(|&o| cut(&distributed, o, &id)).collect();
    Ok(Slices {
        mission: net.name.clone(),
        mission_id: id,
        slices,
        distributed,
    })
}

fn max_input_depth(net: &Net, t: NodeId) -> u8 {
    net.preset(t)
        .chain(net.read_set(t))
        .filter_map(|p| net.place(p).map(|p| p.depth))
        .max()
        .unwrap_or(0)
}

/// Rewrites the net so that every bundle becomes one crossing arc.
fn apply_bundles(net: &Net, owner: &[Owner], bundles: &[Bundle]) -> Net {
    let mut graph: DiGraph<Node, Arc> =
        DiGraph::with_capacity(net.graph.node_count(), net.graph.edge_count());
    for v in net.graph.node_indices() {
        let mut node = net.graph[v].clone();
        match &mut node {
            Node::Place(p) => p.owner = owner[v.index()],
            Node::Transition(t) => t.owner = owner[v.index()],
        }
        graph.add_node(node);
    }
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
                    (ColourOp::Keep, max_input_depth(net, *transition))
                };
                let inbox = graph.add_node(Node::Place(Place {
                    id: format!("{}.out.{}.p", t.id, name(*to)),
                    label: format!("from {}", t.label),
                    kind: PlaceKind::Control,
                    owner: *to,
                    span: Some(t.span),
                    depth,
                }));
                let proxy = graph.add_node(Node::Transition(Transition {
                    id: format!("{}.out.{}", t.id, name(*to)),
                    label: format!("fan-out of {}", t.label),
                    kind: TransitionKind::Fork,
                    owner: *to,
                    span: t.span,
                    guard: None,
                    delay: None,
                }));
                extra.push((*transition, inbox, ArcKind::Produce, send));
                extra.push((inbox, proxy, ArcKind::Consume, ColourOp::Keep));
                for (p, c) in targets {
                    let local = if same { ColourOp::Keep } else { c };
                    extra.push((proxy, p, ArcKind::Produce, local));
                }
            }
            Bundle::PreJoin { join, from, places } => {
                let j = net.transition(*join).expect("pre-join before a transition");
                let depth = net.place(places[0]).map_or(0, |p| p.depth);
                for &p in places {
                    if let Node::Place(place) = &mut graph[p] {
                        place.owner = *from;
                    }
                    for e in net.graph.edges_connecting(p, *join) {
                        skip[e.id().index()] = true;
                    }
                }
                let pre = graph.add_node(Node::Transition(Transition {
                    id: format!("{}.in.{}", j.id, name(*from)),
                    label: format!("join on {} before {}", name(*from), j.label),
                    kind: TransitionKind::Join,
                    owner: *from,
                    span: j.span,
                    guard: None,
                    delay: None,
                }));
                let inbox = graph.add_node(Node::Place(Place {
                    id: format!("{}.in.{}.p", j.id, name(*from)),
                    label: format!("joined on {}", name(*from)),
                    kind: PlaceKind::Control,
                    owner: owner[join.index()],
                    span: Some(j.span),
                    depth,
                }));
                for &p in places {
                    extra.push((p, pre, ArcKind::Consume, ColourOp::Keep));
                }
                extra.push((pre, inbox, ArcKind::Produce, ColourOp::Keep));
                extra.push((inbox, *join, ArcKind::Consume, ColourOp::Keep));
            }
            Bundle::Forward { place, from, arcs } => {
                let p = net.place(*place).expect("forward into a place");
                let first = net.graph.edge_endpoints(arcs[0]).expect("edge").0;
                let span = net.transition(first).map(|t| t.span).unwrap_or_default();
                let local = graph.add_node(Node::Place(Place {
                    id: format!("{}.fwd.{}.p", p.id, name(*from)),
                    label: format!("{} on {}", p.label, name(*from)),
                    kind: PlaceKind::Control,
                    owner: *from,
                    span: p.span,
                    depth: p.depth,
                }));
                let fwd = graph.add_node(Node::Transition(Transition {
                    id: format!("{}.fwd.{}", p.id, name(*from)),
                    label: format!("forward to {}", p.label),
                    kind: TransitionKind::Silent,
                    owner: *from,
                    span,
                    guard: None,
                    delay: None,
                }));
                for &e in arcs {
                    skip[e.index()] = true;
                    let s = net.graph.edge_endpoints(e).expect("edge").0;
                    extra.push((s, local, ArcKind::Produce, net.graph[e].colour));
                }
                extra.push((local, fwd, ArcKind::Consume, ColourOp::Keep));
                extra.push((fwd, *place, ArcKind::Produce, ColourOp::Keep));
            }
        }
    }
    for e in net.graph.edge_references() {
        if !skip[e.id().index()] {
            graph.add_edge(e.source(), e.target(), *e.weight());
        }
    }
    for (a, b, kind, colour) in extra {
        graph.add_edge(
            a,
            b,
            Arc {
                kind,
                weight: 1,
                colour,
            },
        );
    }
    Net {
        name: net.name.clone(),
        graph,
        drones: net.drones.clone(),
        profiles: net.profiles.clone(),
        initial_marking: net.initial_marking.clone(),
        initial_place: net.initial_place,
        final_place: net.final_place,
    }
}

/// The slice of one owner: its nodes, its internal arcs, and a bridge for
/// every arc between it and another owner.
fn cut(net: &Net, me: Owner, mission_id: &str) -> Slice {
    let mut local = vec![u32::MAX; net.graph.node_count()];
    let mut places = Vec::new();
    let mut transitions = Vec::new();
    for v in net.graph.node_indices() {
        if net.owner(v) != me {
            continue;
        }
        match &net.graph[v] {
            Node::Place(p) => {
                local[v.index()] = places.len() as u32;
                places.push(p.clone());
            }
            Node::Transition(t) => {
                local[v.index()] = transitions.len() as u32;
                transitions.push(SliceTransition {
                    transition: t.clone(),
                    consume: Vec::new(),
                    read: Vec::new(),
                    produce: Vec::new(),
                });
            }
        }
    }
    let mut bridges_in = Vec::new();
    let mut bridges_out = Vec::new();
    let mut peers = BTreeSet::new();
    for (id, e) in bridge_order(net).into_iter().enumerate() {
        let (t, p) = net.graph.edge_endpoints(e).expect("edge");
        let (from, to) = (net.owner(t), net.owner(p));
        if from == me {
            peers.insert(owner_name(net, to));
            bridges_out.push(BridgeOut {
                id: id as u32,
                transition: local[t.index()],
                to: owner_name(net, to),
                colour: net.graph[e].colour,
            });
        } else if to == me {
            peers.insert(owner_name(net, from));
            bridges_in.push(BridgeIn {
                id: id as u32,
                from: owner_name(net, from),
                inbox: local[p.index()],
            });
        }
    }
    // Internal arcs, in a stable order (by node, then by arc insertion).
    for v in net.graph.node_indices() {
        if net.owner(v) != me || net.is_place(v) {
            continue;
        }
        let st = &mut transitions[local[v.index()] as usize];
        let mut ins: Vec<_> = net.graph.edges_directed(v, Direction::Incoming).collect();
        ins.sort_by_key(|e| e.id());
        for e in ins {
            match e.weight().kind {
                ArcKind::Consume => st.consume.push(local[e.source().index()]),
                ArcKind::Read => st.read.push(local[e.source().index()]),
                ArcKind::Produce => {}
            }
        }
        let mut outs: Vec<_> = net.graph.edges_directed(v, Direction::Outgoing).collect();
        outs.sort_by_key(|e| e.id());
        for e in outs {
            if net.owner(e.target()) == me {
                st.produce.push(Produce {
                    place: local[e.target().index()],
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
        .map(|&p| local[p.index()])
        .collect();
    let final_place = (net.owner(net.final_place) == me).then(|| local[net.final_place.index()]);
    Slice {
        mission: net.name.clone(),
        mission_id: mission_id.to_string(),
        drone: owner_name(net, me),
        profile: match me {
            Owner::Drone(d) => net.profiles.get(d.0 as usize).cloned(),
            _ => None,
        },
        drones: net.drones.clone(),
        places,
        transitions,
        initial_marking,
        final_place,
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
