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
    for (d, name) in names.drones().iter().enumerate() {
        let home = space.home(d as u16);
        let at = Vec3::new(home.x, home.y, 0.0);
        if space.airspace.breach(at, at).is_some() {
            out.push(Finding {
                kind: FindingKind::LeavesAirspace,
                message: format!(
                    "{name}'s home ({:.1}, {:.1}) is outside the fence",
                    home.x, home.y
                ),
                labels: Vec::new(),
                notes: vec!["move the home or the fence in the fleet file".into()],
                trace: None,
                geometry: Some(Geometry {
                    legs: Vec::new(),
                    closest: Some((at, at)),
                    distance: None,
                }),
            });
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    let mut out_of = std::collections::BTreeSet::new();
    for (m, legs) in positions.legs.iter().enumerate() {
        let t = &positions.motions[m];
        let home = space.home(t.drone);
        for leg in legs {
            let sweep = leg.sweep.at(Vec3::new(home.x, home.y, 0.0));
            let Some(breach) = sweep.breach(&space.airspace) else {
                continue;
            };
            // A leg that starts outside follows one that left: that one
            // is the finding.
            let (start, _) = sweep.ends();
            if matches!(sweep, Shape::Leg(..)) && space.airspace.breach(start, start).is_some() {
                continue;
            }
            if !seen.insert((t.span.start, t.span.end)) {
                break;
            }
            // The first way out of each drone is the finding; fixed, the
            // next check shows the next.
            if !out_of.insert(t.drone) {
                break;
            }
            out.push(breach_finding(
                t,
                leg,
                sweep,
                breach,
                space,
                names,
                positions.exact_rounds,
            ));
            break;
        }
    }
    // A drift shows at every step of the loop and at everything after
    // it: say it once per drone, at a step inside the loop.
    let mut drifting = std::collections::BTreeSet::new();
    let mut drifts: Vec<&Drift> = positions.drifts.iter().collect();
    drifts.sort_by_key(|d| (std::cmp::Reverse(d.colour.len()), d.motion));
    for drift in drifts {
        if drifting.insert(positions.motions[drift.motion].drone) {
            out.push(drift_finding(drift, positions, space, names));
        }
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
    exact_rounds: u32,
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
        Breach::Floor(_) => format!(
            "goes down to {:.1} m, below the floor of {} m",
            p.z, a.floor
        ),
    };
    let round = match leg.colour.last() {
        Some(k) if *k < exact_rounds => format!(" in round {} of its loop", k + 1),
        Some(k) => format!(" in round {} or later of its loop", k + 1),
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
    // Follow the drift until a round's leg leaves the airspace, if it has
    // bounds. The first start kept is that of the round after the ones
    // the loop's counter still told apart.
    let done_before = drift.colour.last().copied().unwrap_or(0) as u64;
    let bounded = space.airspace.fence.is_some() || space.airspace.ceiling.is_some();
    let mut out_in = None;
    if step.norm() > 0.0 && bounded {
        for i in 0..DRIFT_ROUNDS {
            let a = first + step * i as f64 + offset;
            if let Some(b) = space.airspace.breach(a, a + step) {
                out_in = Some((done_before + i + 1, b.point()));
                break;
            }
        }
    }
    let far = drift
        .starts
        .iter()
        .map(|s| corner(s).distance(first))
        .fold(0.0, f64::max);
    let steady = n >= 3
        && (step - (corner(&drift.starts[n - 2]) - corner(&drift.starts[n - 3]))).norm() < 1e-6;
    let how = if steady && step.norm() > 0.0 {
        format!(
            "each round of its loop moves {drone} ({:.1}, {:.1}, {:.1}) m further",
            step.x, step.y, step.z
        )
    } else {
        format!(
            "the rounds of its loop can take {drone} somewhere new each time ({:.1} m away within {n} rounds)",
            far
        )
    };
    let message = match out_in {
        Some((round, p)) if steady => format!(
            "{}: {how}; in round {round} it leaves the airspace at ({:.1}, {:.1}, {:.1})",
            names.action(&t.action),
            p.x,
            p.y,
            p.z
        ),
        _ => format!(
            "{}: {how}, without bound: it can leave any fence",
            names.action(&t.action)
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
            closest: out_in.map(|(_, p)| (p, p)),
            distance: None,
        }),
    }
}
