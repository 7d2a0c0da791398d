//! Do two nets show the same behaviour? Language equivalence of their
//! visible-event automata, decided on the fly by a subset construction over
//! both reachability graphs.
//!
//! # What is compared
//!
//! - **Visible events**: the start, end and cancel of every action instance,
//!   with the colour of the firing (its loop counters), plus `final` (a
//!   firing that marks the final place) and `deadlock` (a reachable marking
//!   where nothing can fire and the final place is empty). Everything else
//!   (forks, joins, branches, bridge deliveries...) is silent.
//! - **Guards are abstracted**: a condition over drone state may hold or not
//!   at any moment, so a guarded transition may fire whenever its tokens are
//!   there. Colour guards (`RepeatFor`'s counters) are decided exactly, since
//!   the net decides them itself. Delays are ignored (untimed semantics).
//! - **Colours**: the binding colour of a firing is the longest colour among
//!   the tokens it consumes or reads (the greatest on a tie), as in petri's
//!   reference token game; loop counters saturate
//!   at a cap one above the largest count a colour guard tests, which keeps
//!   the state space finite while every colour guard still decides exactly.
//! - **Result**: when both state spaces fit the budget, the two sets of
//!   visible traces (prefix-closed, `deadlock` and `final` included, so
//!   completed runs are compared too) are equal or a shortest distinguishing
//!   trace is returned. When the budget runs out first, the traces are equal
//!   up to the reported number of visible events.
//!
//! # Reduction
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
//! sides of an `If` or of a loop head outside `Do` regions). Making the
//! choice first commutes with every other firing, so only the choice is
//! explored from such a marking. Every loop has a choice at its head that
//! may leave it, so no silent cycle hides a transition for ever.

use std::collections::{BTreeMap, HashMap, VecDeque};

use eamos_petri::net::{ArcKind, ColourOp, Net, TransitionKind};
use petgraph::visit::EdgeRef;
use petgraph::Direction;

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

/// A visible event.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Event {
    Start { instance: u32, colour: Vec<u8> },
    End { instance: u32, colour: Vec<u8> },
    Cancel { instance: u32, colour: Vec<u8> },
    Final,
    Deadlock,
}

impl std::fmt::Display for Event {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Event::Start { instance, colour } => write!(f, "start#{instance}{colour:?}"),
            Event::End { instance, colour } => write!(f, "end#{instance}{colour:?}"),
            Event::Cancel { instance, colour } => write!(f, "cancel#{instance}{colour:?}"),
            Event::Final => write!(f, "final"),
            Event::Deadlock => write!(f, "deadlock"),
        }
    }
}

/// The outcome of a comparison.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// Both state spaces explored: the trace sets are equal.
    Equivalent { pairs: usize, longest: usize },
    /// Budget reached: the traces agree up to `depth` visible events.
    EquivalentUpTo { depth: usize, pairs: usize },
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

/// A colour packed in a word: its length in the top byte, counter `i`
/// (outermost first) in byte `i`; bytes past the length are zero, so equal
/// colours are equal words and a longer colour is a greater word.
type Colour = u64;
type Marking = Box<[(u32, Colour)]>;

/// Loops nested deeper than this around one place are beyond the explorer.
const MAX_DEPTH: u64 = 7;

fn colour_len(c: Colour) -> u64 {
    c >> 56
}

fn innermost(c: Colour) -> u32 {
    match colour_len(c) {
        0 => 0,
        n => ((c >> (8 * (n - 1))) & 0xff) as u32,
    }
}

fn unpack(c: Colour) -> Vec<u8> {
    (0..colour_len(c))
        .map(|i| ((c >> (8 * i)) & 0xff) as u8)
        .collect()
}

struct T {
    consume: Vec<u32>,
    read: Vec<u32>,
    produce: Vec<(u32, ColourOp)>,
    below: Option<u32>,
    at_least: Option<u32>,
    label: Option<(u8, u32)>,
    marks_final: bool,
    eager: bool,
    /// Silent, one input place consumed only by silent transitions like it
    /// (a free choice, such as an `If` on a condition): the choice may be
    /// made at once, before anything else.
    chooser: bool,
}

struct Game {
    place_ids: Vec<String>,
    transitions: Vec<T>,
    /// Transitions that consume or read each place: only those of marked
    /// places can be enabled.
    users: Vec<Vec<u32>>,
    /// Transitions without input places: enabled in every marking.
    sources: Vec<u32>,
    cap: u8,
    final_place: u32,
    initial: Marking,
}

