//! The coloured Petri net of a mission.
//!
//! Places and transitions are nodes of one petgraph graph; arcs are its
//! edges. The net is 1-safe by construction (every place holds at most one
//! token), so a token's colour only has to tell repetitions apart: it is the
//! iteration counter of every loop around the place, outermost first. A
//! consumer that does not care about colours (the checker, PNML export) reads
//! the net as a plain P/T net.
//!
//! Every transition carries its owner (a drone, the ground station, or none
//! yet: the slicer decides) and the span of the mission text it came from.

use petgraph::graph::{DiGraph, EdgeIndex, NodeIndex};
use petgraph::visit::EdgeRef;
use petgraph::Direction;
use serde::{Deserialize, Serialize};

use eamos_lang::hir::{DroneId, Expr};
use eamos_lang::Span;

/// Who runs a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Owner {
    /// The ground station: it holds the initial token and starts the mission.
    Gcs,
    Drone(DroneId),
    /// Forks, joins, merges and the like: placed by the slicer.
    Unassigned,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Node {
    Place(Place),
    Transition(Transition),
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Place {
    /// Stable, unique, XML-safe id (`p17`, `final`).
    pub id: String,
    /// What a person reads in a drawing.
    pub label: String,
    pub kind: PlaceKind,
    pub owner: Owner,
    pub span: Option<Span>,
    /// Number of loops around the place: the length of its tokens' colour.
    pub depth: u8,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PlaceKind {
    /// Holds the initial token, owned by the ground station.
    Initial,
    /// Between two steps of control flow.
    Control,
    /// Marked while a drone action runs.
    Running(ActionRef),
    /// Marked once the event has been signalled.
    Event(String),
    /// Marked until the event is signalled (keeps `Signal` 1-safe).
    EventPending(String),
    /// Holds state of an interruptible `Do` region (running / interrupted).
    Region { region: u32, interrupted: bool },
    /// Marked when the mission has ended.
    Final,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Transition {
    /// Stable, unique, XML-safe id (`t42`).
    pub id: String,
    pub label: String,
    pub kind: TransitionKind,
    pub owner: Owner,
    pub span: Span,
    /// Fires only while the guard holds; `None` is always true.
    pub guard: Option<Guard>,
    /// A timed transition (`PauseFor`) fires this many seconds after it is
    /// enabled.
    pub delay: Option<f64>,
}

/// A transition guard: the condition, or its negation, must hold.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Guard {
    pub cond: Expr,
    pub negated: bool,
}

impl Guard {
    /// Every drone whose state the guard reads.
    pub fn drones(&self) -> Vec<DroneId> {
        self.cond.drones()
    }
}

/// One action instance of the mission (each call of a block is its own
/// instance, so the same source line can yield several).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionRef {
    pub drone: DroneId,
    pub name: String,
    pub args: Vec<f64>,
    /// Unique per action instance in the net.
    pub instance: u32,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum TransitionKind {
    /// Takes the initial token and starts the mission.
    Init,
    /// Asks the drone to start the action: input control place -> running.
    ActionStart(ActionRef),
    /// The action has reported success: running -> next control place.
    ActionEnd(ActionRef),
    /// The action is cancelled by an interrupted `Do`: running -> next place.
    ActionCancel(ActionRef),
    /// Passes over a step without running it (inside an interrupted `Do`).
    Skip,
    Fork,
    Join,
    /// One side of a condition: guarded, with its complement beside it.
    Branch,
    /// Where branches of a condition or loop meet again.
    Merge,
    /// Back to the head of a loop (the token's innermost counter goes up).
    LoopBack,
    /// `PauseFor`: a timed transition.
    Pause,
    Signal,
    Await,
    /// The condition of a `Do` has stopped letting its body go on.
    Interrupt,
    /// Puts the token in the final place.
    Finish,
    /// Any other internal step.
    Silent,
}

impl TransitionKind {
    pub fn action(&self) -> Option<&ActionRef> {
        match self {
            TransitionKind::ActionStart(a)
            | TransitionKind::ActionEnd(a)
            | TransitionKind::ActionCancel(a) => Some(a),
            _ => None,
        }
    }
}

/// An arc. Place -> transition arcs consume (or only look, for `Read`);
/// transition -> place arcs produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Arc {
    pub kind: ArcKind,
    pub weight: u32,
    /// How the token's colour changes along a producing arc.
    pub colour: ColourOp,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ArcKind {
    Consume,
    Produce,
    /// A test arc: the transition needs the token but leaves it in place.
    Read,
}

/// Colour functions on producing arcs. Colours are the iteration counters of
/// the loops around a place, outermost first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ColourOp {
    /// Same colour as the consumed tokens.
    Keep,
    /// Entering a loop: push a counter at 0.
    Enter,
    /// Looping back: add one to the innermost counter.
    Next,
    /// Leaving a loop: drop the innermost counter.
    Leave,
    /// Event places have no colour: an event happens once for the mission.
    Plain,
}

/// A colour: loop iteration counters, outermost first.
pub type Colour = Vec<u32>;

impl ColourOp {
    pub fn apply(self, c: &[u32]) -> Colour {
        let mut c = c.to_vec();
        match self {
            ColourOp::Keep => {}
            ColourOp::Enter => c.push(0),
            ColourOp::Next => {
                if let Some(last) = c.last_mut() {
                    *last += 1;
                }
            }
            ColourOp::Leave => {
                c.pop();
            }
            ColourOp::Plain => c.clear(),
        }
        c
    }
}

pub type NodeId = NodeIndex<u32>;

/// The net of one mission.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Net {
    /// The mission (`package`) name.
    pub name: String,
    pub graph: DiGraph<Node, Arc>,
    /// Drone names by [`DroneId`].
    pub drones: Vec<String>,
    /// Drone profile names by [`DroneId`].
    pub profiles: Vec<String>,
    /// Places holding one token at the start: the initial place and the
    /// places of events not yet signalled, and the like.
    pub initial_marking: Vec<NodeId>,
    pub initial_place: NodeId,
    /// The mission has ended when this place (id `final`) is marked.
    pub final_place: NodeId,
}

