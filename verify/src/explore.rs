//! Breadth-first exploration of the reachable markings, with stubborn sets.
//!
//! # Store
//! A marking is worked on as a fixed-width row of `u64` words (one bit per
//! place for 1-safe nets, one byte per place otherwise) and stored compact:
//! its marked places as gaps in LEB128, with their counts when counted, in
//! one byte arena, identified by a `u32` id. On a 35,000-place mission net a
//! row is 4.4 KB and the compact form some tens of bytes. A `hashbrown` table
//! maps the hash of the compact form to its id, keeping 32 bits of the hash
//! beside the id so that growing the table never touches the arena. The
//! memory bound counts the arena's bytes as used. Every state keeps its BFS parent and the transition that led to it,
//! so the path to any state is a shortest path of the explored graph.
//!
//! # Parallelism
//! States are expanded in id order, in chunks: the successors of a chunk are
//! computed in parallel (rayon) against the store as it stands, then inserted
//! one by one in chunk order. Ids, and so counterexamples, therefore do not
//! depend on the number of threads or on scheduling.
//!
//! # Reduction
//! At each marking a *stubborn set* `S` is built and only its enabled
//! transitions are fired. The construction (Valmari's, for P/T nets with read
//! arcs) starts from one enabled transition and closes under:
//! * `t ∈ S` enabled: add every transition that consumes a place `t` consumes
//!   or reads, and every transition that reads a place `t` consumes (all that
//!   could disable `t` or be disabled by it);
//! * `t ∈ S` disabled: pick one input place short of tokens (the *scapegoat*)
//!   and add every transition that raises its count (nothing outside `S` can
//!   then enable `t`).
//!
//! This gives D1 (a transition of `S` commutes with any sequence of
//! transitions outside `S`) and D2 with every enabled transition of `S` a key
//! transition (no sequence outside `S` disables it). Several seeds are tried
//! and the set with the fewest enabled transitions wins.
//!
//! What the reduced graph preserves, and why:
//! * **Deadlocks**, with their shortest distance. If `M -σ-> D` with `D`
//!   dead, some transition of `σ` is in `S(M)` (otherwise a key transition,
//!   which `σ` cannot disable, would be enabled in `D`); moving the first one
//!   to the front (D1) gives a path of the same length through the reduced
//!   graph. So breadth-first search finds a deadlock at the same depth as full
//!   exploration would.
//! * **Fireability of every transition** (used for dead actions and for the
//!   monitors of [`crate::ptnet`]). This needs a proviso against *ignoring*:
//!   a transition `t` enabled at `M` but left out of every stubborn set along
//!   a cycle of the reduced graph would never fire. We use Valmari's
//!   terminal-component condition: every terminal strong component of the
//!   reduced graph holds a fully expanded marking. It gives what the
//!   arguments here need: from any `M`, for any `t` enabled at `M`, some
//!   reduced path leads to a marking whose stubborn set holds `t`. (Follow
//!   any reduced path from `M` into a terminal component; while `t` stays out
//!   of the stubborn sets nothing disables it, because a transition of `S`
//!   that could disable `t` pulls `t` into `S`; inside the component a path
//!   reaches the fully expanded marking, where `t` is in the set.) So
//!   firing sequences of the full net can be replayed in the reduced graph
//!   one transition at a time, as with stubborn sets for deadlocks.
//!
//!   The condition is checked after the breadth-first pass, on the graph it
//!   built (Tarjan's algorithm): one marking of each terminal component
//!   without a full expansion is expanded in full, the exploration goes on
//!   from the new markings, and this repeats until no such component is
//!   left. The usual proviso of breadth-first search ("expand in full when a
//!   reduced successor is already stored") is far stronger than needed: every
//!   diamond and every drone coming round its loop triggers it, and on
//!   missions whose drones loop and branch independently it undoes the
//!   reduction (2 million markings and counting for a 20-drone stress
//!   mission that the terminal-component condition settles in 8,000).
//! * **"The final marking stays reachable"** (termination). For a reduced
//!   marking, a path to a marking with `final` marked can be replayed in the
//!   reduced graph by the same argument, provided nothing consumes from
//!   `final` (true of mission nets; checked for PNML input, else reduction is
//!   switched off); and a reachable marking from which `final` is unreachable
//!   has a reduced counterpart, because keys fired in front of the path to it
//!   keep it unreachable.
//!
//! Monitors are never fired; they are checked in every explored marking
//! (finding them anywhere is sound), and they take part in the closure as
//! readers so that the preservation argument covers them.
//!
//! Non-safe nets (PNML input) are explored in full with byte counters; a
//! marking that strictly covers one of its BFS ancestors proves the net
//! unbounded (the path between them can be repeated forever).

use std::time::Instant;

use hashbrown::HashTable;
use rayon::prelude::*;

use crate::ptnet::{PtNet, Seeds};

pub(crate) mod deadlock;
mod enabled;

pub(crate) use enabled::Parent;

