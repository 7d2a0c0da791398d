//! The compact form of a net that exploration works on.
//!
//! Exploration fires millions of transitions, so it cannot chase petgraph
//! edges: places and transitions get dense indices, every arc list is a slice
//! of one flat array, and the lists a stubborn-set closure needs (who
//! consumes, reads or produces a place; which transitions conflict with one)
//! are computed once here.
//!
//! Besides the transitions of the net the compact form holds *monitors*:
//! pseudo-transitions that only read places and are never fired. A monitor is
//! enabled exactly in the markings a property wants to find (two running
//! places of one drone both marked; a transition able to fire into a marked
//! place), so looking for such a marking becomes asking whether a transition
//! can ever be enabled, which stubborn sets with the terminal-component proviso preserve
//! (see [`crate::explore`]).

use eamos_lang::Span;
use eamos_petri::name::Name;

/// Above this many rounds a `RepeatFor` is not explored. Its counter is
/// explored exactly (one marking per round, see the module doc), with one
/// place and one copy of the guarded steps per round, so time and memory
/// grow with the square of the count: with a one-action body, a debug build
/// took 0.2 s for 250 rounds, 3.5 s and 75 MB for 1,000, 395 s and 5.4 GB
/// for 10,000; a billion would run for hours into the memory bound. A count
/// is no reason to unroll that many states, so instead of a partial
/// exploration the check says at once which loop is too large. (Loops
/// nested in loops multiply their rounds; the memory bound still stops
/// those.)
pub(crate) const MAX_COUNTED_ROUNDS: u32 = 1_000;

/// A list of lists stored flat: `items[offsets[i]..offsets[i + 1]]` is list `i`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Csr<T> {
    offsets: Vec<u32>,
    items: Vec<T>,
}

impl<T: Clone> Csr<T> {
    pub(crate) fn from_lists(lists: &[Vec<T>]) -> Self {
        let mut offsets = Vec::with_capacity(lists.len() + 1);
        let mut items = Vec::new();
        offsets.push(0);
        for l in lists {
            items.extend(l.iter().cloned());
            offsets.push(items.len() as u32);
        }
        Csr { offsets, items }
    }
}

impl<T: Copy + Default> Csr<T> {
    /// `n` lists from `(list, item)` pairs, each list's items in the
    /// pairs' order: a counting sort, no list of its own per list.
    pub(crate) fn from_pairs(n: usize, pairs: &[(u32, T)]) -> Self {
        let mut offsets = vec![0u32; n + 1];
        for &(i, _) in pairs {
            offsets[i as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut items = vec![T::default(); pairs.len()];
        for &(i, item) in pairs {
            items[fill[i as usize] as usize] = item;
            fill[i as usize] += 1;
        }
        Csr { offsets, items }
    }
}

impl<T> Csr<T> {
    /// Appends a list.
    pub(crate) fn push(&mut self, list: impl IntoIterator<Item = T>) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.items.extend(list);
        self.offsets.push(self.items.len() as u32);
    }

    /// Keeps the first `n` lists.
    pub(crate) fn truncate(&mut self, n: usize) {
        if let Some(&end) = self.offsets.get(n) {
            self.items.truncate(end as usize);
            self.offsets.truncate(n + 1);
        }
    }

    /// How many lists.
    pub(crate) fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    #[inline]
    pub(crate) fn get(&self, i: usize) -> &[T] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// List `i`, or none where fewer lists were made (none, in a default
    /// `Csr`).
    #[inline]
    pub(crate) fn get_or_none(&self, i: usize) -> &[T] {
        if i + 1 < self.offsets.len() {
            self.get(i)
        } else {
            &[]
        }
    }
}

/// What a transition is, in the words a person reads in a counterexample.
/// Its texts are shared [`Name`]s: the net's own ids and labels, not
/// copies of them, and a copy of the whole net (with monitors, with the
/// spatial model's steps) shares them again.
#[derive(Debug, Clone, PartialEq)]
pub struct StepInfo {
    /// Stable id of the transition in the net (`t42`) or the PNML file.
    pub id: Name,
    /// Its label (or PNML name).
    pub label: Name,
    /// The kind of step, in the net's terms (`ActionStart`, `Branch`, ...).
    pub kind: Name,
    /// What a person reads: `D1.FlyByX(0.2) starts`.
    pub text: Name,
    /// Forks, joins and other plumbing that only matters to tools.
    pub internal: bool,
    pub span: Option<Span>,
    /// For a guarded transition: the condition's span and whether the step
    /// means that the condition held (`true`) or did not (`false`).
    pub guard: Option<(Span, bool)>,
}

/// What a place is, for naming it in findings.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaceInfo {
    pub id: Name,
    pub label: Name,
    pub span: Option<Span>,
    /// The name of the event, for event places.
    pub event: Option<Name>,
    /// The place that marks the end of the mission.
    pub is_final: bool,
    /// Bookkeeping (event places and the like): a token here is not a
    /// branch of the mission waiting somewhere.
    pub auxiliary: bool,
    /// Added by the checker (loop counters), not a place of the net: left
    /// out of the markings that counterexamples report.
    pub synthetic: bool,
}

