//! The observed trace of a run: every drone's action starts, ends and
//! cancellations, merged from the one event stream, and the condition
//! decisions the drones took.

use std::collections::HashSet;

use eamos_exec::event::{Event, Kind};
use eamos_petri::net::{Colour, Net, TransitionKind};

/// Two mission times closer than this are a tie: the simulated clock moves
/// in steps, and events of one step have no order in mission time.
pub const TIE: f64 = 1e-9;

/// What a drone did with an action.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    Start,
    End,
    Cancel,
}

/// One visible event: a drone started, ended or cancelled an action
/// instance (with its arguments and loop colour) at a mission time.
#[derive(Debug, Clone, PartialEq)]
pub struct Seen {
    pub time: f64,
    pub drone: String,
    pub step: Step,
    pub action: String,
    pub args: Vec<f64>,
    pub instance: u32,
    pub colour: Colour,
}

/// What a run showed of the mission.
#[derive(Debug, Default)]
pub struct Observed {
    /// The visible events, by mission time; each drone's own events in the
    /// order it emitted them.
    pub seen: Vec<Seen>,
    /// Every transition that fired with a condition guard, by id, with its
    /// binding colour: the drones' decisions, the guards' observed values.
    pub decided: HashSet<(String, Colour)>,
    /// What the stream says that no executor may do, whatever the net.
    pub broken: Vec<String>,
}

/// The observed trace of `events` (a run of `net`'s slices).
///
/// A start is the executor's `ActionStarted` (the adapter is asked); an end
/// or a cancellation is the firing of the net's `ActionEnd` or
/// `ActionCancel` (its `Fired` event), which must follow the adapter's
/// report of success (`ActionFinished` ok) for an end.
pub fn observe(net: &Net, events: &[Event]) -> Observed {
    let mut out = Observed::default();
    let mut succeeded: HashSet<(String, u32, Colour)> = HashSet::new();
    for e in events {
        match &e.kind {
            Kind::ActionStarted {
                action,
                args,
                instance,
                colour,
                ..
            } => out.seen.push(Seen {
                time: e.time,
                drone: e.drone.clone(),
                step: Step::Start,
                action: action.clone(),
                args: args.clone(),
                instance: *instance,
                colour: colour.clone(),
            }),
            Kind::ActionFinished {
                instance,
                colour,
                outcome,
                ..
            } if outcome == "ok" => {
                succeeded.insert((e.drone.clone(), *instance, colour.clone()));
            }
            Kind::Fired {
                transition, colour, ..
            } => {
                // Nodes the slicer added (bundles, the ends) are not the
                // global net's: only its own transitions are looked at.
                let Some(t) = net.find(transition).and_then(|n| net.transition(n)) else {
                    continue;
                };
                if t.guard.as_ref().is_some_and(|g| g.condition().is_some()) {
                    out.decided.insert((t.id.to_string(), colour.clone()));
                }
                let (step, a) = match &t.kind {
                    TransitionKind::ActionEnd(a) => (Step::End, a),
                    TransitionKind::ActionCancel(a) => (Step::Cancel, a),
                    _ => continue,
                };
                let key = (e.drone.clone(), a.instance, colour.clone());
                if step == Step::End && !succeeded.remove(&key) {
                    out.broken.push(format!(
                        "{} ended {} (instance {}, colour {colour:?}) before its adapter reported success",
                        e.drone, a.name, a.instance
                    ));
                }
                out.seen.push(Seen {
                    time: e.time,
                    drone: e.drone.clone(),
                    step,
                    action: a.name.to_string(),
                    args: a.args.clone(),
                    instance: a.instance,
                    colour: colour.clone(),
                });
            }
            _ => {}
        }
    }
    // Stable: each drone's own order stays as it emitted its events.
    out.seen.sort_by(|a, b| a.time.total_cmp(&b.time));
    out
}

/// The visible events cut into groups of one mission time (ties).
pub fn ties(seen: &[Seen]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=seen.len() {
        if i == seen.len() || seen[i].time - seen[start].time > TIE {
            if start < i {
                out.push(start..i);
            }
            start = i;
        }
    }
    out
}