/// How markings are packed into words.
pub(crate) trait Encoding: Copy + Send + Sync + 'static {
    const MAX: u32;
    fn words(places: usize) -> usize;
    fn get(m: &[u64], p: u32) -> u32;
    fn set(m: &mut [u64], p: u32, v: u32);
    fn for_each_marked(m: &[u64], f: impl FnMut(u32));
    /// Whether the compact form carries a count after each place (else
    /// every listed place holds one token).
    const COUNTED: bool;
    /// Appends the marking in the store's compact form: the marked places
    /// as gaps from the previous one, in LEB128 (and, with counts, the
    /// count after each). Equal markings encode to equal bytes.
    fn encode(m: &[u64], out: &mut Vec<u8>) {
        let mut last = 0u32;
        Self::for_each_marked(m, |p| {
            put_varint(p - last, out);
            if Self::COUNTED {
                out.push(Self::get(m, p) as u8);
            }
            last = p;
        });
    }
    /// Writes the marking `bytes` encodes into `out` (all words).
    fn decode(bytes: &[u8], out: &mut [u64]) {
        out.iter_mut().for_each(|w| *w = 0);
        for (p, count) in entries::<Self>(bytes) {
            Self::set(out, p, count);
        }
    }
    /// The tokens on `p` in an encoded marking, without decoding it all.
    fn tokens(bytes: &[u8], p: u32) -> u32 {
        entries::<Self>(bytes)
            .find(|&(q, _)| q >= p)
            .map_or(0, |(q, count)| if q == p { count } else { 0 })
    }
}

/// The marked places of an encoded marking, in order, with their counts.
fn entries<E: Encoding>(bytes: &[u8]) -> impl Iterator<Item = (u32, u32)> + '_ {
    let (mut i, mut p) = (0, 0u32);
    std::iter::from_fn(move || {
        if i >= bytes.len() {
            return None;
        }
        p += get_varint(bytes, &mut i);
        let count = if E::COUNTED {
            i += 1;
            u32::from(bytes[i - 1])
        } else {
            1
        };
        Some((p, count))
    })
}

fn put_varint(mut v: u32, out: &mut Vec<u8>) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn get_varint(bytes: &[u8], i: &mut usize) -> u32 {
    let mut v = 0u32;
    let mut shift = 0;
    loop {
        let b = bytes[*i];
        *i += 1;
        v |= u32::from(b & 0x7f) << shift;
        if b < 0x80 {
            return v;
        }
        shift += 7;
    }
}

/// One bit per place: 1-safe nets.
#[derive(Clone, Copy)]
pub(crate) struct Bits;

/// One byte per place: up to 255 tokens.
#[derive(Clone, Copy)]
pub(crate) struct Bytes;

impl Encoding for Bits {
    const MAX: u32 = 1;
    const COUNTED: bool = false;
    fn words(places: usize) -> usize {
        places.div_ceil(64).max(1)
    }
    #[inline]
    fn get(m: &[u64], p: u32) -> u32 {
        (m[p as usize >> 6] >> (p & 63)) as u32 & 1
    }
    #[inline]
    fn set(m: &mut [u64], p: u32, v: u32) {
        let w = &mut m[p as usize >> 6];
        *w = (*w & !(1 << (p & 63))) | ((v as u64 & 1) << (p & 63));
    }
    fn for_each_marked(m: &[u64], mut f: impl FnMut(u32)) {
        for (i, &w) in m.iter().enumerate() {
            let mut w = w;
            while w != 0 {
                f((i * 64) as u32 + w.trailing_zeros());
                w &= w - 1;
            }
        }
    }
}

impl Encoding for Bytes {
    const MAX: u32 = 255;
    const COUNTED: bool = true;
    fn words(places: usize) -> usize {
        places.div_ceil(8).max(1)
    }
    #[inline]
    fn get(m: &[u64], p: u32) -> u32 {
        (m[p as usize >> 3] >> ((p & 7) * 8)) as u32 & 0xff
    }
    #[inline]
    fn set(m: &mut [u64], p: u32, v: u32) {
        let shift = (p & 7) * 8;
        let w = &mut m[p as usize >> 3];
        *w = (*w & !(0xff << shift)) | ((v as u64 & 0xff) << shift);
    }
    fn for_each_marked(m: &[u64], mut f: impl FnMut(u32)) {
        for (i, &w) in m.iter().enumerate() {
            let mut w = w;
            while w != 0 {
                let byte = w.trailing_zeros() / 8;
                f((i * 8) as u32 + byte);
                w &= !(0xff << (byte * 8));
            }
        }
    }
}

#[inline]
fn hash_bytes(m: &[u8]) -> u64 {
    const K: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut h = K ^ (m.len() as u64);
    let mut chunks = m.chunks_exact(8);
    for c in &mut chunks {
        let w = u64::from_le_bytes(c.try_into().expect("chunks of eight"));
        h = (h ^ w).wrapping_mul(K);
        h ^= h >> 32;
    }
    let mut tail = [0u8; 8];
    tail[..chunks.remainder().len()].copy_from_slice(chunks.remainder());
    h = (h ^ u64::from_le_bytes(tail)).wrapping_mul(K);
    h ^= h >> 32;
    // Final avalanche (murmur3's fmix64) so both ends of the word are good.
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^ (h >> 33)
}

/// The table keeps 32 bits of the hash beside the id; this widens them back
/// into the 64 bits hashbrown wants (its top bits pick control bytes, its low
/// bits pick buckets).
#[inline]
fn widen(h32: u32) -> u64 {
    (h32 as u64) << 32 | h32 as u64
}

