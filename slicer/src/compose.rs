//! The slices of a mission put back together as one net, with every bridge
//! an asynchronous channel: the sending transition puts a token into a
//! channel place, a separate *deliver* transition moves it to the inbox
//! later. The slices' ends (one per owner that holds one) are joined into
//! one place `final` by a transition no drone runs: the mission has ended
//! when every slice has reached its end. This is the net the drones play
//! together over a network that delays messages arbitrarily; [`crate::equivalence`] compares it with the
//! mission net.

use std::collections::BTreeMap;

use eamos_petri::net::{
    Arc, ArcKind, ColourOp, Net, Node, NodeId, Owner, Place, PlaceKind, Transition, TransitionKind,
};
use petgraph::graph::DiGraph;

use crate::slice::Slice;

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
    let mut finals = Vec::new();
    let arc = |kind, colour| Arc {
        kind,
        weight: 1,
        colour,
    };
    for s in slices {
        let places: Vec<NodeId> = s
            .places
            .iter()
            .map(|p| {
                let v = graph.add_node(Node::Place(p.clone()));
                match p.kind {
                    PlaceKind::Initial => initials.push(v),
                    PlaceKind::Final => finals.push(v),
                    _ => {}
                }
                v
            })
            .collect();
        let transitions: Vec<NodeId> = s
            .transitions
            .iter()
            .map(|t| graph.add_node(Node::Transition(t.transition.clone())))
            .collect();
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
                id: format!("bridge{}", b.id),
                label: format!("bridge {} {} -> {}", b.id, s.drone, b.to),
                kind: PlaceKind::Control,
                owner: Owner::Unassigned,
                span: None,
                depth,
            }));
            let span = s.transitions[b.transition as usize].transition.span;
            let deliver = graph.add_node(Node::Transition(Transition {
                id: format!("deliver{}", b.id),
                label: format!("deliver bridge {}", b.id),
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
    let final_place = match finals.as_slice() {
        [] => return Err(ComposeError::NoEnd),
        [one] => *one,
        ends => {
            // The mission has ended when every slice has reached its end:
            // a join that no drone runs.
            let done = graph.add_node(Node::Place(Place {
                id: "final".into(),
                label: "every slice has ended".into(),
                kind: PlaceKind::Final,
                owner: Owner::Unassigned,
                span: None,
                depth: 0,
            }));
            let join = graph.add_node(Node::Transition(Transition {
                id: "finish".into(),
                label: "every slice has ended".into(),
                kind: TransitionKind::Finish,
                owner: Owner::Unassigned,
                span: Default::default(),
                guard: None,
                delay: None,
            }));
            for &end in ends {
                graph.add_edge(end, join, arc(ArcKind::Consume, ColourOp::Keep));
            }
            graph.add_edge(join, done, arc(ArcKind::Produce, ColourOp::Keep));
            done
        }
    };
    Ok(Net {
        name: first.mission.clone(),
        graph,
        drones: first.drones.clone(),
        profiles: Vec::new(),
        initial_marking,
        initial_place: initials[0],
        final_place,
    })
}
