//! Post-agglomeration (Berthelot's rule; "sequence" or "free
//! agglomeration" in TAPAAL's and Haddad and Pradat-Peyre's lists): a
//! place `p` whose consumers can do nothing but empty it is fused away,
//! each producer `h` of `p` followed at once by a consumer `f` of `p`
//! becoming one transition `h;f`.
//!
//! Conditions on `p`: not the final place; empty at the start; read by no
//! transition; every producer `h` puts exactly one token into it and does
//! not consume it; every consumer `f` has `p` as its only input (weight one,
//! no read arcs) and does not produce `p`; there is at least one of each,
//! and one of the two sides has a single member (so the `|H| x |F|` fused
//! transitions never outnumber the `|H| + |F|` they replace); and a fused
//! `h;f` never puts two tokens into one place (`h` and `f` produce into
//! disjoint places), so a 1-safe net stays one bit per place.
//!
//! Why a dead marking without `final` stays reachable, both ways:
//! * A run of the reduced net is a run of the original with each `h;f`
//!   written `h f`: `h` is enabled where `h;f` is (same inputs, same read
//!   arcs), then `f` is (`p` was empty and now holds `h`'s token). It ends
//!   in the same marking with `p` empty. There `f` is disabled, `h` is
//!   disabled because `h;f` is, and every other transition is enabled as in
//!   the reduced net, since none of them consumes or reads `p`. So a dead
//!   marking of the reduced net is a dead marking of the original, with the
//!   same `final`.
//! * A run of the original net to a dead marking `D` leaves `p` empty (a
//!   token there would enable a consumer). Take its first firing of a
//!   consumer `f` and the last firing of a producer `h` before it: the
//!   firings between them neither touch `p` nor are needed by `f`, and
//!   firing `f` earlier only adds tokens to them, so `f` can move to just
//!   after `h` and the run still reaches `D`. Repeating this pairs every
//!   firing of a consumer with one of a producer, and the run is a run of
//!   the reduced net reaching `D` without `p`.
//!
//! The same argument shows every marking of the reduced net reachable in
//! the original (with `p` empty), so a 1-safe net reduces to a 1-safe net
//! and the searches may keep their one bit per place.

use super::work::{Origin, Tr, Work};
use crate::ptnet::RawTransition;

/// Fuses `p` away if the rule applies; the places whose surroundings
/// changed go into `touched`.
pub(super) fn try_place(w: &mut Work, p: u32, touched: &mut Vec<u32>) -> bool {
    let Some(pairs) = candidates(w, p) else {
        return false;
    };
    let (hs, fs) = pairs;
    let mut removed_h = Vec::new();
    for &h in &hs {
        if let Some(tr) = w.remove(h, touched) {
            removed_h.push(tr);
        }
    }
    let mut removed_f = Vec::new();
    for &f in &fs {
        if let Some(tr) = w.remove(f, touched) {
            removed_f.push(tr);
        }
    }
    for h in &removed_h {
        for f in &removed_f {
            let mut post: Vec<(u32, u32)> = h
                .arcs
                .post
                .iter()
                .copied()
                .filter(|&(q, _)| q != p)
                .collect();
            post.extend(f.arcs.post.iter().copied());
            post.sort_unstable();
            let origin = w.origin(Origin::Seq(h.origin, f.origin));
            let fused = Tr {
                arcs: RawTransition {
                    pre: h.arcs.pre.clone(),
                    read: h.arcs.read.clone(),
                    post,
                },
                origin,
            };
            touched.extend(Work::places_of(&fused));
            w.add(fused);
        }
    }
    w.place_alive[p as usize] = false;
    true
}

/// The producers and consumers of `p` if the rule's conditions hold.
fn candidates(w: &Work, p: u32) -> Option<(Vec<u32>, Vec<u32>)> {
    let pi = p as usize;
    if !w.place_alive[pi] || w.is_final(p) || w.net.initial[pi] != 0 {
        return None;
    }
    if !w.readers[pi].is_empty() {
        return None;
    }
    let (hs, fs) = (&w.producers[pi], &w.consumers[pi]);
    if hs.is_empty() || fs.is_empty() || (hs.len() > 1 && fs.len() > 1) {
        return None;
    }
    if hs.iter().any(|h| fs.contains(h)) {
        return None;
    }
    // The consumers first: their test is short, a producer's is as long
    // as its outputs. The outputs of a fork over the fleet are tried again
    // each time one of them is fused (the fork's arcs change), and most
    // fail on their consumer (an action's start reads more than its
    // place): testing the fork first read 4 billion arcs at 1,000 drones.
    for &f in fs {
        let tr = w.tr(f)?;
        if tr.arcs.pre.as_slice() != [(p, 1)] || !tr.arcs.read.is_empty() {
            return None;
        }
    }
    for &h in hs {
        let tr = w.tr(h)?;
        if tr.arcs.post.iter().find(|&&(q, _)| q == p) != Some(&(p, 1)) {
            return None;
        }
    }
    for &h in hs {
        let h_post = &w.tr(h)?.arcs.post;
        for &f in fs {
            let f_post = &w.tr(f)?.arcs.post;
            let shared = h_post
                .iter()
                .any(|&(q, _)| q != p && f_post.iter().any(|&(r, _)| r == q));
            if shared {
                return None;
            }
        }
    }
    Some((hs.clone(), fs.clone()))
}
