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

/// A symmetric place-by-place bit matrix.
pub(crate) struct Concurrency {
    n: usize,
    words: usize,
    bits: Vec<u64>,
    /// Transitions and outputs that could get a second token.
    unsafe_pairs: Vec<(u32, u32)>,
}

impl Concurrency {
    pub(crate) fn compute(net: &PtNet) -> Self {
        let n = net.n_places();
        let words = n.div_ceil(64).max(1);
        let mut c = Concurrency {
            n,
            words,
            bits: vec![0; n * words],
            unsafe_pairs: Vec::new(),
        };
        let marked: Vec<u32> = (0..n as u32)
            .filter(|&p| net.initial[p as usize] > 0)
            .collect();
        for &p in &marked {
            for &q in &marked {
                if p != q {
                    c.set(p, q);
                }
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
            for &p in out {
                for &q in out {
                    if p != q {
                        c.set(p, q);
                    }
                }
            }
        }
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
                    c.join_row(p, &compatible, &mut grown);
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
    fn compatible(&self, net: &PtNet, t: usize, inputs: &[u32], out: &mut [u64]) {
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
            let row = self.row(q);
            for (o, r) in out.iter_mut().zip(row) {
                *o &= *r;
            }
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

    /// Makes `p` concurrent with every place of `with` (but itself), and
    /// pushes onto `grown` every place whose row got a new pair (`p` first,
    /// then the new partners). Whole words first, single bits only for the
    /// new pairs (to keep the matrix symmetric): each pair of the relation
    /// is set once, however many times the fixpoint visits it.
    fn join_row(&mut self, p: u32, with: &[u64], grown: &mut Vec<u32>) {
        let base = p as usize * self.words;
        let mut changed = false;
        for (wi, &w) in with.iter().enumerate() {
            let mut new = w & !self.bits[base + wi];
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
            self.bits[base + wi] |= new;
            while new != 0 {
                let x = wi * 64 + new.trailing_zeros() as usize;
                new &= new - 1;
                self.bits[x * self.words + p as usize / 64] |= 1 << (p % 64);
                grown.push(x as u32);
            }
        }
    }

    fn row(&self, p: u32) -> &[u64] {
        &self.bits[p as usize * self.words..(p as usize + 1) * self.words]
    }

    fn set(&mut self, p: u32, q: u32) {
        self.bits[p as usize * self.words + q as usize / 64] |= 1 << (q % 64);
        self.bits[q as usize * self.words + p as usize / 64] |= 1 << (p % 64);
    }

    pub(crate) fn get(&self, p: u32, q: u32) -> bool {
        self.bits[p as usize * self.words + q as usize / 64] >> (q % 64) & 1 == 1
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

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

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
