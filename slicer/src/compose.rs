//! The slices of a mission put back together as one net, with every bridge
//! an asynchronous channel: the sending transition puts a token into a
//! channel place, a separate *deliver* transition moves it to the inbox
//! later. Every node is owned by the slice it came from, so a firing says
//! which drone ran it.
//!
//! The end protocol the executors follow is part of the net: a slice that
//! marks its [`Slice::final_place`] sends the `end` notice to the ground
//! station's slice (a silent *tell* step marks a place there), which, once
//! it holds a notice from every owner its [`Slice::ends`] lists, sends the
//! `ended` notice to every slice (a silent *relay* step); a slice stops once
//! it holds that notice. Without a ground station's slice, each *tell*
//! marks a place at every slice, and a slice stops once it holds a notice
//! from every owner its own [`Slice::ends`] lists.
//! The mission's `final` is marked by a transition no drone runs, once every
//! slice has stopped. A slice that never reaches its end, or that waits for
//! an owner that never sends, keeps `final` unmarked: a deadlock. A stopped
//! slice is not silenced here (that would take a read arc on every one of
//! its transitions, which the comparison's reductions cannot step over), so
//! a slice that lists too few ends and stops while a peer still waits for
//! its tokens is not told apart from a right one.
//!
//! This is the net the drones play together over a network that delays
//! messages arbitrarily; [`crate::equivalence`] compares it with the
//! mission net.

use std::collections::BTreeMap;

use eamos_lang::hir::DroneId;
use eamos_petri::net::{
    Arc, ArcKind, ColourOp, Net, Node, NodeId, Owner, Place, PlaceKind, Transition, TransitionKind,
};
use petgraph::graph::DiGraph;

use crate::slice::{Slice, GCS};

/// Slices that do not fit together.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ComposeError {
    #[error("slices of different missions: `{0}` and `{1}`")]
    Mission(String, String),
    #[error("two slices for `{0}`")]
    Duplicate(String),
    #[error("bridge {id} is sent by `{from}` to `{to}`, but no slice of `{to}` receives it from `{from}`")]
    Unmatched { id: u32, from: String, to: String },
    #[error("bridge {id} is received by `{to}` from `{from}`, but `{from}` does not send it")]
    Unsent { id: u32, from: String, to: String },
    #[error("the slices hold {0} initial places, one is needed")]
    Initial(usize),
    #[error("the slices hold no end of the mission")]
    NoEnd,
    #[error("the slice of `{0}` waits for no end: it would stop before it starts")]
    WaitsForNoEnd(String),
}