/// All explored markings, each in its compact form ([`Encoding::encode`]):
/// a mission net's marking holds a few dozen places out of tens of
/// thousands, so a row of one bit per place would cost kilobytes where the
/// gaps between marked places cost tens of bytes.
pub(crate) struct Store {
    pub words: usize,
    arena: Vec<u8>,
    /// Where each marking's bytes end in the arena.
    ends: Vec<u64>,
    decode: fn(&[u8], &mut [u64]),
    tokens: fn(&[u8], u32) -> u32,
    /// BFS parent and the transition fired from it (`u32::MAX` for the root).
    pub parent: Vec<u32>,
    pub via: Vec<u32>,
    table: HashTable<u64>,
}

impl Store {
    fn new<E: Encoding>(words: usize) -> Self {
        Store {
            words,
            arena: Vec::new(),
            ends: Vec::new(),
            decode: E::decode,
            tokens: E::tokens,
            parent: Vec::new(),
            via: Vec::new(),
            table: HashTable::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// The marking `id`, one row of words as [`Encoding`] packs them.
    pub fn marking(&self, id: u32) -> Vec<u64> {
        let mut out = vec![0; self.words];
        self.marking_into(id, &mut out);
        out
    }

    pub fn marking_into(&self, id: u32, out: &mut [u64]) {
        (self.decode)(self.encoded(id), out);
    }

    /// The tokens on `p` in marking `id`.
    pub fn tokens(&self, id: u32, p: u32) -> u32 {
        (self.tokens)(self.encoded(id), p)
    }

    fn encoded(&self, id: u32) -> &[u8] {
        let lo = match id {
            0 => 0,
            _ => self.ends[id as usize - 1] as usize,
        };
        &self.arena[lo..self.ends[id as usize] as usize]
    }

    fn find(&self, m: &[u8], h: u64) -> Option<u32> {
        let h32 = h as u32;
        self.table
            .find(widen(h32), |&e| {
                e >> 32 == h32 as u64 && self.encoded(e as u32) == m
            })
            .map(|&e| e as u32)
    }

    /// Inserts an encoded marking; returns its id and whether it is new.
    fn insert(&mut self, m: &[u8], h: u64, parent: u32, via: u32) -> (u32, bool) {
        if let Some(id) = self.find(m, h) {
            return (id, false);
        }
        let id = self.parent.len() as u32;
        self.arena.extend_from_slice(m);
        self.ends.push(self.arena.len() as u64);
        self.parent.push(parent);
        self.via.push(via);
        let h32 = h as u32;
        self.table
            .insert_unique(widen(h32), (h32 as u64) << 32 | id as u64, |&e| {
                widen((e >> 32) as u32)
            });
        (id, true)
    }

    /// What the store holds: the arena's bytes as used (it grows by
    /// doubling, and the bound should stop on what the markings cost, not
    /// on the headroom), the rest as allocated.
    fn bytes(&self) -> usize {
        self.arena.len()
            + self.ends.capacity() * 8
            + self.parent.capacity() * 4
            + self.via.capacity() * 4
            + self.table.capacity() * 9
    }

    /// The transitions from the root to a state.
    pub fn path(&self, mut id: u32) -> Vec<u32> {
        let mut out = Vec::new();
        while self.parent[id as usize] != u32::MAX {
            out.push(self.via[id as usize]);
            id = self.parent[id as usize];
        }
        out.reverse();
        out
    }
}

/// How a run is set up.
#[derive(Clone)]
pub(crate) struct Config<'a> {
    pub reduction: bool,
    pub max_bytes: usize,
    /// Keep the graph's edges (for the termination analysis). Reduced
    /// exploration keeps them anyway: its proviso needs them.
    pub keep_edges: bool,
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
    /// Stop at the first deadlock (a dead marking without the final
    /// place): breadth-first, so at a shortest one.
    pub first_deadlock: bool,
}

/// Why exploration stopped before the end.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Stop {
    /// The memory bound was reached.
    Memory,
    /// A 1-safe exploration met a second token: `t` fired from `state`.
    Unsafe { state: u32, t: u32, place: u32 },
    /// A place would exceed the counter's capacity.
    Overflow { state: u32, t: u32, place: u32 },
    /// `state` strictly covers its ancestor `ancestor`.
    Unbounded { state: u32, ancestor: u32 },
    /// More states than ids.
    TooManyStates,
    /// A deadlock was found and only that was asked.
    Deadlock,
}

pub(crate) struct Exploration {
    pub store: Store,
    pub stop: Option<Stop>,
    /// Dead markings, in BFS order.
    pub dead: Vec<u32>,
    /// Transitions fired somewhere (bit per real transition).
    pub fired: Vec<bool>,
    /// For each monitor, the first marking it was enabled in.
    pub monitor_hits: Vec<Option<u32>>,
    /// Successors of each expanded state (CSR), if kept.
    pub edge_offsets: Vec<u64>,
    pub edges: Vec<u32>,
    /// The transition of each kept edge.
    pub edge_trans: Vec<u32>,
    pub expanded: usize,
    /// Whether each state was expanded in full (the terminal-component
    /// proviso looks for components without one).
    pub fully: Vec<bool>,
    pub full_expansions: usize,
    pub edge_count: u64,
    pub max_tokens: u32,
    pub seconds: f64,
}

impl Exploration {
    pub(crate) fn new<E: Encoding>(net: &PtNet, words: usize) -> Self {
        Exploration {
            store: Store::new::<E>(words),
            stop: None,
            dead: Vec::new(),
            fired: vec![false; net.n_real],
            monitor_hits: vec![None; net.monitors.len()],
            edge_offsets: Vec::new(),
            edges: Vec::new(),
            edge_trans: Vec::new(),
            expanded: 0,
            fully: Vec::new(),
            full_expansions: 0,
            edge_count: 0,
            max_tokens: 0,
            seconds: 0.0,
        }
    }

