//! The equivalence checker's reductions change no verdict.
//!
//! Firing a sole-consumer silent step at once and making a free choice
//! first are argued sound in `equivalence/mod.rs`; here the argument is held
//! against the plain search, which fires every enabled transition in every
//! marking. For random missions (see `common/gen.rs`, smaller ones, since
//! the plain search of a composition explores every order of its bridge
//! deliveries) the mission net is compared with its composed slices, with a
//! mutant of them (so that `Different` verdicts are compared too) and with
//! itself, with and without the reductions: the verdicts agree, and a
//! distinguishing trace is as short either way (both searches are
//! breadth-first over the same determinised automata).
//!
//! Cases: `PROPTEST_CASES` (default 400, about 6 s in a debug build on two
//! cores; more by hand).

mod common;

use common::mutate::{mutant, KINDS};
use eamos_petri::Net;
use eamos_slicer::compose::compose;
use eamos_slicer::equivalence::{compare_with, explore, Budget, Reductions, Verdict};
use eamos_slicer::slice_distributed;
use proptest::prelude::*;

const DEFAULT_CASES: u32 = 400;
const BUDGET: Budget = Budget {
    pairs: 200_000,
    markings: 400_000,
};

/// The verdict's kind and, for a difference, the length of the shortest
/// distinguishing trace.
fn gist(v: &Verdict) -> Result<(bool, usize), String> {
    match v {
        Verdict::Equivalent { .. } => Ok((true, 0)),
        Verdict::Different { trace, .. } => Ok((false, trace.len())),
        other => Err(common::explain(other)),
    }
}

fn agree(left: &Net, right: &Net, what: &str) -> Result<bool, String> {
    let reduced = gist(&compare_with(left, right, BUDGET, Reductions::ALL))?;
    let plain = gist(&compare_with(left, right, BUDGET, Reductions::NONE))
        .map_err(|e| format!("{what}, without reductions: {e}"))?;
    if reduced != plain {
        return Err(format!(
            "{what}: with the reductions {reduced:?}, without {plain:?} (equivalent, trace length)"
        ));
    }
    Ok(reduced.0)
}

#[test]
fn the_reduced_search_gives_the_verdicts_of_the_plain_one() {
    let compared = std::sync::atomic::AtomicUsize::new(0);
    let different = std::sync::atomic::AtomicUsize::new(0);
    let strategy = (common::gen::small_mission(), any::<usize>());
    common::run(DEFAULT_CASES, &strategy, |(case, pick)| {
        let (_, net) = common::compiled(&case)?;
        let (slices, distributed) =
            slice_distributed(&net).map_err(|e| format!("slicing failed: {e}"))?;
        let composed = compose(&slices.slices).map_err(|e| e.to_string())?;
        let mut pairs = vec![(composed.clone(), "the slices".to_string())];
        pairs.push((net.clone(), "itself".to_string()));
        if let Some(fired) = explore(&composed, BUDGET.markings).map(|e| e.fired) {
            let kind = KINDS[pick % KINDS.len()];
            if let Some(m) = mutant(
                kind,
                &net,
                &slices,
                &distributed,
                &fired,
                pick / KINDS.len(),
            ) {
                if let Ok(c) = compose(&m.slices) {
                    pairs.push((c, format!("{kind:?} {}", m.site)));
                }
            }
        }
        for (right, what) in &pairs {
            let equivalent = agree(&net, right, what)?;
            compared.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if !equivalent {
                different.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
        }
        Ok(())
    });
    let (compared, different) = (compared.into_inner(), different.into_inner());
    eprintln!("{compared} comparisons agreed with and without reductions, {different} of them `Different`");
    assert!(different >= 20, "too few differences compared: {different}");
}
