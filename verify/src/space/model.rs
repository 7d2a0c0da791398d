//! Where every drone can be, leg by leg: the analysis the spatial
//! properties stand on.
//!
//! Per drone, the motions it flies (actions whose profile declares a
//! `motion`) in the order its control flow allows ([`crate::space::walk`]):
//! from home, each motion's possible starts are the possible ends of the
//! motions that can come just before it, so relative moves (`FlyByX`) are
//! followed from where the drone really is on every branch and through
//! every loop. Loop rounds of a `RepeatFor` are told apart by the token's
//! colour; a loop that never brings the drone back (a net displacement per
//! round, under a condition) would add new starts for ever: past
//! [`MAX_STARTS`] at one step the drone is said to drift.

use std::cell::Cell;
use std::collections::{BTreeSet, VecDeque};

// Walks and starts are looked up by the thousand: Fx, as in `walk.rs`.
use rustc_hash::FxHashMap as HashMap;

use eamos_geo::Vec3;
use eamos_lang::Span;
use eamos_petri::net::{ActionRef, Colour, GuardKind, Net, NodeId, PlaceKind, TransitionKind};
use eamos_profile::{ActionSig, ProfileTable, ValueType};

use crate::conditions::{possibility, Domain, Possibility};

use super::shape::Shape;
use super::walk::{OutOfBudget, Walker};

/// More distinct starts than this at one step of one round: a drift.
pub(crate) const MAX_STARTS: usize = 1024;

/// Steps of all walks together before the analysis gives up.
pub(crate) const WALK_BUDGET: usize = 40_000_000;

/// One action instance of a drone that the analyses track.
#[derive(Debug, Clone)]
pub(crate) struct Tracked {
    pub drone: u16,
    pub running: NodeId,
    pub action: ActionRef,
    pub sig: ActionSig,
    pub span: Span,
    pub starts: Vec<NodeId>,
    pub ends: Vec<NodeId>,
    pub cancels: Vec<NodeId>,
}

/// The actions of a net whose profile entry `keep` selects, with their
/// transitions.
pub(crate) fn tracked(
    net: &Net,
    profiles: &ProfileTable,
    keep: impl Fn(&ActionSig) -> bool,
) -> Vec<Tracked> {
    let mut out = Vec::new();
    for (r, p) in net.places() {
        let PlaceKind::Running(a) = &p.kind else {
            continue;
        };
        let Some(sig) = net
            .profiles
            .get(a.drone.0 as usize)
            .and_then(|name| profiles.get(name))
            .and_then(|profile| profile.actions.get(a.name.as_str()))
        else {
            continue;
        };
        if !keep(sig) {
            continue;
        }
        let mut t = Tracked {
            drone: a.drone.0,
            running: r,
            action: ActionRef::clone(a),
            sig: sig.clone(),
            span: p.span.unwrap_or_default(),
            starts: net.producers(r).collect(),
            ends: Vec::new(),
            cancels: Vec::new(),
        };
        for (c, _) in net.consumers(r) {
            match net.transition(c).map(|t| &t.kind) {
                Some(TransitionKind::ActionCancel(_)) => t.cancels.push(c),
                _ => t.ends.push(c),
            }
        }
        if t.span == Span::default() {
            if let Some(s) = t.starts.first().and_then(|&s| net.transition(s)) {
                t.span = s.span;
            }
        }
        out.push(t);
    }
    out
}

/// What a drone rests at before a motion starts: its home, the end of a
/// motion, or somewhere on a motion that was cancelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) enum Last {
    Home,
    End(usize),
    Cancel(usize),
}

/// One way a motion can be flown.
#[derive(Debug, Clone)]
pub(crate) struct Leg {
    pub sweep: Shape,
    /// Loop rounds around it (outermost first), counted from 0.
    pub colour: Colour,
}

/// A motion whose starts keep moving round after round.
#[derive(Debug, Clone)]
pub(crate) struct Drift {
    pub motion: usize,
    /// The loop rounds of the step that drifts: empty after the loop.
    pub colour: Colour,
    /// Its first starts, in the order they were found.
    pub starts: Vec<Shape>,
}