impl Net {
    pub fn new(name: impl Into<String>, drones: Vec<String>, profiles: Vec<String>) -> Self {
        let mut graph = DiGraph::new();
        let initial_place = graph.add_node(Node::Place(Place {
            id: "initial".into(),
            label: "start".into(),
            kind: PlaceKind::Initial,
            owner: Owner::Gcs,
            span: None,
            depth: 0,
        }));
        let final_place = graph.add_node(Node::Place(Place {
            id: "final".into(),
            label: "end".into(),
            kind: PlaceKind::Final,
            owner: Owner::Unassigned,
            span: None,
            depth: 0,
        }));
        Net {
            name: name.into(),
            graph,
            drones,
            profiles,
            initial_marking: vec![initial_place],
            initial_place,
            final_place,
        }
    }

    pub fn add_place(&mut self, mut place: Place) -> NodeId {
        let n = self.graph.add_node(Node::Place(place.clone()));
        if place.id.is_empty() {
            place.id = format!("p{}", n.index());
            self.graph[n] = Node::Place(place);
        }
        n
    }

    pub fn add_transition(&mut self, mut t: Transition) -> NodeId {
        let n = self.graph.add_node(Node::Transition(t.clone()));
        if t.id.is_empty() {
            t.id = format!("t{}", n.index());
            self.graph[n] = Node::Transition(t);
        }
        n
    }

    /// Adds an arc of weight 1. From a place it consumes; from a transition
    /// it produces with the given colour function.
    pub fn arc(&mut self, from: NodeId, to: NodeId, colour: ColourOp) -> EdgeIndex {
        let kind = if self.is_place(from) {
            ArcKind::Consume
        } else {
            ArcKind::Produce
        };
        self.graph.add_edge(
            from,
            to,
            Arc {
                kind,
                weight: 1,
                colour,
            },
        )
    }

    /// Adds a read (test) arc: `t` needs a token in `p` but leaves it there.
    pub fn read_arc(&mut self, p: NodeId, t: NodeId) -> EdgeIndex {
        self.graph.add_edge(
            p,
            t,
            Arc {
                kind: ArcKind::Read,
                weight: 1,
                colour: ColourOp::Keep,
            },
        )
    }

