//! A search for one deadlock, when that is all that is asked.
//!
//! Breadth-first exploration has to store every marking of a level before
//! it looks at the next, so a deadlock deep in a large state space is found
//! only after most of it is stored (the symmetric dining philosophers: the
//! deadlock is at depth `n`, behind a frontier growing exponentially). This
//! search goes depth-first, with the same stubborn sets: they preserve
//! every deadlock (see the parent module), and depth-first needs no proviso
//! because a deadlock is a marking, not a path. It stops at the first
//! deadlock; its path is a counterexample, not a shortest one (breadth-first
//! with [`super::Config::first_deadlock`] gives that).
//!
//! A dead marking with the final place marked is the mission's end, not a
//! deadlock.

use std::time::Instant;

use super::{
    expand, hash_bytes, initial_marking, Encoding, Expanded, Exploration, Parent, Scratch, Stop,
};
use crate::ptnet::PtNet;

/// One marking on the search stack: its successors and the next to try.
struct Frame {
    id: u32,
    next: usize,
    succ: Expanded,
}

/// Explores depth-first until a deadlock (in `ex.dead`), the memory bound,
/// `max_states`, or the end of the reduced state space (then no deadlock is
/// reachable).
pub(crate) fn search<E: Encoding>(
    net: &PtNet,
    reduction: bool,
    max_bytes: usize,
    max_states: usize,
) -> Exploration {
    let start = Instant::now();
    let words = E::words(net.n_places());
    let mut ex = Exploration::new::<E>(net, words);
    let mut s = Scratch::new(net.n_all(), words);
    let mut m = initial_marking::<E>(net);
    let mut bytes = Vec::new();
    E::encode(&m, &mut bytes);
    ex.store
        .insert(&bytes, hash_bytes(&bytes), u32::MAX, u32::MAX);
    let is_deadlock = |ex: &Exploration, id: u32, r: &Expanded| {
        r.dead && net.final_place.is_none_or(|f| ex.store.tokens(id, f) == 0)
    };
    let first = expand::<E>(net, reduction, &mut s, &m, None);
    ex.expanded = 1;
    let mut stack = vec![Frame {
        id: 0,
        next: 0,
        succ: first,
    }];
    if let Err(stop) = check_overflow(&stack[0]) {
        ex.stop = Some(stop);
    } else if is_deadlock(&ex, 0, &stack[0].succ) {
        ex.dead.push(0);
    }
    while ex.stop.is_none() && ex.dead.is_empty() {
        let Some(top) = stack.last_mut() else { break };
        if top.next == top.succ.trans.len() {
            stack.pop();
            continue;
        }
        let k = top.next;
        top.next += 1;
        let t = top.succ.trans[k];
        let lo = if k == 0 { 0 } else { top.succ.ends[k - 1] };
        let enc = &top.succ.succ[lo..top.succ.ends[k]];
        ex.fired[t as usize] = true;
        ex.edge_count += 1;
        if ex.store.len() >= u32::MAX as usize - 1 {
            ex.stop = Some(Stop::TooManyStates);
            break;
        }
        let (id, new) = ex.store.insert(enc, top.succ.hashes[k], top.id, t);
        if !new {
            continue;
        }
        ex.store.marking_into(id, &mut m);
        let parent = Parent {
            enabled: &top.succ.enabled,
            fired: t,
        };
        let r = expand::<E>(net, reduction, &mut s, &m, Some(parent));
        ex.expanded += 1;
        let frame = Frame {
            id,
            next: 0,
            succ: r,
        };
        if let Err(stop) = check_overflow(&frame) {
            ex.stop = Some(stop);
        } else if is_deadlock(&ex, id, &frame.succ) {
            ex.dead.push(id);
        } else if ex.store.len() >= max_states {
            ex.stop = Some(Stop::TooManyStates);
        } else if ex.store.len() % 1024 == 0 && ex.memory_bytes() > max_bytes {
            ex.stop = Some(Stop::Memory);
        }
        stack.push(frame);
    }
    ex.seconds = start.elapsed().as_secs_f64();
    if E::MAX == 1 {
        ex.max_tokens = 1;
    }
    ex
}

/// A second token: the search runs on nets proved 1-safe, so this is a
/// bug of the net compiler or of that proof, reported as breadth-first
/// exploration reports it.
fn check_overflow(frame: &Frame) -> Result<(), Stop> {
    match frame.succ.overflow {
        Some((t, place)) => Err(Stop::Unsafe {
            state: frame.id,
            t,
            place,
        }),
        None => Ok(()),
    }
}