fn colour_caps(net: &Net) -> u32 {
    net.transitions()
        .filter_map(|(_, t)| t.guard.as_ref())
        .filter_map(|g| {
            // Probe the guard: the smallest counter at which it changes.
            (0..=u8::MAX as u32).find(|&n| g.holds_on_colour(&[n]) != g.holds_on_colour(&[0]))
        })
        .max()
        .unwrap_or(0)
}

impl Game {
    fn of(net: &Net) -> Game {
        let mut index = vec![u32::MAX; net.graph.node_count()];
        let mut place_ids = Vec::new();
        let mut final_place = u32::MAX;
        for (v, p) in net.places() {
            index[v.index()] = place_ids.len() as u32;
            if v == net.final_place {
                final_place = place_ids.len() as u32;
            }
            place_ids.push(p.id.clone());
        }
        let cap = (colour_caps(net) + 1).clamp(2, 250) as u8;
        let transitions: Vec<T> = net
            .transitions()
            .map(|(v, t)| {
                let mut consume = Vec::new();
                let mut read = Vec::new();
                for e in net.graph.edges_directed(v, Direction::Incoming) {
                    match e.weight().kind {
                        ArcKind::Consume => consume.push(index[e.source().index()]),
                        ArcKind::Read => read.push(index[e.source().index()]),
                        ArcKind::Produce => {}
                    }
                }
                let produce: Vec<(u32, ColourOp)> = net
                    .graph
                    .edges_directed(v, Direction::Outgoing)
                    .map(|e| (index[e.target().index()], e.weight().colour))
                    .collect();
                let (mut below, mut at_least) = (None, None);
                if let Some(g) = &t.guard {
                    if let Some(n) = (0..=u8::MAX as u32)
                        .find(|&n| g.holds_on_colour(&[n]) != g.holds_on_colour(&[0]))
                    {
                        if g.holds_on_colour(&[0]) == Some(true) {
                            below = Some(n);
                        } else {
                            at_least = Some(n);
                        }
                    } else if g.holds_on_colour(&[0]) == Some(false) {
                        at_least = Some(u32::MAX);
                    }
                }
                let label = match &t.kind {
                    TransitionKind::ActionStart(a) => Some((0, a.instance)),
                    TransitionKind::ActionEnd(a) => Some((1, a.instance)),
                    TransitionKind::ActionCancel(a) => Some((2, a.instance)),
                    _ => None,
                };
                let marks_final = produce.iter().any(|&(p, _)| p == final_place);
                let sole = net
                    .preset(v)
                    .all(|p| net.graph.edges_directed(p, Direction::Outgoing).count() == 1);
                let eager = label.is_none()
                    && !marks_final
                    && read.is_empty()
                    && !consume.is_empty()
                    && sole;
                let chooser = label.is_none()
                    && !marks_final
                    && read.is_empty()
                    && consume.len() == 1
                    && net.preset(v).all(|p| {
                        net.graph.edges_directed(p, Direction::Outgoing).all(|e| {
                            let u = e.target();
                            e.weight().kind == ArcKind::Consume
                                && net
                                    .transition(u)
                                    .is_some_and(|ut| ut.kind.action().is_none())
                                && net.graph.edges_directed(u, Direction::Incoming).count() == 1
                                && !net.postset(u).any(|(q, _)| q == net.final_place)
                        })
                    });
                T {
                    consume,
                    read,
                    produce,
                    below,
                    at_least,
                    label,
                    marks_final,
                    eager,
                    chooser,
                }
            })
            .collect();
        let mut users = vec![Vec::new(); place_ids.len()];
        for (k, t) in transitions.iter().enumerate() {
            for &p in t.consume.iter().chain(&t.read) {
                users[p as usize].push(k as u32);
            }
        }
        let sources = (0..transitions.len() as u32)
            .filter(|&k| {
                let t = &transitions[k as usize];
                t.consume.is_empty() && t.read.is_empty()
            })
            .collect();
        let mut initial: Vec<(u32, Colour)> = net
            .initial_marking
            .iter()
            .map(|&p| (index[p.index()], 0))
            .collect();
        initial.sort();
        initial.dedup();
        Game {
            place_ids,
            transitions,
            users,
            sources,
            cap,
            final_place,
            initial: initial.into_boxed_slice(),
        }
    }

    fn token(m: &Marking, p: u32) -> Option<&Colour> {
        m.binary_search_by_key(&p, |(q, _)| *q)
            .ok()
            .map(|i| &m[i].1)
    }