    pub fn complete(&self) -> bool {
        self.stop.is_none()
    }

    pub fn memory_bytes(&self) -> usize {
        self.store.bytes()
            + self.edges.capacity() * 4
            + self.edge_trans.capacity() * 4
            + self.edge_offsets.capacity() * 8
    }
}

/// Per-thread buffers, stamped instead of cleared.
struct Scratch {
    gen: u32,
    enabled_at: Vec<u32>,
    seen_at: Vec<u32>,
    in_s: Vec<u32>,
    enabled: Vec<u32>,
    stack: Vec<u32>,
    cur: Vec<u32>,
    best: Vec<u32>,
    /// The transitions whose overflow `enabled::after` leaves to judge.
    touched: Vec<u32>,
    buf: Vec<u64>,
    /// How long the last successor encoded here was: a marking's
    /// successors are about as long as its siblings and cousins.
    succ_len: usize,
}

impl Scratch {
    fn new(n: usize, words: usize) -> Self {
        Scratch {
            gen: 0,
            enabled_at: vec![0; n],
            seen_at: vec![0; n],
            in_s: vec![0; n],
            enabled: Vec::new(),
            stack: Vec::new(),
            cur: Vec::new(),
            best: Vec::new(),
            touched: Vec::new(),
            buf: vec![0; words],
            succ_len: 0,
        }
    }

    fn next_gen(&mut self) -> u32 {
        if self.gen == u32::MAX {
            self.gen = 0;
            self.enabled_at.iter_mut().for_each(|x| *x = 0);
            self.seen_at.iter_mut().for_each(|x| *x = 0);
            self.in_s.iter_mut().for_each(|x| *x = 0);
        }
        self.gen += 1;
        self.gen
    }
}

/// What expanding one marking produced.
#[derive(Default)]
struct Expanded {
    dead: bool,
    full: bool,
    trans: Vec<u32>,
    /// Successors, encoded, one after the other; `ends` says where each
    /// stops.
    succ: Vec<u8>,
    ends: Vec<usize>,
    hashes: Vec<u64>,
    monitors: Vec<u32>,
    overflow: Option<(u32, u32)>,
    /// The transitions enabled in the marking, sorted (its children's
    /// [`Parent`]).
    enabled: Vec<u32>,
}

/// Fires `t` into `out`; on a count above the encoding's capacity returns
/// the place.
#[inline]
fn fire<E: Encoding>(net: &PtNet, m: &[u64], t: usize, out: &mut [u64]) -> Result<(), u32> {
    out.copy_from_slice(m);
    for &(p, w) in net.pre.get(t) {
        E::set(out, p, E::get(out, p) - w);
    }
    for &(p, w) in net.post.get(t) {
        let v = E::get(out, p) + w;
        if v > E::MAX {
            return Err(p);
        }
        E::set(out, p, v);
    }
    Ok(())
}

/// The place where firing `t` (enabled) would count above the encoding's
/// capacity, the one [`fire`] would name, without firing it: a state has
/// about one enabled transition per drone in flight, and copying the
/// marking for each made the check of a state grow with the fleet twice
/// over (102 copies of 618 words a state at 1,000 drones).
fn overflow<E: Encoding>(net: &PtNet, m: &[u64], t: usize) -> Option<u32> {
    // Both lists are sorted by place, each place once (`ptnet::merge`).
    let mut pre = net.pre.get(t).iter().peekable();
    for &(p, w) in net.post.get(t) {
        while pre.next_if(|&&(q, _)| q < p).is_some() {}
        let consumed = pre.next_if(|&&(q, _)| q == p).map_or(0, |&(_, v)| v);
        if E::get(m, p) - consumed + w > E::MAX {
            return Some(p);
        }
    }
    None
}

/// Expands marking `m`: what is enabled in it (from its parent's when
/// given), the transitions to fire, their successors.
fn expand<E: Encoding>(
    net: &PtNet,
    reduction: bool,
    s: &mut Scratch,
    m: &[u64],
    parent: Option<Parent>,
) -> Expanded {
    let gen = s.next_gen();
    match parent {
        Some(parent) => enabled::after::<E>(net, m, s, gen, parent),
        None => enabled::from_scratch::<E>(net, m, s, gen),
    }
    let mut out = Expanded::default();
    let real_enabled = s.enabled.partition_point(|&t| !net.is_monitor(t));
    out.monitors = s.enabled[real_enabled..]
        .iter()
        .map(|&t| t - net.n_real as u32)
        .collect();
    if real_enabled == 0 {
        out.dead = true;
        return out;
    }
    // Two tokens are checked on every enabled transition, fired or not: it
    // costs little and finds compiler bugs early.
    // From a parent, only the transitions `enabled::after` names can
    // overflow here: the others did not there, or no child would exist.
    let candidates = match parent {
        Some(_) => &s.touched[..],
        None => &s.enabled[..real_enabled],
    };
    let enabled_here = |t: u32| !net.is_monitor(t) && s.enabled_at[t as usize] == gen;
    for &t in candidates.iter().filter(|&&t| enabled_here(t)) {
        if let Some(p) = overflow::<E>(net, m, t as usize) {
            out.overflow = Some((t, p));
            return out;
        }
    }
    let chosen: Vec<u32> = if reduction && real_enabled > 1 {
        stubborn::<E>(net, m, s, gen, real_enabled);
        std::mem::take(&mut s.best)
    } else {
        s.enabled[..real_enabled].to_vec()
    };
    out.full = chosen.len() == real_enabled;
    successors::<E>(net, m, &chosen, s, &mut out);
    s.best = chosen;
    out.enabled = s.enabled.clone();
    out
}

