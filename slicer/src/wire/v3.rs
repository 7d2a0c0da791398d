//! Version 3 of the slice file: what a drone reads, as plain data.
//!
//! These types name nothing of the compiler (no `hir`, no net types): the
//! compiler may rename a variant or add a field to its own types, and a
//! slice written by the last release still reads, because only the
//! conversion (`convert.rs`) changes. A change here is a new format version
//! (`v4.rs`), never an edit of this one.
//!
//! Indices (places, transitions, drones) are positions in the slice's own
//! lists, as [`crate::Slice`] has them; names are the mission's.

use serde::{Deserialize, Serialize};

/// One drone's (or the ground station's) part of a mission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Slice {
    pub mission: String,
    pub mission_id: String,
    pub drone: String,
    pub profile: Option<String>,
    /// Every drone of the mission; guards and actions name them by index.
    pub drones: Vec<String>,
    pub places: Vec<Place>,
    pub transitions: Vec<Transition>,
    pub initial_marking: Vec<u32>,
    pub final_place: Option<u32>,
    pub ends: Vec<String>,
    pub bridges_in: Vec<BridgeIn>,
    pub bridges_out: Vec<BridgeOut>,
    pub peers: Vec<String>,
    pub telemetry: Vec<String>,
}

/// A byte range of the mission text, for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Span {
    pub start: u32,
    pub end: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Owner {
    Gcs,
    /// By index into [`Slice::drones`].
    Drone(u16),
    Unassigned,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Place {
    pub id: String,
    pub label: String,
    pub kind: PlaceKind,
    pub owner: Owner,
    pub span: Option<Span>,
    /// Loops around the place: the length of its tokens' colour.
    pub depth: u8,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaceKind {
    Initial,
    Control,
    Running(Action),
    Event(String),
    EventPending(String),
    Region { region: u32, interrupted: bool },
    Final,
}

/// One action instance: which drone, which action, its arguments.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Action {
    pub drone: u16,
    pub name: String,
    pub args: Vec<f64>,
    pub instance: u32,
}

/// A transition with its arcs to this slice's places.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Transition {
    pub id: String,
    pub label: String,
    pub kind: TransitionKind,
    pub owner: Owner,
    pub span: Span,
    pub guard: Option<Guard>,
    /// Seconds after being enabled that a timed transition fires.
    pub delay: Option<f64>,
    pub consume: Vec<u32>,
    pub read: Vec<u32>,
    pub produce: Vec<Produce>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TransitionKind {
    Init,
    ActionStart(Action),
    ActionEnd(Action),
    ActionCancel(Action),
    Skip,
    Fork,
    Join,
    Branch,
    Merge,
    LoopBack,
    Pause,
    Signal,
    Await,
    Interrupt,
    Finish,
    Silent,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Guard {
    /// The condition (or its negation) holds now.
    Cond { cond: Condition, negated: bool },
    /// The token's innermost loop counter is below `n`.
    IterationBelow(u32),
    /// The token's innermost loop counter is at least `n`.
    IterationAtLeast(u32),
}

/// A condition over drone state, its nodes in postfix order: each operator
/// takes its operands from the nodes before it. Flat rather than nested so
/// that reading a damaged or hostile file never recurses: a reader checks
/// the operand counts and the depth as it rebuilds the tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Condition {
    pub nodes: Vec<Term>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    Number {
        value: f64,
        span: Span,
    },
    Bool {
        value: bool,
        span: Span,
    },
    /// `D3.X()`, `D1.DistanceTo(D2)`: drones by index.
    Property {
        drone: u16,
        name: String,
        args: Vec<u16>,
        span: Span,
    },
    /// Applies to the one node before it.
    Unary {
        op: UnaryOp,
        span: Span,
    },
    /// Applies to the two nodes before it, left operand first.
    Binary {
        op: BinaryOp,
        span: Span,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UnaryOp {
    Not,
    Neg,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BinaryOp {
    Or,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Add,
    Sub,
    Mul,
    Div,
}

/// An arc that puts a token into a place of the slice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Produce {
    pub place: u32,
    pub colour: Colour,
}

/// How a token's colour (its loop counters) changes along an arc.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Colour {
    Keep,
    Enter,
    Next,
    Leave,
    Plain,
}

/// Tokens from peer `from` on bridge `id` arrive in place `inbox`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BridgeIn {
    pub id: u32,
    pub from: String,
    pub inbox: u32,
}

/// Firing `transition` sends a token to peer `to` on bridge `id`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BridgeOut {
    pub id: u32,
    pub transition: u32,
    pub to: String,
    pub colour: Colour,
}
