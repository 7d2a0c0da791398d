//! A structural over-approximation of which places can be marked together.
//!
//! Exploration has to look for pairs of places marked at once (two running
//! actions of one drone) and for transitions that could fire into a marked
//! place (two tokens). Watching every pair would pull every branch into every
//! stubborn set; instead this module computes, without exploring, a relation
//! `p || q` that holds for every pair that *can* be marked together in a
//! reachable marking of a 1-safe net (the concurrency relation of Kovalyov and
//! Esparza, widened to read arcs, which count as consuming and producing the
//! place they read). Exploration then only watches the pairs in the relation.
//!
//! The rules, applied until nothing changes:
//! 1. two places marked at the start are concurrent;
//! 2. two places a transition produces (or reads) are concurrent;
//! 3. a place `x` that is concurrent with every input of a transition `t`
//!    and not consumed by `t` is concurrent with every output of `t`.
//!
//! Soundness, by induction over firing sequences of a safe net: if `p` and
//! `q` are marked after `M -t-> M'`, either both were marked in `M` (then
//! the relation already has them), or `t` produced both (rule 2), or `t`
//! produced one while the other, untouched by `t`, was marked together with
//! all of `t`'s inputs (rule 3). The same induction proves the net 1-safe when
//! no transition `t` has an output `p`, outside its inputs, that is
//! concurrent with all of `t`'s inputs: that is how [`Concurrency::unsafe_candidates`]
//! is used.
//!
//! The relation is computed over classes of places that the rules give
//! equal rows (the places of a chain, see [`chains`]), and read back
//! place by place.

use crate::ptnet::{Csr, PtNet};
use crate::relation::{Relation, Run};

/// Inputs with more producers than this, and transitions with more
/// places around them than that, get no pairs in
/// [`Concurrency::mutex_inputs`].
const MUTEX_PRODUCERS: usize = 8;
const MUTEX_AROUND: usize = 16;

/// The relation, and what it says about 1-safety.
pub(crate) struct Concurrency {
    /// The class of every place, whose row it shares (see [`chains`]).
    class: Vec<u32>,
    classes: usize,
    /// A bit matrix, or runs of classes for a large net (`relation.rs`).
    pairs: Relation,
    /// Transitions and outputs that could get a second token.
    unsafe_pairs: Vec<(u32, u32)>,
}

/// The arcs the rules read, over classes of places, a list per
/// transition. Flat: rule 3's sweeps read every transition's lists, and a
/// heap block each (three per transition, 20,000 transitions at 500
/// drones) missed the cache on most reads.
struct ClassArcs {
    /// Consumed, and consumed or read.
    consumed: Csr<u32>,
    inputs: Csr<u32>,
    /// Produced or read.
    outputs: Csr<u32>,
}

impl ClassArcs {
    fn of(net: &PtNet, class: &[u32]) -> Self {
        let mut arcs = ClassArcs {
            consumed: Csr::default(),
            inputs: Csr::default(),
            outputs: Csr::default(),
        };
        let mut v: Vec<u32> = Vec::new();
        let mut push = |to: &mut Csr<u32>, lists: &[&[(u32, u32)]]| {
            v.clear();
            v.extend(
                lists
                    .iter()
                    .flat_map(|l| l.iter().map(|&(p, _)| class[p as usize])),
            );
            v.sort_unstable();
            v.dedup();
            to.push(v.iter().copied());
        };
        for t in 0..net.n_real {
            let (pre, read, post) = (net.pre.get(t), net.read.get(t), net.post.get(t));
            push(&mut arcs.consumed, &[pre]);
            push(&mut arcs.inputs, &[pre, read]);
            push(&mut arcs.outputs, &[post, read]);
        }
        arcs
    }
}

