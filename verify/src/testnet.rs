//! Small random P/T nets for the unit tests of the structural methods,
//! and their reachable markings by brute force.

use std::collections::{HashSet, VecDeque};

use proptest::prelude::*;

use crate::ptnet::{PlaceInfo, PtNet, RawTransition, StepInfo};

/// Consumed, read and produced places of one transition.
pub(crate) type Arcs = (Vec<u32>, Vec<u32>, Vec<u32>);

pub(crate) fn net(places: usize, initial: &[bool], ts: &[Arcs]) -> PtNet {
    let place = |i: usize| PlaceInfo {
        id: format!("p{i}").into(),
        label: "".into(),
        span: None,
        event: None,
        is_final: false,
        auxiliary: false,
        synthetic: false,
    };
    let step = |i: usize| StepInfo {
        id: format!("t{i}").into(),
        label: "".into(),
        kind: "".into(),
        text: "".into(),
        internal: false,
        span: None,
        guard: None,
    };
    let arcs = |v: &[u32]| v.iter().map(|&p| (p, 1)).collect::<Vec<_>>();
    PtNet::new(
        (0..places).map(place).collect(),
        (0..ts.len()).map(step).collect(),
        ts.iter()
            .map(|(pre, read, post)| RawTransition {
                pre: arcs(pre),
                read: arcs(read),
                post: arcs(post),
            })
            .collect(),
        initial.iter().map(|&m| m as u32).collect(),
        None,
    )
}

/// Every marking reachable without ever putting a second token in a
/// place (the relation speaks of 1-safe nets; runs past a second token
/// are cut there, which only shrinks what must be covered).
pub(crate) fn safe_markings(net: &PtNet) -> Vec<Vec<bool>> {
    let m0: Vec<bool> = net.initial.iter().map(|&c| c > 0).collect();
    let mut seen = HashSet::from([m0.clone()]);
    let mut queue = VecDeque::from([m0]);
    let mut out = Vec::new();
    while let Some(m) = queue.pop_front() {
        for t in 0..net.n_real {
            let enabled = net
                .pre
                .get(t)
                .iter()
                .chain(net.read.get(t))
                .all(|&(p, _)| m[p as usize]);
            if !enabled {
                continue;
            }
            let mut next = m.clone();
            for &(p, _) in net.pre.get(t) {
                next[p as usize] = false;
            }
            if net.post.get(t).iter().any(|&(p, _)| next[p as usize]) {
                continue;
            }
            for &(p, _) in net.post.get(t) {
                next[p as usize] = true;
            }
            if seen.insert(next.clone()) {
                queue.push_back(next);
            }
        }
        out.push(m);
    }
    out
}

pub(crate) fn random() -> impl Strategy<Value = (usize, Vec<bool>, Vec<Arcs>)> {
    (2usize..8).prop_flat_map(|n| {
        let places = || proptest::collection::vec(0..n as u32, 0..3);
        (
            Just(n),
            proptest::collection::vec(proptest::bool::weighted(0.3), n),
            proptest::collection::vec((places(), places(), places()), 1..8),
        )
    })
}