/// A monitor: a marking shape a property looks for.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum MonitorKind {
    /// Two running places of one drone, whose actions exclude each other.
    Conflict { a: u32, b: u32 },
    /// Transition `t` could fire while `place`, which it produces into, is
    /// already marked: two tokens.
    Unsafe { t: u32, place: u32 },
    /// Two places whose marking together puts two drones closer than the
    /// separation: a drone's leg under way (`a`) and another's leg or rest
    /// (`b`); `pair` indexes the spatial candidates.
    Near { a: u32, b: u32, pair: u32 },
}

/// The net as exploration sees it. Transitions `0..n_real` are the net's;
/// `n_real..` are monitors (read arcs only, never fired).
#[derive(Debug, Clone)]
pub(crate) struct PtNet {
    pub places: Vec<PlaceInfo>,
    pub steps: Vec<StepInfo>,
    pub n_real: usize,
    pub monitors: Vec<MonitorKind>,
    /// `(place, weight)` consumed, read and produced by each transition.
    pub pre: Csr<(u32, u32)>,
    pub read: Csr<(u32, u32)>,
    pub post: Csr<(u32, u32)>,
    /// Per place: transitions consuming it, reading it, raising its count.
    pub consumers: Csr<u32>,
    pub readers: Csr<u32>,
    pub producers: Csr<u32>,
    /// Per transition: what a stubborn set must also hold when it holds this
    /// transition enabled (everything that could disable it or that it could
    /// disable).
    pub conflicts: Csr<u32>,
    /// Per real transition: pairs of an input `p` and a place `c` around
    /// it (input or output) where `p` can be filled only once `c` is empty
    /// (`Concurrency::mutex_inputs`); empty where no concurrency relation
    /// was computed.
    pub mutex_inputs: Csr<(u32, u32)>,
    /// Transitions with no input at all: always enabled.
    pub sources: Vec<u32>,
    pub initial: Vec<u32>,
    pub final_place: Option<u32>,
    /// How a stubborn set is picked where no enabled transition is free of
    /// conflicts (see [`Seeds`]).
    pub seeds: Seeds,
}

/// How many enabled transitions a stubborn set is grown from, the smallest
/// set kept.
///
/// The smallest set of a state is not the smallest state space. A mission
/// net is a few sequential processes (the drones), numbered in the order
/// of the mission's text: growing the set from the first enabled
/// transition only advances the mission's earliest part first in every
/// state, the same choice everywhere, so two orders of independent steps
/// meet again soon. Smallest-of-sixteen picked a different drone from one
/// state to the next: a generated 32-drone mission of 20,000 nodes took
/// 183,575 markings (3.4 s) where the first seed takes 45,157 (0.6 s), and
/// 100 drones of 6,000 nodes 77,765 where it takes 10,760. On nets without
/// that shape the smallest set wins (10 philosophers: 182 markings, against
/// 1,552 from the first seed), so a PNML net keeps it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Seeds {
    /// From the first enabled transition only (mission nets).
    First,
    /// From up to this many, the smallest set kept (any other net).
    Smallest(usize),
}