/// Classes of places whose rows are equal by the rules, in a net where no
/// transition can put a second token anywhere: the places of a chain
/// `a -c-> b`, where `c` takes `a` alone and puts `b` alone, `a` has no
/// other consumer, `b` no other producer, neither is read and `b` is not
/// marked at the start. By induction over the rules: every place that
/// rule 3 relates to `a` is related to `b` through `c`; `b` is related to
/// nothing else, as only `c` produces it and a transition that may fire
/// beside `b` may fire beside `a` (it consumes neither, as only `c`
/// consumes `a`); and two places of one chain are related only where a
/// transition may put the chain's first place beside it, an unsafe pair,
/// where the relation is computed again over every place. Stretches of a
/// drone's flow are such chains: a generated fleet has a class for about
/// a third of its places (3,188 for 9,867 at 250 drones, 12,758 for
/// 39,565 at 1,000), so the relation has a tenth of the pairs to set.
///
/// The class of each place, numbered in the order of their first places
/// (a drone's places stay together), and how many.
fn chains(net: &PtNet) -> (Vec<u32>, usize) {
    let n = net.n_places();
    // Arcs counted over the real transitions, produce arcs each one:
    // `PtNet::producers` leaves out a transition that puts back what it
    // takes, which the rules count as producing it.
    let mut consumed = vec![0u32; n];
    let mut produced = vec![0u32; n];
    let mut read = vec![false; n];
    for t in 0..net.n_real {
        net.pre
            .get(t)
            .iter()
            .for_each(|&(p, _)| consumed[p as usize] += 1);
        net.post
            .get(t)
            .iter()
            .for_each(|&(p, _)| produced[p as usize] += 1);
        net.read
            .get(t)
            .iter()
            .for_each(|&(p, _)| read[p as usize] = true);
    }
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for t in 0..net.n_real {
        let (&[(a, _)], &[(b, _)], &[]) = (net.pre.get(t), net.post.get(t), net.read.get(t)) else {
            continue;
        };
        let (ai, bi) = (a as usize, b as usize);
        if a == b || consumed[ai] != 1 || produced[bi] != 1 || read[ai] || read[bi] {
            continue;
        }
        if net.initial[bi] != 0 {
            continue;
        }
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
    let mut class = vec![u32::MAX; n];
    let mut classes = 0;
    for p in 0..n as u32 {
        let r = root(&mut parent, p) as usize;
        if class[r] == u32::MAX {
            class[r] = classes;
            classes += 1;
        }
        class[p as usize] = class[r];
    }
    (class, classes as usize)
}

impl Concurrency {
    pub(crate) fn compute(net: &PtNet) -> Self {
        let (class, classes) = chains(net);
        if classes < net.n_places() {
            let c = Self::compute_in(net, class, classes, Relation::new(classes));
            if c.unsafe_pairs.is_empty() {
                return c;
            }
        }
        Self::by_place(net, Relation::new(net.n_places()))
    }

    /// The relation of `net` with every place a class of its own, built
    /// in `pairs` (empty, over its places).
    fn by_place(net: &PtNet, pairs: Relation) -> Self {
        let n = net.n_places();
        Self::compute_in(net, (0..n as u32).collect(), n, pairs)
    }

    /// The relation of `net` over the classes `class` (see [`chains`]),
    /// built in `pairs` (empty, over `classes`).
    fn compute_in(net: &PtNet, class: Vec<u32>, classes: usize, pairs: Relation) -> Self {
        let n = classes;
        let words = crate::relation::words(n);
        let arcs = ClassArcs::of(net, &class);
        let mut c = Concurrency {
            class,
            classes,
            pairs,
            unsafe_pairs: Vec::new(),
        };
        let mut marked: Vec<u32> = (0..net.n_places())
            .filter(|&p| net.initial[p] > 0)
            .map(|p| c.class[p])
            .collect();
        marked.sort_unstable();
        marked.dedup();
        for (i, &p) in marked.iter().enumerate() {
            for &q in &marked[i + 1..] {
                c.pairs.relate(p, q);
            }
        }
        for t in 0..arcs.outputs.len() {
            let out = arcs.outputs.get(t);
            for (i, &p) in out.iter().enumerate() {
                for &q in &out[i + 1..] {
                    c.pairs.relate(p, q);
                }
            }
        }
        c.pairs.settle_all();
        // Rule 3 to its fixpoint, in sweeps over the transitions (in id
        // order, which the net compiler makes follow the mission, so most
        // of the relation flows down a drone's chain in one sweep). A
        // transition is evaluated again only when the row of one of its
        // inputs grew since it last was: `compatible(t)` reads only those.
        // (Evaluating every transition on every sweep cost most of a check
        // of a 20,000-node mission: 144 sweeps of 34,000 transitions.) A
        // transition within one class relates nothing new.
        let moving: Vec<usize> = (0..arcs.inputs.len())
            .filter(|&t| {
                let outs = arcs.outputs.get(t);
                !(outs.len() == 1 && outs == arcs.inputs.get(t))
            })
            .collect();
        let mut grown_at = vec![1u64; n];
        let mut seen_at = vec![0u64; arcs.inputs.len()];
        let mut clock = 1u64;
        let mut compatible = vec![0u64; words];
        let mut row = vec![0u64; words];
        let mut runs = Vec::new();
        let mut grown = Vec::new();
        loop {
            let mut changed = false;
            for &t in &moving {
                let (ins, outs) = (arcs.inputs.get(t), arcs.outputs.get(t));
                let stale =
                    seen_at[t] == 0 || ins.iter().any(|&p| grown_at[p as usize] > seen_at[t]);
                if !stale {
                    continue;
                }
                clock += 1;
                seen_at[t] = clock;
                c.compatible(ins, arcs.consumed.get(t), &mut compatible);
                for &p in outs {
                    c.join_row(p, &compatible, (&mut row, &mut runs), &mut grown);
                }
                if !grown.is_empty() {
                    changed = true;
                    clock += 1;
                    for x in grown.drain(..) {
                        grown_at[x as usize] = clock;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        c.pairs.settle_all();
        for t in 0..arcs.inputs.len() {
            c.compatible(arcs.inputs.get(t), arcs.consumed.get(t), &mut compatible);
            for &(p, _) in net.post.get(t) {
                let k = c.class[p as usize];
                let consumed = arcs.consumed.get(t).contains(&k);
                if !consumed && compatible[k as usize / 64] >> (k % 64) & 1 == 1 {
                    c.unsafe_pairs.push((t as u32, p));
                }
            }
        }
        c
    }

    /// Classes that can be marked while a transition with `inputs` is
    /// enabled and that it leaves alone: concurrent with (or equal to)
    /// each input, and not `consumed`.
    fn compatible(&mut self, inputs: &[u32], consumed: &[u32], out: &mut [u64]) {
        out.iter_mut().for_each(|w| *w = !0);
        if let Some(last) = out.last_mut() {
            let rem = self.classes % 64;
            if rem != 0 {
                *last = (1u64 << rem) - 1;
            }
        }
        if self.classes == 0 {
            out.iter_mut().for_each(|w| *w = 0);
        }
        // Each input's row and the input itself: an input stays only if
        // it is concurrent with every other input (the relation is
        // symmetric), which asking each pair of inputs did at the square
        // of a join's inputs (a fleet-wide block's join has one a drone).
        for &q in inputs {
            let (w, bit) = (q as usize / 64, 1u64 << (q % 64));
            let own = out[w] & bit;
            self.pairs.and_into(q, out);
            out[w] |= own;
        }
        for &p in consumed {
            out[p as usize / 64] &= !(1u64 << (p % 64));
        }
    }

    /// Makes `p` concurrent with every place of `with`, and pushes onto
    /// `grown` every place whose row got a new pair (`p` first, then the
    /// new partners). Row `p` takes the new pairs at once; each partner's
    /// half is queued on its row (see `relation.rs`), so that each pair of
    /// the relation is set once, however many times the fixpoint visits it.
    /// `row` and `runs` are room to work in.
    fn join_row(
        &mut self,
        p: u32,
        with: &[u64],
        (row, runs): (&mut [u64], &mut Vec<Run>),
        grown: &mut Vec<u32>,
    ) {
        self.pairs.copy_into(p, row);
        // Mostly nothing is new (a transition is looked at again whenever
        // an input's row grew): found in one pass the compiler vectorises.
        // (`p` is not new to its own row.)
        let (pw, pbit) = (p as usize / 64, 1u64 << (p % 64));
        let had = row[pw] & pbit;
        row[pw] |= pbit;
        let fresh = with
            .iter()
            .zip(row.iter())
            .fold(0, |a, (w, r)| a | (w & !r));
        row[pw] = (row[pw] & !pbit) | had;
        if fresh == 0 {
            return;
        }
        let mut changed = false;
        for (wi, &w) in with.iter().enumerate() {
            let mut new = w & !row[wi];
            if wi == p as usize / 64 {
                new &= !(1u64 << (p % 64));
            }
            if new == 0 {
                continue;
            }
            if !changed {
                changed = true;
                grown.push(p);
            }
            row[wi] |= new;
            while new != 0 {
                let x = wi * 64 + new.trailing_zeros() as usize;
                new &= new - 1;
                self.pairs.queue(x as u32, p);
                grown.push(x as u32);
            }
        }
        if changed {
            self.pairs.replace(p, row, runs);
        }
    }

    pub(crate) fn get(&self, p: u32, q: u32) -> bool {
        let (a, b) = (self.class[p as usize], self.class[q as usize]);
        a != b && self.pairs.get(a, b)
    }

    /// Per real transition `u` of `net` (monitors, which only read and
    /// come after them, have no list: see `Csr::get_or_none`), the pairs
    /// `(p, c)` of an input `p` and another place `c` around `u` (an input
    /// or an output) such that no producer of `p` can fire while `c` is
    /// marked: each has an input that is never marked together with `c`.
    /// Where `p` is empty and `c` marked, `u` can be enabled only once a
    /// consumer of `c` has emptied it, so those consumers are a necessary
    /// enabling set of `u` (see `waits_on_the_set` in `explore.rs`): a few
    /// transitions beside the current ones, where the producers of `p`
    /// would lead back through every step of the mission that came before
    /// (a `Do` region's fork, whose output is still marked, back to the
    /// mission's start). The relation is over the first `known` places
    /// (the net may have more, with copies of transitions: the spatial
    /// check's rest records), and only holds of a 1-safe net.
    pub(crate) fn mutex_inputs(&self, net: &PtNet, known: usize) -> Csr<(u32, u32)> {
        let inputs = |t: usize| net.pre.get(t).iter().chain(net.read.get(t));
        let never_with = |t: usize, c: u32| {
            inputs(t).any(|&(q, _)| (q as usize) < known && q != c && !self.get(q, c))
        };
        let lists: Vec<Vec<(u32, u32)>> = (0..net.n_real)
            .map(|u| {
                let mut pairs = Vec::new();
                // A fleet-wide join has a thousand inputs: a million
                // pairs, each a few lookups, for one transition.
                let around = net.pre.get(u).len() + net.read.get(u).len() + net.post.get(u).len();
                if around > MUTEX_AROUND {
                    return pairs;
                }
                for &(p, w) in inputs(u) {
                    if w != 1 || p as usize >= known {
                        continue;
                    }
                    let producers = net.producers.get(p as usize);
                    // A place filled from everywhere (an event signalled
                    // by many drones) would cost more than it saves.
                    if producers.len() > MUTEX_PRODUCERS {
                        continue;
                    }
                    for &(c, _) in inputs(u).chain(net.post.get(u)) {
                        let fits = c != p
                            && (c as usize) < known
                            && producers
                                .iter()
                                .all(|&t| t as usize == u || never_with(t as usize, c));
                        if fits {
                            pairs.push((p, c));
                        }
                    }
                }
                pairs
            })
            .collect();
        Csr::from_lists(&lists)
    }

    /// Pairs `(t, p)` where `t` might fire into an already marked `p`. Empty
    /// means the net is 1-safe (if its initial marking is).
    pub(crate) fn unsafe_candidates(&self) -> &[(u32, u32)] {
        &self.unsafe_pairs
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::{net, random, safe_markings, Arcs};
    use proptest::prelude::*;

    /// The rules as written, on a matrix of booleans, applied to every
    /// transition until nothing changes: what the relation, its work list
    /// and its runs are held against. Also the unsafe pairs, by their
    /// definition.
    fn by_the_rules(net: &PtNet) -> (Vec<Vec<bool>>, Vec<(u32, u32)>) {
        let n = net.n_places();
        let mut r = vec![vec![false; n]; n];
        let marked: Vec<usize> = (0..n).filter(|&p| net.initial[p] > 0).collect();
        for &p in &marked {
            for &q in &marked {
                r[p][q] = p != q;
            }
        }
        let places = |arcs: &[&[(u32, u32)]]| -> Vec<usize> {
            let mut v: Vec<usize> = arcs
                .iter()
                .flat_map(|a| a.iter().map(|&(p, _)| p as usize))
                .collect();
            v.sort_unstable();
            v.dedup();
            v
        };
        let ins = |t: usize| places(&[net.pre.get(t), net.read.get(t)]);
        let outs = |t: usize| places(&[net.post.get(t), net.read.get(t)]);
        let consumed = |t: usize| places(&[net.pre.get(t)]);
        let compatible = |r: &Vec<Vec<bool>>, t: usize, x: usize| {
            let i = ins(t);
            !consumed(t).contains(&x)
                && i.iter()
                    .all(|&q| r[q][x] || (x == q && i.iter().all(|&o| o == q || r[q][o])))
        };
        for t in 0..net.n_real {
            for &p in &outs(t) {
                for &q in &outs(t) {
                    r[p][q] |= p != q;
                }
            }
        }
        loop {
            let mut changed = false;
            for t in 0..net.n_real {
                for x in 0..n {
                    if !compatible(&r, t, x) {
                        continue;
                    }
                    for p in outs(t) {
                        if p != x && !r[x][p] {
                            r[x][p] = true;
                            r[p][x] = true;
                            changed = true;
                        }
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let mut unsafe_pairs = Vec::new();
        for t in 0..net.n_real {
            for &(p, _) in net.post.get(t) {
                if compatible(&r, t, p as usize) {
                    unsafe_pairs.push((t as u32, p));
                }
            }
        }
        (r, unsafe_pairs)
    }

    /// `net`'s arcs with some produce arcs `t -> p` cut into a chain
    /// `t -> x1 -> ... -> xk -> p` through new places and transitions:
    /// `(t, i, k)` cuts the `i`-th output of transition `t` (both taken
    /// modulo what there is) `k` times.
    fn with_chains(
        mut n: usize,
        mut initial: Vec<bool>,
        mut ts: Vec<Arcs>,
        cuts: &[(usize, usize, usize)],
    ) -> (usize, Vec<bool>, Vec<Arcs>) {
        for &(t, i, k) in cuts {
            let t = t % ts.len();
            if ts[t].2.is_empty() {
                continue;
            }
            let i = i % ts[t].2.len();
            for _ in 0..k {
                let p = ts[t].2[i];
                let x = n as u32;
                n += 1;
                initial.push(false);
                ts[t].2[i] = x;
                ts.push((vec![x], vec![], vec![p]));
            }
        }
        (n, initial, ts)
    }

    #[test]
    fn the_places_of_a_chain_share_a_class_and_a_row() {
        // p0 -t0-> p1 -t1-> p2, beside p3 -t2-> p4.
        let ts = vec![
            (vec![0], vec![], vec![1]),
            (vec![1], vec![], vec![2]),
            (vec![3], vec![], vec![4]),
        ];
        let net = net(5, &[true, false, false, true, false], &ts);
        let (class, classes) = chains(&net);
        assert_eq!(classes, 2);
        assert_eq!(class, [0, 0, 0, 1, 1]);
        let c = Concurrency::compute(&net);
        for p in 0..3 {
            for q in 3..5 {
                assert!(c.get(p, q) && c.get(q, p), "p{p} and p{q}");
            }
            assert!(!c.get(p, (p + 1) % 3));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

        #[test]
        fn the_relation_is_the_one_the_rules_give((n, initial, ts) in random()) {
            let net = net(n, &initial, &ts);
            let (rules, unsafe_pairs) = by_the_rules(&net);
            for pairs in [Relation::matrix(n), Relation::runs(n)] {
                let c = Concurrency::by_place(&net, pairs);
                for p in 0..n as u32 {
                    for q in 0..n as u32 {
                        prop_assert_eq!(c.get(p, q), rules[p as usize][q as usize], "{} and {}", p, q);
                    }
                }
                prop_assert_eq!(c.unsafe_candidates(), &unsafe_pairs[..]);
            }
        }

        /// The relation over chains' classes, falling back to places where
        /// a transition may put a second token, is the relation by the rules,
        /// on random nets whose arcs are cut into chains here and there.
        #[test]
        fn the_relation_over_chains_is_the_one_the_rules_give(
            (n, initial, ts) in random(),
            cuts in prop::collection::vec((0usize..8, 0usize..3, 1usize..3), 0..6),
        ) {
            let (n, initial, ts) = with_chains(n, initial, ts, &cuts);
            let net = net(n, &initial, &ts);
            let (rules, unsafe_pairs) = by_the_rules(&net);
            let c = Concurrency::compute(&net);
            for p in 0..n as u32 {
                for q in 0..n as u32 {
                    prop_assert_eq!(c.get(p, q), rules[p as usize][q as usize], "{} and {}", p, q);
                }
            }
            prop_assert_eq!(c.unsafe_candidates(), &unsafe_pairs[..]);
        }

        /// Where `(p, c)` is a pair of `u`, no producer of `p` but `u` is
        /// enabled in a reachable marking with `c` marked: `p` is filled
        /// only once `c` is empty.
        #[test]
        fn no_producer_of_a_mutex_input_is_enabled_beside_its_pair(
            (n, initial, ts) in random(),
        ) {
            let net = net(n, &initial, &ts);
            let pairs = Concurrency::compute(&net).mutex_inputs(&net, n);
            let enabled = |m: &[bool], t: usize| {
                net.pre.get(t).iter().chain(net.read.get(t)).all(|&(q, _)| m[q as usize])
            };
            for m in safe_markings(&net) {
                for u in 0..net.n_real {
                    for &(p, c) in pairs.get(u) {
                        for &t in net.producers.get(p as usize) {
                            prop_assert!(
                                t as usize == u || !m[c as usize] || !enabled(&m, t as usize),
                                "t{t} fills p{p} with p{c} marked in {m:?} (pair of t{u})"
                            );
                        }
                    }
                }
            }
        }

        #[test]
        fn every_pair_of_places_marked_together_is_in_the_relation((n, initial, ts) in random()) {
            let net = net(n, &initial, &ts);
            let c = Concurrency::compute(&net);
            for m in safe_markings(&net) {
                for p in 0..n as u32 {
                    for q in 0..n as u32 {
                        if p != q && m[p as usize] && m[q as usize] {
                            prop_assert!(c.get(p, q), "{p} and {q} marked together in {m:?}");
                        }
                    }
                }
            }
        }
    }
}
