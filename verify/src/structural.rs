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

use crate::ptnet::PtNet;
use crate::relation::{Relation, Run};

/// The relation, and what it says about 1-safety.
pub(crate) struct Concurrency {
    n: usize,
    /// A bit matrix, or runs of places for a large net (`relation.rs`).
    pairs: Relation,
    /// Transitions and outputs that could get a second token.
    unsafe_pairs: Vec<(u32, u32)>,
}

impl Concurrency {
    pub(crate) fn compute(net: &PtNet) -> Self {
        Self::compute_in(net, Relation::new(net.n_places()))
    }

    /// The relation of `net`, built in `pairs` (empty, over its places).
    fn compute_in(net: &PtNet, pairs: Relation) -> Self {
        let n = net.n_places();
        let words = crate::relation::words(n);
        let mut c = Concurrency {
            n,
            pairs,
            unsafe_pairs: Vec::new(),
        };
        let marked: Vec<u32> = (0..n as u32)
            .filter(|&p| net.initial[p as usize] > 0)
            .collect();
        for (i, &p) in marked.iter().enumerate() {
            for &q in &marked[i + 1..] {
                c.pairs.relate(p, q);
            }
        }
        // Inputs and outputs with read arcs counted on both sides.
        let inputs: Vec<Vec<u32>> = (0..net.n_real)
            .map(|t| {
                let mut v: Vec<u32> = net
                    .pre
                    .get(t)
                    .iter()
                    .chain(net.read.get(t))
                    .map(|&(p, _)| p)
                    .collect();
                v.sort_unstable();
                v.dedup();
                v
            })
            .collect();
        let outputs: Vec<Vec<u32>> = (0..net.n_real)
            .map(|t| {
                let mut v: Vec<u32> = net
                    .post
                    .get(t)
                    .iter()
                    .chain(net.read.get(t))
                    .map(|&(p, _)| p)
                    .collect();
                v.sort_unstable();
                v.dedup();
                v
            })
            .collect();
        for out in &outputs {
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
        // of a 20,000-node mission: 144 sweeps of 34,000 transitions.)
        let mut grown_at = vec![1u64; n];
        let mut seen_at = vec![0u64; inputs.len()];
        let mut clock = 1u64;
        let mut compatible = vec![0u64; words];
        let mut row = vec![0u64; words];
        let mut runs = Vec::new();
        let mut grown = Vec::new();
        loop {
            let mut changed = false;
            for (t, ins) in inputs.iter().enumerate() {
                let stale =
                    seen_at[t] == 0 || ins.iter().any(|&p| grown_at[p as usize] > seen_at[t]);
                if !stale {
                    continue;
                }
                clock += 1;
                seen_at[t] = clock;
                c.compatible(net, t, ins, &mut compatible);
                for &p in &outputs[t] {
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
        for (t, ins) in inputs.iter().enumerate() {
            c.compatible(net, t, ins, &mut compatible);
            for &(p, _) in net.post.get(t) {
                let consumed = net.pre.get(t).iter().any(|&(q, _)| q == p);
                if !consumed && compatible[p as usize / 64] >> (p % 64) & 1 == 1 {
                    c.unsafe_pairs.push((t as u32, p));
                }
            }
        }
        c
    }

    /// Places that can be marked while `t` is enabled and that `t` leaves
    /// alone: concurrent with (or equal to) each input, and not consumed.
    fn compatible(&mut self, net: &PtNet, t: usize, inputs: &[u32], out: &mut [u64]) {
        out.iter_mut().for_each(|w| *w = !0);
        if let Some(last) = out.last_mut() {
            let rem = self.n % 64;
            if rem != 0 {
                *last = (1u64 << rem) - 1;
            }
        }
        if self.n == 0 {
            out.iter_mut().for_each(|w| *w = 0);
        }
        for &q in inputs {
            self.pairs.and_into(q, out);
            out[q as usize / 64] |= (1u64 << (q % 64)) & self.row_mask(q, inputs);
        }
        for &(p, _) in net.pre.get(t) {
            out[p as usize / 64] &= !(1u64 << (p % 64));
        }
    }

    /// `q` itself counts as compatible with input `q` only if it is also
    /// concurrent with every other input.
    fn row_mask(&self, q: u32, inputs: &[u32]) -> u64 {
        if inputs.iter().all(|&o| o == q || self.get(q, o)) {
            !0
        } else {
            0
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
        self.pairs.get(p, q)
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
    use crate::testnet::{net, random, safe_markings};
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

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

        #[test]
        fn the_relation_is_the_one_the_rules_give((n, initial, ts) in random()) {
            let net = net(n, &initial, &ts);
            let (rules, unsafe_pairs) = by_the_rules(&net);
            for pairs in [Relation::matrix(n), Relation::runs(n)] {
                let c = Concurrency::compute_in(&net, pairs);
                for p in 0..n as u32 {
                    for q in 0..n as u32 {
                        prop_assert_eq!(c.get(p, q), rules[p as usize][q as usize], "{} and {}", p, q);
                    }
                }
                prop_assert_eq!(c.unsafe_candidates(), &unsafe_pairs[..]);
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
