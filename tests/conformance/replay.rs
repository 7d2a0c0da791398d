//! Is an observed trace a trace of the global mission net? A search over
//! the reference token game (`eamos_petri::game`) for a firing sequence
//! whose visible firings are the observed events.
//!
//! - Visible firings are the net's `ActionStart`, `ActionEnd` and
//!   `ActionCancel`; one matches an observed event when the drone owning its
//!   action, the action's name, arguments and instance, the step and the
//!   binding colour are the observed ones. Every other transition is silent
//!   and may fire whenever the game lets it.
//! - The visible firings come in an order of the observed mission times:
//!   events of different times in time order; events of one time (a tie)
//!   in any order, but each drone's own in the order it emitted them.
//! - A condition guard takes the value the run observed: a guarded
//!   transition may fire with a colour exactly when a drone fired it with
//!   that colour. Colour guards (`RepeatFor`) are the game's own.
//! - `complete`: the whole trace is consumed and the game then reaches the
//!   final marking by silent firings.
//!
//! Why an order of mission times is one causality allows: every drone of a
//! one-process run reads the one simulated clock, which never goes back;
//! an event is stamped when its executor says it, a bridge token leaves
//! after the firing that sends it and arrives before the firing it
//! enables. So an event that causes another is never stamped later; two
//! of one stamp (the clock moves in simulation steps) may have happened
//! either way round. An end is the firing of `ActionEnd` (the drone's
//! `Fired` event), not the adapter's report, which comes before it and
//! alone proves nothing of the net; `trace.rs` checks that every end
//! follows such a report.

use std::collections::HashSet;

use eamos_petri::game::{self, Marking};
use eamos_petri::net::{Guard, Net, Transition, TransitionKind};

use super::trace::{ties, Observed, Seen, Step};

/// Markings the search may visit before it gives up (a failure: the trace
/// is not known to be one of the net).
const BUDGET: usize = 400_000;

/// Where the search is: the marking and how much of the trace it matched
/// (whole tie groups, then per drone how many of its events of the next).
#[derive(Clone, PartialEq, Eq, Hash)]
struct State {
    marking: Marking,
    group: usize,
    taken: Vec<u16>,
}

/// `Ok` when `observed` is a trace of `net` (a complete one if `complete`),
/// else why not: the furthest the search got and what it could not match.
pub fn conforms(net: &Net, observed: &Observed, complete: bool) -> Result<(), String> {
    let seen = &observed.seen;
    let groups = ties(seen);
    let drones = net.drones.clone();
    let mut oracle = |t: &Transition, _: &Guard, c: &[u32]| {
        observed.decided.contains(&(t.id.to_string(), c.to_vec()))
    };
    let start = State {
        marking: Marking::initial(net),
        group: 0,
        taken: vec![0; drones.len()],
    };
    let mut stack = vec![start.clone()];
    let mut visited: HashSet<State> = HashSet::from([start]);
    let mut furthest = 0usize;
    // What the drones showed next where the search got furthest.
    let mut expected: Vec<Seen> = Vec::new();
    while let Some(s) = stack.pop() {
        if visited.len() > BUDGET {
            return Err(format!(
                "gave up after {BUDGET} markings, {furthest} of {} events matched",
                seen.len()
            ));
        }
        let done: usize =
            s.group_start(&groups) + s.taken.iter().map(|&k| k as usize).sum::<usize>();
        if s.group == groups.len() && (!complete || s.marking.is_final(net)) {
            return Ok(());
        }
        let fresh = done > furthest || done == 0;
        furthest = furthest.max(done);
        // The next event each drone may show now.
        let next: Vec<&Seen> = match groups.get(s.group) {
            Some(g) => drones
                .iter()
                .enumerate()
                .filter_map(|(d, name)| {
                    seen[g.clone()]
                        .iter()
                        .filter(|e| &e.drone == name)
                        .nth(s.taken[d] as usize)
                })
                .collect(),
            None => Vec::new(),
        };
        if fresh {
            expected = next.iter().map(|e| (*e).clone()).collect();
        }
        for en in game::enabled(net, &s.marking, &mut oracle) {
            let t = net.transition(en.transition).expect("a transition");
            let after = |s: &State| -> Option<State> {
                let marking = game::fire(net, &s.marking, en.transition).ok()?;
                Some(State {
                    marking,
                    ..s.clone()
                })
            };
            let succ = match visible(net, &t.kind) {
                None => after(&s),
                Some((step, drone, a)) => next
                    .iter()
                    .find(|e| {
                        e.step == step
                            && e.drone == drone
                            && e.action == a.name
                            && e.args == a.args
                            && e.instance == a.instance
                            && e.colour == en.colour
                    })
                    .and_then(|e| {
                        let d = drones.iter().position(|n| *n == e.drone)?;
                        let mut n = after(&s)?;
                        n.taken[d] += 1;
                        n.advance(&groups, seen, &drones);
                        Some(n)
                    }),
            };
            if let Some(n) = succ {
                if visited.insert(n.clone()) {
                    stack.push(n);
                }
            }
        }
    }
    let stuck = if expected.is_empty() {
        "the final marking".to_string()
    } else {
        let each: Vec<String> = expected.iter().map(|e| format!("{e:?}")).collect();
        format!("any of\n  {}", each.join("\n  "))
    };
    Err(format!(
        "no firing sequence of the net shows the observed trace: {furthest} of {} events \
         matched at most, then none reaches {stuck}",
        seen.len()
    ))
}

/// The step, drone and action of a visible transition.
fn visible<'n>(
    net: &'n Net,
    kind: &'n TransitionKind,
) -> Option<(Step, &'n str, &'n eamos_petri::net::ActionRef)> {
    let (step, a) = match kind {
        TransitionKind::ActionStart(a) => (Step::Start, a),
        TransitionKind::ActionEnd(a) => (Step::End, a),
        TransitionKind::ActionCancel(a) => (Step::Cancel, a),
        _ => return None,
    };
    Some((step, net.drones[a.drone.0 as usize].as_str(), a))
}

impl State {
    fn group_start(&self, groups: &[std::ops::Range<usize>]) -> usize {
        groups
            .get(self.group)
            .map_or_else(|| groups.last().map_or(0, |g| g.end), |g| g.start)
    }

    /// Moves on to the next tie group once this one is all matched.
    fn advance(&mut self, groups: &[std::ops::Range<usize>], seen: &[Seen], drones: &[String]) {
        let g = &groups[self.group];
        let all = drones.iter().enumerate().all(|(d, name)| {
            seen[g.clone()].iter().filter(|e| &e.drone == name).count() == self.taken[d] as usize
        });
        if all {
            self.group += 1;
            self.taken.iter_mut().for_each(|k| *k = 0);
        }
    }
}
