//! Structural reductions before a deadlock search: a smaller net with the
//! same answer to "can a dead marking without `final` be reached?", and a
//! way back from its traces to the original net's.
//!
//! The rules (each file says why it is sound for that question):
//! * [`agglomerate`]: post-agglomeration, which fuses the long runs of
//!   single-input single-output places and transitions of mission nets and
//!   the steps that follow a fork or lead into a merge;
//! * [`redundant`]: structurally dead transitions, sink places and
//!   duplicate transitions.
//!
//! They are applied until none applies. They never touch the place
//! `final`, never change what a transition of the reduced net consumes or
//! reads from the original's, and every transition of the reduced net
//! stands for a sequence of the original's ([`Origin`]): a trace found on
//! the reduced net expands into a trace of the original, which
//! [`replay_to_deadlock`] fires on the original net before anyone sees it.
//!
//! They are sound for deadlocks only: fusing steps changes the lengths of
//! runs (a shortest counterexample of the reduced net need not expand to a
//! shortest one) and which markings are passed through, so the other
//! properties and the shortest deadlock are decided on the net as it is.
//! The net must have no monitors, whose read arcs the rules do not follow.
//!
//! A mission net is reduced as the P/T skeleton the checker explores
//! ([`crate::mission`]: guards free to hold or not, loop counters as
//! places of their own): the rules read nothing but its arcs, its initial
//! marking and which place is `final`, so they are sound for any net the
//! searches accept, and the coloured net is never rewritten.

mod agglomerate;
mod redundant;
mod work;

use crate::ptnet::{PtNet, RawTransition};
use work::{Origin, Work};

/// A reduced net and where each of its transitions comes from.
pub(crate) struct Reduced {
    pub net: PtNet,
    /// Per transition of `net`, its node in `origins`.
    roots: Vec<u32>,
    origins: Vec<Origin>,
    /// How often each rule applied (said in the report, and the tests
    /// see that each one is exercised).
    pub applied: Applied,
}

/// How often each rule applied.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Applied {
    pub agglomerations: usize,
    pub never_marked: usize,
    pub sinks: usize,
    pub duplicates: usize,
}

impl Reduced {
    /// The trace of the original net that a trace of the reduced net
    /// stands for, step by step.
    pub(crate) fn expand(&self, trace: &[u32]) -> Vec<u32> {
        let mut out = Vec::with_capacity(trace.len());
        let mut stack = Vec::new();
        for &t in trace {
            let Some(&root) = self.roots.get(t as usize) else {
                continue;
            };
            stack.push(root);
            while let Some(o) = stack.pop() {
                match self.origins.get(o as usize) {
                    Some(&Origin::Step(s)) => out.push(s),
                    Some(&Origin::Seq(a, b)) => {
                        stack.push(b);
                        stack.push(a);
                    }
                    None => {}
                }
            }
        }
        out
    }
}

/// The net reduced by every rule until none applies; `None` when no rule
/// applies (or the net has monitors, which the rules do not follow).
pub(crate) fn reduce(net: &PtNet) -> Option<Reduced> {
    if !net.monitors.is_empty() {
        return None;
    }
    let mut w = Work::new(net);
    let mut applied = Applied::default();
    let mut queue: Vec<u32> = (0..net.n_places() as u32).rev().collect();
    let mut queued = vec![true; net.n_places()];
    loop {
        while let Some(p) = queue.pop() {
            queued[p as usize] = false;
            let mut touched = Vec::new();
            if redundant::try_never_marked(&mut w, p, &mut touched) {
                applied.never_marked += 1;
            } else if redundant::try_sink(&mut w, p, &mut touched) {
                applied.sinks += 1;
            } else if agglomerate::try_place(&mut w, p, &mut touched) {
                applied.agglomerations += 1;
            }
            for q in touched {
                if !queued[q as usize] && w.place_alive[q as usize] {
                    queued[q as usize] = true;
                    queue.push(q);
                }
            }
        }
        let mut touched = Vec::new();
        let twins = redundant::duplicates(&mut w, &mut touched);
        if twins == 0 {
            break;
        }
        applied.duplicates += twins;
        for q in touched {
            if !queued[q as usize] && w.place_alive[q as usize] {
                queued[q as usize] = true;
                queue.push(q);
            }
        }
    }
    // The rules keep `final`; a net without it would answer another
    // question, so should one ever drop it the net stays as it is.
    let final_kept = net.final_place.is_none_or(|f| w.place_alive[f as usize]);
    let changed = applied != Applied::default();
    (changed && final_kept).then(|| pack(net, w, applied))
}

