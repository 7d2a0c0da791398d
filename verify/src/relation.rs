//! A symmetric relation over places, row by row: bits, or for a large
//! net the runs of consecutive places related to each place. (The
//! concurrency relation holds it over classes of places, `structural.rs`;
//! what is said here of places holds of those classes.)
//!
//! The concurrency relation (`structural.rs`) relates 6-8 % of all pairs
//! of places of a generated mission, a number quadratic in its size: as a
//! bit matrix it was 196 MB at 1,000 drones (40,000 places), most of a
//! check's memory. The net compiler numbers a drone's places along its
//! flow, so a row is a few runs of consecutive places (about 0.18 times
//! the fleet's size), a fraction of its bits.
//!
//! Places along one stretch of a drone's flow, between two meetings with
//! other drones, are concurrent with the same places: their rows are
//! equal. Each distinct row is kept once and shared (a quarter of the rows
//! of a generated mission are distinct, at 500 and at 1,000 drones).
//!
//! Setting one pair into a list of runs is a search and an insertion, and
//! the relation's fixpoint sets each of its pairs' second halves one by
//! one (27 million at 500 drones). They are queued on their row instead
//! and merged in at once when the queue grows as long as the row; a row
//! is read as its runs and its queue together, and a row replaced whole
//! takes its queue in.

use std::sync::Arc;

use rustc_hash::FxHashSet;

/// Places `start..end`, the runs of a row sorted, apart and not touching.
pub(crate) type Run = (u32, u32);

/// The relation as runs.
pub(crate) struct Runs {
    n: usize,
    rows: Vec<Arc<[Run]>>,
    /// Every row held, once: a row's runs are shared by every row equal
    /// to it, and dropped with the last of them.
    distinct: FxHashSet<Arc<[Run]>>,
    queued: Vec<Vec<u32>>,
    /// Room to work in: the queued places a row read keeps; a row merged.
    kept: Vec<u32>,
    merged: Vec<Run>,
}

impl Runs {
    fn new(n: usize) -> Self {
        let empty: Arc<[Run]> = Arc::new([]);
        Runs {
            n,
            rows: vec![empty.clone(); n],
            distinct: FxHashSet::from_iter([empty]),
            queued: vec![Vec::new(); n],
            kept: Vec::new(),
            merged: Vec::new(),
        }
    }

    /// Row `p` becomes `runs`, shared with the rows equal to it.
    fn set_row(&mut self, p: u32, runs: &[Run]) {
        let row = match self.distinct.get(runs) {
            Some(row) => row.clone(),
            None => {
                let row: Arc<[Run]> = runs.into();
                self.distinct.insert(row.clone());
                row
            }
        };
        let old = std::mem::replace(&mut self.rows[p as usize], row);
        // Held by the set alone once this row lets it go.
        if Arc::strong_count(&old) == 2 {
            self.distinct.remove(&*old);
        }
    }

    fn queue(&mut self, p: u32, q: u32) {
        let row = p as usize;
        self.queued[row].push(q);
        if self.queued[row].len() > self.rows[row].len().max(32) {
            self.settle(p);
        }
    }

    /// Merges row `p`'s queue into its runs.
    fn settle(&mut self, p: u32) {
        let row = p as usize;
        if self.queued[row].is_empty() {
            return;
        }
        let mut points = std::mem::take(&mut self.queued[row]);
        points.sort_unstable();
        points.dedup();
        let mut merged = std::mem::take(&mut self.merged);
        merge(&self.rows[row], &points, &mut merged);
        self.set_row(p, &merged);
        self.merged = merged;
        forget(&mut points);
        self.queued[row] = points;
    }

    fn settle_all(&mut self) {
        for p in 0..self.n as u32 {
            self.settle(p);
        }
    }

    /// Whether `p` and `q` are related.
    fn get(&self, p: u32, q: u32) -> bool {
        let row = &self.rows[p as usize];
        let i = row.partition_point(|&(start, _)| start <= q);
        (i > 0 && q < row[i - 1].1) || self.queued[p as usize].contains(&q)
    }

