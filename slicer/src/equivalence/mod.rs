//! Do two nets show the same behaviour? Language equivalence of their
//! visible-event automata, decided on the fly by a subset construction over
//! both reachability graphs.
//!
//! # What is compared
//!
//! - **Visible events** ([`Event`]) say who does what: the start, end and
//!   cancel of every action instance with its drone, its action and its
//!   arguments, and the owner whose slice runs the step; every decision of a
//!   condition over drone state (a transition guarded by one), with the
//!   condition as the mission wrote it, whether it had to hold or fail, and
//!   the owner that evaluates it when it reads a drone; every timed step with
//!   its delay in seconds; `final` (a firing that marks the final place) and
//!   `deadlock` (a reachable marking where nothing can fire and the final
//!   place is empty). Each carries the colour of the firing (its loop
//!   counters). Everything else (forks, joins, merges, bridge deliveries,
//!   signals, colour-guarded loop steps) is silent. A transition's runner is
//!   its owner: in the mission net the compiler's, in a composition of
//!   slices ([`crate::compose`]) the slice it came from.
//! - **Guards are not evaluated**: a condition over drone state may hold or
//!   not at any moment, so a guarded transition may fire whenever its tokens
//!   are there, and its firing shows which way the condition went. Colour
//!   guards (`RepeatFor`'s counters) are decided exactly, since the net
//!   decides them itself. Delays are compared as values, not waited for.
//! - **Colours**: the binding colour of a firing is the longest colour among
//!   the tokens it consumes or reads (the greatest on a tie), as in petri's
//!   reference token game; loop counters saturate
//!   at a cap one above the largest count a colour guard tests, which keeps
//!   the state space finite while every colour guard still decides exactly.
//! - **Result**: when both state spaces fit the budget, the two sets of
//!   visible traces (prefix-closed, `deadlock` and `final` included, so
//!   completed runs are compared too) are equal or a shortest distinguishing
//!   trace is returned. When the budget runs out first, nothing is decided
//!   ([`Verdict::OutOfBudget`]).
//!
//! # Reductions
//!
//! A silent transition whose input places it alone consumes (no other
//! consumer, no reader, no read arcs of its own) is fired at once when
//! enabled: it can neither be disabled nor disable anything, so firing it
//! first changes no visible trace and no dead marking. Bridge deliveries,
//! forks and joins are such transitions, which is what keeps the composed
//! net's state space close to the mission net's.
//!
//! Likewise a *free choice*: a marked place whose consumers are all silent
//! transitions with that place as their only input and no read arc (the two
//! sides of a `RepeatFor` head, or of a merge nobody guards). Making the
//! choice first commutes with every other firing, so only the choice is
//! explored from such a marking. Every loop has a choice at its head that
//! may leave it, so no silent cycle hides a transition for ever.
//!
//! Both can be turned off ([`Reductions`], [`compare_with`]); the property
//! test `tests/reductions.rs` holds the reduced search against the plain one.

mod event;
mod game;
mod side;

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};

use eamos_petri::net::Net;

pub use event::{Event, Step};
use game::Stop;
use side::Side;

/// How much of the state spaces to explore at most.
#[derive(Debug, Clone, Copy)]
pub struct Budget {
    /// Pairs of determinised states (the product of the two subset
    /// constructions).
    pub pairs: usize,
    /// Markings of both nets together.
    pub markings: usize,
}

impl Default for Budget {
    fn default() -> Self {
        Budget {
            pairs: 10_000,
            markings: 40_000,
        }
    }
}

/// Which reductions the exploration may use. Both are on by default; the
/// property tests turn them off to hold the reduced search against the
/// plain one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reductions {
    /// Fire a silent transition that is the only consumer of its inputs at
    /// once, alone.
    pub eager: bool,
    /// Make a free choice first, alone.
    pub free_choice: bool,
}

impl Default for Reductions {
    fn default() -> Self {
        Reductions::ALL
    }
}

impl Reductions {
    pub const ALL: Reductions = Reductions {
        eager: true,
        free_choice: true,
    };
    pub const NONE: Reductions = Reductions {
        eager: false,
        free_choice: false,
    };
}

/// The outcome of a comparison.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// Both state spaces explored: the trace sets are equal.
    Equivalent { pairs: usize, longest: usize },
    /// The budget ran out: nothing is decided. Traces were found equal up
    /// to `depth` visible events, which proves nothing about longer ones.
    OutOfBudget {
        depth: usize,
        pairs: usize,
        markings: usize,
    },
    /// After `trace`, one net can show events the other cannot.
    Different {
        trace: Vec<Event>,
        only_left: Vec<Event>,
        only_right: Vec<Event>,
    },
    /// Loops nest deeper around one place than the explorer can count.
    TooDeep,
    /// A place received a second token: the net is not 1-safe.
    Unsafe {
        left: bool,
        place: String,
        trace: Vec<Event>,
    },
}

/// Compares the visible behaviour of two nets (see the module docs).
pub fn compare(left: &Net, right: &Net, budget: Budget) -> Verdict {
    compare_with(left, right, budget, Reductions::ALL)
}