/// One net from all slices of a mission, bridges as channels.
pub fn compose(slices: &[Slice]) -> Result<Net, ComposeError> {
    let first = match slices.first() {
        Some(s) => s,
        None => return Err(ComposeError::Initial(0)),
    };
    let mut by_name = BTreeMap::new();
    for (i, s) in slices.iter().enumerate() {
        if s.mission_id != first.mission_id {
            return Err(ComposeError::Mission(
                first.mission.clone(),
                s.mission.clone(),
            ));
        }
        if by_name.insert(s.drone.clone(), i).is_some() {
            return Err(ComposeError::Duplicate(s.drone.clone()));
        }
    }
    let mut graph: DiGraph<Node, Arc> = DiGraph::new();
    let mut place_at: Vec<Vec<NodeId>> = Vec::new();
    let mut trans_at: Vec<Vec<NodeId>> = Vec::new();
    let mut initial_marking = Vec::new();
    let mut initials = Vec::new();
    let mut ends: Vec<Option<NodeId>> = Vec::new();
    let arc = |kind, colour| Arc {
        kind,
        weight: 1,
        colour,
    };
    for s in slices {
        let owner = owner_of(s);
        let places: Vec<NodeId> = s
            .places
            .iter()
            .map(|p| {
                let v = graph.add_node(Node::Place(Place { owner, ..p.clone() }));
                if p.kind == PlaceKind::Initial {
                    initials.push(v);
                }
                v
            })
            .collect();
        let transitions: Vec<NodeId> = s
            .transitions
            .iter()
            .map(|t| {
                graph.add_node(Node::Transition(Transition {
                    owner,
                    ..t.transition.clone()
                }))
            })
            .collect();
        ends.push(s.final_place.map(|p| places[p as usize]));
        for (t, st) in transitions.iter().zip(&s.transitions) {
            for &p in &st.consume {
                graph.add_edge(
                    places[p as usize],
                    *t,
                    arc(ArcKind::Consume, ColourOp::Keep),
                );
            }
            for &p in &st.read {
                graph.add_edge(places[p as usize], *t, arc(ArcKind::Read, ColourOp::Keep));
            }
            for pr in &st.produce {
                graph.add_edge(
                    *t,
                    places[pr.place as usize],
                    arc(ArcKind::Produce, pr.colour),
                );
            }
        }
        initial_marking.extend(s.initial_marking.iter().map(|&p| places[p as usize]));
        place_at.push(places);
        trans_at.push(transitions);
    }
    for (si, s) in slices.iter().enumerate() {
        for b in &s.bridges_out {
            let receiver = by_name.get(&b.to).copied();
            let inbox = receiver.and_then(|r| {
                slices[r]
                    .bridges_in
                    .iter()
                    .find(|i| i.id == b.id && i.from == s.drone)
                    .map(|i| place_at[r][i.inbox as usize])
            });
            let Some(inbox) = inbox else {
                return Err(ComposeError::Unmatched {
                    id: b.id,
                    from: s.drone.clone(),
                    to: b.to.clone(),
                });
            };
            let depth = match &graph[inbox] {
                Node::Place(p) => p.depth,
                Node::Transition(_) => 0,
            };
            let channel = graph.add_node(Node::Place(Place {
                id: format!("bridge{}", b.id).into(),
                label: format!("bridge {} {} -> {}", b.id, s.drone, b.to).into(),
                kind: PlaceKind::Control,
                owner: Owner::Unassigned,
                span: None,
                depth,
            }));
            let span = s.transitions[b.transition as usize].transition.span;
            let deliver = graph.add_node(Node::Transition(Transition {
                id: format!("deliver{}", b.id).into(),
                label: format!("deliver bridge {}", b.id).into(),
                kind: TransitionKind::Silent,
                owner: Owner::Unassigned,
                span,
                guard: None,
                delay: None,
            }));
            graph.add_edge(
                trans_at[si][b.transition as usize],
                channel,
                arc(ArcKind::Produce, b.colour),
            );
            graph.add_edge(channel, deliver, arc(ArcKind::Consume, ColourOp::Keep));
            graph.add_edge(deliver, inbox, arc(ArcKind::Produce, ColourOp::Keep));
        }
        for b in &s.bridges_in {
            let sent = by_name.get(&b.from).is_some_and(|&r| {
                slices[r]
                    .bridges_out
                    .iter()
                    .any(|o| o.id == b.id && o.to == s.drone)
            });
            if !sent {
                return Err(ComposeError::Unsent {
                    id: b.id,
                    from: b.from.clone(),
                    to: s.drone.clone(),
                });
            }
        }
    }
    if initials.len() != 1 {
        return Err(ComposeError::Initial(initials.len()));
    }
    if ends.iter().all(Option::is_none) {
        return Err(ComposeError::NoEnd);
    }
    if let Some(s) = slices.iter().find(|s| s.ends.is_empty()) {
        return Err(ComposeError::WaitsForNoEnd(s.drone.clone()));
    }
    let final_place = end_protocol(&mut graph, slices, &ends);
    Ok(Net {
        name: first.mission.clone(),
        graph,
        drones: first.drones.to_vec(),
        profiles: Vec::new(),
        initial_marking,
        initial_place: initials[0],
        final_place,
    })
}

/// The owner that runs a slice, as the mission names it.
fn owner_of(s: &Slice) -> Owner {
    match s.drones.iter().position(|d| *d == s.drone) {
        _ if s.drone == GCS => Owner::Gcs,
        Some(i) => Owner::Drone(DroneId(i as u16)),
        None => Owner::Unassigned,
    }
}

