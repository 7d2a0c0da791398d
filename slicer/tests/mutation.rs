//! A wrong slicing never passes for a right one.
//!
//! For random missions (see `common/gen.rs`), the right slices are broken
//! in one of seven ways a slicer bug would break them (`common/mutate.rs`):
//! drop a bridge, swap two actions of one drone, move an action into another
//! owner's slice, decide a condition on another drone, flip a guard, drop a
//! delay, drop an end notice. Every
//! mutant must be refused (by [`Slice::validate`], which an executor's
//! decoder runs, or by [`compose`]) or found `Different` from the mission
//! net. A mutant whose change leaves the mission's behaviour as it was is
//! accepted only when the same change made to the mission net is found
//! equivalent too (see `common/mutate.rs`): it is then counted apart, never
//! skipped. The counts per kind are printed.
//!
//! Cases: `PROPTEST_CASES` (default 300 missions, about 15 s in a debug
//! build on two cores; more by hand).

mod common;

use std::collections::BTreeMap;
use std::sync::Mutex;

use common::mutate::{mutant, Kind, KINDS};
use eamos_slicer::compose::compose;
use eamos_slicer::equivalence::{compare, explore, Verdict};
use eamos_slicer::{slice_distributed, Slice};
use proptest::prelude::*;

const DEFAULT_CASES: u32 = 300;

#[derive(Debug, Default, Clone, Copy)]
struct Count {
    generated: usize,
    different: usize,
    refused: usize,
    equivalent_mission_change: usize,
}

/// How a mutant was caught, or that it is equivalent and so is its analog;
/// `Err` for an escaped mutant.
fn judge(net: &eamos_petri::Net, m: &common::mutate::Mutant) -> Result<Outcome, String> {
    if m.slices.iter().any(|s| Slice::validate(s).is_err()) {
        return Ok(Outcome::Refused);
    }
    let Ok(composed) = compose(&m.slices) else {
        return Ok(Outcome::Refused);
    };
    match compare(net, &composed, common::BUDGET) {
        Verdict::Different { .. } | Verdict::Unsafe { .. } => return Ok(Outcome::Different),
        Verdict::Equivalent { .. } => {}
        other => {
            return Err(format!(
                "{:?} {}: {}",
                m.kind,
                m.site,
                common::explain(&other)
            ))
        }
    }
    let escaped = || format!("{:?} {} escaped: found equivalent", m.kind, m.site);
    match m.analog.as_ref().map(|a| compare(net, a, common::BUDGET)) {
        Some(Verdict::Equivalent { .. }) => Ok(Outcome::EquivalentChange),
        Some(Verdict::Different { .. }) | None => Err(escaped()),
        Some(other) => Err(format!(
            "{} (analog: {})",
            escaped(),
            common::explain(&other)
        )),
    }
}

enum Outcome {
    Different,
    Refused,
    EquivalentChange,
}

#[test]
fn every_mutant_of_the_slices_of_random_missions_is_caught() {
    let counts: Mutex<BTreeMap<Kind, Count>> = Mutex::new(BTreeMap::new());
    let strategy = (common::gen::mission(), any::<usize>());
    common::run(DEFAULT_CASES, &strategy, |(case, pick)| {
        let (_, net) = common::compiled(&case)?;
        let (slices, distributed) =
            slice_distributed(&net).map_err(|e| format!("slicing failed: {e}"))?;
        let composed = compose(&slices.slices).map_err(|e| e.to_string())?;
        let fired = explore(&composed, common::BUDGET.markings)
            .map(|e| e.fired)
            .ok_or("the slices' state space is beyond the budget")?;
        for kind in KINDS {
            let Some(m) = mutant(kind, &net, &slices, &distributed, &fired, pick) else {
                continue;
            };
            let outcome = judge(&net, &m)?;
            let mut counts = counts.lock().expect("not poisoned");
            let c = counts.entry(kind).or_default();
            c.generated += 1;
            match outcome {
                Outcome::Different => c.different += 1,
                Outcome::Refused => c.refused += 1,
                Outcome::EquivalentChange => c.equivalent_mission_change += 1,
            }
        }
        Ok(())
    });
    let counts = counts.into_inner().expect("not poisoned");
    for (kind, c) in &counts {
        eprintln!(
            "{kind:?}: {} mutants, {} found different, {} refused, {} equivalent (so is the same \
             change to the mission)",
            c.generated, c.different, c.refused, c.equivalent_mission_change
        );
    }
    // A kind that was never tried proves nothing: every one must be. And a
    // checker blind to a kind of change would find its mutants and their
    // analogs alike equivalent: such changes are rare (a few in a hundred).
    for kind in KINDS {
        let c = counts.get(&kind).copied().unwrap_or_default();
        assert!(
            c.different + c.refused >= 10,
            "{kind:?}: only {} mutants caught: the missions give it too few sites",
            c.different + c.refused
        );
        assert!(
            c.equivalent_mission_change * 5 <= c.generated,
            "{kind:?}: {} of {} mutants equivalent: is the checker blind to them?",
            c.equivalent_mission_change,
            c.generated
        );
    }
}
