//! The findings of `separation`: a pair the exploration reached, in
//! mission terms (one per two drones, the others in its notes), and homes
//! that start too close.

use std::collections::{BTreeMap, BTreeSet};

use super::model::Last;
use super::near::{Extended, Other};
use super::shape::Shape;
use super::Prepared;
use crate::report::{Finding, FindingKind, GeoLeg, Geometry, Label};

/// The finding for a candidate the exploration reached, with its trace.
pub(crate) fn near_findings(
    prep: &Prepared,
    ext: &Extended,
    hits: &[(u32, usize)],
    trace: &dyn Fn(u32) -> crate::report::Trace,
) -> Vec<Finding> {
    let Ok(pos) = &prep.positions else {
        return Vec::new();
    };
    let names = &prep.names;
    let sep = prep.space.airspace.separation;
    let mut seen = BTreeSet::new();
    // One finding per two drones, the closest way they can meet; the
    // others are listed in its notes.
    type Found = (bool, Finding, String);
    let mut by_pair: BTreeMap<(u16, u16), Vec<Found>> = BTreeMap::new();
    for &(state, i) in hits {
        let c = &ext.candidates[i];
        let a = &pos.motions[c.motion];
        let (other_drone, other_text, other_span) = match c.other {
            Other::Moving(n) => {
                let b = &pos.motions[n];
                (
                    b.drone,
                    format!("{} under way", names.action(&b.action)),
                    Some(b.span),
                )
            }
            Other::Resting(d, Last::Home) => (d, format!("{} at home", names.drone(d)), None),
            Other::Resting(d, Last::End(n)) => (
                d,
                format!(
                    "{} resting where {} ended",
                    names.drone(d),
                    names.action(&pos.motions[n].action)
                ),
                Some(pos.motions[n].span),
            ),
            Other::Resting(d, Last::Cancel(n)) => (
                d,
                format!(
                    "{} stopped somewhere on {}",
                    names.drone(d),
                    names.action(&pos.motions[n].action)
                ),
                Some(pos.motions[n].span),
            ),
        };
        let key = (
            a.span.start,
            a.span.end,
            other_span.map(|s| (s.start, s.end)),
            other_drone,
        );
        if !seen.insert(key) {
            continue;
        }
        let p = c.closest.first;
        let q = c.closest.second;
        let mut labels = vec![Label {
            span: a.span,
            text: format!("{} flies this leg", names.drone(a.drone)),
        }];
        if let Some(s) = other_span {
            labels.push(Label {
                span: s,
                text: match c.other {
                    Other::Moving(_) => {
                        format!("while {} flies this one", names.drone(other_drone))
                    }
                    _ => format!(
                        "while {} rests where this leg ends",
                        names.drone(other_drone)
                    ),
                },
            });
        }
        let leg = |d: u16, s: Shape, span| {
            let (from, to) = s.ends();
            GeoLeg {
                drone: names.drone(d),
                from,
                to,
                boxed: matches!(s, Shape::Box(..)),
                span,
            }
        };
        let both_moving = matches!(c.other, Other::Moving(_));
        let summary = format!(
            "{} ({}) with {}{}",
            names.action(&a.action),
            names.line(a.span),
            other_text,
            other_span.map_or(String::new(), |s| format!(" ({})", names.line(s)))
        );
        let pair = (a.drone.min(other_drone), a.drone.max(other_drone));
        by_pair.entry(pair).or_default().push((both_moving, Finding {
            kind: FindingKind::TooClose,
            message: format!(
                "{} can come within {:.2} m of {} (separation {} m)",
                names.action(&a.action),
                c.closest.distance,
                other_text,
                sep
            ),
            labels,
            notes: vec![
                format!(
                    "closest approach: ({:.2}, {:.2}, {:.2}) and ({:.2}, {:.2}, {:.2}), fleet frame (metres north, east, up)",
                    p.x, p.y, p.z, q.x, q.y, q.z
                ),
                "order the two with Signal/Await, or fly them at different heights".into(),
            ],
            trace: Some(trace(state)),
            geometry: Some(Geometry {
                legs: vec![
                    leg(a.drone, c.shapes.0, Some(a.span)),
                    leg(other_drone, c.shapes.1, other_span),
                ],
                closest: Some((p, q)),
                distance: Some(c.closest.distance),
            }),
        }, summary));
    }
    let mut out = Vec::new();
    // The closest way first (the pair's closest possible approach is the
    // finding's distance), then legs both under way, then the shortest
    // interleaving.
    for (_, mut list) in by_pair {
        list.sort_by(|a, b| {
            distance(&a.1)
                .total_cmp(&distance(&b.1))
                .then(b.0.cmp(&a.0))
                .then(trace_len(&a.1).cmp(&trace_len(&b.1)))
        });
        let mut rest = list.split_off(1);
        let Some((_, mut f, _)) = list.pop() else {
            continue;
        };
        if !rest.is_empty() {
            let n = rest.len();
            rest.truncate(8);
            let lines: Vec<String> = rest.into_iter().map(|(_, _, s)| s).collect();
            f.notes.push(format!(
                "the same two drones can also meet {n} more way(s): {}{}",
                lines.join("; "),
                if n > 8 { "; ..." } else { "" }
            ));
        }
        out.push(f);
    }
    out
}

fn distance(f: &Finding) -> f64 {
    f.geometry
        .as_ref()
        .and_then(|g| g.distance)
        .unwrap_or(f64::MAX)
}

fn trace_len(f: &Finding) -> usize {
    f.trace.as_ref().map_or(0, |t| t.steps.len())
}

/// Homes closer than the separation: a finding before anything moves.
pub(crate) fn homes_findings(prep: &Prepared) -> Vec<Finding> {
    let names = &prep.names;
    let sep = prep.space.airspace.separation;
    let mut out = Vec::new();
    let n = names.drones().len() as u16;
    for a in 0..n {
        for b in a + 1..n {
            let (p, q) = (prep.space.home(a), prep.space.home(b));
            let d = p.distance(q);
            if d < sep {
                out.push(Finding {
                    kind: FindingKind::TooClose,
                    message: format!(
                        "{} and {} start {d:.2} m apart, closer than the separation ({sep} m)",
                        names.drone(a),
                        names.drone(b)
                    ),
                    labels: Vec::new(),
                    notes: vec!["move their homes apart in the fleet file".into()],
                    trace: None,
                    geometry: Some(Geometry {
                        legs: Vec::new(),
                        closest: Some((p, q)),
                        distance: Some(d),
                    }),
                });
            }
        }
    }
    out
}