/// Where every drone can be.
#[derive(Debug, Default)]
pub(crate) struct Positions {
    pub motions: Vec<Tracked>,
    pub legs: Vec<Vec<Leg>>,
    /// Per motion: where the drone rests after it (ended; cancelled).
    pub ends: Vec<Vec<Shape>>,
    pub stops: Vec<Vec<Shape>>,
    /// Per motion: what the drone can rest at just before it starts.
    pub preds: Vec<BTreeSet<Last>>,
    pub drifts: Vec<Drift>,
    /// Loop rounds below this are told apart; at it, they are not.
    pub exact_rounds: u32,
}

impl Positions {
    /// The shapes a drone rests in when its last motion was `last`.
    pub(crate) fn rest(&self, last: Last) -> Vec<Shape> {
        match last {
            Last::Home => vec![Shape::point(Vec3::ZERO)],
            Last::End(m) => self.ends[m].clone(),
            Last::Cancel(m) => self.stops[m].clone(),
        }
    }

    /// Every rest of a drone (home, ends, stops), once each.
    pub(crate) fn lasts(&self, drone: u16) -> Vec<Last> {
        let mut out = vec![Last::Home];
        for (m, t) in self.motions.iter().enumerate() {
            if t.drone == drone {
                out.push(Last::End(m));
                if !t.cancels.is_empty() {
                    out.push(Last::Cancel(m));
                }
            }
        }
        out
    }
}

