//! The part of a mission one drone (or the ground station) runs.
//!
//! A slice is self-contained: with it and its drone's capability profile a
//! drone can play its share of the token game. It keeps a marking over the
//! slice's [`places`](Slice::places) (at most one token per place, a token
//! being a colour: loop counters, outermost first), fires enabled
//! [`transitions`](Slice::transitions) (consume, read, produce with the colour
//! function of each arc), starts and cancels actions for `ActionStart` /
//! `ActionCancel` transitions, and talks to peers over bridges:
//!
//! - when a transition fires, for every [`BridgeOut`] whose `transition` it
//!   is, send the message `(bridge id, colour)` to the peer `to`, where the
//!   colour is the consumed colour with the bridge's colour function applied;
//! - a message `(id, colour)` from a peer puts a token of that colour into
//!   the `inbox` of the [`BridgeIn`] with that id.
//!
//! The mission has ended when every owner in [`Slice::ends`] has marked its
//! [`final_place`](Slice::final_place); each tells the others with a control
//! notice that is not a bridge.
//!
//! Nothing else crosses between drones. At most one message per bridge is in
//! flight at any time when the mission net is 1-safe (see the crate docs), so
//! an executor never has to queue two tokens for one inbox.

use std::collections::BTreeSet;
use std::sync::Arc;

use eamos_lang::hir::Expr;
use eamos_petri::net::{ColourOp, GuardKind, Place, PlaceKind, Transition};

use crate::error::DecodeError;

/// Index of a place in [`Slice::places`].
pub type LocalPlace = u32;
/// Index of a transition in [`Slice::transitions`].
pub type LocalTransition = u32;
/// A bridge's number, unique in the mission, the same in the sending and the
/// receiving slice.
pub type BridgeId = u32;

/// The name the ground station goes by as a peer.
pub const GCS: &str = "GCS";

#[derive(Debug, Clone, PartialEq)]
pub struct Slice {
    /// The mission (`package`) name.
    pub mission: String,
    /// Identity of the mission, as given to [`crate::slice_as`] (the net's
    /// hash when cut by [`crate::slice`]). Peers with another identity run
    /// another mission and must not exchange tokens.
    pub mission_id: String,
    /// The drone (or [`GCS`]) that runs this slice.
    pub drone: String,
    /// The capability profile of the drone; `None` for the ground station.
    pub profile: Option<String>,
    /// Every drone of the mission by `DroneId` index: guards and actions name
    /// drones by index. Shared by the slices cut together: a fleet of N
    /// drones would otherwise hold N^2 names (4 MB of 250 drones' slices).
    pub drones: Arc<[String]>,
    pub places: Vec<Place>,
    pub transitions: Vec<SliceTransition>,
    /// Places holding a token (of the empty colour) at the start.
    pub initial_marking: Vec<LocalPlace>,
    /// This slice's end of the mission, if it holds one: marked when its
    /// part of the mission's last join is done.
    pub final_place: Option<LocalPlace>,
    /// Every owner (drone or [`GCS`]) that holds an end, sorted as the
    /// mission's owners. The mission has ended when each of them has reached
    /// its end; an executor that reaches its own tells every peer with the
    /// `end` control notice. Owners not listed just play until then.
    /// Shared by the slices cut together, as `drones` is.
    pub ends: Arc<[String]>,
    pub bridges_in: Vec<BridgeIn>,
    pub bridges_out: Vec<BridgeOut>,
    /// Peers this slice sends to or receives from, sorted.
    pub peers: Vec<String>,
    /// Other drones whose state the guards of this slice read: the executor
    /// subscribes to their telemetry.
    pub telemetry: Vec<String>,
}

/// A transition with its local arcs.
#[derive(Debug, Clone, PartialEq)]
pub struct SliceTransition {
    /// Kind (action start/end/cancel with the action and its arguments),
    /// guard, delay, label, span and stable id from the mission net.
    pub transition: Transition,
    /// Places it takes a token from.
    pub consume: Vec<LocalPlace>,
    /// Places whose token it needs but leaves in place.
    pub read: Vec<LocalPlace>,
    /// Places it puts a token into, with the colour function of each arc.
    pub produce: Vec<Produce>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Produce {
    pub place: LocalPlace,
    pub colour: ColourOp,
}

/// Tokens from a peer arrive here.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BridgeIn {
    pub id: BridgeId,
    pub from: String,
    pub inbox: LocalPlace,
}

/// Firing `transition` sends a token to a peer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BridgeOut {
    pub id: BridgeId,
    pub transition: LocalTransition,
    pub to: String,
    /// Applied to the consumed colour to give the colour sent.
    pub colour: ColourOp,
}

impl Slice {
    /// Arcs between this slice's own places and transitions.
    pub fn internal_arcs(&self) -> usize {
        self.transitions
            .iter()
            .map(|t| t.consume.len() + t.read.len() + t.produce.len())
            .sum()
    }