/// The arcs of one transition, to build a [`PtNet`] from.
#[derive(Debug, Clone, Default)]
pub(crate) struct RawTransition {
    pub pre: Vec<(u32, u32)>,
    pub read: Vec<(u32, u32)>,
    pub post: Vec<(u32, u32)>,
}

fn merge(arcs: &mut Vec<(u32, u32)>) {
    arcs.sort_unstable();
    let mut out: Vec<(u32, u32)> = Vec::with_capacity(arcs.len());
    for &(p, w) in arcs.iter() {
        match out.last_mut() {
            Some(last) if last.0 == p => last.1 += w,
            _ => out.push((p, w)),
        }
    }
    *arcs = out;
}

impl PtNet {
    pub(crate) fn new(
        mut places: Vec<PlaceInfo>,
        mut steps: Vec<StepInfo>,
        mut transitions: Vec<RawTransition>,
        initial: Vec<u32>,
        final_place: Option<u32>,
    ) -> Self {
        // Grown one by one: up to twice their length, and they are held
        // through the exploration.
        places.shrink_to_fit();
        steps.shrink_to_fit();
        for t in &mut transitions {
            merge(&mut t.pre);
            merge(&mut t.read);
            merge(&mut t.post);
        }
        let n_real = transitions.len();
        let mut net = PtNet {
            places,
            steps,
            n_real,
            monitors: Vec::new(),
            pre: Csr::default(),
            read: Csr::default(),
            post: Csr::default(),
            consumers: Csr::default(),
            readers: Csr::default(),
            producers: Csr::default(),
            conflicts: Csr::default(),
            mutex_inputs: Csr::default(),
            sources: Vec::new(),
            initial,
            final_place,
            seeds: Seeds::Smallest(16),
        };
        for t in &transitions {
            net.pre.push(t.pre.iter().copied());
            net.read.push(t.read.iter().copied());
            net.post.push(t.post.iter().copied());
        }
        drop(transitions);
        net.index();
        net
    }

    /// The raw arcs of the real transitions (to rebuild with monitors).
    pub(crate) fn raw(&self) -> Vec<RawTransition> {
        (0..self.n_real)
            .map(|t| RawTransition {
                pre: self.pre.get(t).to_vec(),
                read: self.read.get(t).to_vec(),
                post: self.post.get(t).to_vec(),
            })
            .collect()
    }

    /// Adds monitors (replacing any there were).
    pub(crate) fn with_monitors(mut self, monitors: Vec<MonitorKind>) -> Self {
        let real = self.n_real;
        self.pre.truncate(real);
        self.read.truncate(real);
        self.post.truncate(real);
        for m in &monitors {
            let mut read = match *m {
                MonitorKind::Conflict { a, b } | MonitorKind::Near { a, b, .. } => {
                    vec![(a, 1), (b, 1)]
                }
                MonitorKind::Unsafe { t, place } => {
                    let t = t as usize;
                    let mut r: Vec<(u32, u32)> = self.pre.get(t).to_vec();
                    r.extend(self.read.get(t).iter().copied());
                    r.push((place, 1));
                    r
                }
            };
            // A monitor needs each place's count at least as high as the
            // transition it watches does; reading is enough to say so.
            read.sort_unstable();
            let mut merged: Vec<(u32, u32)> = Vec::new();
            for (p, w) in read {
                match merged.last_mut() {
                    Some(last) if last.0 == p => last.1 = last.1.max(w),
                    _ => merged.push((p, w)),
                }
            }
            self.pre.push([]);
            self.read.push(merged);
            self.post.push([]);
        }
        self.monitors = monitors;
        self.index();
        self
    }

