//! Inputs the fuzz targets (`fuzz/fuzz_targets/slice_*.rs`) found, kept as
//! tests: each one a slice file the decoders once got wrong.

mod common;

use eamos_petri::net::{PlaceKind, TransitionKind};
use eamos_slicer::{slice, DecodeError, Slice};

fn drone2_of_experiment_b() -> Slice {
    slice(common::paper_net("experiment_b"))
        .expect("the paper mission slices")
        .get("Drone2")
        .expect("Drone2 has a slice")
        .clone()
}

/// JSON must give back the very same numbers: an agent that reads a slice
/// written by `eamos build -o` flies the arguments the checker saw, and a
/// slice re-encoded after reading must hash as it did before.
#[test]
fn an_argument_that_needs_17_digits_survives_the_json_form_exactly() {
    let mut s = drone2_of_experiment_b();
    let mut changed = 0;
    for p in &mut s.places {
        if let PlaceKind::Running(a) = &mut p.kind {
            for x in &mut std::sync::Arc::make_mut(a).args {
                *x = 1.000_000_000_014_324_5;
                changed += 1;
            }
        }
    }
    assert!(
        changed > 0,
        "experiment B's Drone2 flies moves with arguments"
    );
    let back = Slice::from_json(&s.to_json()).expect("a slice reads back");
    assert_eq!(back, s);
    assert_eq!(back.to_bytes(), s.to_bytes());
}

/// A binary slice whose take-off height is NaN passed the checksum (the
/// damage was made before it) and decoded: a drone would have been sent to
/// no height at all.
#[test]
fn a_slice_with_an_argument_that_is_not_a_number_is_refused() {
    let mut s = drone2_of_experiment_b();
    let takeoff = s
        .places
        .iter_mut()
        .find_map(|p| match &mut p.kind {
            PlaceKind::Running(a) if a.name == "Takeoff" => Some(std::sync::Arc::make_mut(a)),
            _ => None,
        })
        .expect("Drone2 takes off");
    takeoff.args[0] = f64::NAN;
    let e = Slice::from_bytes(&s.to_bytes()).unwrap_err();
    assert!(matches!(e, DecodeError::Inconsistent(_)), "{e}");
    assert!(e.to_string().contains("Takeoff"), "{e}");
}

#[test]
fn a_slice_with_an_infinite_delay_or_argument_on_a_transition_is_refused() {
    let base = drone2_of_experiment_b();
    let mut delayed = base.clone();
    delayed.transitions[0].transition.delay = Some(f64::INFINITY);
    let mut moved = base.clone();
    let t = moved
        .transitions
        .iter_mut()
        .find(|t| {
            t.transition
                .kind
                .action()
                .is_some_and(|a| !a.args.is_empty())
        })
        .expect("a transition starts a move");
    match &mut t.transition.kind {
        TransitionKind::ActionStart(a)
        | TransitionKind::ActionEnd(a)
        | TransitionKind::ActionCancel(a) => {
            std::sync::Arc::make_mut(a).args[0] = f64::NEG_INFINITY
        }
        other => panic!("only actions have arguments: {other:?}"),
    }
    for s in [delayed, moved] {
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
    }
    assert!(base.validate().is_ok());
}
