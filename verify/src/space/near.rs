//! `separation`: which legs and rests of two drones come within the
//! separation, and the monitors that ask the exploration whether they can
//! be marked at once.

use std::collections::{BTreeMap, BTreeSet};

use eamos_geo::Vec3;

use super::model::{Last, Positions};
use super::shape::{Closest, Shape};
use super::Prepared;
use crate::ptnet::{MonitorKind, PlaceInfo, PtNet};
use crate::structural::Concurrency;

/// Two shapes of two drones that come within the separation.
#[derive(Debug, Clone)]
pub(crate) struct Candidate {
    /// The motion under way.
    pub motion: usize,
    pub other: Other,
    pub closest: Closest,
    /// The two shapes, fleet frame.
    pub shapes: (Shape, Shape),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Other {
    /// Another drone's motion, under way at the same time.
    Moving(usize),
    /// Another drone at rest.
    Resting(u16, Last),
}

/// The compact net with the drones' rest records, and its monitors.
pub(crate) struct Extended {
    /// The net with the rest records, when some drone needs one (`None`:
    /// the net as it was serves).
    pub net: Option<PtNet>,
    pub monitors: Vec<MonitorKind>,
    pub candidates: Vec<Candidate>,
    /// Drones whose legs may overlap one another: their rests cannot be
    /// recorded, so the separation is not decided for them.
    pub unordered: Vec<u16>,
    /// Set when more pairs come within the separation than
    /// [`MAX_WATCHED`]: none is watched and the separation is undecided.
    pub too_many: Option<usize>,
}

/// Monitors slow the exploration down (each one keeps the stubborn sets
/// from leaving out what could enable it), and a mission with hundreds of
/// close pairs has a problem a person must look at first: past this many
/// the separation is left undecided, with the count.
pub(crate) const MAX_WATCHED: usize = 200;

/// Adds the rest records and the separation monitors to `pt`.
pub(crate) fn extend(pt: &PtNet, conc: &Concurrency, prep: &Prepared) -> Extended {
    let Ok(pos) = &prep.positions else {
        return Extended {
            net: None,
            monitors: Vec::new(),
            candidates: Vec::new(),
            unordered: Vec::new(),
            too_many: None,
        };
    };
    let drones: BTreeSet<u16> = pos.motions.iter().map(|t| t.drone).collect();
    let unordered: Vec<u16> = drones
        .iter()
        .copied()
        .filter(|&d| {
            let mine: Vec<u32> = (0..pos.motions.len())
                .filter(|&m| pos.motions[m].drone == d)
                .map(|m| prep.running[m])
                .collect();
            mine.iter()
                .enumerate()
                .any(|(i, &a)| mine[i + 1..].iter().any(|&b| conc.get(a, b)))
        })
        .collect();
    let candidates = candidates(pos, prep, conc, &unordered);
    if candidates.len() > MAX_WATCHED {
        return Extended {
            net: None,
            monitors: Vec::new(),
            candidates: Vec::new(),
            unordered,
            too_many: Some(candidates.len()),
        };
    }
    // Only drones another one can come near while they rest need their
    // rests recorded (each record multiplies the markings a little).
    let resting: BTreeSet<u16> = candidates
        .iter()
        .filter_map(|c| match c.other {
            Other::Resting(d, _) => Some(d),
            Other::Moving(_) => None,
        })
        .collect();
    // Without rest records the net is the one it was: no need to copy and
    // build it again (the big missions keep their drones apart, and pay
    // nothing).
    let (net, last_place) = if resting.is_empty() {
        (None, BTreeMap::new())
    } else {
        let (net, last_place) = record_rests(pt, pos, prep, &resting);
        (Some(net), last_place)
    };
    let monitors = candidates
        .iter()
        .enumerate()
        .map(|(i, c)| MonitorKind::Near {
            a: prep.running[c.motion],
            b: match c.other {
                Other::Moving(m) => prep.running[m],
                Other::Resting(d, l) => last_place[&(d, l)],
            },
            pair: i as u32,
        })
        .collect();
    Extended {
        net,
        monitors,
        candidates,
        unordered,
        too_many: None,
    }
}

/// The net with a record of where each drone of `resting` rests: one place
/// per rest, moved by the ends and cancels of its motions.
fn record_rests(
    pt: &PtNet,
    pos: &Positions,
    prep: &Prepared,
    resting: &BTreeSet<u16>,
) -> (PtNet, BTreeMap<(u16, Last), u32>) {
    let mut places = pt.places.clone();
    let mut initial = pt.initial.clone();
    let mut raw = pt.raw();
    let mut steps = pt.steps.clone();
    // One "last" place per rest of every ordered drone, also those that
    // never fly (they rest at home throughout).
    let mut last_place: BTreeMap<(u16, Last), u32> = BTreeMap::new();
    for &d in resting {
        for last in pos.lasts(d) {
            let i = places.len() as u32;
            places.push(PlaceInfo {
                id: format!("{}@{}", prep.names.drone(d), last_id(last)).into(),
                label: format!("{} rests at {}", prep.names.drone(d), last_id(last)).into(),
                span: None,
                event: None,
                is_final: false,
                auxiliary: true,
                synthetic: true,
            });
            initial.push(u32::from(last == Last::Home));
            last_place.insert((d, last), i);
        }
    }
    for (m, t) in pos.motions.iter().enumerate() {
        if !resting.contains(&t.drone) {
            continue;
        }
        let preds: Vec<u32> = pos.preds[m]
            .iter()
            .filter_map(|l| last_place.get(&(t.drone, *l)).copied())
            .collect();
        for (list, now) in [
            (&prep.ends[m], Last::End(m)),
            (&prep.cancels[m], Last::Cancel(m)),
        ] {
            let Some(&to) = last_place.get(&(t.drone, now)) else {
                continue;
            };
            for &r in list.iter() {
                let base = raw[r as usize].clone();
                for (k, &from) in preds.iter().enumerate() {
                    let mut copy = base.clone();
                    copy.pre.push((from, 1));
                    copy.post.push((to, 1));
                    if k == 0 {
                        raw[r as usize] = copy;
                    } else {
                        raw.push(copy);
                        steps.push(steps[r as usize].clone());
                    }
                }
            }
        }
    }
    let mut recorded = PtNet::new(places, steps, raw, initial, pt.final_place);
    recorded.seeds = pt.seeds;
    (recorded, last_place)
}

fn last_id(last: Last) -> String {
    match last {
        Last::Home => "home".into(),
        Last::End(m) => format!("end{m}"),
        Last::Cancel(m) => format!("stop{m}"),
    }
}

/// Every leg and leg, or leg and rest, of two drones that come within the
/// separation, closest first per pair.
fn candidates(
    pos: &Positions,
    prep: &Prepared,
    conc: &Concurrency,
    unordered: &[u16],
) -> Vec<Candidate> {
    let sep = prep.space.airspace.separation;
    let offset = |d: u16| prep.space.home(d);
    let world = |d: u16, s: Shape| s.at(offset(d));
    let legs: Vec<Vec<Shape>> = pos
        .legs
        .iter()
        .enumerate()
        .map(|(m, ls)| {
            ls.iter()
                .map(|l| world(pos.motions[m].drone, l.sweep))
                .collect()
        })
        .collect();
    let leg_bounds: Vec<Option<(Vec3, Vec3)>> = legs.iter().map(|s| bounds(s, sep)).collect();
    let mut rests: Vec<(u16, Last, Vec<Shape>)> = Vec::new();
    for d in 0..prep.names.drones().len() as u16 {
        if unordered.contains(&d) {
            continue;
        }
        for last in pos.lasts(d) {
            let shapes: Vec<Shape> = pos.rest(last).into_iter().map(|s| world(d, s)).collect();
            rests.push((d, last, shapes));
        }
    }
    let mut out = Vec::new();
    let closest = |a: &[Shape], b: &[Shape]| -> Option<(Closest, Shape, Shape)> {
        let mut best: Option<(Closest, Shape, Shape)> = None;
        for &x in a {
            for &y in b {
                let c = x.closest(y);
                if best.as_ref().is_none_or(|b| c.distance < b.0.distance) {
                    best = Some((c, x, y));
                }
            }
        }
        best.filter(|b| b.0.distance < sep)
    };
    let rest_bounds: Vec<Option<(Vec3, Vec3)>> =
        rests.iter().map(|(_, _, s)| bounds(s, 0.0)).collect();
    // Keyed by the motion, then its moving others before its resting ones,
    // each in order: the order in which every pair used to be compared.
    let mut found: Vec<((usize, u8, usize), Candidate)> = Vec::new();
    overlapping(&leg_bounds, &leg_bounds, |m, n| {
        let (a, b) = (&pos.motions[m], &pos.motions[n]);
        if n <= m || a.drone == b.drone || !conc.get(prep.running[m], prep.running[n]) {
            return;
        }
        if let Some((c, x, y)) = closest(&legs[m], &legs[n]) {
            let candidate = Candidate {
                motion: m,
                other: Other::Moving(n),
                closest: c,
                shapes: (x, y),
            };
            found.push(((m, 0, n), candidate));
        }
    });
    overlapping(&leg_bounds, &rest_bounds, |m, r| {
        let (d, last, shapes) = &rests[r];
        if *d == pos.motions[m].drone {
            return;
        }
        if let Some((c, x, y)) = closest(&legs[m], shapes) {
            let candidate = Candidate {
                motion: m,
                other: Other::Resting(*d, *last),
                closest: c,
                shapes: (x, y),
            };
            found.push(((m, 1, r), candidate));
        }
    });
    found.sort_by_key(|(key, _)| *key);
    out.extend(found.into_iter().map(|(_, c)| c));
    out
}

/// Calls `pair(i, j)` for each box `i` of `a` and box `j` of `b` that
/// overlap, in no particular order: a sweep over both, sorted by their low
/// ends along the axis that tells them apart best. Comparing every leg with
/// every other was most of the check of a 200-drone mission; sweeping
/// along x compared them all again where drones fly lanes along x.
fn overlapping(
    a: &[Option<(Vec3, Vec3)>],
    b: &[Option<(Vec3, Vec3)>],
    mut pair: impl FnMut(usize, usize),
) {
    let axis = sweep_axis(a.iter().chain(b).flatten());
    let (lo, hi) = (
        |bx: &(Vec3, Vec3)| axis(bx.0),
        |bx: &(Vec3, Vec3)| axis(bx.1),
    );
    let by_low = |boxes: &[Option<(Vec3, Vec3)>]| {
        let mut order: Vec<(usize, (Vec3, Vec3))> = boxes
            .iter()
            .enumerate()
            .filter_map(|(i, bx)| bx.map(|bx| (i, bx)))
            .collect();
        order.sort_by(|x, y| lo(&x.1).total_cmp(&lo(&y.1)));
        order
    };
    let (sa, sb) = (by_low(a), by_low(b));
    // `b`'s boxes whose low end has been passed and whose high end has not.
    let mut open: Vec<(usize, (Vec3, Vec3))> = Vec::new();
    let mut next = 0;
    for &(i, ba) in &sa {
        while next < sb.len() && lo(&sb[next].1) <= hi(&ba) {
            open.push(sb[next]);
            next += 1;
        }
        open.retain(|(_, bb)| hi(bb) >= lo(&ba));
        for &(j, bb) in &open {
            if overlap(ba, bb) {
                pair(i, j);
            }
        }
    }
}

/// The axis along which boxes are shortest for the room they spread over:
/// the fewest of them overlap along it, so the fewest meet in a sweep.
fn sweep_axis<'b>(boxes: impl Iterator<Item = &'b (Vec3, Vec3)>) -> fn(Vec3) -> f64 {
    const AXES: [fn(Vec3) -> f64; 3] = [|v| v.x, |v| v.y, |v| v.z];
    let (mut low, mut high, mut length) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], [0.0; 3]);
    for bx in boxes {
        for (k, axis) in AXES.iter().enumerate() {
            low[k] = low[k].min(axis(bx.0));
            high[k] = high[k].max(axis(bx.1));
            length[k] += axis(bx.1) - axis(bx.0);
        }
    }
    let crowding = |k: usize| {
        let room = high[k] - low[k];
        if room > 0.0 {
            length[k] / room
        } else {
            f64::INFINITY
        }
    };
    (0..3)
        .min_by(|&i, &j| crowding(i).total_cmp(&crowding(j)))
        .map_or(AXES[0], |k| AXES[k])
}