    /// Clears in `bits` every place outside row `p`.
    fn and_into(&mut self, p: u32, bits: &mut [u64]) {
        let queued = &self.queued[p as usize];
        self.kept.clear();
        self.kept.extend(
            queued
                .iter()
                .filter(|&&q| bits[q as usize / 64] >> (q % 64) & 1 == 1),
        );
        let mut at = 0;
        for &(start, end) in self.rows[p as usize].iter() {
            fill(bits, at, start, false);
            at = end;
        }
        fill(bits, at, bits.len() as u32 * 64, false);
        for &q in &self.kept {
            bits[q as usize / 64] |= 1 << (q % 64);
        }
    }

    /// Row `p` as bits.
    fn copy_into(&self, p: u32, bits: &mut [u64]) {
        bits.fill(0);
        for &(start, end) in self.rows[p as usize].iter() {
            fill(bits, start, end, true);
        }
        for &q in &self.queued[p as usize] {
            bits[q as usize / 64] |= 1 << (q % 64);
        }
    }

    /// Row `p` becomes `bits`, which hold all of it (its queue too);
    /// `runs` is room to build it in.
    fn replace(&mut self, p: u32, bits: &[u64], runs: &mut Vec<Run>) {
        runs_of(bits, runs);
        self.set_row(p, runs);
        forget(&mut self.queued[p as usize]);
    }
}

/// Up to this many places (or classes of places) the relation is a bit
/// matrix (at most 8 MB), the quicker to compute; beyond, runs. The bound
/// was 4,096 when the relation was over places: at 250 drones (9,867
/// places) runs took the check from 37 to 30 MB and from 0.23 to 0.29 s,
/// and at 20,000 and 40,000 places, where a matrix would be 50 and 200
/// MB, the distinct rows hold 0.42 and 1.35 million runs, 3.3 and 10.8 MB.
/// Over classes (`structural.rs`) a net has a third as many: 6,310 at 500
/// drones, where the matrix (5 MB) took the check from 0.45 to 0.31 s and
/// left its peak where it was (54.1 and 54.4 MB: the relation is gone
/// before the exploration peaks); 12,758 at 1,000, where runs stay.
const MATRIX_UP_TO: usize = 8_192;

/// A symmetric relation over places.
pub(crate) enum Relation {
    Matrix(Matrix),
    Runs(Runs),
}

impl Relation {
    /// The empty relation over `n` places, in the form for its size.
    pub(crate) fn new(n: usize) -> Self {
        if n <= MATRIX_UP_TO {
            Self::matrix(n)
        } else {
            Self::runs(n)
        }
    }

    pub(crate) fn matrix(n: usize) -> Self {
        let words = words(n);
        Relation::Matrix(Matrix {
            words,
            bits: vec![0; n * words],
        })
    }

    pub(crate) fn runs(n: usize) -> Self {
        Relation::Runs(Runs::new(n))
    }

    /// Relates `p` and `q`, `p != q`.
    pub(crate) fn relate(&mut self, p: u32, q: u32) {
        self.queue(p, q);
        self.queue(q, p);
    }

    /// Puts `q` in row `p` (at once, or once its queue is merged in: it
    /// is read as if at once).
    pub(crate) fn queue(&mut self, p: u32, q: u32) {
        match self {
            Relation::Matrix(m) => m.bits[p as usize * m.words + q as usize / 64] |= 1 << (q % 64),
            Relation::Runs(r) => r.queue(p, q),
        }
    }

    /// Merges every row's queue into its runs: the relation at its most
    /// compact.
    pub(crate) fn settle_all(&mut self) {
        if let Relation::Runs(r) = self {
            r.settle_all();
        }
    }

    pub(crate) fn get(&self, p: u32, q: u32) -> bool {
        match self {
            Relation::Matrix(m) => m.row(p)[q as usize / 64] >> (q % 64) & 1 == 1,
            Relation::Runs(r) => r.get(p, q),
        }
    }

