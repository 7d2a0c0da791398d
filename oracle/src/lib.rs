//! The yardstick `eamos check` is held against: every reachable marking of
//! the reference token game (`eamos_petri::game`), visited one by one.
//!
//! The checker is clever (stubborn sets, the terminal-component proviso,
//! structural concurrency, a P/T skeleton with counter places, bit-packed
//! markings, rayon); this search is not. It shares nothing with the checker
//! but the net and the capability profiles, so that a mistake in any of the
//! checker's shortcuts shows up as a disagreement with it. It is meant for
//! tests: it stores every marking and every edge and gives up past a bound
//! ([`Answer::TooLarge`]) rather than run for long.
//!
//! # What it decides, and how guards are treated
//!
//! The game is played from the initial marking with the checker's own
//! abstraction of the world, built here from the net alone:
//!
//! * **Condition guards** (`If`, condition loops, waits, `Do`) may hold and
//!   may fail at every moment, each independently of the others and of its
//!   earlier answers: the game's guard oracle answers "holds" for every
//!   guarded transition whose tokens are there, so both sides of a choice
//!   are explored, as `check` explores them. The one exception is a guard
//!   that no sensor value can make true: `check` leaves its transition out
//!   (interval reasoning over the profiles' ranges). The caller says which
//!   guards those are (`may_hold`); the checker's reasoning is not used.
//! * **Colour guards** (`RepeatFor`) are decided by the game on the tokens'
//!   colours, exactly. Counters of condition loops grow without bound, so
//!   every counter is capped at the largest count any colour guard of the
//!   net compares with: a guard only asks whether the innermost counter is
//!   below its count, and capping commutes with every colour function
//!   (enter, next, leave, keep, plain), so the capped game has the same
//!   runs, guard by guard, and finitely many markings.
//! * **Time** does not exist: a `PauseFor` is a transition that may fire.
//!
//! Then:
//! * **deadlock**: a reachable marking in which nothing may fire and
//!   `final` is not marked, with a shortest firing sequence to it
//!   (breadth-first search); a dead marking with `final` and some other
//!   token is kept apart ([`Verdicts::unclean_end`]);
//! * **termination**: from every reachable marking some marking with `final`
//!   marked is reachable;
//! * **conflicts**: the running places of one drone whose actions exclude
//!   each other (its profile says so) marked together in some marking;
//! * **dead actions**: the `ActionStart` transitions that never fire;
//! * **1-safety**: a firing that would put a second token into a place (or
//!   a token of the wrong colour depth) ends the search with the run that
//!   leads there: the game cannot go on, and the net is broken.

use std::collections::{BTreeSet, HashMap, VecDeque};

use eamos_petri::game::{self, FireError, Firing, Marking};
use eamos_petri::net::{Guard, GuardKind, Net, NodeId, PlaceKind, Transition, TransitionKind};
use eamos_profile::ProfileTable;

/// What the search found.
#[derive(Debug, Clone)]
pub enum Answer {
    /// Every reachable marking was visited.
    Decided(Verdicts),
    /// A firing breaks the net's invariants; `run` leads to it, `error`
    /// says how. No other property is decided.
    Broken { run: Vec<Firing>, error: FireError },
    /// More than the bound of markings: nothing is decided.
    TooLarge { markings: usize },
}

/// The verdicts of a complete search.
#[derive(Debug, Clone, Default)]
pub struct Verdicts {
    /// Reachable markings (colours capped, see the crate documentation).
    pub markings: usize,
    /// A shortest run to a dead marking in which `final` is not marked: the
    /// mission is stuck before its end.
    pub deadlock: Option<Vec<Firing>>,
    /// A shortest run to a dead marking with `final` marked and some place
    /// other than an event's still marked: a token left behind at the end.
    /// The game calls it a deadlock ([`Marking::is_final`] does not hold),
    /// `check` does not (the end is reached). Compiled missions never get
    /// there, by construction; arbitrary nets may.
    pub unclean_end: Option<Vec<Firing>>,
    pub terminates: bool,
    /// Pairs of running places (smaller node first) of one drone whose
    /// actions exclude each other, marked together somewhere.
    pub conflicts: BTreeSet<(NodeId, NodeId)>,
    /// `ActionStart` transitions that fire somewhere.
    pub started: BTreeSet<NodeId>,
}

impl Answer {
    /// The verdicts, if the search decided them.
    pub fn decided(&self) -> Option<&Verdicts> {
        match self {
            Answer::Decided(v) => Some(v),
            _ => None,
        }
    }
}