fn successors<E: Encoding>(
    net: &PtNet,
    m: &[u64],
    ts: &[u32],
    s: &mut Scratch,
    out: &mut Expanded,
) {
    // Sized before: grown a byte at a time, the successors' bytes were a
    // tenth of the allocations of a 500-drone check.
    out.succ.reserve_exact((s.succ_len + 8) * ts.len());
    out.trans.reserve_exact(ts.len());
    out.ends.reserve_exact(ts.len());
    out.hashes.reserve_exact(ts.len());
    for &t in ts {
        // Overflow was ruled out above.
        let _ = fire::<E>(net, m, t as usize, &mut s.buf);
        out.trans.push(t);
        let lo = out.succ.len();
        E::encode(&s.buf, &mut out.succ);
        s.succ_len = out.succ.len() - lo;
        out.hashes.push(hash_bytes(&out.succ[lo..]));
        out.ends.push(out.succ.len());
    }
}

/// Leaves in `s.best` the enabled transitions of the smallest stubborn set
/// found from the seeds the net asks for ([`Seeds`]).
fn stubborn<E: Encoding>(net: &PtNet, m: &[u64], s: &mut Scratch, gen: u32, real_enabled: usize) {
    let seeds = match net.seeds {
        Seeds::First => 1,
        Seeds::Smallest(n) => n,
    };
    s.best.clear();
    // An enabled transition in conflict with nothing is a stubborn set on
    // its own (its closure adds nothing): take the first, without building
    // closures that may walk back through a drone's whole chain of disabled
    // steps before they lose to it.
    if let Some(&t) = s.enabled[..real_enabled]
        .iter()
        .find(|&&t| net.conflicts.get(t as usize).iter().all(|&u| u == t))
    {
        s.best.push(t);
        return;
    }
    s.best.extend_from_slice(&s.enabled[..real_enabled]);
    for i in 0..real_enabled.min(seeds) {
        let seed = s.enabled[i];
        if closure::<E>(net, m, s, gen, seed) && s.cur.len() < s.best.len() {
            std::mem::swap(&mut s.cur, &mut s.best);
            if s.best.len() == 1 {
                break;
            }
        }
    }
    s.best.sort_unstable();
}

/// The closure from one seed; its enabled transitions end in `s.cur`. Gives
/// up (returns false) once it cannot beat the best set so far.
fn closure<E: Encoding>(net: &PtNet, m: &[u64], s: &mut Scratch, gen: u32, seed: u32) -> bool {
    // A fresh stamp for membership, distinct from the enabled stamps.
    let sgen = s.next_gen();
    let Scratch {
        enabled_at,
        in_s,
        stack,
        cur,
        best,
        ..
    } = s;
    let limit = best.len();
    cur.clear();
    stack.clear();
    in_s[seed as usize] = sgen;
    stack.push(seed);
    while let Some(t) = stack.pop() {
        let ti = t as usize;
        if enabled_at[ti] == gen {
            if net.is_monitor(t) {
                // Found in this marking anyway: nothing to protect.
                continue;
            }
            cur.push(t);
            if cur.len() >= limit {
                return false;
            }
            for &u in net.conflicts.get(ti) {
                if in_s[u as usize] != sgen {
                    in_s[u as usize] = sgen;
                    stack.push(u);
                }
            }
        } else if !waits_on_the_set::<E>(net, m, in_s, sgen, ti) {
            let p = scapegoat::<E>(net, m, in_s, sgen, ti);
            for &u in net.producers.get(p as usize) {
                if in_s[u as usize] != sgen {
                    in_s[u as usize] = sgen;
                    stack.push(u);
                }
            }
        }
    }
    true
}

/// Whether disabled `t` can be enabled only after a transition already in
/// the set fires: it has an empty input `p` that can be filled only once a
/// marked place `c` around it is empty (`PtNet::mutex_inputs`), and every
/// consumer of `c` but `t` (not enabled before) is in the set. Those
/// consumers are then a necessary enabling set of `t` that adds nothing,
/// where `p`'s producers would lead back through every step before it (a
/// `Do` region's fork, whose output is still marked, back to the
/// mission's start: two thousand steps a closure at 1,000 drones).
fn waits_on_the_set<E: Encoding>(
    net: &PtNet,
    m: &[u64],
    in_s: &[u32],
    sgen: u32,
    t: usize,
) -> bool {
    net.mutex_inputs.get_or_none(t).iter().any(|&(p, c)| {
        E::get(m, p) == 0
            && E::get(m, c) > 0
            && net
                .consumers
                .get(c as usize)
                .iter()
                .all(|&u| u as usize == t || in_s[u as usize] == sgen)
    })
}

