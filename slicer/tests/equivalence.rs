//! The slices of a mission, played together over asynchronous channels,
//! behave exactly like the mission's net.
//!
//! For random missions written as mission text and compiled by the front
//! end (see `common/gen.rs`): compile with petri's compiler, slice, compose
//! the slices with one channel place and one deliver transition per bridge
//! and the executors' end protocol ([`eamos_slicer::compose`]), and compare
//! the composition with the mission net by [`eamos_slicer::equivalence`]:
//! language equivalence of the visible-event automata (which drone runs
//! which action with which arguments, which drone decides which condition
//! which way, which delays, in which loop round; `final`, `deadlock`),
//! decided by a subset construction over both reachability graphs.
//!
//! Every case is compared exactly: the generator and the budget are sized so
//! that both state spaces fit, and a case whose comparison runs out of
//! budget fails the test, printing the mission.
//!
//! Every mission without conditions or loops is also checked against the
//! lower bound of bridges ([`eamos_slicer::bound`]): the slicer may never
//! claim fewer.
//!
//! Cases: `PROPTEST_CASES` (default 2000, about a minute in a debug build
//! on two cores; more by hand, e.g. `PROPTEST_CASES=20000`).

mod common;

use std::sync::atomic::{AtomicUsize, Ordering};

use eamos_lang::hir::Stmt;
use eamos_petri::net::{ArcKind, Net, Owner, TransitionKind};
use eamos_slicer::bound::lower_bound;
use eamos_slicer::compose::compose;
use eamos_slicer::equivalence::{compare, Verdict};
use eamos_slicer::{cut_along_owners, slice, slice_distributed, Slice};
use petgraph::visit::EdgeRef;

const DEFAULT_CASES: u32 = 2000;

/// Every consume and read arc stays on one owner, except the arcs from the
/// owners' ends into the join that ends the mission, which nobody runs.
fn no_consume_or_read_arc_crosses(net: &Net) -> Result<(), String> {
    for e in net.graph.edge_references() {
        let into_the_end = net.owner(e.target()) == Owner::Unassigned
            && net
                .transition(e.target())
                .is_some_and(|t| t.kind == TransitionKind::Finish)
            && net.postset(e.target()).all(|(p, _)| p == net.final_place);
        if matches!(e.weight().kind, ArcKind::Consume | ArcKind::Read)
            && net.owner(e.source()) != net.owner(e.target())
            && !into_the_end
        {
            return Err(format!(
                "{:?} arc {} -> {} crosses owners",
                e.weight().kind,
                net.place(e.source()).map_or("?", |p| &p.id),
                net.transition(e.target()).map_or("?", |t| &t.id),
            ));
        }
    }
    Ok(())
}

/// Both file forms give back the slice that was written.
fn round_trips(s: &Slice) -> Result<(), String> {
    let back = Slice::from_bytes(&s.to_bytes())
        .map_err(|e| format!("binary round trip of {}: {e}", s.drone))?;
    let read = Slice::from_json(&s.to_json())
        .map_err(|e| format!("JSON round trip of {}: {e}", s.drone))?;
    if &back != s || &read != s {
        return Err(format!("a round trip changed {}", s.drone));
    }
    Ok(())
}

#[test]
fn the_composed_slices_of_random_missions_have_the_traces_of_the_mission_net() {
    let exact = AtomicUsize::new(0);
    let bounded_missions = AtomicUsize::new(0);
    let at_bound = AtomicUsize::new(0);
    let longest = AtomicUsize::new(0);
    common::run(DEFAULT_CASES, &common::gen::mission(), |case| {
        let (mission, net) = common::compiled(&case)?;
        let slices = slice(&net).map_err(|e| format!("slicing failed: {e}"))?;
        let (_, distributed) =
            slice_distributed(&net).map_err(|e| format!("slicing failed: {e}"))?;
        no_consume_or_read_arc_crosses(&distributed)?;
        if cut_along_owners(&distributed, &slices.mission_id) != slices.slices {
            return Err("cutting the distributed net again gives other slices".into());
        }
        if let Some(bound) = lower_bound(&mission) {
            if slices.bridge_count() < bound {
                return Err(format!(
                    "{} bridges, fewer than the lower bound {bound}: the bound or the slicing is wrong",
                    slices.bridge_count()
                ));
            }
            bounded_missions.fetch_add(1, Ordering::Relaxed);
            if slices.bridge_count() == bound {
                at_bound.fetch_add(1, Ordering::Relaxed);
            }
        }
        for s in &slices.slices {
            s.validate().map_err(|e| format!("{}: {e}", s.drone))?;
            round_trips(s)?;
        }
        let composed = compose(&slices.slices).map_err(|e| e.to_string())?;
        match compare(&net, &composed, common::BUDGET) {
            Verdict::Equivalent { longest: l, .. } => {
                exact.fetch_add(1, Ordering::Relaxed);
                longest.fetch_max(l, Ordering::Relaxed);
                Ok(())
            }
            other => Err(common::explain(&other)),
        }
    });
    eprintln!(
        "{} missions compared exactly (longest trace compared: {} events); {} of {} missions \
         without conditions or loops sliced with exactly the lower bound of bridges",
        exact.into_inner(),
        longest.into_inner(),
        at_bound.into_inner(),
        bounded_missions.into_inner()
    );
}

