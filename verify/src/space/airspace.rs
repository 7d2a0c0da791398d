//! The `airspace` property: every leg of every drone, not only its
//! waypoints, stays inside the fence, below the ceiling and above the
//! floor; and no loop moves a drone further every round without bound.

use eamos_geo::{Breach, Vec3};

use super::model::{Drift, Positions};
use super::shape::Shape;
use super::{Names, Space};
use crate::report::{Finding, FindingKind, GeoLeg, Geometry, Label};

/// Rounds a drift is followed for, looking for where it leaves the
/// airspace: a million rounds of a millimetre is a kilometre.
const DRIFT_ROUNDS: u64 = 1_000_000;

pub(crate) fn findings(positions: &Positions, space: &Space, names: &Names) -> Vec<Finding> {
    let mut out = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for (m, legs) in positions.legs.iter().enumerate() {
        let t = &positions.motions[m];
        let home = space.home(t.drone);
        for leg in legs {
            let sweep = leg.sweep.at(Vec3::new(home.x, home.y, 0.0));
            let Some(breach) = sweep.breach(&space.airspace) else {
                continue;
            };
            if !seen.insert((t.span.start, t.span.end)) {
                break;
            }
            out.push(breach_finding(t, leg, sweep, breach, space, names));
            break;
        }
    }
    for drift in &positions.drifts {
        out.push(drift_finding(drift, positions, space, names));
    }
    out
}

fn breach_finding(
    t: &super::model::Tracked,
    leg: &super::model::Leg,
    sweep: Shape,
    breach: Breach,
    space: &Space,
    names: &Names,
) -> Finding {
    let drone = names.drone(t.drone);
    let p = breach.point();
    let a = &space.airspace;
    let why = match breach {
        Breach::Fence(_) => "leaves the fence".to_string(),
        Breach::Ceiling(_) => format!(
            "climbs to {:.1} m, above the ceiling of {} m",
            p.z,
            a.ceiling.unwrap_or_default()
        ),
        Breach::Floor(_) => format!("goes down to {:.1} m, below the floor of {} m", p.z, a.floor),
    };
    let round = match leg.colour.last() {
        Some(k) => format!(" in round {} of its loop", k + 1),
        None => String::new(),
    };
    let (from, to) = sweep.ends();
    Finding {
        kind: FindingKind::LeavesAirspace,
        message: format!(
            "{}{round} {why} at ({:.1}, {:.1}, {:.1})",
            names.action(&t.action),
            p.x,
            p.y,
            p.z
        ),
        labels: vec![Label {
            span: t.span,
            text: format!("{drone} {why} here"),
        }],
        notes: vec![format!(
            "the leg runs from ({:.1}, {:.1}, {:.1}) to ({:.1}, {:.1}, {:.1}) in the fleet frame (metres north, east, up)",
            from.x, from.y, from.z, to.x, to.y, to.z
        )],
        trace: None,
        geometry: Some(Geometry {
            legs: vec![GeoLeg {
                drone,
                from,
                to,
                boxed: matches!(sweep, Shape::Box(..)),
                span: Some(t.span),
            }],
            closest: Some((p, p)),
            distance: None,
        }),
    }
}

fn drift_finding(drift: &Drift, positions: &Positions, space: &Space, names: &Names) -> Finding {
    let t = &positions.motions[drift.motion];
    let drone = names.drone(t.drone);
    let home = space.home(t.drone);
    let offset = Vec3::new(home.x, home.y, 0.0);
    let corner = |s: &Shape| s.ends().0;
    let n = drift.starts.len();
    let (first, last) = (corner(&drift.starts[0]), corner(&drift.starts[n - 1]));
    let step = if n >= 2 {
        last - corner(&drift.starts[n - 2])
    } else {
        Vec3::ZERO
    };
    // Follow the drift until it leaves the airspace, if it has bounds.
    let bounded = space.airspace.fence.is_some() || space.airspace.ceiling.is_some();
    let mut out_after = None;
    if step.norm() > 0.0 {
        for k in 0..DRIFT_ROUNDS {
            let p = first + step * k as f64;
            if let Some(b) = space.airspace.breach(p + offset, p + offset) {
                out_after = Some((k, b.point()));
                break;
            }
            if !bounded && k > 0 {
                break;
            }
        }
    }
    let message = match out_after {
        Some((k, p)) if bounded => format!(
            "{}: each round of its loop moves {drone} ({:.1}, {:.1}, {:.1}) m further; after {k} round(s) it is out of the airspace at ({:.1}, {:.1}, {:.1})",
            names.action(&t.action),
            step.x, step.y, step.z, p.x, p.y, p.z
        ),
        _ => format!(
            "{}: each round of its loop moves {drone} ({:.1}, {:.1}, {:.1}) m further, without bound: it leaves any fence",
            names.action(&t.action),
            step.x, step.y, step.z
        ),
    };
    Finding {
        kind: FindingKind::Drift,
        message,
        labels: vec![Label {
            span: t.span,
            text: format!("{drone} starts this leg somewhere new every round"),
        }],
        notes: vec![
            "the loop runs for as long as its condition lets it: bound it (RepeatFor) or bring the drone back within the body".into(),
        ],
        trace: None,
        geometry: Some(Geometry {
            legs: vec![GeoLeg {
                drone,
                from: first + offset,
                to: last + offset,
                boxed: false,
                span: Some(t.span),
            }],
            closest: out_after.map(|(_, p)| (p, p)),
            distance: None,
        }),
    }
}
