//! The token game the comparison plays: one net's transitions with packed
//! colours, what each shows when it fires, and which ones the reductions may
//! take first.

use eamos_petri::net::{ArcKind, ColourOp, Net};
use petgraph::visit::EdgeRef;
use petgraph::Direction;

use super::event::Label;
use super::Reductions;

/// A colour packed in a word: its length in the top byte, counter `i`
/// (outermost first) in byte `i`; bytes past the length are zero, so equal
/// colours are equal words and a longer colour is a greater word.
pub(super) type Colour = u64;
pub(super) type Marking = Box<[(u32, Colour)]>;

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

pub(super) fn unpack(c: Colour) -> Vec<u8> {
    (0..colour_len(c))
        .map(|i| ((c >> (8 * i)) & 0xff) as u8)
        .collect()
}

pub(super) enum Stop {
    Unsafe(String),
    Budget,
    TooDeep,
}

pub(super) struct T {
    pub id: String,
    pub consume: Vec<u32>,
    read: Vec<u32>,
    produce: Vec<(u32, ColourOp)>,
    below: Option<u32>,
    at_least: Option<u32>,
    pub label: Option<Label>,
    pub marks_final: bool,
    /// Silent, and the only consumer of each of its input places: it can
    /// neither be disabled nor disable anything, so it may fire at once.
    pub eager: bool,
    /// Silent, one input place consumed only by silent transitions like it
    /// (a free choice, such as a `RepeatFor` head): the choice may be made
    /// at once, before anything else.
    pub chooser: bool,
}

pub(super) struct Game {
    pub place_ids: Vec<String>,
    pub transitions: Vec<T>,
    /// Transitions that consume or read each place: only those of marked
    /// places can be enabled.
    pub users: Vec<Vec<u32>>,
    /// Transitions without input places: enabled in every marking.
    pub sources: Vec<u32>,
    cap: u8,
    pub final_place: u32,
    pub initial: Marking,
}

/// The smallest counter at which a colour guard changes its value.
fn colour_caps(net: &Net) -> u32 {
    net.transitions()
        .filter_map(|(_, t)| t.guard.as_ref())
        .filter_map(|g| {
            (0..=u8::MAX as u32).find(|&n| g.holds_on_colour(&[n]) != g.holds_on_colour(&[0]))
        })
        .max()
        .unwrap_or(0)
}

impl Game {
    pub fn of(net: &Net, reductions: Reductions) -> Game {
        let mut index = vec![u32::MAX; net.graph.node_count()];
        let mut place_ids = Vec::new();
        let mut final_place = u32::MAX;
        for (v, p) in net.places() {
            index[v.index()] = place_ids.len() as u32;
            if v == net.final_place {
                final_place = place_ids.len() as u32;
            }
            place_ids.push(p.id.to_string());
        }
        let cap = (colour_caps(net) + 1).clamp(2, 250) as u8;
        let silent = |u| {
            net.transition(u)
                .is_some_and(|t| Label::of(net, t).is_none())
        };
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
                let label = Label::of(net, t);
                let marks_final = produce.iter().any(|&(p, _)| p == final_place);
                let quiet = label.is_none() && !marks_final && read.is_empty();
                let sole = net
                    .preset(v)
                    .all(|p| net.graph.edges_directed(p, Direction::Outgoing).count() == 1);
                let eager = reductions.eager && quiet && !consume.is_empty() && sole;
                let chooser = reductions.free_choice
                    && quiet
                    && consume.len() == 1
                    && net.preset(v).all(|p| {
                        net.graph.edges_directed(p, Direction::Outgoing).all(|e| {
                            let u = e.target();
                            e.weight().kind == ArcKind::Consume
                                && silent(u)
                                && net.graph.edges_directed(u, Direction::Incoming).count() == 1
                                && !net.postset(u).any(|(q, _)| q == net.final_place)
                        })
                    });
                T {
                    id: t.id.to_string(),
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

    pub fn token(m: &Marking, p: u32) -> Option<&Colour> {
        m.binary_search_by_key(&p, |(q, _)| *q)
            .ok()
            .map(|i| &m[i].1)
    }

    /// The binding colour if `t` is enabled in `m`: the longest colour among
    /// the tokens it consumes or reads, as in the reference token game (the
    /// greatest on a tie, so the order of arcs does not matter).
    pub fn enabled(&self, m: &Marking, t: &T) -> Option<Colour> {
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
    pub fn fire(&self, m: &Marking, t: &T, colour: Colour) -> Result<Marking, Stop> {
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