/// Follows every drone's motions from home.
pub(crate) fn positions(
    net: &Net,
    profiles: &ProfileTable,
    walker: &Walker,
) -> Result<Positions, OutOfBudget> {
    // Rounds are told apart up to the explorer's own bound; past it the
    // legs of a loop are not followed (the check says which loop).
    let counted_too_far = net.transitions().any(|(_, t)| {
        matches!(
            t.guard.as_ref().map(|g| &g.kind),
            Some(GuardKind::IterationBelow(n)) | Some(GuardKind::IterationAtLeast(n))
                if *n > crate::ptnet::MAX_COUNTED_ROUNDS
        )
    });
    if counted_too_far {
        return Err(OutOfBudget);
    }
    let motions = tracked(net, profiles, |sig| sig.motion.is_some());
    let mut start_of: HashMap<NodeId, usize> = HashMap::default();
    for (m, t) in motions.iter().enumerate() {
        for &s in &t.starts {
            start_of.insert(s, m);
        }
    }
    let n = motions.len();
    let mut out = Positions {
        legs: vec![Vec::new(); n],
        ends: vec![Vec::new(); n],
        stops: vec![Vec::new(); n],
        preds: vec![BTreeSet::new(); n],
        ..Positions::default()
    };
    let mut budget = WALK_BUDGET;
    let mut work: VecDeque<(usize, Colour, Shape, Last)> = VecDeque::new();
    let mut unblocked = Unblocked::default();
    let drones: BTreeSet<u16> = motions.iter().map(|t| t.drone).collect();
    for &d in &drones {
        let stop = |t: NodeId| start_of.get(&t).is_some_and(|&m| motions[m].drone == d);
        let home = Shape::point(Vec3::ZERO);
        let said_no = Cell::new(false);
        let blocked = |t: NodeId| noted(&said_no, decided_false(net, profiles, t, d, home));
        let reach = walker.walk(
            walker.initial(),
            Some(d),
            &stop,
            true,
            &blocked,
            None,
            &mut budget,
        )?;
        if !said_no.get() {
            unblocked.from_home.insert(d, reach.stops.clone());
        }
        for (t, c) in reach.stops {
            work.push_back((start_of[&t], c, Shape::point(Vec3::ZERO), Last::Home));
        }
    }
    type Next = Vec<(usize, Colour)>;
    let mut next: HashMap<(usize, Colour, bool, [i64; 7]), Next> = HashMap::default();
    type Starts = (BTreeSet<[i64; 7]>, Vec<Shape>);
    let mut starts: HashMap<(usize, Colour), Starts> = HashMap::default();
    let mut ends_seen: Vec<BTreeSet<[i64; 7]>> = vec![BTreeSet::new(); n];
    let mut stops_seen: Vec<BTreeSet<[i64; 7]>> = vec![BTreeSet::new(); n];
    let mut drifting: BTreeSet<(usize, Colour)> = BTreeSet::new();
    while let Some((m, c, s, _)) = work.pop_front() {
        let entry = starts.entry((m, c.clone())).or_default();
        if entry.0.contains(&s.key()) {
            continue;
        }
        if entry.1.len() >= MAX_STARTS {
            if drifting.insert((m, c.clone())) {
                out.drifts.push(Drift {
                    motion: m,
                    colour: c.clone(),
                    starts: entry.1.clone(),
                });
            }
            continue;
        }
        entry.0.insert(s.key());
        entry.1.push(s);
        let t = &motions[m];
        let (end, sweep) = s.fly(&t.sig, &t.action.args).unwrap_or((s, s));
        out.legs[m].push(Leg {
            sweep,
            colour: c.clone(),
        });
        if ends_seen[m].insert(end.key()) {
            out.ends[m].push(end);
        }
        let d = t.drone;
        let stop = |t: NodeId| start_of.get(&t).is_some_and(|&m| motions[m].drone == d);
        for cancel in [false, true] {
            let via = if cancel { &t.cancels } else { &t.ends };
            if via.is_empty() {
                continue;
            }
            let at = if cancel { sweep.stopped_on() } else { end };
            let key = (m, c.clone(), cancel, at.key());
            if !next.contains_key(&key) {
                let said_no = Cell::new(false);
                let blocked = |t: NodeId| noted(&said_no, decided_false(net, profiles, t, d, at));
                let reach = walker.walk_after(
                    via,
                    &c,
                    cancel,
                    Some(d),
                    &stop,
                    true,
                    &blocked,
                    &mut budget,
                )?;
                if !said_no.get() {
                    let after = (m, c.clone(), cancel);
                    unblocked.after.insert(after, reach.stops.clone());
                }
                let list = reach
                    .stops
                    .into_iter()
                    .map(|(t, c)| (start_of[&t], c))
                    .collect();
                next.insert(key.clone(), list);
            }
            let (rest, last) = if cancel {
                let rest = sweep.stopped_on();
                if stops_seen[m].insert(rest.key()) {
                    out.stops[m].push(rest);
                }
                (rest, Last::Cancel(m))
            } else {
                (end, Last::End(m))
            };
            for (m2, c2) in &next[&key] {
                work.push_back((*m2, c2.clone(), rest, last));
            }
        }
    }
    out.preds = preds(walker, &motions, &start_of, &unblocked, &mut budget)?;
    out.exact_rounds = walker.cap();
    out.motions = motions;
    Ok(out)
}

/// Where walks that no guard stopped came to (the stops and their
/// colours): the same walks with every guard free to hold go the same way,
/// and `preds` takes them from here rather than walking them again.
#[derive(Default)]
struct Unblocked {
    /// By drone, from the start of the mission.
    from_home: HashMap<u16, Vec<(NodeId, Colour)>>,
    /// By motion, round and whether it was cancelled, from its end.
    after: HashMap<(usize, Colour, bool), Vec<(NodeId, Colour)>>,
}

/// `no`, noted in `said_no` if true.
fn noted(said_no: &Cell<bool>, no: bool) -> bool {
    said_no.set(said_no.get() || no);
    no
}