    /// Works out, from the arcs, each place's consumers, readers and
    /// producers, each transition's conflicts, and the sources. Built in
    /// flat lists, not a list per place: a net is indexed three times in a
    /// check (the mission's, with the rests recorded, with the monitors),
    /// and with a heap block per place and transition that took 8 % of a
    /// 500-drone check, most of it in malloc and free.
    fn index(&mut self) {
        let np = self.places.len();
        let nt = self.n_all();
        let (mut consumers, mut readers, mut producers) = (Vec::new(), Vec::new(), Vec::new());
        let mut sources = Vec::new();
        for t in 0..nt {
            let ti = t as u32;
            let (pre, read) = (self.pre.get(t), self.read.get(t));
            consumers.extend(pre.iter().map(|&(p, _)| (p, ti)));
            readers.extend(read.iter().map(|&(p, _)| (p, ti)));
            for &(p, w) in self.post.get(t) {
                let consumed = pre.iter().find(|&&(q, _)| q == p).map_or(0, |&(_, v)| v);
                if w > consumed {
                    producers.push((p, ti));
                }
            }
            if pre.is_empty() && read.is_empty() && t < self.n_real {
                sources.push(ti);
            }
        }
        self.consumers = Csr::from_pairs(np, &consumers);
        self.readers = Csr::from_pairs(np, &readers);
        self.producers = Csr::from_pairs(np, &producers);
        let mut conflicts = Csr::default();
        let mut c: Vec<u32> = Vec::new();
        for t in 0..nt {
            c.clear();
            if t < self.n_real {
                let (pre, read) = (self.pre.get(t), self.read.get(t));
                for &(p, _) in pre.iter().chain(read) {
                    c.extend_from_slice(self.consumers.get(p as usize));
                }
                for &(p, _) in pre {
                    c.extend_from_slice(self.readers.get(p as usize));
                }
                c.sort_unstable();
                c.dedup();
                c.retain(|&u| u as usize != t);
            }
            conflicts.push(c.iter().copied());
        }
        self.conflicts = conflicts;
        // Made for the transitions as they were: the caller makes them again.
        self.mutex_inputs = Csr::default();
        self.sources = sources;
    }

    pub(crate) fn n_places(&self) -> usize {
        self.places.len()
    }

    /// Real transitions and monitors.
    pub(crate) fn n_all(&self) -> usize {
        self.n_real + self.monitors.len()
    }

    pub(crate) fn is_monitor(&self, t: u32) -> bool {
        t as usize >= self.n_real
    }

    /// Whether the initial marking and every arc fit the one-bit encoding.
    pub(crate) fn fits_bits(&self) -> bool {
        self.initial.iter().all(|&c| c <= 1)
            && (0..self.n_all()).all(|t| {
                self.pre.get(t).iter().all(|&(_, w)| w == 1)
                    && self.read.get(t).iter().all(|&(_, w)| w == 1)
                    && self.post.get(t).iter().all(|&(_, w)| w == 1)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::Csr;

    #[test]
    fn lists_pushed_read_back_and_truncating_keeps_the_first_ones() {
        let mut c: Csr<u32> = Csr::default();
        c.truncate(0);
        assert_eq!(c.len(), 0);
        c.push([3, 1]);
        c.push([]);
        c.push([7]);
        assert_eq!(
            (c.len(), c.get(0), c.get(1), c.get(2)),
            (3, &[3, 1][..], &[][..], &[7][..])
        );
        c.truncate(1);
        assert_eq!((c.len(), c.get(0)), (1, &[3, 1][..]));
        c.push([9]);
        assert_eq!(c.get(1), &[9]);
        c.truncate(5);
        assert_eq!(c.len(), 2);
    }
}