    /// The bridges a transition sends on when it fires.
    pub fn sends(&self, t: LocalTransition) -> impl Iterator<Item = &BridgeOut> + '_ {
        self.bridges_out.iter().filter(move |b| b.transition == t)
    }

    /// The local place with this stable id.
    pub fn place_by_id(&self, id: &str) -> Option<LocalPlace> {
        self.places
            .iter()
            .position(|p| p.id == id)
            .map(|i| i as u32)
    }

    /// The local transition with this stable id.
    pub fn transition_by_id(&self, id: &str) -> Option<LocalTransition> {
        self.transitions
            .iter()
            .position(|t| t.transition.id == id)
            .map(|i| i as u32)
    }

    /// Checks that every index points inside the slice and that the bridge
    /// tables agree with the peer list, so that an executor can index
    /// without checking. Decoding calls it: an inconsistent slice never
    /// reaches an executor.
    pub fn validate(&self) -> Result<(), DecodeError> {
        let bad = |m: String| Err(DecodeError::Inconsistent(m));
        let np = self.places.len() as u32;
        let nt = self.transitions.len() as u32;
        let place_ok = |p: LocalPlace| p < np;
        for (i, t) in self.transitions.iter().enumerate() {
            let all = t
                .consume
                .iter()
                .chain(&t.read)
                .copied()
                .chain(t.produce.iter().map(|p| p.place));
            for p in all {
                if !place_ok(p) {
                    return bad(format!(
                        "transition #{i} `{}` names place #{p}, the slice has {np} places",
                        t.transition.id
                    ));
                }
            }
        }
        for &p in &self.initial_marking {
            if !place_ok(p) {
                return bad(format!(
                    "initial marking names place #{p}, the slice has {np} places"
                ));
            }
        }
        if let Some(p) = self.final_place {
            if !place_ok(p) || self.places[p as usize].kind != PlaceKind::Final {
                return bad(format!(
                    "final place #{p} is not a final place of the slice"
                ));
            }
        }
        if self.ends.is_empty() {
            return bad("no owner holds an end of the mission".to_string());
        }
        if self.final_place.is_some() != self.ends.contains(&self.drone) {
            return bad(format!(
                "`{}` {} an end of the mission but the list of ends {:?} says otherwise",
                self.drone,
                if self.final_place.is_some() {
                    "holds"
                } else {
                    "holds no"
                },
                self.ends
            ));
        }
        let mut ids = BTreeSet::new();
        let mut peers = BTreeSet::new();
        for b in &self.bridges_in {
            if !place_ok(b.inbox) {
                return bad(format!(
                    "bridge {} delivers into place #{}, the slice has {np} places",
                    b.id, b.inbox
                ));
            }
            if !ids.insert(b.id) {
                return bad(format!("bridge {} appears twice", b.id));
            }
            peers.insert(b.from.clone());
        }
        for b in &self.bridges_out {
            if b.transition >= nt {
                return bad(format!(
                    "bridge {} is sent by transition #{}, the slice has {nt} transitions",
                    b.id, b.transition
                ));
            }
            if !ids.insert(b.id) {
                return bad(format!("bridge {} appears twice", b.id));
            }
            peers.insert(b.to.clone());
        }
        if peers.contains(&self.drone) {
            return bad(format!("`{}` has a bridge to itself", self.drone));
        }
        let listed: BTreeSet<String> = self.peers.iter().cloned().collect();
        if listed != peers {
            return bad(format!(
                "peer list {:?} does not match the bridges' peers {:?}",
                self.peers, peers
            ));
        }
        for name in self
            .peers
            .iter()
            .chain(&self.telemetry)
            .chain(self.ends.iter())
        {
            if name != GCS && !self.drones.contains(name) {
                return bad(format!("`{name}` is not a drone of the mission"));
            }
        }
        for t in &self.transitions {
            let mut named: Vec<u16> = t
                .transition
                .kind
                .action()
                .map(|a| a.drone.0)
                .into_iter()
                .collect();
            if let Some(g) = &t.transition.guard {
                named.extend(g.drones().iter().map(|d| d.0));
            }
            if let Some(&d) = named.iter().find(|&&d| d as usize >= self.drones.len()) {
                return bad(format!(
                    "transition `{}` names drone #{d}, the mission has {} drones",
                    t.transition.id,
                    self.drones.len()
                ));
            }
        }
        if self.drone != GCS && !self.drones.contains(&self.drone) {
            return bad(format!("`{}` is not a drone of the mission", self.drone));
        }
        // Numbers fly drones: the compiler folds only finite constants, so
        // a NaN or an infinity in an argument, a delay or a condition is
        // damage, never a mission (found by the `slice_binary` fuzz target).
        for p in &self.places {
            if let PlaceKind::Running(a) = &p.kind {
                if !a.args.iter().all(|x| x.is_finite()) {
                    return bad(format!(
                        "place `{}` runs {} with an argument that is not a finite number",
                        p.id, a.name
                    ));
                }
            }
        }
        for t in &self.transitions {
            let t = &t.transition;
            let args = t
                .kind
                .action()
                .is_none_or(|a| a.args.iter().all(|x| x.is_finite()));
            let delay = t.delay.is_none_or(f64::is_finite);
            let guard = t.guard.as_ref().is_none_or(|g| match &g.kind {
                GuardKind::Cond { cond, .. } => finite(cond),
                _ => true,
            });
            if !(args && delay && guard) {
                return bad(format!(
                    "transition `{}` has a number that is not finite",
                    t.id
                ));
            }
        }
        Ok(())
    }
}

/// Every number of a condition is finite.
fn finite(e: &Expr) -> bool {
    match e {
        Expr::Number { value, .. } => value.is_finite(),
        Expr::Unary { operand, .. } => finite(operand),
        Expr::Binary { lhs, rhs, .. } => finite(lhs) && finite(rhs),
        Expr::Bool { .. } | Expr::Property { .. } => true,
    }
}
