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
//! reached (printed at the end). The test requires at least 90% of the cases
//! to be exact (about 95% are).
//!
//! Every mission without conditions or loops is also checked against the
//! lower bound of bridges ([`eamos_slicer::bound`]): the slicer may never
//! claim fewer.
//!
//! Cases: `PROPTEST_CASES` (default 2000, about a minute and a half in a
//! debug build on two cores).

mod common;

use std::sync::atomic::{AtomicUsize, Ordering};

use eamos_petri::net::{ArcKind, Net, Owner, TransitionKind};
use eamos_slicer::bound::lower_bound;
use eamos_slicer::compose::compose;
use eamos_slicer::equivalence::{compare, Budget, Verdict};
use eamos_slicer::{slice, Slice};
use petgraph::visit::EdgeRef;
use proptest::test_runner::{Config, TestCaseError, TestError, TestRunner};

const DEFAULT_CASES: u32 = 2000;
/// At least this share of the cases (in percent) must be compared
/// exactly. The others are missions (wide PARs of `Do` regions whose
/// abstracted guards may interrupt at any moment) whose determinised states
/// hold thousands of markings; for them the traces are compared up to the
/// depth the budget allows, which the test prints.
const MIN_EXACT_PERCENT: usize = 90;

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

#[test]
fn the_composed_slices_of_random_missions_have_the_traces_of_the_mission_net() {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        max_shrink_time: 120_000,
        ..Config::default()
    });
    let profiles = common::profiles();
    let exact = AtomicUsize::new(0);
    let bounded = AtomicUsize::new(0);
    let depths = std::sync::Mutex::new(Vec::new());
    let bounded_missions = AtomicUsize::new(0);
    let at_bound = AtomicUsize::new(0);
    let result = runner.run(&common::gen::mission(), |mission| {
        let net = eamos_petri::compile(&mission, &profiles);
        let slices =
            slice(&net).map_err(|e| TestCaseError::fail(format!("slicing failed: {e}")))?;
        no_consume_or_read_arc_crosses(&slices.distributed).map_err(TestCaseError::fail)?;
        if let Some(bound) = lower_bound(&mission) {
            if slices.bridge_count() < bound {
                return Err(TestCaseError::fail(format!(
                    "{} bridges, fewer than the lower bound {bound}: the bound or the slicing is wrong",
                    slices.bridge_count()
                )));
            }
            bounded_missions.fetch_add(1, Ordering::Relaxed);
            if slices.bridge_count() == bound {
                at_bound.fetch_add(1, Ordering::Relaxed);
            }
        }
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
            let read = Slice::from_json(&s.to_json()).map_err(|e| {
                TestCaseError::fail(format!("JSON round trip of {}: {e}", s.drone))
            })?;
            if &read != s {
                return Err(TestCaseError::fail(format!(
                    "JSON round trip changed {}",
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
            Verdict::EquivalentUpTo { depth, .. } => {
                bounded.fetch_add(1, Ordering::Relaxed);
                depths.lock().expect("not poisoned").push(depth);
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
    let mut depths = depths.into_inner().expect("not poisoned");
    depths.sort_unstable();
    eprintln!(
        "{exact} missions compared exactly, {bounded} up to the budget (visible events \
         compared: {depths:?}); {} of {} missions without conditions or loops sliced with \
         exactly the lower bound of bridges",
        at_bound.into_inner(),
        bounded_missions.into_inner()
    );
    assert!(
        exact * 100 >= (exact + bounded) * MIN_EXACT_PERCENT,
        "only {exact} of {} comparisons were exact",
        exact + bounded
    );
}
