//! A 20-drone mission of about 5000 nodes whose parallel branches interleave
//! astronomically (twenty chains of 125 actions: more than 10^50 markings in
//! full), with cross-drone synchronisation: the deadlock proof must stay
//! small with stubborn sets. The time is printed, not asserted (machines are
//! noisy); run `cargo test --release -p eamos-verify --test stress --
//! --nocapture` to see it.

mod common;

use std::time::Instant;

use common::Builder;
use eamos_lang::Span;
use eamos_petri::net::TransitionKind;
use eamos_verify::{check_net, Options, Property, Verdict};

const DRONES: usize = 20;
const ACTIONS: usize = 125;

/// Returns the builder; line `k` of drone `d`'s block is its `k`-th action.
// Drone and step indices address several tables at once.
#[allow(clippy::needless_range_loop)]
fn stress_mission() -> Builder {
    let mut src = String::from("package Stress\n");
    let mut spans = vec![Vec::new(); DRONES];
    for (d, spans) in spans.iter_mut().enumerate() {
        src.push_str(&format!("func SEQ_D{d}() {{\n"));
        for k in 0..ACTIONS {
            let line = format!("\tD{d}.FlyByX({k})\n");
            let start = src.len() + 1;
            spans.push(Span::new(start, start + line.len() - 2));
            src.push_str(&line);
        }
        src.push_str("}\n");
    }
    let names: Vec<String> = (0..DRONES).map(|d| format!("D{d}")).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut b = Builder::new("Stress", &refs, &src);
    let events: Vec<_> = (0..DRONES).map(|d| b.event(&format!("s{d}"))).collect();
    let p = b.init();
    let mut heads = b.fork(p, DRONES, Span::default());
    for k in 0..ACTIONS {
        for d in 0..DRONES {
            heads[d] = b.action_at(heads[d], d as u16, "FlyByX", &[k as f64], spans[d][k]);
            // Drone d tells drone d+1 it is a third of the way.
            if k == ACTIONS / 3 {
                heads[d] = b.signal_at(heads[d], events[d], spans[d][k]);
            }
            if k == ACTIONS / 2 {
                let from = (d + DRONES - 1) % DRONES;
                heads[d] = b.await_at(heads[d], events[from], spans[d][k]);
            }
        }
        // Pairs of drones meet at four fifths.
        if k == ACTIONS * 4 / 5 {
            for d in (0..DRONES).step_by(2) {
                let x = b.place("met");
                let y = b.place("met");
                b.trans(
                    TransitionKind::Join,
                    spans[d][k],
                    &[heads[d], heads[d + 1]],
                    &[x, y],
                );
                heads[d] = x;
                heads[d + 1] = y;
            }
        }
    }
    let end = b.join(&heads, Span::default());
    b.finish(end);
    b
}

#[test]
fn a_twenty_drone_mission_of_five_thousand_nodes_is_proved_free_of_deadlock() {
    let b = stress_mission();
    let nodes = b.net.graph.node_count();
    assert!(nodes >= 5000, "{nodes} nodes");
    let profiles = eamos_profile::builtin();
    let started = Instant::now();
    let r = check_net(&b.net, &profiles, Some(&b.src), &Options::default());
    let elapsed = started.elapsed();
    println!(
        "stress: {nodes} nodes, {} places, {} transitions: {} states, {} edges, {} full expansions; exploration {:.3} s, whole check {:.3} s",
        r.stats.places,
        r.stats.transitions,
        r.stats.states,
        r.stats.edges,
        r.stats.full_expansions,
        r.stats.seconds,
        elapsed.as_secs_f64()
    );
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Safety), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::DeadActions), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Conflicts), Some(&Verdict::Holds));
    // The reduced graph is a thin path through the interleavings.
    assert!(r.stats.states < 100_000, "{} states", r.stats.states);
}

#[test]
fn a_twenty_drone_mission_with_a_wait_cycle_is_caught() {
    // Drone 0 waits halfway for drone 19's signal; without the token that
    // lets drone 19 signal, drone 0 waits for ever and the others with it.
    let mut b = stress_mission();
    let profiles = eamos_profile::builtin();
    // Make the first await impossible: drop the initial pending token of
    // event s19, so drone 0's await (at k = 62) can never pass.
    let pending = b
        .net
        .places()
        .find(|(_, p)| p.label == "s19 pending")
        .map(|(n, _)| n)
        .unwrap();
    b.net.initial_marking.retain(|&p| p != pending);
    let r = check_net(&b.net, &profiles, Some(&b.src), &Options::default());
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Violated));
    assert!(r.stats.states < 100_000, "{} states", r.stats.states);
}
