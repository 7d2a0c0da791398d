//! The nominal timeline: when each action of each drone starts and ends if
//! every action takes its profile's nominal duration (flights timed at the
//! profile's speeds over the leg `eamos_verify::plan` found) and every
//! step fires as soon as its inputs are there.
//!
//! A choice draws every branch at once (a step waits for the latest of
//! the ways into it) and a loop draws its first round (arcs out of a
//! loop-back are not followed): the timeline is the mission's shape in
//! time, not a prediction of one run.

use std::collections::{BTreeSet, HashMap, VecDeque};

use eamos_petri::net::{Net, NodeId, TransitionKind};
use eamos_verify::Plan;
use serde::Serialize;

use crate::input::{line_of, Input};

#[derive(Debug, Clone, Serialize)]
pub struct Timeline {
    /// One lane per drone, in the mission's order.
    pub lanes: Vec<Lane>,
    /// Where a drone waits for another: from the end of one drone's action
    /// to the start of another drone's.
    pub waits: Vec<Wait>,
    /// Seconds until the last action ends.
    pub length: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Lane {
    pub drone: usize,
    pub bars: Vec<Bar>,
}

/// One action of one drone.
#[derive(Debug, Clone, Serialize)]
pub struct Bar {
    pub action: String,
    pub start: f64,
    pub end: f64,
    pub line: u32,
}

#[derive(Debug, Clone, Serialize)]
pub struct Wait {
    pub from_drone: usize,
    pub from_time: f64,
    pub to_drone: usize,
    pub to_time: f64,
    /// `Drone3.Takeoff(5) → Drone1.Takeoff(1.5)`.
    pub label: String,
}

pub(crate) fn timeline(input: &Input) -> Timeline {
    let net = input.net;
    let times = times(net, &|t| duration(input, t));
    let mut lanes: Vec<Lane> = (0..net.drones.len())
        .map(|drone| Lane {
            drone,
            bars: Vec::new(),
        })
        .collect();
    let mut waits = Vec::new();
    let mut seen = BTreeSet::new();
    let mut length: f64 = 0.0;
    for (n, t) in net.transitions() {
        let TransitionKind::ActionStart(a) = &t.kind else {
            continue;
        };
        let start = times.get(&n).copied().unwrap_or(0.0);
        let end = start + duration(input, n).unwrap_or(0.0);
        length = length.max(end);
        let text = action_text(net, &a.name, a.drone.0 as usize, &a.args);
        if let Some(lane) = lanes.get_mut(a.drone.0 as usize) {
            lane.bars.push(Bar {
                action: text.clone(),
                start,
                end,
                line: line_of(input.source, t.span),
            });
        }
        for before in ends_before(net, n) {
            let Some(TransitionKind::ActionEnd(b)) = net.transition(before).map(|t| &t.kind) else {
                continue;
            };
            if b.drone == a.drone || !seen.insert((before, n)) {
                continue;
            }
            waits.push(Wait {
                from_drone: b.drone.0 as usize,
                from_time: times.get(&before).copied().unwrap_or(0.0),
                to_drone: a.drone.0 as usize,
                to_time: start,
                label: format!(
                    "{} → {text}",
                    action_text(net, &b.name, b.drone.0 as usize, &b.args)
                ),
            });
        }
    }
    for lane in &mut lanes {
        lane.bars
            .sort_by(|x, y| x.start.total_cmp(&y.start).then(x.line.cmp(&y.line)));
    }
    Timeline {
        lanes,
        waits,
        length,
    }
}

fn action_text(net: &Net, name: &str, drone: usize, args: &[f64]) -> String {
    let args: Vec<String> = args.iter().map(|v| format!("{v}")).collect();
    let who = net.drones.get(drone).map_or("?", String::as_str);
    format!("{who}.{name}({})", args.join(", "))
}

/// How long transition `t` takes to fire after its inputs are there: an
/// action's end its nominal duration after its start, a timed pause its
/// delay; `None` for everything else.
fn duration(input: &Input, t: NodeId) -> Option<f64> {
    let net = input.net;
    let tr = net.transition(t)?;
    if let Some(d) = tr.delay {
        return Some(d);
    }
    let (TransitionKind::ActionStart(a) | TransitionKind::ActionEnd(a)) = &tr.kind else {
        return None;
    };
    let profile = input.profiles.get(net.profiles.get(a.drone.0 as usize)?)?;
    let sig = profile.actions.get(a.name.as_str())?;
    // A flight starts where the checker says the drone is: its first
    // planned leg, in the drone's own frame (from its home).
    let start = match input.plan {
        Ok(plan) => start_of(plan, a.instance, a.drone.0 as usize),
        Err(_) => [0.0; 3],
    };
    sig.nominal_duration(start, &a.args, profile.speeds.as_ref())
}

fn start_of(plan: &Plan, instance: u32, drone: usize) -> [f64; 3] {
    let home = plan.homes.get(drone).copied().unwrap_or_default();
    plan.legs
        .iter()
        .find(|l| l.instance == instance)
        .map_or([0.0; 3], |l| {
            [l.from.x - home.x, l.from.y - home.y, l.from.z]
        })
}

/// The time each transition fires, nominally. Arcs out of loop-backs are
/// left out; what still forms a cycle (a region place read inside its own
/// body) is broken by firing the earliest-ready step of it with the inputs
/// known so far.
fn times(net: &Net, took: &dyn Fn(NodeId) -> Option<f64>) -> HashMap<NodeId, f64> {
    let follow = |from: NodeId| {
        !matches!(
            net.transition(from).map(|t| &t.kind),
            Some(TransitionKind::LoopBack)
        )
    };
    // Inputs still unknown, per node.
    let mut waiting: HashMap<NodeId, usize> = HashMap::new();
    for n in net.graph.node_indices() {
        let count = if net.is_place(n) {
            net.producers(n).filter(|&p| follow(p)).count()
        } else {
            net.preset(n).count() + net.read_set(n).count()
        };
        waiting.insert(n, count);
    }
    let mut at: HashMap<NodeId, f64> = HashMap::new();
    let mut ready: VecDeque<NodeId> = waiting
        .iter()
        .filter(|&(_, &c)| c == 0)
        .map(|(&n, _)| n)
        .collect();
    let mut done: BTreeSet<NodeId> = BTreeSet::new();
    let outputs = |n: NodeId| -> Vec<NodeId> {
        if net.is_place(n) {
            net.consumers(n).map(|(t, _)| t).collect()
        } else if follow(n) {
            net.postset(n).map(|(p, _)| p).collect()
        } else {
            Vec::new()
        }
    };
    loop {
        while let Some(n) = ready.pop_front() {
            if !done.insert(n) {
                continue;
            }
            let inputs: Vec<NodeId> = if net.is_place(n) {
                net.producers(n).filter(|&p| follow(p)).collect()
            } else {
                net.preset(n).chain(net.read_set(n)).collect()
            };
            let mut t = inputs
                .iter()
                .filter_map(|i| at.get(i))
                .fold(0.0_f64, |a, &b| a.max(b));
            // An action's end fires its duration after its start; the
            // start itself takes no time.
            let starts = matches!(
                net.transition(n).map(|t| &t.kind),
                Some(TransitionKind::ActionStart(_))
            );
            if !net.is_place(n) && !starts {
                t += took(n).unwrap_or(0.0);
            }
            at.insert(n, t);
            for o in outputs(n) {
                if let Some(c) = waiting.get_mut(&o) {
                    *c = c.saturating_sub(1);
                    if *c == 0 {
                        ready.push_back(o);
                    }
                }
            }
        }
        // A cycle left: fire the first of its nodes that has some input.
        let next = net.graph.node_indices().find(|n| {
            !done.contains(n)
                && (net.is_place(*n) && net.producers(*n).any(|p| at.contains_key(&p))
                    || !net.is_place(*n) && net.preset(*n).any(|p| at.contains_key(&p)))
        });
        match next {
            Some(n) => ready.push_back(n),
            None => break,
        }
    }
    at
}

/// The action ends (and cancels) of any drone that transition `t` waits
/// for directly: walking back from its inputs through places and plumbing,
/// stopping at the first action end on each way.
fn ends_before(net: &Net, t: NodeId) -> Vec<NodeId> {
    let mut out = Vec::new();
    let mut seen = BTreeSet::new();
    let mut work: Vec<NodeId> = net.preset(t).chain(net.read_set(t)).collect();
    while let Some(p) = work.pop() {
        if !seen.insert(p) {
            continue;
        }
        for producer in net.producers(p) {
            match net.transition(producer).map(|t| &t.kind) {
                Some(TransitionKind::ActionEnd(_) | TransitionKind::ActionCancel(_)) => {
                    out.push(producer)
                }
                Some(TransitionKind::LoopBack | TransitionKind::ActionStart(_)) | None => {}
                Some(_) => work.extend(net.preset(producer).chain(net.read_set(producer))),
            }
        }
    }
    out
}