/// Visits every reachable marking of `net`, at most `max_markings`.
/// `may_hold` answers, for a transition with a condition guard, whether any
/// sensor value could make that guard true (see the crate documentation);
/// `|_, _| true` unless a test built a guard that cannot hold.
pub fn search(
    net: &Net,
    profiles: &ProfileTable,
    may_hold: &mut dyn FnMut(&Transition, &Guard) -> bool,
    max_markings: usize,
) -> Answer {
    let cap = colour_cap(net);
    let capped = |m: Marking| m.map_colours(|c| c.iter().map(|&k| k.min(cap)).collect());
    let mut guards = |t: &Transition, g: &Guard, _: &[u32]| may_hold(t, g);

    let first = capped(Marking::initial(net));
    let mut index: HashMap<Marking, u32> = HashMap::from([(first.clone(), 0)]);
    let mut markings = vec![first];
    // How each marking was first reached: its parent and the firing.
    let mut reached_by: Vec<Option<(u32, Firing)>> = vec![None];
    let mut successors: Vec<Vec<u32>> = Vec::new();
    let mut stuck: Option<u32> = None;
    let mut unclean_end: Option<u32> = None;
    let mut v = Verdicts::default();
    let run_to = |reached_by: &[Option<(u32, Firing)>], mut m: u32| {
        let mut run = Vec::new();
        while let Some((parent, f)) = &reached_by[m as usize] {
            run.push(f.clone());
            m = *parent;
        }
        run.reverse();
        run
    };

    let mut queue = VecDeque::from([0u32]);
    while let Some(m) = queue.pop_front() {
        let marking = markings[m as usize].clone();
        v.conflicts.extend(conflicts(net, profiles, &marking));
        let enabled = game::enabled(net, &marking, &mut guards);
        if enabled.is_empty() && !marking.is_final(net) {
            let first = if marking.is_marked(net.final_place) {
                &mut unclean_end
            } else {
                &mut stuck
            };
            first.get_or_insert(m);
        }
        let mut next = Vec::with_capacity(enabled.len());
        for e in enabled {
            let after = match game::fire(net, &marking, e.transition) {
                Ok(after) => capped(after),
                Err(error) => {
                    let mut run = run_to(&reached_by, m);
                    run.push(e);
                    return Answer::Broken { run, error };
                }
            };
            if matches!(
                net.transition(e.transition).map(|t| &t.kind),
                Some(TransitionKind::ActionStart(_))
            ) {
                v.started.insert(e.transition);
            }
            let id = match index.get(&after) {
                Some(&id) => id,
                None => {
                    if markings.len() >= max_markings {
                        return Answer::TooLarge {
                            markings: markings.len(),
                        };
                    }
                    let id = markings.len() as u32;
                    index.insert(after.clone(), id);
                    markings.push(after);
                    reached_by.push(Some((m, e)));
                    queue.push_back(id);
                    id
                }
            };
            next.push(id);
        }
        successors.resize(m as usize + 1, Vec::new());
        successors[m as usize] = next;
    }
    successors.resize(markings.len(), Vec::new());

    v.markings = markings.len();
    v.deadlock = stuck.map(|d| run_to(&reached_by, d));
    v.unclean_end = unclean_end.map(|d| run_to(&reached_by, d));
    let ends = markings.iter().map(|m| m.is_marked(net.final_place));
    v.terminates = reaches_all(&successors, ends.collect());
    Answer::Decided(v)
}

/// The largest count a colour guard of the net compares a counter with:
/// above it, no guard tells two counters apart.
fn colour_cap(net: &Net) -> u32 {
    net.transitions()
        .filter_map(|(_, t)| match t.guard.as_ref()?.kind {
            GuardKind::IterationBelow(n) | GuardKind::IterationAtLeast(n) => Some(n),
            GuardKind::Cond { .. } => None,
        })
        .max()
        .unwrap_or(0)
}

/// Pairs of running places of one drone, both marked in `m`, whose actions
/// exclude each other in the drone's profile.
fn conflicts(net: &Net, profiles: &ProfileTable, m: &Marking) -> Vec<(NodeId, NodeId)> {
    let running: Vec<(NodeId, &eamos_petri::net::ActionRef)> = m
        .places()
        .filter_map(|p| match &net.place(p)?.kind {
            PlaceKind::Running(a) => Some((p, &**a)),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    for (i, (p, a)) in running.iter().enumerate() {
        for (q, b) in &running[i + 1..] {
            let profile = net
                .profiles
                .get(a.drone.0 as usize)
                .and_then(|name| profiles.get(name));
            if a.drone == b.drone && profile.is_some_and(|pr| pr.excludes(&a.name, &b.name)) {
                out.push((*p.min(q), *p.max(q)));
            }
        }
    }
    out
}

/// Whether every marking reaches one of the `ends` (by index), through the
/// successor lists: a backward search from the ends.
fn reaches_all(successors: &[Vec<u32>], ends: Vec<bool>) -> bool {
    let mut predecessors: Vec<Vec<u32>> = vec![Vec::new(); successors.len()];
    for (m, next) in successors.iter().enumerate() {
        for &n in next {
            predecessors[n as usize].push(m as u32);
        }
    }
    let mut reach = ends;
    let mut queue: VecDeque<u32> = (0..reach.len() as u32)
        .filter(|&m| reach[m as usize])
        .collect();
    while let Some(m) = queue.pop_front() {
        for &p in &predecessors[m as usize] {
            if !reach[p as usize] {
                reach[p as usize] = true;
                queue.push_back(p);
            }
        }
    }
    reach.iter().all(|&r| r)
}
