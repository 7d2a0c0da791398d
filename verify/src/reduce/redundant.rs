//! Places and transitions that no dead marking depends on.
//!
//! * **Dead transitions** (structurally dead, rule of "never marked
//!   places"): a place empty at the start whose every producer also
//!   consumes or reads it can never gain its first token, so whatever
//!   consumes or reads it never fires. Taking those transitions out changes
//!   neither the reachable markings nor whether one is dead. The place goes
//!   too unless it is `final` (which is then simply never marked).
//! * **Sink places** (a redundant place in the usual lists): a place no
//!   transition consumes or reads, other than `final`, never enables or
//!   disables anything; dropping it from the net only forgets its count.
//!   A 1-safe net stays 1-safe.
//! * **Duplicate transitions** (identical pre, read and post arcs): one is
//!   enabled exactly when its twin is and does the same, so keeping one of
//!   them keeps every reachable marking and whether it is dead.
//!
//! None of these rules changes a run of the reduced net into anything
//! but a run of the original: a trace maps back step for step.

use std::collections::HashMap;

use super::work::Work;

/// Takes out the transitions that `p` proves dead, and `p` with them.
pub(super) fn try_never_marked(w: &mut Work, p: u32, touched: &mut Vec<u32>) -> bool {
    let pi = p as usize;
    if !w.place_alive[pi] || w.net.initial[pi] != 0 {
        return false;
    }
    let needs_p = |t: &u32| w.consumers[pi].contains(t) || w.readers[pi].contains(t);
    if !w.producers[pi].iter().all(needs_p) {
        return false;
    }
    let doomed: Vec<u32> = w.consumers[pi]
        .iter()
        .chain(&w.readers[pi])
        .copied()
        .collect();
    if doomed.is_empty() && w.is_final(p) {
        return false;
    }
    for t in doomed {
        w.remove(t, touched);
    }
    if !w.is_final(p) {
        w.place_alive[pi] = false;
    }
    true
}

/// Drops `p` if nothing consumes or reads it and it is not `final`.
pub(super) fn try_sink(w: &mut Work, p: u32, touched: &mut Vec<u32>) -> bool {
    let pi = p as usize;
    if !w.place_alive[pi] || w.is_final(p) {
        return false;
    }
    if !w.consumers[pi].is_empty() || !w.readers[pi].is_empty() {
        return false;
    }
    for t in std::mem::take(&mut w.producers[pi]) {
        if let Some(Some(tr)) = w.trs.get_mut(t as usize) {
            tr.arcs.post.retain(|&(q, _)| q != p);
            touched.extend(Work::places_of(tr));
        }
    }
    w.place_alive[pi] = false;
    true
}

/// A transition's pre, read and post arcs, sorted.
type ArcLists = (Vec<(u32, u32)>, Vec<(u32, u32)>, Vec<(u32, u32)>);

/// Takes out every transition with the same arcs as an earlier one;
/// returns how many.
pub(super) fn duplicates(w: &mut Work, touched: &mut Vec<u32>) -> usize {
    let mut seen: HashMap<ArcLists, u32> = HashMap::new();
    let mut twins = Vec::new();
    for (t, tr) in w.trs.iter().enumerate() {
        let Some(tr) = tr else { continue };
        let key = (
            tr.arcs.pre.clone(),
            tr.arcs.read.clone(),
            tr.arcs.post.clone(),
        );
        if seen.insert(key, t as u32).is_some() {
            twins.push(t as u32);
        }
    }
    for &t in &twins {
        w.remove(t, touched);
    }
    twins.len()
}
