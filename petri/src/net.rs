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

pub use crate::name::Name;

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
    pub id: Name,
    /// What a person reads in a drawing.
    pub label: Name,
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
    Running(SharedAction),
    /// Marked once the event has been signalled.
    Event(String),
    /// Marked until the event is signalled (keeps `Signal` 1-safe).
    EventPending(String),
    /// Holds state of an interruptible `Do` region (running / interrupted).
    Region { region: u32, interrupted: bool },
    /// Marked when the mission has ended.
    Final,
}

impl PlaceKind {
    /// Places that record whether an event has happened. They are the only
    /// places besides `final` that may stay marked once the mission has ended.
    pub fn is_event_state(&self) -> bool {
        matches!(self, PlaceKind::Event(_) | PlaceKind::EventPending(_))
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Transition {
    /// Stable, unique, XML-safe id (`t42`).
    pub id: Name,
    pub label: Name,
    pub kind: TransitionKind,
    pub owner: Owner,
    pub span: Span,
    /// Fires only while the guard holds; `None` is always true. Boxed:
    /// few transitions have one, and inline it was a third of every node
    /// of the net and of its slices.
    pub guard: Option<Box<Guard>>,
    /// A timed transition (`PauseFor`) fires this many seconds after it is
    /// enabled.
    pub delay: Option<f64>,
}

/// A transition guard. Most guards ask the world (a condition over drone
/// state); the guards of `RepeatFor` only look at the token's own colour, so
/// they are decided inside the net and never cost a message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Guard {
    pub kind: GuardKind,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum GuardKind {
    /// The condition (or, if `negated`, its negation) holds now.
    Cond { cond: Expr, negated: bool },
    /// The innermost iteration counter of the token is below `n`.
    IterationBelow(u32),
    /// The innermost iteration counter of the token is at least `n`.
    IterationAtLeast(u32),
}

impl Guard {
    /// A guard on a condition over drone state.
    pub fn cond(cond: Expr, negated: bool) -> Self {
        Guard {
            kind: GuardKind::Cond { cond, negated },
        }
    }

    /// A colour guard: fewer than `n` iterations done.
    pub fn iteration_below(n: u32) -> Self {
        Guard {
            kind: GuardKind::IterationBelow(n),
        }
    }

    /// A colour guard: at least `n` iterations done.
    pub fn iteration_at_least(n: u32) -> Self {
        Guard {
            kind: GuardKind::IterationAtLeast(n),
        }
    }

    /// The condition and whether the guard is its negation; `None` for a
    /// colour guard.
    pub fn condition(&self) -> Option<(&Expr, bool)> {
        match &self.kind {
            GuardKind::Cond { cond, negated } => Some((cond, *negated)),
            _ => None,
        }
    }

    /// Every drone whose state the guard reads (none for a colour guard).
    pub fn drones(&self) -> Vec<DroneId> {
        match &self.kind {
            GuardKind::Cond { cond, .. } => cond.drones(),
            _ => Vec::new(),
        }
    }

    /// Whether the guard holds when its condition has the value `cond_value`
    /// (applies the negation). Colour guards ignore the value: use
    /// [`Guard::holds_on_colour`] for them.
    pub fn holds_when(&self, cond_value: bool) -> bool {
        match &self.kind {
            GuardKind::Cond { negated, .. } => cond_value != *negated,
            _ => cond_value,
        }
    }

    /// The value of a colour guard on a token colour (iteration counters,
    /// outermost first); `None` for a condition guard, which only the world
    /// can answer.
    pub fn holds_on_colour(&self, colour: &[u32]) -> Option<bool> {
        let innermost = colour.last().copied().unwrap_or(0);
        match self.kind {
            GuardKind::Cond { .. } => None,
            GuardKind::IterationBelow(n) => Some(innermost < n),
            GuardKind::IterationAtLeast(n) => Some(innermost >= n),
        }
    }
}

/// An action as the nodes of a net hold it: one allocation shared by its
/// start, running place, end and cancels, and by every copy of the net
/// (distributed net, slices). Inline, with its name and arguments, it was
/// the largest part of every node. Serialised as the action itself.
pub type SharedAction = std::sync::Arc<ActionRef>;

/// One action instance of the mission (each call of a block is its own
/// instance, so the same source line can yield several).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionRef {
    pub drone: DroneId,
    pub name: Name,
    pub args: Vec<f64>,
    /// Unique per action instance in the net.
    pub instance: u32,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum TransitionKind {
    /// Takes the initial token and starts the mission.
    Init,
    /// Asks the drone to start the action: input control place -> running.
    ActionStart(SharedAction),
    /// The action has reported success: running -> next control place.
    ActionEnd(SharedAction),
    /// The action is cancelled by an interrupted `Do`: running -> next place.
    ActionCancel(SharedAction),
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
    /// A wait on the world: `PauseWhile`/`PauseUntil` and the proceed step of
    /// `WaitWhile`/`WaitUntil` (guarded, no complement), or `PauseFor` (a
    /// timed transition with a `delay`).
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
    pub fn action(&self) -> Option<&SharedAction> {
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

/// The id of the `index`th node, `p17` or `t42`, written on the stack
/// digit by digit: the [`Name`] is then the node's only allocation for it,
/// and the formatting machinery (some 300 instructions an id, one id per
/// node) is not needed for a prefix and a number.
fn indexed_id(prefix: char, index: usize) -> Name {
    let mut buf = [0u8; 32];
    let mut at = buf.len();
    let mut n = index;
    loop {
        at -= 1;
        buf[at] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    let mut utf8 = [0u8; 4];
    let prefix = prefix.encode_utf8(&mut utf8).as_bytes();
    at -= prefix.len();
    buf[at..at + prefix.len()].copy_from_slice(prefix);
    Name::from(std::str::from_utf8(&buf[at..]).expect("a char and ASCII digits"))
}

/// A place that the owners of its consumers pull onto several drones.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OwnershipViolation {
    pub place: NodeId,
    /// The distinct assigned owners involved, sorted.
    pub owners: Vec<Owner>,
}

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

    /// The id an empty id becomes on the next node added: `p<index>` for
    /// a place, `t<index>` for a transition. A compiler that knows its
    /// nodes get indexed ids passes this one instead of an empty one.
    pub fn next_id(&self, prefix: char) -> Name {
        indexed_id(prefix, self.graph.node_count())
    }

    /// Adds a place; an empty id becomes `p<index>`.
    pub fn add_place(&mut self, mut place: Place) -> NodeId {
        // The id is known before the node is added: adding first and
        // rewriting it cloned every node of the net once.
        if place.id.is_empty() {
            place.id = indexed_id('p', self.graph.node_count());
        }
        self.graph.add_node(Node::Place(place))
    }

    /// Adds a transition; an empty id becomes `t<index>`.
    pub fn add_transition(&mut self, mut t: Transition) -> NodeId {
        if t.id.is_empty() {
            t.id = indexed_id('t', self.graph.node_count());
        }
        self.graph.add_node(Node::Transition(t))
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
        self.graph
            .node_indices()
            .filter_map(move |n| match &self.graph[n] {
                Node::Place(p) => Some((n, p)),
                Node::Transition(_) => None,
            })
    }

    pub fn transitions(&self) -> impl Iterator<Item = (NodeId, &Transition)> + '_ {
        self.graph
            .node_indices()
            .filter_map(move |n| match &self.graph[n] {
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

    /// Every arc: source node, target node and the arc.
    pub fn arcs(&self) -> impl Iterator<Item = (NodeId, NodeId, &Arc)> + '_ {
        self.graph
            .edge_references()
            .map(|e| (e.source(), e.target(), e.weight()))
    }

    /// Places whose owner and the owners of the transitions that consume or
    /// read them name more than one drone (or a drone and the ground
    /// station). Such a place could not live on one drone, so the net could
    /// not be sliced: every compiled net must return nothing here.
    pub fn ownership_violations(&self) -> Vec<OwnershipViolation> {
        let mut out = Vec::new();
        for (p, place) in self.places() {
            let mut owners: Vec<Owner> = std::iter::once(place.owner)
                .chain(self.consumers(p).map(|(t, _)| self.owner(t)))
                .filter(|o| *o != Owner::Unassigned)
                .collect();
            owners.sort();
            owners.dedup();
            if owners.len() > 1 {
                out.push(OwnershipViolation { place: p, owners });
            }
        }
        out
    }

    /// The node with this stable id.
    pub fn find(&self, id: &str) -> Option<NodeId> {
        self.graph.node_indices().find(|&n| match &self.graph[n] {
            Node::Place(p) => p.id == id,
            Node::Transition(t) => t.id == id,
        })
    }

    /// The stable id of a place or transition.
    pub fn id(&self, n: NodeId) -> &str {
        match &self.graph[n] {
            Node::Place(p) => &p.id,
            Node::Transition(t) => &t.id,
        }
    }

    pub fn owner(&self, n: NodeId) -> Owner {
        match &self.graph[n] {
            Node::Place(p) => p.owner,
            Node::Transition(t) => t.owner,
        }
    }

    /// A name a person recognises: the drone name, `GCS` or `-` (and
    /// `unknown drone` for an id the net does not know, rather than a panic).
    pub fn owner_name(&self, o: Owner) -> &str {
        match o {
            Owner::Gcs => "GCS",
            Owner::Drone(d) => self
                .drones
                .get(d.0 as usize)
                .map_or("unknown drone", String::as_str),
            Owner::Unassigned => "-",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indexed_ids_are_the_prefix_and_the_index() {
        assert_eq!(indexed_id('p', 0), "p0");
        assert_eq!(indexed_id('t', 42), "t42");
        assert_eq!(indexed_id('p', usize::MAX), format!("p{}", usize::MAX));
    }

    #[test]
    fn colour_functions_count_loop_iterations() {
        assert_eq!(ColourOp::Enter.apply(&[2]), vec![2, 0]);
        assert_eq!(ColourOp::Next.apply(&[2, 0]), vec![2, 1]);
        assert_eq!(ColourOp::Leave.apply(&[2, 1]), vec![2]);
        assert_eq!(ColourOp::Plain.apply(&[2, 1]), Vec::<u32>::new());
    }

    #[test]
    fn colour_guards_look_at_the_innermost_counter_only() {
        let below = Guard::iteration_below(2);
        assert_eq!(below.holds_on_colour(&[5, 1]), Some(true));
        assert_eq!(below.holds_on_colour(&[0, 2]), Some(false));
        let at_least = Guard::iteration_at_least(2);
        assert_eq!(at_least.holds_on_colour(&[0, 2]), Some(true));
        assert!(below.drones().is_empty());
    }

    #[test]
    fn a_condition_guard_applies_its_negation_and_needs_the_world() {
        let cond = Expr::Bool {
            value: true,
            span: Span::default(),
        };
        let g = Guard::cond(cond, true);
        assert!(!g.holds_when(true));
        assert!(g.holds_when(false));
        assert_eq!(g.holds_on_colour(&[]), None);
        assert!(g.condition().is_some_and(|(_, negated)| negated));
    }

    #[test]
    fn a_place_consumed_by_two_drones_is_an_ownership_violation() {
        let mut net = Net::new("M", vec!["D1".into(), "D2".into()], vec![]);
        let p = net.add_place(Place {
            id: Name::default(),
            label: "p".into(),
            kind: PlaceKind::Control,
            owner: Owner::Unassigned,
            span: None,
            depth: 0,
        });
        for d in [0, 1] {
            let t = net.add_transition(Transition {
                id: Name::default(),
                label: "t".into(),
                kind: TransitionKind::Silent,
                owner: Owner::Drone(DroneId(d)),
                span: Span::default(),
                guard: None,
                delay: None,
            });
            net.arc(p, t, ColourOp::Keep);
        }
        let v = net.ownership_violations();
        assert_eq!(v.len(), 1);
        assert_eq!(v[0].place, p);
        assert_eq!(v[0].owners.len(), 2);
    }

    #[test]
    fn a_new_net_has_an_initial_and_a_final_place_with_stable_ids() {
        let net = Net::new("M", vec!["D1".into()], vec!["Quadcopter".into()]);
        assert_eq!(net.place(net.initial_place).unwrap().owner, Owner::Gcs);
        assert_eq!(net.find("final"), Some(net.final_place));
        assert_eq!(net.initial_marking, vec![net.initial_place]);
    }
}