    /// The binding colour if `t` is enabled in `m`: the longest colour among
    /// the tokens it consumes or reads, as in the reference token game (the
    /// greatest on a tie, so the order of arcs does not matter).
    fn enabled(&self, m: &Marking, t: &T) -> Option<Colour> {
        let mut colour: Colour = 0;
        for &p in t.consume.iter().chain(&t.read) {
            colour = colour.max(*Self::token(m, p)?);
        }
        let innermost = innermost(colour);
        if t.below.is_some_and(|n| innermost >= n) || t.at_least.is_some_and(|n| innermost < n) {
            return None;
        }
        Some(colour)
    }

    fn apply(&self, op: ColourOp, c: Colour) -> Result<Colour, Stop> {
        let n = colour_len(c);
        Ok(match op {
            ColourOp::Keep => c,
            ColourOp::Enter if n >= MAX_DEPTH => return Err(Stop::TooDeep),
            ColourOp::Enter => (c & ((1 << 56) - 1)) | ((n + 1) << 56),
            ColourOp::Next if n == 0 => c,
            ColourOp::Next => {
                let shift = 8 * (n - 1);
                let v = ((c >> shift) & 0xff).saturating_add(1).min(self.cap as u64);
                (c & !(0xff << shift)) | (v << shift)
            }
            ColourOp::Leave if n == 0 => c,
            ColourOp::Leave => (c & !(0xff << (8 * (n - 1))) & ((1 << 56) - 1)) | ((n - 1) << 56),
            ColourOp::Plain => 0,
        })
    }

    /// Fires `t`; `Unsafe` if a place would hold two tokens.
    fn fire(&self, m: &Marking, t: &T, colour: Colour) -> Result<Marking, Stop> {
        let mut next: Vec<(u32, Colour)> = m
            .iter()
            .filter(|(p, _)| !t.consume.contains(p))
            .copied()
            .collect();
        for &(p, op) in &t.produce {
            if next.iter().any(|(q, _)| *q == p) {
                return Err(Stop::Unsafe(self.place_ids[p as usize].clone()));
            }
            next.push((p, self.apply(op, colour)?));
        }
        next.sort_unstable();
        Ok(next.into_boxed_slice())
    }
}

struct Succ {
    silent: Vec<u32>,
    visible: Vec<(Event, u32)>,
    dead: bool,
}

/// One net's markings and determinised states, explored lazily.
struct Side {
    game: Game,
    ids: HashMap<Marking, u32>,
    markings: Vec<Marking>,
    succ: Vec<Option<Succ>>,
    macros: HashMap<Vec<u32>, u32>,
    macro_sets: Vec<Vec<u32>>,
    macro_succ: Vec<Option<BTreeMap<Event, u32>>>,
}

enum Stop {
    Unsafe(String),
    Budget,
    TooDeep,
}

impl Side {
    fn new(net: &Net) -> Side {
        Side {
            game: Game::of(net),
            ids: HashMap::new(),
            markings: Vec::new(),
            succ: Vec::new(),
            macros: HashMap::new(),
            macro_sets: Vec::new(),
            macro_succ: Vec::new(),
        }
    }

    fn intern(&mut self, m: Marking) -> u32 {
        if let Some(&i) = self.ids.get(&m) {
            return i;
        }
        let i = self.markings.len() as u32;
        self.ids.insert(m.clone(), i);
        self.markings.push(m);
        self.succ.push(None);
        i
    }

    fn successors(&mut self, i: u32) -> Result<(), Stop> {
        if self.succ[i as usize].is_some() {
            return Ok(());
        }
        let m = self.markings[i as usize].clone();
        let mut silent = Vec::new();
        let mut visible = Vec::new();
        let mut any = false;
        let mut candidates: Vec<usize> = m
            .iter()
            .flat_map(|(p, _)| self.game.users[*p as usize].iter().map(|&k| k as usize))
            .chain(self.game.sources.iter().map(|&k| k as usize))
            .collect();
        candidates.sort_unstable();
        candidates.dedup();
        let eager = candidates.iter().copied().find(|&k| {
            self.game.transitions[k].eager
                && self.game.enabled(&m, &self.game.transitions[k]).is_some()
        });
        // A free choice: every transition that could take the token of one
        // place, and nothing else; the others wait until it is made.
        let choice = || {
            let k = candidates.iter().copied().find(|&k| {
                let t = &self.game.transitions[k];
                t.chooser && self.game.enabled(&m, t).is_some()
            })?;
            let p = self.game.transitions[k].consume[0];
            Some(
                self.game.users[p as usize]
                    .iter()
                    .map(|&k| k as usize)
                    .collect::<Vec<usize>>(),
            )
        };
        let chosen: Vec<usize> = match eager {
            Some(k) => vec![k],
            None => choice().unwrap_or_else(|| candidates.clone()),
        };
        for k in chosen {
            let t = &self.game.transitions[k];
            let Some(colour) = self.game.enabled(&m, t) else {
                continue;
            };
            any = true;
            let next = self.game.fire(&m, t, colour)?;
            let event = match t.label {
                Some((0, instance)) => Some(Event::Start {
                    instance,
                    colour: unpack(colour),
                }),
                Some((1, instance)) => Some(Event::End {
                    instance,
                    colour: unpack(colour),
                }),
                Some((_, instance)) => Some(Event::Cancel {
                    instance,
                    colour: unpack(colour),
                }),
                None if t.marks_final => Some(Event::Final),
                None => None,
            };
            let j = self.intern(next);
            match event {
                Some(e) => visible.push((e, j)),
                None => silent.push(j),
            }
        }
        let final_marked = Game::token(&m, self.game.final_place).is_some();
        self.succ[i as usize] = Some(Succ {
            silent,
            visible,
            dead: !any && !final_marked,
        });
        Ok(())
    }