/// What each motion can start from, as the checker's exploration sees the
/// net: every guard may hold or not. (The positions above decide some
/// guards on where the drone is; the rests the exploration records must
/// cover every path it can take, or it would find a drone stuck where no
/// drone is.)
fn preds(
    walker: &Walker,
    motions: &[Tracked],
    start_of: &HashMap<NodeId, usize>,
    unblocked: &Unblocked,
    budget: &mut usize,
) -> Result<Vec<BTreeSet<Last>>, OutOfBudget> {
    let mut preds = vec![BTreeSet::new(); motions.len()];
    let mut seen: BTreeSet<(usize, Colour)> = BTreeSet::new();
    let mut work: Vec<(usize, Colour)> = Vec::new();
    let drones: BTreeSet<u16> = motions.iter().map(|t| t.drone).collect();
    for &d in &drones {
        let stop = |t: NodeId| start_of.get(&t).is_some_and(|&m| motions[m].drone == d);
        let stops = match unblocked.from_home.get(&d) {
            Some(stops) => stops.clone(),
            None => {
                let seeds = walker.initial();
                walker
                    .walk(seeds, Some(d), &stop, true, &|_| false, None, budget)?
                    .stops
            }
        };
        for (t, c) in stops {
            preds[start_of[&t]].insert(Last::Home);
            work.push((start_of[&t], c));
        }
    }
    while let Some((m, c)) = work.pop() {
        if !seen.insert((m, c.clone())) {
            continue;
        }
        let t = &motions[m];
        let d = t.drone;
        let stop = |t: NodeId| start_of.get(&t).is_some_and(|&m| motions[m].drone == d);
        for (via, last, cancel) in [
            (&t.ends, Last::End(m), false),
            (&t.cancels, Last::Cancel(m), true),
        ] {
            if via.is_empty() {
                continue;
            }
            let stops = match unblocked.after.get(&(m, c.clone(), cancel)) {
                Some(stops) => stops.clone(),
                None => {
                    walker
                        .walk_after(via, &c, cancel, Some(d), &stop, true, &|_| false, budget)?
                        .stops
                }
            };
            for (t2, c2) in stops {
                preds[start_of[&t2]].insert(last);
                work.push((start_of[&t2], c2));
            }
        }
    }
    Ok(preds)
}

/// How far from where a leg ends a drone may really stop (the simulator
/// arrives within 0.3 m; autopilots within their own radius): a guard on
/// the drone's own position is decided only if it is decided all over
/// this far around.
pub(crate) const ARRIVAL: f64 = 0.5;

/// Whether transition `t`, whose guard reads only `drone`'s own state,
/// cannot fire with the drone resting at `at`.
fn decided_false(net: &Net, profiles: &ProfileTable, t: NodeId, drone: u16, at: Shape) -> bool {
    let Some(tr) = net.transition(t) else {
        return false;
    };
    let Some((cond, negated)) = tr.guard.as_ref().and_then(|g| g.condition()) else {
        return false;
    };
    // Wherever it is evaluated, the guard reads the drone between two of
    // its motions (the walk stops at the next), so where it rests. A drone
    // flying two legs at once breaks this, and the conflicts say so.
    if cond.drones().iter().any(|d| d.0 != drone) {
        return false;
    }
    // Where the drone rests: a point, or anywhere in a box after a
    // cancelled leg.
    let (p, q) = at.ends();
    let profile = net
        .profiles
        .get(drone as usize)
        .and_then(|name| profiles.get(name));
    let domain = |d: eamos_lang::hir::DroneId, name: &str| -> Option<Domain> {
        let (lo, hi) = match name {
            "X" => (p.x.min(q.x), p.x.max(q.x)),
            "Y" => (p.y.min(q.y), p.y.max(q.y)),
            "Z" => (p.z.min(q.z), p.z.max(q.z)),
            _ => {
                let sig = profile?.properties.get(name)?;
                return match sig.ty {
                    ValueType::Bool => Some(Domain { lo: 0.0, hi: 1.0 }),
                    ValueType::Number => sig.range.map(|(lo, hi)| Domain { lo, hi }),
                };
            }
        };
        (d.0 == drone).then_some(Domain {
            lo: lo - ARRIVAL,
            hi: hi + ARRIVAL,
        })
    };
    matches!(
        (possibility(cond, &domain), negated),
        (Possibility::NeverHolds, false) | (Possibility::AlwaysHolds, true)
    )
}