/// An input of a disabled transition that lacks tokens: preferably one whose
/// producers are all in the set already, else the one with fewest producers.
fn scapegoat<E: Encoding>(net: &PtNet, m: &[u64], in_s: &[u32], sgen: u32, t: usize) -> u32 {
    let mut best: Option<(usize, u32)> = None;
    for &(p, w) in net.pre.get(t).iter().chain(net.read.get(t)) {
        if E::get(m, p) >= w {
            continue;
        }
        let prods = net.producers.get(p as usize);
        let missing = prods.iter().filter(|&&u| in_s[u as usize] != sgen).count();
        if missing == 0 {
            return p;
        }
        if best.is_none_or(|(b, _)| missing < b) {
            best = Some((missing, p));
        }
    }
    // A disabled transition has an input short of tokens.
    best.map_or(0, |(_, p)| p)
}

/// Whether `a` covers `b` strictly.
fn strictly_covers<E: Encoding>(a: &[u64], b: &[u64], places: usize) -> bool {
    let mut bigger = false;
    for p in 0..places as u32 {
        let (x, y) = (E::get(a, p), E::get(b, p));
        if x < y {
            return false;
        }
        bigger |= x > y;
    }
    bigger
}

pub(crate) fn initial_marking<E: Encoding>(net: &PtNet) -> Vec<u64> {
    let mut m0 = vec![0u64; E::words(net.n_places())];
    for (p, &c) in net.initial.iter().enumerate() {
        E::set(&mut m0, p as u32, c.min(E::MAX));
    }
    m0
}

/// Explores the reachable markings of `net`.
pub(crate) fn explore<E: Encoding>(net: &PtNet, cfg: &Config) -> Exploration {
    let start = Instant::now();
    let words = E::words(net.n_places());
    let keep_edges = cfg.keep_edges || cfg.reduction;
    let mut ex = Exploration::new::<E>(net, words);
    let m0 = initial_marking::<E>(net);
    let mut m0_bytes = Vec::new();
    E::encode(&m0, &mut m0_bytes);
    ex.store
        .insert(&m0_bytes, hash_bytes(&m0_bytes), u32::MAX, u32::MAX);
    ex.max_tokens = net.initial.iter().copied().max().unwrap_or(0);
    if keep_edges {
        ex.edge_offsets.push(0);
    }
    // Edges out of markings expanded a second time, in full, by the proviso:
    // (from, to, transition). Merged into the CSR arrays at the end.
    let mut extra: Vec<(u32, u32, u32)> = Vec::new();
    let counting = E::MAX > 1;
    let n_all = net.n_all();
    let mut cursor = 0usize;
    let mut chunk = 64usize;
    // Room for the expansions done on this thread, made once: a frontier of
    // a few markings at a time is common (one successor a marking under
    // stubborn sets), and zeroing three vectors as long as the net's
    // transitions for each cost a sixth of the exploration at 1,000 drones.
    let mut own = (Scratch::new(n_all, words), vec![0; words]);
    let mut kept = enabled::Kept::new(cfg.max_bytes / 4);
    'outer: loop {
        while cursor < ex.store.len() {
            let hi = ex.store.len().min(cursor + chunk);
            let store = &ex.store;
            let reduction = cfg.reduction;
            let parents = &kept;
            let results: Vec<Expanded> = if hi - cursor < 32 {
                let (s, m) = &mut own;
                (cursor..hi)
                    .map(|id| {
                        store.marking_into(id as u32, m);
                        expand::<E>(net, reduction, s, m, parents.parent_of(store, id as u32))
                    })
                    .collect()
            } else {
                (cursor..hi)
                    .into_par_iter()
                    .map_init(
                        || (Scratch::new(n_all, words), vec![0; words]),
                        |(s, m), id| {
                            store.marking_into(id as u32, m);
                            expand::<E>(net, reduction, s, m, parents.parent_of(store, id as u32))
                        },
                    )
                    .collect()
            };
            for (i, mut r) in results.into_iter().enumerate() {
                let id = (cursor + i) as u32;
                ex.expanded += 1;
                ex.fully.push(r.full || r.dead);
                let dead = r.dead;
                kept.expanded(&ex.store, id);
                let enabled = std::mem::take(&mut r.enabled);
                match absorb::<E>(&mut ex, net, id, r, None) {
                    Ok(children) => kept.keep(id, enabled, children),
                    Err(stop) => {
                        ex.stop = Some(stop);
                        break 'outer;
                    }
                }
                let at_end = net.final_place.is_some_and(|f| ex.store.tokens(id, f) > 0);
                if cfg.first_deadlock && dead && !at_end {
                    ex.stop = Some(Stop::Deadlock);
                    break 'outer;
                }
                if keep_edges {
                    ex.edge_offsets.push(ex.edges.len() as u64);
                }
            }
            cursor = hi;
            chunk = (chunk * 2).min(1 << 14);
            if let Some(f) = cfg.progress {
                f(ex.store.len(), cursor);
            }
            if ex.memory_bytes() + extra.capacity() * 12 + kept.bytes() > cfg.max_bytes {
                ex.stop = Some(Stop::Memory);
                break 'outer;
            }
        }
        if !cfg.reduction {
            break;
        }
        let ignoring = unexpanded_terminal_components(&ex, &extra);
        if ignoring.is_empty() {
            break;
        }
        for id in ignoring {
            let mut r = expand::<E>(net, false, &mut own.0, &ex.store.marking(id), None);
            ex.fully[id as usize] = true;
            let enabled = std::mem::take(&mut r.enabled);
            match absorb::<E>(&mut ex, net, id, r, Some(&mut extra)) {
                Ok(children) => kept.keep(id, enabled, children),
                Err(stop) => {
                    ex.stop = Some(stop);
                    break 'outer;
                }
            }
        }
    }
    if keep_edges && !extra.is_empty() {
        merge_edges(&mut ex, &mut extra);
    }
    if !counting {
        ex.max_tokens = 1;
    }
    ex.seconds = start.elapsed().as_secs_f64();
    ex
}