/// The bounding box of shapes, grown by `margin`.
fn bounds(shapes: &[Shape], margin: f64) -> Option<(Vec3, Vec3)> {
    let mut it = shapes.iter().flat_map(|s| {
        let (a, b) = s.ends();
        [a, b]
    });
    let first = it.next()?;
    let (mut lo, mut hi) = (first, first);
    for p in it {
        lo = Vec3::new(lo.x.min(p.x), lo.y.min(p.y), lo.z.min(p.z));
        hi = Vec3::new(hi.x.max(p.x), hi.y.max(p.y), hi.z.max(p.z));
    }
    let g = Vec3::new(margin, margin, margin);
    Some((lo - g, hi + g))
}

fn overlap(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> bool {
    a.0.x <= b.1.x
        && b.0.x <= a.1.x
        && a.0.y <= b.1.y
        && b.0.y <= a.1.y
        && a.0.z <= b.1.z
        && b.0.z <= a.1.z
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn boxes() -> impl Strategy<Value = Vec<Option<(Vec3, Vec3)>>> {
        let corner = || (-20.0..20.0f64, -20.0..20.0f64, -5.0..5.0f64);
        let size = || (0.0..15.0f64, 0.0..15.0f64, 0.0..4.0f64);
        proptest::collection::vec(
            proptest::option::weighted(0.9, (corner(), size())).prop_map(|b| {
                b.map(|((x, y, z), (w, d, h))| (Vec3::new(x, y, z), Vec3::new(x + w, y + d, z + h)))
            }),
            0..40,
        )
    }

    /// Drones flying lanes along x, one beside the other along y: their
    /// legs' boxes all overlap along x and none along y, so the sweep goes
    /// along y; a climb in a column is swept along x.
    #[test]
    fn the_sweep_goes_along_the_axis_that_tells_the_boxes_apart() {
        let lane = |y: f64| {
            (
                Vec3::new(-30.0, y - 0.5, 1.0),
                Vec3::new(30.0, y + 0.5, 4.0),
            )
        };
        let lanes: Vec<_> = (0..10).map(|d| lane(3.0 * d as f64)).collect();
        assert_eq!(sweep_axis(lanes.iter())(Vec3::new(1.0, 2.0, 3.0)), 2.0);
        let column = |x: f64| (Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.5, 0.5, 40.0));
        let columns: Vec<_> = (0..10).map(|d| column(3.0 * d as f64)).collect();
        assert_eq!(sweep_axis(columns.iter())(Vec3::new(1.0, 2.0, 3.0)), 1.0);
    }

    proptest! {
        #[test]
        fn the_sweep_finds_exactly_the_pairs_of_boxes_that_overlap(a in boxes(), b in boxes()) {
            let mut swept = Vec::new();
            overlapping(&a, &b, |i, j| swept.push((i, j)));
            swept.sort_unstable();
            let mut every = Vec::new();
            for (i, x) in a.iter().enumerate() {
                for (j, y) in b.iter().enumerate() {
                    if let (Some(x), Some(y)) = (x, y) {
                        if overlap(*x, *y) {
                            every.push((i, j));
                        }
                    }
                }
            }
            prop_assert_eq!(swept, every);
        }
    }
}