/// [`compare`] with the reductions of one's choice.
pub fn compare_with(left: &Net, right: &Net, budget: Budget, reductions: Reductions) -> Verdict {
    let mut sides = [Side::new(left, reductions), Side::new(right, reductions)];
    let mut parents: Vec<(usize, Option<Event>)> = Vec::new();
    let mut depth_of: Vec<usize> = Vec::new();
    let trace = |parents: &Vec<(usize, Option<Event>)>, mut i: usize| {
        let mut t = Vec::new();
        while let (p, Some(e)) = &parents[i] {
            t.push(e.clone());
            i = *p;
        }
        t.reverse();
        t
    };
    let markings = |sides: &[Side; 2]| sides[0].markings.len() + sides[1].markings.len();
    let mut start = [0u32; 2];
    for k in 0..2 {
        let m = sides[k].game.initial.clone();
        let init = sides[k].intern(m);
        match sides[k].closure(vec![init], budget.markings) {
            Ok(m) => start[k] = m,
            Err(Stop::Unsafe(place)) => {
                return Verdict::Unsafe {
                    left: k == 0,
                    place,
                    trace: Vec::new(),
                }
            }
            Err(Stop::Budget) => {
                return Verdict::OutOfBudget {
                    depth: 0,
                    pairs: 0,
                    markings: markings(&sides),
                }
            }
            Err(Stop::TooDeep) => return Verdict::TooDeep,
        }
    }
    let mut visited: HashMap<(u32, u32), usize> = HashMap::new();
    let mut queue = VecDeque::new();
    visited.insert((start[0], start[1]), 0);
    parents.push((0, None));
    depth_of.push(0);
    queue.push_back(((start[0], start[1]), 0usize));
    let mut longest = 0;
    while let Some(((a, b), id)) = queue.pop_front() {
        let depth = depth_of[id];
        longest = longest.max(depth);
        let out_of_budget = |sides: &[Side; 2], pairs| Verdict::OutOfBudget {
            depth,
            pairs,
            markings: markings(sides),
        };
        if visited.len() > budget.pairs {
            return out_of_budget(&sides, visited.len());
        }
        let mut succ = [BTreeMap::new(), BTreeMap::new()];
        for (k, m) in [(0, a), (1, b)] {
            let room = budget.markings.saturating_sub(markings(&sides)) + sides[k].markings.len();
            match sides[k].macro_successors(m, room) {
                Ok(s) => succ[k] = s,
                Err(Stop::Unsafe(place)) => {
                    return Verdict::Unsafe {
                        left: k == 0,
                        place,
                        trace: trace(&parents, id),
                    }
                }
                Err(Stop::Budget) => return out_of_budget(&sides, visited.len()),
                Err(Stop::TooDeep) => return Verdict::TooDeep,
            }
        }
        let only_left: Vec<Event> = succ[0]
            .keys()
            .filter(|e| !succ[1].contains_key(e))
            .cloned()
            .collect();
        let only_right: Vec<Event> = succ[1]
            .keys()
            .filter(|e| !succ[0].contains_key(e))
            .cloned()
            .collect();
        if !only_left.is_empty() || !only_right.is_empty() {
            return Verdict::Different {
                trace: trace(&parents, id),
                only_left,
                only_right,
            };
        }
        for (e, &ma) in &succ[0] {
            let mb = succ[1][e];
            if let std::collections::hash_map::Entry::Vacant(v) = visited.entry((ma, mb)) {
                let nid = parents.len();
                v.insert(nid);
                parents.push((id, Some(e.clone())));
                depth_of.push(depth + 1);
                queue.push_back(((ma, mb), nid));
            }
        }
    }
    Verdict::Equivalent {
        pairs: visited.len(),
        longest,
    }
}

/// What a plain walk of one net's reachable markings found.
#[derive(Debug, Clone)]
pub struct Explored {
    /// Reachable markings, as the reduced search visits them.
    pub markings: usize,
    /// The ids of the transitions that fire in some run. Explored with the
    /// reductions, so every transition reported fires in a reachable
    /// marking; one the reductions never needed to fire may be missing.
    /// Mutation tests pick their sites among these, so that a mutant
    /// changes something a run does.
    pub fired: BTreeSet<String>,
}

/// Walks the markings of `net` that the comparison would visit; `None` when
/// there are more than `markings` (or the net is not 1-safe, or too deep).
pub fn explore(net: &Net, markings: usize) -> Option<Explored> {
    let mut side = Side::new(net, Reductions::ALL);
    let m = side.game.initial.clone();
    let init = side.intern(m);
    let mut fired = BTreeSet::new();
    let mut queue = vec![init];
    let mut seen = vec![true];
    while let Some(i) = queue.pop() {
        side.successors(i).ok()?;
        if side.markings.len() > markings {
            return None;
        }
        seen.resize(side.markings.len(), false);
        let succ = side.succ[i as usize].as_ref().expect("computed");
        let next = succ
            .silent
            .iter()
            .copied()
            .chain(succ.visible.iter().map(|(_, k, j)| (*k, *j)));
        for (k, j) in next {
            fired.insert(k);
            if !seen[j as usize] {
                seen[j as usize] = true;
                queue.push(j);
            }
        }
    }
    Some(Explored {
        markings: side.markings.len(),
        fired: fired
            .into_iter()
            .map(|k| side.game.transitions[k as usize].id.clone())
            .collect(),
    })
}
