//! The slices of a mission, played together over asynchronous channels,
//! behave exactly like the mission's net.
//!
//! For random checked missions (see `common/gen.rs`): compile with petri's
//! compiler, slice, compose the slices with one channel place and one
//! deliver transition per bridge ([`eamos_slicer::compose`]), and compare
//! the composition with the mission net by [`eamos_slicer::equivalence`]:
//! language equivalence of the visible-event automata (action start, end
//! and cancel with their loop colours, `final`, `deadlock`), guards
//! abstracted to nondeterministic choices, decided by a subset construction
//! over both reachability graphs. When both state spaces fit the budget the
//! comparison is exact; otherwise it covers every trace up to the depth
//! reached, and the test requires that most cases are exact and that the
//! others still reach a useful depth.
//!
//! Cases: `PROPTEST_CASES` (default 2000, about a minute in a debug build on
//! two cores).

mod common;

use std::sync::atomic::{AtomicUsize, Ordering};

use eamos_petri::net::{ArcKind, Net};
use eamos_slicer::compose::compose;
use eamos_slicer::equivalence::{compare, Budget, Verdict};
use eamos_slicer::{slice, Slice};
use petgraph::visit::EdgeRef;
use proptest::test_runner::{Config, TestCaseError, TestError, TestRunner};

const DEFAULT_CASES: u32 = 2000;
/// Bounded cases must still compare every trace of at least this many
/// visible events.
const MIN_DEPTH: usize = 8;

fn no_consume_or_read_arc_crosses(net: &Net) -> Result<(), String> {
    for e in net.graph.edge_references() {
        if matches!(e.weight().kind, ArcKind::Consume | ArcKind::Read)
            && net.owner(e.source()) != net.owner(e.target())
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

#[test]
fn the_composed_slices_of_random_missions_have_the_traces_of_the_mission_net() {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let profiles = common::profiles();
    let exact = AtomicUsize::new(0);
    let bounded = AtomicUsize::new(0);
    let result = runner.run(&common::gen::mission(), |mission| {
        let net = eamos_petri::compile(&mission, &profiles);
        let slices =
            slice(&net).map_err(|e| TestCaseError::fail(format!("slicing failed: {e}")))?;
        no_consume_or_read_arc_crosses(&slices.distributed).map_err(TestCaseError::fail)?;
        for s in &slices.slices {
            let back = Slice::from_bytes(&s.to_bytes()).map_err(|e| {
                TestCaseError::fail(format!("binary round trip of {}: {e}", s.drone))
            })?;
            if &back != s {
                return Err(TestCaseError::fail(format!(
                    "binary round trip changed {}",
                    s.drone
                )));
            }
        }
        let composed = compose(&slices.slices).map_err(|e| TestCaseError::fail(e.to_string()))?;
        match compare(&net, &composed, Budget::default()) {
            Verdict::Equivalent { .. } => {
                exact.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Verdict::EquivalentUpTo { depth, .. } if depth >= MIN_DEPTH => {
                bounded.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            other => Err(TestCaseError::fail(format!("{other:?}"))),
        }
    });
    match result {
        Ok(()) => {}
        Err(TestError::Fail(reason, mission)) => {
            panic!("{reason}\nminimal mission: {mission:#?}")
        }
        Err(e) => panic!("{e}"),
    }
    let (exact, bounded) = (exact.into_inner(), bounded.into_inner());
    eprintln!("{exact} missions compared exactly, {bounded} up to the budget");
    assert!(
        exact * 10 >= (exact + bounded) * 9,
        "only {exact} of {} comparisons were exact",
        exact + bounded
    );
}