    /// Clears in `bits` every place outside row `p`.
    pub(crate) fn and_into(&mut self, p: u32, bits: &mut [u64]) {
        match self {
            Relation::Matrix(m) => bits.iter_mut().zip(m.row(p)).for_each(|(b, r)| *b &= r),
            Relation::Runs(r) => r.and_into(p, bits),
        }
    }

    /// Row `p` as bits.
    pub(crate) fn copy_into(&self, p: u32, bits: &mut [u64]) {
        match self {
            Relation::Matrix(m) => bits.copy_from_slice(m.row(p)),
            Relation::Runs(r) => r.copy_into(p, bits),
        }
    }

    /// Row `p` becomes `bits`, which hold all of it; `runs` is room to
    /// work in.
    pub(crate) fn replace(&mut self, p: u32, bits: &[u64], runs: &mut Vec<Run>) {
        match self {
            Relation::Matrix(m) => {
                let w = m.words;
                m.bits[p as usize * w..(p as usize + 1) * w].copy_from_slice(bits);
            }
            Relation::Runs(r) => r.replace(p, bits, runs),
        }
    }
}

/// The words of a row of bits over `n` places (one at least).
pub(crate) fn words(n: usize) -> usize {
    n.div_ceil(64).max(1)
}

/// The relation as a bit matrix, `words` words a row.
pub(crate) struct Matrix {
    words: usize,
    bits: Vec<u64>,
}

impl Matrix {
    fn row(&self, p: u32) -> &[u64] {
        &self.bits[p as usize * self.words..(p as usize + 1) * self.words]
    }
}

/// Empties a row's queue; a long one's room is given back (the relation's
/// memory is its runs, not its queues).
fn forget(points: &mut Vec<u32>) {
    if points.capacity() > 64 {
        *points = Vec::new();
    } else {
        points.clear();
    }
}

/// Sets (`on`) or clears the bits of places `start..end`.
fn fill(bits: &mut [u64], start: u32, end: u32, on: bool) {
    if start >= end {
        return;
    }
    let (start, end) = (start as usize, end as usize);
    let (first, last) = (start / 64, (end - 1) / 64);
    for (w, word) in bits.iter_mut().enumerate().take(last + 1).skip(first) {
        let lo = if w == first { start % 64 } else { 0 };
        let hi = if w == last { (end - 1) % 64 + 1 } else { 64 };
        let mask = if hi - lo == 64 {
            !0
        } else {
            ((1u64 << (hi - lo)) - 1) << lo
        };
        if on {
            *word |= mask;
        } else {
            *word &= !mask;
        }
    }
}

/// The runs of set bits of `bits` into `runs`.
fn runs_of(bits: &[u64], runs: &mut Vec<Run>) {
    runs.clear();
    let mut open: Option<u32> = None;
    for (w, &word) in bits.iter().enumerate() {
        let base = w as u32 * 64;
        let mut b = 0;
        while b < 64 {
            // Zeros come in from the top: a run that reaches it goes on
            // into the next word.
            let rest = word >> b;
            match open {
                None if rest == 0 => break,
                None => {
                    b += rest.trailing_zeros();
                    open = Some(base + b);
                }
                Some(_) if rest.trailing_ones() >= 64 - b => break,
                Some(start) => {
                    b += rest.trailing_ones();
                    runs.push((start, base + b));
                    open = None;
                }
            }
        }
    }
    if let Some(start) = open {
        runs.push((start, bits.len() as u32 * 64));
    }
}

