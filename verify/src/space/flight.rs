//! The `flight-state` property: every action starts in a flight state its
//! profile allows (no motion before take-off, no take-off in the air or
//! disarmed, no disarming in flight), and every argument is in the range
//! its profile declares.
//!
//! Per drone, the states it can be in when each of its actions starts are
//! found by following its actions in order from home (disarmed on the
//! ground), as the positions are ([`crate::space::walk`]); the states are
//! three, so loops need no counting. A finding names the action, the state
//! it can start in, and the drone's own actions that lead there.

use std::collections::BTreeMap;

use rustc_hash::FxHashMap as HashMap;

use eamos_geo::Airspace;
use eamos_petri::net::{Net, NodeId};
use eamos_profile::{FlightState, ProfileTable};

use super::model::tracked;
use super::walk::{OutOfBudget, Walker};
use super::Names;
use crate::report::{Finding, FindingKind, Label};

/// The findings of the flight-state property.
pub(crate) fn findings(
    net: &Net,
    profiles: &ProfileTable,
    walker: &Walker,
    airspace: &Airspace,
    names: &Names,
) -> Result<Vec<Finding>, OutOfBudget> {
    let mut out = Vec::new();
    out.extend(states(net, profiles, walker, names)?);
    out.extend(arguments(net, profiles, airspace, names));
    Ok(out)
}

fn states(
    net: &Net,
    profiles: &ProfileTable,
    walker: &Walker,
    names: &Names,
) -> Result<Vec<Finding>, OutOfBudget> {
    let actions = tracked(net, profiles, |sig| sig.flight.is_some());
    let mut start_of: HashMap<NodeId, usize> = HashMap::default();
    for (i, t) in actions.iter().enumerate() {
        for &s in &t.starts {
            start_of.insert(s, i);
        }
    }
    let mut budget = super::model::WALK_BUDGET;
    // (action, state it starts in) -> the pair before it, if any.
    let mut came_from: BTreeMap<(usize, FlightState), Option<(usize, FlightState)>> =
        BTreeMap::new();
    type Step = (usize, FlightState);
    let mut work: Vec<(usize, FlightState, Option<Step>)> = Vec::new();
    let mut next: HashMap<(usize, bool), Vec<usize>> = HashMap::default();
    let drones: std::collections::BTreeSet<u16> = actions.iter().map(|t| t.drone).collect();
    for &d in &drones {
        let stop = |t: NodeId| start_of.get(&t).is_some_and(|&i| actions[i].drone == d);
        for (t, _) in walker
            .walk(
                walker.initial(),
                Some(d),
                &stop,
                false,
                &|_| false,
                None,
                &mut budget,
            )?
            .stops
        {
            work.push((start_of[&t], FlightState::Disarmed, None));
        }
    }
    while let Some((i, s, from)) = work.pop() {
        if came_from.contains_key(&(i, s)) {
            continue;
        }
        came_from.insert((i, s), from);
        let a = &actions[i];
        // A refused action leaves the drone as it was: report it once, and
        // judge what follows as if it had not been there.
        let after = a.sig.state_after(s).unwrap_or(s);
        let d = a.drone;
        let stop = |t: NodeId| start_of.get(&t).is_some_and(|&i| actions[i].drone == d);
        for cancel in [false, true] {
            let via = if cancel { &a.cancels } else { &a.ends };
            if via.is_empty() {
                continue;
            }
            if let std::collections::hash_map::Entry::Vacant(e) = next.entry((i, cancel)) {
                let list = walker
                    .walk_after(
                        via,
                        &[],
                        cancel,
                        Some(d),
                        &stop,
                        false,
                        &|_| false,
                        &mut budget,
                    )?
                    .stops
                    .into_iter()
                    .map(|(t, _)| start_of[&t])
                    .collect();
                e.insert(list);
            }
            // A cancelled action may have done its part or not.
            let states: &[FlightState] = if cancel { &[s, after] } else { &[after] };
            for &j in &next[&(i, cancel)] {
                for &s2 in states {
                    work.push((j, s2, Some((i, s))));
                }
            }
        }
    }
    let mut out = Vec::new();
    let mut reported: std::collections::BTreeSet<(u32, u32, FlightState)> = Default::default();
    for &(i, s) in came_from.keys() {
        let a = &actions[i];
        if a.sig.may_start_in(s) || !reported.insert((a.span.start, a.span.end, s)) {
            continue;
        }
        let drone = names.drone(a.drone);
        let allowed: Vec<String> = a.sig.starts_in().iter().map(|s| s.to_string()).collect();
        let mut path = Vec::new();
        let mut at = came_from[&(i, s)];
        while let Some((j, sj)) = at {
            path.push(format!(
                "{} ({}, {drone} {sj})",
                names.action(&actions[j].action),
                names.line(actions[j].span)
            ));
            at = came_from.get(&(j, sj)).copied().flatten();
            if path.len() > 12 {
                path.push("...".into());
                break;
            }
        }
        path.reverse();
        let mut notes = vec![format!(
            "{} may start only {}",
            a.action.name,
            allowed.join(" or ")
        )];
        notes.push(if path.is_empty() {
            format!("{drone} starts the mission {s}, and this is its first action")
        } else {
            format!("{drone} gets there through: {}", path.join(" -> "))
        });
        out.push(Finding {
            kind: FindingKind::FlightState,
            message: format!("{} can start while {drone} is {s}", names.action(&a.action)),
            labels: vec![Label {
                span: a.span,
                text: format!("{drone} is {s} here"),
            }],
            notes,
            trace: None,
            geometry: None,
        });
    }
    Ok(out)
}

fn arguments(
    net: &Net,
    profiles: &ProfileTable,
    airspace: &Airspace,
    names: &Names,
) -> Vec<Finding> {
    let mut out = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for a in tracked(net, profiles, |sig| !sig.params.is_empty()) {
        if !seen.insert((a.span.start, a.span.end, format!("{:?}", a.action.args))) {
            continue;
        }
        for (param, &value) in a.sig.params.iter().zip(&a.action.args) {
            if let Some(why) = param.out_of_range(value, airspace.ceiling) {
                out.push(Finding {
                    kind: FindingKind::ArgumentRange,
                    message: format!("{}: {why}", names.action(&a.action)),
                    labels: vec![Label {
                        span: a.span,
                        text: format!("`{}` is {value}", param.name),
                    }],
                    notes: Vec::new(),
                    trace: None,
                    geometry: None,
                });
            }
        }
    }
    out
}