/// Records what expanding `id` produced: findings, new markings, edges (into
/// the CSR arrays, or into `extra` for a second expansion). Says how many
/// of the markings were new.
fn absorb<E: Encoding>(
    ex: &mut Exploration,
    net: &PtNet,
    id: u32,
    r: Expanded,
    mut extra: Option<&mut Vec<(u32, u32, u32)>>,
) -> Result<u32, Stop> {
    let counting = E::MAX > 1;
    for &mi in &r.monitors {
        let hit = &mut ex.monitor_hits[mi as usize];
        if hit.is_none() {
            *hit = Some(id);
        }
    }
    if let Some((t, place)) = r.overflow {
        return Err(if counting {
            Stop::Overflow {
                state: id,
                t,
                place,
            }
        } else {
            Stop::Unsafe {
                state: id,
                t,
                place,
            }
        });
    }
    if r.dead {
        ex.dead.push(id);
    }
    if r.full && !r.dead {
        ex.full_expansions += 1;
    }
    let keep_edges = !ex.edge_offsets.is_empty();
    let mut children = 0;
    for (k, &t) in r.trans.iter().enumerate() {
        ex.fired[t as usize] = true;
        let lo = if k == 0 { 0 } else { r.ends[k - 1] };
        let succ = &r.succ[lo..r.ends[k]];
        if ex.store.len() >= u32::MAX as usize - 1 {
            return Err(Stop::TooManyStates);
        }
        let (sid, new) = ex.store.insert(succ, r.hashes[k], id, t);
        children += u32::from(new);
        ex.edge_count += 1;
        match extra.as_deref_mut() {
            Some(extra) => extra.push((id, sid, t)),
            None if keep_edges => {
                ex.edges.push(sid);
                ex.edge_trans.push(t);
            }
            None => {}
        }
        if new && counting {
            let succ = ex.store.marking(sid);
            for p in 0..net.n_places() as u32 {
                ex.max_tokens = ex.max_tokens.max(E::get(&succ, p));
            }
            let mut a = id;
            loop {
                if strictly_covers::<E>(&succ, &ex.store.marking(a), net.n_places()) {
                    return Err(Stop::Unbounded {
                        state: sid,
                        ancestor: a,
                    });
                }
                let p = ex.store.parent[a as usize];
                if p == u32::MAX {
                    break;
                }
                a = p;
            }
        }
    }
    Ok(children)
}

/// One marking of each terminal strong component of the explored graph that
/// holds no fully expanded marking, found with an iterative Tarjan (written
/// here because petgraph's `tarjan_scc` recurses once per state along a
/// path, and reduced state spaces are paths hundreds of thousands long).
fn unexpanded_terminal_components(ex: &Exploration, extra: &[(u32, u32, u32)]) -> Vec<u32> {
    let n = ex.store.len();
    // Successors: the CSR row, then the extra edges (sorted by source).
    let mut extra_sorted: Vec<(u32, u32)> = extra.iter().map(|&(a, b, _)| (a, b)).collect();
    extra_sorted.sort_unstable();
    let mut extra_off = vec![0u32; n + 1];
    for &(a, _) in &extra_sorted {
        extra_off[a as usize + 1] += 1;
    }
    for i in 0..n {
        extra_off[i + 1] += extra_off[i];
    }
    let succ = |v: usize, k: usize| -> Option<u32> {
        let base = ex.edge_offsets[v] as usize;
        let row = ex.edge_offsets[v + 1] as usize - base;
        if k < row {
            return Some(ex.edges[base + k]);
        }
        let e = extra_off[v] as usize + (k - row);
        (e < extra_off[v + 1] as usize).then(|| extra_sorted[e].1)
    };
    const NONE: u32 = u32::MAX;
    let mut index = vec![NONE; n];
    let mut low = vec![0u32; n];
    let mut on_stack = vec![false; n];
    let mut stack: Vec<u32> = Vec::new();
    let mut call: Vec<(u32, usize)> = Vec::new();
    let mut comp_of = vec![NONE; n];
    let mut comps = 0u32;
    let mut members: Vec<u32> = Vec::new();
    let mut ignoring: Vec<u32> = Vec::new();
    let mut next = 0u32;
    for root in 0..n {
        if index[root] != NONE {
            continue;
        }
        call.push((root as u32, 0));
        index[root] = next;
        low[root] = next;
        next += 1;
        stack.push(root as u32);
        on_stack[root] = true;
        while let Some(&mut (v, ref mut k)) = call.last_mut() {
            let vi = v as usize;
            if let Some(w) = succ(vi, *k) {
                *k += 1;
                let wi = w as usize;
                if index[wi] == NONE {
                    index[wi] = next;
                    low[wi] = next;
                    next += 1;
                    stack.push(w);
                    on_stack[wi] = true;
                    call.push((w, 0));
                } else if on_stack[wi] {
                    low[vi] = low[vi].min(index[wi]);
                }
                continue;
            }
            call.pop();
            if let Some(&(u, _)) = call.last() {
                low[u as usize] = low[u as usize].min(low[vi]);
            }
            if low[vi] == index[vi] {
                members.clear();
                loop {
                    let w = stack.pop().expect("Tarjan stack holds the component");
                    on_stack[w as usize] = false;
                    comp_of[w as usize] = comps;
                    members.push(w);
                    if w == v {
                        break;
                    }
                }
                // Components come out successors first: an edge leaving this
                // one goes to a component already numbered.
                let terminal = members.iter().all(|&m| {
                    (0..)
                        .map_while(|k| succ(m as usize, k))
                        .all(|w| comp_of[w as usize] == comps)
                });
                if terminal && !members.iter().any(|&m| ex.fully[m as usize]) {
                    ignoring.push(*members.iter().min().expect("components are not empty"));
                }
                comps += 1;
            }
        }
    }
    ignoring
}