/// The working net packed into a [`PtNet`]: live places renumbered in
/// their original order, live transitions in theirs.
fn pack(net: &PtNet, w: Work, applied: Applied) -> Reduced {
    let mut index = vec![u32::MAX; net.n_places()];
    let mut places = Vec::new();
    let mut initial = Vec::new();
    for (p, &alive) in w.place_alive.iter().enumerate() {
        if alive {
            index[p] = places.len() as u32;
            places.push(net.places[p].clone());
            initial.push(net.initial[p]);
        }
    }
    let renumber = |arcs: &[(u32, u32)]| -> Vec<(u32, u32)> {
        arcs.iter()
            .filter(|&&(p, _)| index[p as usize] != u32::MAX)
            .map(|&(p, k)| (index[p as usize], k))
            .collect()
    };
    let mut steps = Vec::new();
    let mut raw = Vec::new();
    let mut roots = Vec::new();
    for tr in w.trs.iter().flatten() {
        // Named after the first step it stands for, which has its inputs.
        let mut o = tr.origin;
        let first = loop {
            match w.origins[o as usize] {
                Origin::Step(s) => break s,
                Origin::Seq(a, _) => o = a,
            }
        };
        steps.push(net.steps[first as usize].clone());
        raw.push(RawTransition {
            pre: renumber(&tr.arcs.pre),
            read: renumber(&tr.arcs.read),
            post: renumber(&tr.arcs.post),
        });
        roots.push(tr.origin);
    }
    let final_place = net.final_place.map(|f| index[f as usize]);
    let mut reduced = PtNet::new(places, steps, raw, initial, final_place);
    reduced.seeds = net.seeds;
    Reduced {
        net: reduced,
        roots,
        origins: w.origins,
        applied,
    }
}

/// Why a trace is not a deadlock of the original net.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Unreplayable {
    /// A step put a second token into a place: the net is not 1-safe (a
    /// sink place the rules dropped may count past one), and the search
    /// with token counts answers, as when a search meets a second token.
    SecondToken,
    /// A step was not enabled, or the marking reached is not dead or has
    /// `final` marked: the rules' soundness excludes it.
    NotADeadlock,
}

/// Fires `trace` on `net` from its initial marking, one token per place at
/// most; the marking reached (one bit per place, as [`crate::explore::Bits`]
/// packs it) if every step was enabled, no place got a second token, and
/// the marking is dead with `final` empty. This is what makes a reduced
/// net's counterexample one of the original net.
pub(crate) fn replay_to_deadlock(net: &PtNet, trace: &[u32]) -> Result<Vec<u64>, Unreplayable> {
    use Unreplayable::{NotADeadlock, SecondToken};
    let mut m: Vec<u32> = net.initial.clone();
    if m.iter().any(|&c| c > 1) {
        return Err(SecondToken);
    }
    let enabled = |m: &[u32], t: usize| {
        net.pre
            .get(t)
            .iter()
            .chain(net.read.get(t))
            .all(|&(p, k)| m[p as usize] >= k)
    };
    for &t in trace {
        let t = t as usize;
        if t >= net.n_real || !enabled(&m, t) {
            return Err(NotADeadlock);
        }
        for &(p, k) in net.pre.get(t) {
            m[p as usize] -= k;
        }
        for &(p, k) in net.post.get(t) {
            m[p as usize] += k;
            if m[p as usize] > 1 {
                return Err(SecondToken);
            }
        }
    }
    if (0..net.n_real).any(|t| enabled(&m, t)) {
        return Err(NotADeadlock);
    }
    if net.final_place.is_some_and(|f| m[f as usize] > 0) {
        return Err(NotADeadlock);
    }
    let mut bits = vec![0u64; net.n_places().div_ceil(64).max(1)];
    for (p, &c) in m.iter().enumerate() {
        if c > 0 {
            bits[p >> 6] |= 1 << (p & 63);
        }
    }
    Ok(bits)
}

#[cfg(test)]
mod tests;