    /// The determinised state of a set of markings: their silent closure.
    fn closure(&mut self, seeds: Vec<u32>, budget: usize) -> Result<u32, Stop> {
        let mut seen: Vec<u32> = Vec::new();
        let mut stack = seeds;
        let mut mark = std::collections::HashSet::new();
        while let Some(i) = stack.pop() {
            if !mark.insert(i) {
                continue;
            }
            seen.push(i);
            self.successors(i)?;
            if self.markings.len() > budget {
                return Err(Stop::Budget);
            }
            stack.extend(
                self.succ[i as usize]
                    .as_ref()
                    .expect("computed")
                    .silent
                    .iter()
                    .copied(),
            );
        }
        seen.sort_unstable();
        if let Some(&k) = self.macros.get(&seen) {
            return Ok(k);
        }
        let k = self.macro_sets.len() as u32;
        self.macros.insert(seen.clone(), k);
        self.macro_sets.push(seen);
        self.macro_succ.push(None);
        Ok(k)
    }

    fn macro_successors(&mut self, k: u32, budget: usize) -> Result<BTreeMap<Event, u32>, Stop> {
        if let Some(s) = &self.macro_succ[k as usize] {
            return Ok(s.clone());
        }
        let mut seeds: BTreeMap<Event, Vec<u32>> = BTreeMap::new();
        let mut dead = false;
        for &i in &self.macro_sets[k as usize].clone() {
            let s = self.succ[i as usize]
                .as_ref()
                .expect("closed states are expanded");
            dead |= s.dead;
            for (e, j) in &s.visible {
                seeds.entry(e.clone()).or_default().push(*j);
            }
        }
        let mut out = BTreeMap::new();
        for (e, s) in seeds {
            let m = self.closure(s, budget)?;
            out.insert(e, m);
        }
        if dead {
            let m = self.closure(Vec::new(), budget)?;
            out.insert(Event::Deadlock, m);
        }
        self.macro_succ[k as usize] = Some(out.clone());
        Ok(out)
    }
}

/// Compares the visible behaviour of two nets (see the module docs).
pub fn compare(left: &Net, right: &Net, budget: Budget) -> Verdict {
    let mut sides = [Side::new(left), Side::new(right)];
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
    let init: Vec<u32> = sides
        .iter_mut()
        .map(|s| {
            let m = s.game.initial.clone();
            s.intern(m)
        })
        .collect();
    let mut start = [0u32; 2];
    for k in 0..2 {
        match sides[k].closure(vec![init[k]], budget.markings) {
            Ok(m) => start[k] = m,
            Err(Stop::Unsafe(place)) => {
                return Verdict::Unsafe {
                    left: k == 0,
                    place,
                    trace: Vec::new(),
                }
            }
            Err(Stop::Budget) => return Verdict::EquivalentUpTo { depth: 0, pairs: 0 },
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
        if visited.len() > budget.pairs {
            return Verdict::EquivalentUpTo {
                depth,
                pairs: visited.len(),
            };
        }
        let mut succ = [BTreeMap::new(), BTreeMap::new()];
        for (k, m) in [(0, a), (1, b)] {
            let total = sides[0].markings.len() + sides[1].markings.len();
            let room = budget.markings.saturating_sub(total) + sides[k].markings.len();
            match sides[k].macro_successors(m, room) {
                Ok(s) => succ[k] = s,
                Err(Stop::Unsafe(place)) => {
                    return Verdict::Unsafe {
                        left: k == 0,
                        place,
                        trace: trace(&parents, id),
                    }
                }
                Err(Stop::Budget) => {
                    return Verdict::EquivalentUpTo {
                        depth,
                        pairs: visited.len(),
                    }
                }
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
