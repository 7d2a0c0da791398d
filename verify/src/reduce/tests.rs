//! The reduced net against the original, by brute force on small random
//! nets: the same answer to "is a dead marking without `final`
//! reachable?", and every dead marking of the reduced net reached by a
//! trace that replays on the original to a dead marking.

use std::collections::{HashMap, VecDeque};

use proptest::prelude::*;

use super::{reduce, replay_to_deadlock, Applied};
use crate::ptnet::PtNet;
use crate::testnet::{self, Arcs};

/// Every reachable marking with the trace to it (breadth-first), or
/// `None` if some run puts a second token into a place: the reductions
/// are used on 1-safe nets only.
fn reachable(net: &PtNet) -> Option<Vec<(Vec<u32>, Vec<u32>)>> {
    let m0 = net.initial.clone();
    let mut seen: HashMap<Vec<u32>, usize> = HashMap::from([(m0.clone(), 0)]);
    let mut out = vec![(m0.clone(), Vec::new())];
    let mut queue = VecDeque::from([0usize]);
    while let Some(i) = queue.pop_front() {
        let (m, path) = out[i].clone();
        for t in 0..net.n_real {
            let enabled = net
                .pre
                .get(t)
                .iter()
                .chain(net.read.get(t))
                .all(|&(p, k)| m[p as usize] >= k);
            if !enabled {
                continue;
            }
            let mut next = m.clone();
            for &(p, k) in net.pre.get(t) {
                next[p as usize] -= k;
            }
            for &(p, k) in net.post.get(t) {
                next[p as usize] += k;
                if next[p as usize] > 1 {
                    return None;
                }
            }
            if !seen.contains_key(&next) {
                seen.insert(next.clone(), out.len());
                let mut p = path.clone();
                p.push(t as u32);
                queue.push_back(out.len());
                out.push((next, p));
            }
        }
    }
    Some(out)
}

fn dead(net: &PtNet, m: &[u32]) -> bool {
    let enabled = |t: usize| {
        net.pre
            .get(t)
            .iter()
            .chain(net.read.get(t))
            .all(|&(p, k)| m[p as usize] >= k)
    };
    !(0..net.n_real).any(enabled) && net.final_place.is_none_or(|f| m[f as usize] == 0)
}

/// Splits transition `t` (of `ts`) into `t` feeding a new place and a new
/// transition emptying it into `t`'s outputs: the runs of single-input
/// single-output nodes mission nets are made of.
fn split(places: &mut usize, ts: &mut Vec<Arcs>, t: usize) {
    let p = *places as u32;
    *places += 1;
    let outputs = std::mem::replace(&mut ts[t].2, vec![p]);
    ts.push((vec![p], Vec::new(), outputs));
}

/// A random net, some of its transitions split into sequences, and
/// whether place 0 is `final`.
fn random() -> impl Strategy<Value = (usize, Vec<bool>, Vec<Arcs>, bool)> {
    (
        testnet::random(),
        proptest::collection::vec(0usize..8, 0..6),
        any::<bool>(),
    )
        .prop_map(|((n, mut initial, mut ts), splits, with_final)| {
            let mut places = n;
            for s in splits {
                let t = s % ts.len();
                split(&mut places, &mut ts, t);
                initial.push(false);
            }
            (places, initial, ts, with_final)
        })
}

/// The net, each arc once (weights of one, as in mission nets).
fn build(places: usize, initial: &[bool], ts: &[Arcs], with_final: bool) -> PtNet {
    let set = |v: &[u32]| {
        let mut v = v.to_vec();
        v.sort_unstable();
        v.dedup();
        v
    };
    let ts: Vec<Arcs> = ts
        .iter()
        .map(|(pre, read, post)| {
            let pre = set(pre);
            let mut read = set(read);
            read.retain(|p| !pre.contains(p));
            (pre, read, set(post))
        })
        .collect();
    let mut net = testnet::net(places, initial, &ts);
    if with_final {
        net.final_place = Some(0);
        net.places[0].is_final = true;
    }
    net
}

/// What one case came to.
enum Case {
    /// Not 1-safe, or arcs of weight two: not what the rules are used on.
    Skipped,
    /// No rule applied.
    Unreduced,
    Reduced {
        deadlock: bool,
        applied: Applied,
    },
}