/// Folds the proviso's extra edges into the CSR arrays, each after the
/// edges its marking got in the breadth-first pass.
fn merge_edges(ex: &mut Exploration, extra: &mut Vec<(u32, u32, u32)>) {
    extra.sort_by_key(|&(a, _, _)| a);
    // Rows exist for the expanded markings only (all of them, unless the
    // exploration stopped early); extra edges leave expanded markings.
    let n = ex.edge_offsets.len() - 1;
    let mut offsets = Vec::with_capacity(n + 1);
    let mut edges = Vec::with_capacity(ex.edges.len() + extra.len());
    let mut trans = Vec::with_capacity(ex.edges.len() + extra.len());
    let mut e = 0;
    offsets.push(0u64);
    for v in 0..n {
        let (lo, hi) = (ex.edge_offsets[v] as usize, ex.edge_offsets[v + 1] as usize);
        edges.extend_from_slice(&ex.edges[lo..hi]);
        trans.extend_from_slice(&ex.edge_trans[lo..hi]);
        while e < extra.len() && extra[e].0 as usize == v {
            edges.push(extra[e].1);
            trans.push(extra[e].2);
            e += 1;
        }
        offsets.push(edges.len() as u64);
    }
    ex.edge_offsets = offsets;
    ex.edges = edges;
    ex.edge_trans = trans;
    extra.clear();
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn round_trip<E: Encoding>(places: usize, counts: &[(u32, u32)]) -> Result<(), TestCaseError> {
        let mut m = vec![0u64; E::words(places)];
        for &(p, c) in counts {
            E::set(&mut m, p % places as u32, c.min(E::MAX));
        }
        let mut bytes = Vec::new();
        E::encode(&m, &mut bytes);
        let mut back = vec![!0u64; m.len()];
        E::decode(&bytes, &mut back);
        prop_assert_eq!(&back, &m);
        for p in 0..places as u32 {
            prop_assert_eq!(E::tokens(&bytes, p), E::get(&m, p));
        }
        Ok(())
    }

    proptest! {
        #[test]
        fn a_marking_reads_back_from_its_compact_form_as_it_was(
            places in 1usize..400,
            counts in proptest::collection::vec((0u32..400, 0u32..300), 0..40),
        ) {
            round_trip::<Bits>(places, &counts)?;
            round_trip::<Bytes>(places, &counts)?;
        }
    }

    /// The marking of `net` with `counts` tokens on its first places (at
    /// most what the encoding holds).
    pub(super) fn marking_of<E: Encoding>(net: &PtNet, counts: &[u32]) -> Vec<u64> {
        let mut m = vec![0u64; E::words(net.n_places())];
        for (p, &c) in counts.iter().enumerate().take(net.n_places()) {
            E::set(&mut m, p as u32, c.min(E::MAX));
        }
        m
    }

    /// What [`overflow`] says of every enabled transition of every
    /// marking, against firing it.
    fn overflow_as_fired<E: Encoding>(net: &PtNet, counts: &[u32]) -> Result<(), TestCaseError> {
        let m = marking_of::<E>(net, counts);
        let mut out = m.clone();
        for t in (0..net.n_real).filter(|&t| enabled::enabled::<E>(net, &m, t)) {
            prop_assert_eq!(
                overflow::<E>(net, &m, t),
                fire::<E>(net, &m, t, &mut out).err(),
                "t{}",
                t
            );
        }
        Ok(())
    }

    proptest! {
        #[test]
        fn a_transition_overflows_where_firing_it_would(
            (n, initial, ts) in crate::testnet::random(),
            counts in proptest::collection::vec(0u32..4, 8),
        ) {
            let net = crate::testnet::net(n, &initial, &ts);
            overflow_as_fired::<Bits>(&net, &counts)?;
            overflow_as_fired::<Bytes>(&net, &counts)?;
            let near_full: Vec<u32> = counts.iter().map(|c| 252 + c).collect();
            overflow_as_fired::<Bytes>(&net, &near_full)?;
        }
    }

    #[test]
    fn a_sparse_marking_of_a_large_net_costs_bytes_not_kilobytes() {
        let places = 35_000;
        let mut m = vec![0u64; Bits::words(places)];
        for k in 0..40 {
            Bits::set(&mut m, k * 800 + 7, 1);
        }
        let mut bytes = Vec::new();
        Bits::encode(&m, &mut bytes);
        assert!(bytes.len() <= 80, "{} bytes", bytes.len());
    }
}