/// The union of `runs` and the sorted, distinct `points`, into `out`.
fn merge(runs: &[Run], points: &[u32], out: &mut Vec<Run>) {
    out.clear();
    let mut push = |(start, end): Run| match out.last_mut() {
        Some(last) if start <= last.1 => last.1 = last.1.max(end),
        _ => out.push((start, end)),
    };
    let (mut i, mut j) = (0, 0);
    while i < runs.len() || j < points.len() {
        if j == points.len() || (i < runs.len() && runs[i].0 <= points[j]) {
            push(runs[i]);
            i += 1;
        } else {
            push((points[j], points[j] + 1));
            j += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    proptest! {
        /// Pairs set one by one, in any order and repeated, read back as
        /// set, queued or merged; rows replaced from bits read back as
        /// those bits.
        #[test]
        fn a_relation_holds_exactly_the_pairs_set_in_it(
            n in 1usize..150,
            pairs in prop::collection::vec((0u32..150, 0u32..150), 0..600),
            replaced in prop::collection::vec(any::<u64>(), 3),
        ) {
            let runs = Relation::runs(n);
            let matrix = Relation::matrix(n);
            for mut r in [runs, matrix] {
            let mut set = BTreeSet::new();
            for &(p, q) in &pairs {
                let (p, q) = (p % n as u32, q % n as u32);
                if p != q {
                    r.relate(p, q);
                    set.insert((p, q));
                    set.insert((q, p));
                }
            }
            for settled in [false, true] {
                if settled {
                    r.settle_all();
                }
                for p in 0..n as u32 {
                    for q in 0..n as u32 {
                        prop_assert_eq!(r.get(p, q), set.contains(&(p, q)), "{} {}", p, q);
                    }
                }
            }
            let words = n.div_ceil(64);
            let mut bits: Vec<u64> = replaced.iter().copied().take(words).collect();
            if n % 64 != 0 {
                bits[words - 1] &= (1u64 << (n % 64)) - 1;
            }
            let mut runs = Vec::new();
            r.replace(0, &bits, &mut runs);
            let mut back = vec![0; words];
            r.copy_into(0, &mut back);
            prop_assert_eq!(&back, &bits);
            let mut all = vec![!0; words];
            r.and_into(0, &mut all);
            prop_assert_eq!(&all, &bits);
            if let Relation::Runs(runs_form) = &r {
                prop_assert!(holds_each_row_once(runs_form));
            }
            }
        }

        /// Rows set equal share their runs; a row changed leaves the rows
        /// it shared with as they were; runs no row holds any longer are
        /// let go.
        #[test]
        fn equal_rows_share_their_runs_until_one_changes(
            n in 2usize..150,
            contents in prop::collection::vec(prop::collection::vec(any::<u64>(), 3), 1..4),
            writes in prop::collection::vec((0u32..150, 0usize..4), 1..40),
        ) {
            let words = n.div_ceil(64);
            let contents: Vec<Vec<u64>> = contents
                .into_iter()
                .map(|mut bits| {
                    bits.truncate(words);
                    if n % 64 != 0 {
                        bits[words - 1] &= (1u64 << (n % 64)) - 1;
                    }
                    bits
                })
                .collect();
            let Relation::Runs(mut r) = Relation::runs(n) else { unreachable!() };
            let mut expected = vec![vec![0u64; words]; n];
            let mut room = Vec::new();
            for (p, c) in writes {
                let (p, bits) = (p % n as u32, &contents[c % contents.len()]);
                r.replace(p, bits, &mut room);
                expected[p as usize] = bits.clone();
                prop_assert!(holds_each_row_once(&r));
                let mut back = vec![0; words];
                for (q, bits) in expected.iter().enumerate() {
                    r.copy_into(q as u32, &mut back);
                    prop_assert_eq!(&back, bits, "row {}", q);
                }
            }
        }
    }

    /// Every row's runs are the set's, and the set holds no runs that no
    /// row holds.
    fn holds_each_row_once(r: &Runs) -> bool {
        let held: BTreeSet<&[Run]> = r.rows.iter().map(|row| &**row).collect();
        held.len() == r.distinct.len()
            && r.rows.iter().all(|row| {
                r.distinct
                    .get(&**row)
                    .is_some_and(|kept| Arc::ptr_eq(kept, row))
            })
    }
}