    pub fn is_place(&self, n: NodeId) -> bool {
        matches!(self.graph[n], Node::Place(_))
    }

    pub fn place(&self, n: NodeId) -> Option<&Place> {
        match &self.graph[n] {
            Node::Place(p) => Some(p),
            Node::Transition(_) => None,
        }
    }

    pub fn transition(&self, n: NodeId) -> Option<&Transition> {
        match &self.graph[n] {
            Node::Transition(t) => Some(t),
            Node::Place(_) => None,
        }
    }

    pub fn places(&self) -> impl Iterator<Item = (NodeId, &Place)> + '_ {
        self.graph.node_indices().filter_map(move |n| match &self.graph[n] {
            Node::Place(p) => Some((n, p)),
            Node::Transition(_) => None,
        })
    }

    pub fn transitions(&self) -> impl Iterator<Item = (NodeId, &Transition)> + '_ {
        self.graph.node_indices().filter_map(move |n| match &self.graph[n] {
            Node::Transition(t) => Some((n, t)),
            Node::Place(_) => None,
        })
    }

    /// Places a transition consumes from.
    pub fn preset(&self, t: NodeId) -> impl Iterator<Item = NodeId> + '_ {
        self.inputs(t, ArcKind::Consume)
    }

    /// Places a transition only reads.
    pub fn read_set(&self, t: NodeId) -> impl Iterator<Item = NodeId> + '_ {
        self.inputs(t, ArcKind::Read)
    }

    /// Places a transition produces into, with the colour function of each arc.
    pub fn postset(&self, t: NodeId) -> impl Iterator<Item = (NodeId, ColourOp)> + '_ {
        self.graph
            .edges_directed(t, Direction::Outgoing)
            .map(|e| (e.target(), e.weight().colour))
    }

    /// Transitions that consume from or read a place.
    pub fn consumers(&self, p: NodeId) -> impl Iterator<Item = (NodeId, ArcKind)> + '_ {
        self.graph
            .edges_directed(p, Direction::Outgoing)
            .map(|e| (e.target(), e.weight().kind))
    }

    /// Transitions that produce into a place.
    pub fn producers(&self, p: NodeId) -> impl Iterator<Item = NodeId> + '_ {
        self.graph
            .edges_directed(p, Direction::Incoming)
            .map(|e| e.source())
    }

    fn inputs(&self, t: NodeId, kind: ArcKind) -> impl Iterator<Item = NodeId> + '_ {
        self.graph
            .edges_directed(t, Direction::Incoming)
            .filter(move |e| e.weight().kind == kind)
            .map(|e| e.source())
    }

    /// The node with this stable id.
    pub fn find(&self, id: &str) -> Option<NodeId> {
        self.graph.node_indices().find(|&n| match &self.graph[n] {
            Node::Place(p) => p.id == id,
            Node::Transition(t) => t.id == id,
        })
    }

    pub fn owner(&self, n: NodeId) -> Owner {
        match &self.graph[n] {
            Node::Place(p) => p.owner,
            Node::Transition(t) => t.owner,
        }
    }

    /// A name a person recognises: the drone name, `GCS` or `-`.
    pub fn owner_name(&self, o: Owner) -> &str {
        match o {
            Owner::Gcs => "GCS",
            Owner::Drone(d) => &self.drones[d.0 as usize],
            Owner::Unassigned => "-",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_functions_count_loop_iterations() {
        assert_eq!(ColourOp::Enter.apply(&[2]), vec![2, 0]);
        assert_eq!(ColourOp::Next.apply(&[2, 0]), vec![2, 1]);
        assert_eq!(ColourOp::Leave.apply(&[2, 1]), vec![2]);
        assert_eq!(ColourOp::Plain.apply(&[2, 1]), Vec::<u32>::new());
    }

    #[test]
    fn a_new_net_has_an_initial_and_a_final_place_with_stable_ids() {
        let net = Net::new("M", vec!["D1".into()], vec!["Quadcopter".into()]);
        assert_eq!(net.place(net.initial_place).unwrap().owner, Owner::Gcs);
        assert_eq!(net.find("final"), Some(net.final_place));
        assert_eq!(net.initial_marking, vec![net.initial_place]);
    }
}