#[test]
fn the_slicer_never_claims_fewer_bridges_than_the_lower_bound() {
    // Missions without conditions or loops, where the bound is defined
    // (the property above sees few of them).
    let (bounded, at_bound) = (AtomicUsize::new(0), AtomicUsize::new(0));
    common::run(300, &common::gen::plain_mission(), |case| {
        let (mission, net) = common::compiled(&case)?;
        let slices = slice(&net).map_err(|e| format!("slicing failed: {e}"))?;
        // Awaits that wait for each other have no bound to speak of.
        let Some(bound) = lower_bound(&mission) else {
            return Ok(());
        };
        if slices.bridge_count() < bound {
            return Err(format!(
                "{} bridges, fewer than the lower bound {bound}: the bound or the slicing is wrong",
                slices.bridge_count()
            ));
        }
        bounded.fetch_add(1, Ordering::Relaxed);
        if slices.bridge_count() == bound {
            at_bound.fetch_add(1, Ordering::Relaxed);
        }
        Ok(())
    });
    let bounded = bounded.into_inner();
    eprintln!(
        "{} of {bounded} missions without conditions or loops sliced with exactly the lower bound",
        at_bound.into_inner(),
    );
    assert!(bounded >= 100, "only {bounded} missions had a bound");
}

#[test]
fn the_generated_missions_use_what_the_language_offers() {
    // A generator that lost a construct would leave the property above
    // untested for it: count them over a fixed sample.
    use proptest::strategy::{Strategy, ValueTree};
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let mut text = String::new();
    let (mut awaits_in_loops, mut blocks_called_again) = (0, 0);
    for _ in 0..300 {
        let case = common::gen::mission()
            .new_tree(&mut runner)
            .expect("a mission")
            .current();
        let Ok(mission) = &case.mission else {
            panic!("refused:{case:?}");
        };
        text.push_str(&case.source);
        let mut calls = std::collections::BTreeMap::new();
        mission
            .root
            .walk_blocks(&mut |b| *calls.entry(b.name.clone()).or_insert(0) += 1);
        mission.root.walk(&mut |s| {
            if let Stmt::Repeat { body, .. } | Stmt::RepeatFor { body, .. } = s {
                body.walk(&mut |s| awaits_in_loops += matches!(s, Stmt::Await { .. }) as usize)
            }
        });
        blocks_called_again += calls.values().filter(|&&n| n > 1).count();
    }
    assert!(awaits_in_loops > 0, "no Await inside a loop");
    assert!(blocks_called_again > 0, "no block called twice");
    for needle in [
        "PAR_",
        "If(",
        "WaitWhile(",
        "WaitUntil(",
        "RepeatWhile(",
        "RepeatUntil(",
        "RepeatFor(",
        "PauseWhile(",
        "PauseUntil(",
        "PauseFor(",
        "DoWhile(",
        "DoUntil(",
        "Signal(",
        "Await(",
        "SEQ_S0()",
        "_L0(D",
        ".X()",
        ".Y()",
        ".Z()",
        ".Battery()",
        ".IsArmed()",
        ".DistanceTo(",
        "FlyTo(",
        " && ",
        " || ",
        "!(",
        "true",
        "false",
    ] {
        assert!(
            text.contains(needle),
            "no generated mission uses `{needle}`"
        );
    }
}