fn one_case(
    places: usize,
    initial: &[bool],
    ts: &[Arcs],
    with_final: bool,
) -> Result<Case, String> {
    let net = build(places, initial, ts, with_final);
    if !net.fits_bits() {
        return Ok(Case::Skipped);
    }
    let Some(original) = reachable(&net) else {
        return Ok(Case::Skipped);
    };
    let Some(red) = reduce(&net) else {
        return Ok(Case::Unreduced);
    };
    if red.net.n_places() > net.n_places() || red.net.n_real > net.n_real {
        return Err("the reduced net is larger".into());
    }
    if !red.net.fits_bits() || red.net.final_place.is_some() != net.final_place.is_some() {
        return Err("the reduced net lost one bit per place or `final`".into());
    }
    let reduced = reachable(&red.net).ok_or("the reduced net of a 1-safe net is not 1-safe")?;
    let deadlocks = |all: &[(Vec<u32>, Vec<u32>)], n: &PtNet| all.iter().any(|(m, _)| dead(n, m));
    let deadlock = deadlocks(&original, &net);
    if deadlock != deadlocks(&reduced, &red.net) {
        return Err(format!(
            "the original deadlocks: {deadlock}; the reduced net does not agree"
        ));
    }
    for (m, path) in &reduced {
        if dead(&red.net, m) {
            let trace = red.expand(path);
            if replay_to_deadlock(&net, &trace).is_err() {
                return Err(format!(
                    "trace {path:?} of the reduced net, {trace:?} expanded, is no deadlock of the original"
                ));
            }
        }
    }
    Ok(Case::Reduced {
        deadlock,
        applied: red.applied,
    })
}

#[test]
fn reduced_nets_deadlock_exactly_when_the_original_does() {
    use proptest::test_runner::{Config, TestCaseError, TestRunner};
    let counts = std::cell::RefCell::new(HashMap::new());
    let mut runner = TestRunner::new(Config {
        cases: 10_000,
        failure_persistence: None,
        ..Config::default()
    });
    let result = runner.run(&random(), |(places, initial, ts, with_final)| {
        let case = one_case(places, &initial, &ts, with_final).map_err(TestCaseError::fail)?;
        let mut counts = counts.borrow_mut();
        let mut see = |kind| *counts.entry(kind).or_insert(0usize) += 1;
        match case {
            Case::Skipped => see("skipped"),
            Case::Unreduced => see("unreduced"),
            Case::Reduced { deadlock, applied } => {
                see(if deadlock {
                    "reduced, deadlock"
                } else {
                    "reduced, no deadlock"
                });
                for (rule, n) in [
                    ("agglomeration", applied.agglomerations),
                    ("never marked", applied.never_marked),
                    ("sink", applied.sinks),
                    ("duplicate", applied.duplicates),
                ] {
                    if n > 0 {
                        see(rule);
                    }
                }
            }
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    // A generator drifted into nets no rule touches would pass for ever.
    let counts = counts.into_inner();
    println!("cases: {counts:?}");
    for (kind, min) in [
        ("reduced, deadlock", 2000),
        ("reduced, no deadlock", 500),
        ("agglomeration", 1000),
        ("never marked", 200),
        ("sink", 1000),
        ("duplicate", 30),
    ] {
        let n = counts.get(kind).copied().unwrap_or(0);
        assert!(n >= min, "only {n} cases {kind}, want {min}: {counts:?}");
    }
}

/// A chain `a -> b -> c` behind a marked place is fused into one step,
/// whose trace expands back to the three.
#[test]
fn a_chain_is_fused_and_expands_back() {
    let ts: Vec<Arcs> = vec![
        (vec![0], vec![], vec![1]),
        (vec![1], vec![], vec![2]),
        (vec![2], vec![], vec![3]),
    ];
    let net = testnet::net(4, &[true, false, false, false], &ts);
    let red = reduce(&net).expect("the chain reduces");
    // `b` and `c` fused away, `d` a sink: `a` and one step are left.
    assert_eq!(red.net.n_real, 1);
    assert_eq!(red.net.n_places(), 1);
    let trace = red.expand(&[0]);
    assert_eq!(trace, vec![0, 1, 2]);
    assert!(replay_to_deadlock(&net, &trace).is_ok());
    // One step short is no deadlock of the original.
    assert_eq!(
        replay_to_deadlock(&net, &trace[..2]),
        Err(super::Unreplayable::NotADeadlock)
    );
}

/// `final` is never fused away, nor a transition that consumes it.
#[test]
fn the_final_place_stays() {
    let ts: Vec<Arcs> = vec![(vec![0], vec![], vec![1]), (vec![1], vec![], vec![2])];
    let mut net = testnet::net(3, &[true, false, false], &ts);
    net.final_place = Some(1);
    net.places[1].is_final = true;
    let red = reduce(&net);
    let kept = red.as_ref().map_or(&net, |r| &r.net);
    let f = kept.final_place.expect("final kept");
    assert!(kept.places[f as usize].is_final);
    assert_eq!(kept.consumers.get(f as usize).len(), 1);
}