/// The `end` notices and every slice's stop (see the module docs); returns
/// the mission's `final` place.
fn end_protocol(
    graph: &mut DiGraph<Node, Arc>,
    slices: &[Slice],
    ends: &[Option<NodeId>],
) -> NodeId {
    let arc = |kind, colour| Arc {
        kind,
        weight: 1,
        colour,
    };
    let place = |graph: &mut DiGraph<Node, Arc>, id: String, kind| {
        graph.add_node(Node::Place(Place {
            label: id.clone().into(),
            id: id.into(),
            kind,
            owner: Owner::Unassigned,
            span: None,
            depth: 0,
        }))
    };
    let transition = |graph: &mut DiGraph<Node, Arc>, id: String, kind| {
        graph.add_node(Node::Transition(Transition {
            label: id.clone().into(),
            id: id.into(),
            kind,
            owner: Owner::Unassigned,
            span: Default::default(),
            guard: None,
            delay: None,
        }))
    };
    let done = place(graph, "final".into(), PlaceKind::Final);
    let finish = transition(graph, "finish".into(), TransitionKind::Finish);
    graph.add_edge(finish, done, arc(ArcKind::Produce, ColourOp::Keep));
    if let Some(g) = slices.iter().position(|s| s.drone == GCS) {
        // notice[x]: the notice that `x` has ended, at the ground station.
        let notice: Vec<NodeId> = slices
            .iter()
            .map(|sx| {
                place(
                    graph,
                    format!("notice.{}.{GCS}", sx.drone),
                    PlaceKind::Control,
                )
            })
            .collect();
        for (x, sx) in slices.iter().enumerate() {
            if let Some(end) = ends[x] {
                let tell = transition(graph, format!("tell.{}", sx.drone), TransitionKind::Silent);
                graph.add_edge(end, tell, arc(ArcKind::Consume, ColourOp::Keep));
                graph.add_edge(tell, notice[x], arc(ArcKind::Produce, ColourOp::Keep));
            }
        }
        let relay = transition(graph, "relay".into(), TransitionKind::Silent);
        for name in slices[g].ends.iter() {
            // An owner without a slice never sends: `relay` waits for ever.
            let n = match slices.iter().position(|s| s.drone == *name) {
                Some(x) => notice[x],
                None => place(graph, format!("notice.{name}.{GCS}"), PlaceKind::Control),
            };
            graph.add_edge(n, relay, arc(ArcKind::Consume, ColourOp::Keep));
        }
        for sr in slices {
            let ended = place(graph, format!("ended.{}", sr.drone), PlaceKind::Control);
            graph.add_edge(relay, ended, arc(ArcKind::Produce, ColourOp::Keep));
            let stop = transition(graph, format!("stop.{}", sr.drone), TransitionKind::Silent);
            graph.add_edge(ended, stop, arc(ArcKind::Consume, ColourOp::Keep));
            let stopped = place(graph, format!("stopped.{}", sr.drone), PlaceKind::Control);
            graph.add_edge(stop, stopped, arc(ArcKind::Produce, ColourOp::Keep));
            graph.add_edge(stopped, finish, arc(ArcKind::Consume, ColourOp::Keep));
        }
        return done;
    }
    // notice[x][r]: the notice that `x` has ended, at `r`.
    let mut notice = vec![Vec::new(); slices.len()];
    for (x, sx) in slices.iter().enumerate() {
        for sr in slices {
            let id = format!("notice.{}.{}", sx.drone, sr.drone);
            notice[x].push(place(graph, id, PlaceKind::Control));
        }
        if let Some(end) = ends[x] {
            let tell = transition(graph, format!("tell.{}", sx.drone), TransitionKind::Silent);
            graph.add_edge(end, tell, arc(ArcKind::Consume, ColourOp::Keep));
            for &n in &notice[x] {
                graph.add_edge(tell, n, arc(ArcKind::Produce, ColourOp::Keep));
            }
        }
    }
    for (r, sr) in slices.iter().enumerate() {
        let stop = transition(graph, format!("stop.{}", sr.drone), TransitionKind::Silent);
        for name in sr.ends.iter() {
            // An owner without a slice never sends: `stop` waits for ever.
            let from = slices.iter().position(|s| s.drone == *name);
            let n = match from {
                Some(x) => notice[x][r],
                None => place(
                    graph,
                    format!("notice.{name}.{}", sr.drone),
                    PlaceKind::Control,
                ),
            };
            graph.add_edge(n, stop, arc(ArcKind::Consume, ColourOp::Keep));
        }
        let stopped = place(graph, format!("stopped.{}", sr.drone), PlaceKind::Control);
        graph.add_edge(stop, stopped, arc(ArcKind::Produce, ColourOp::Keep));
        graph.add_edge(stopped, finish, arc(ArcKind::Consume, ColourOp::Keep));
    }
    done
}
