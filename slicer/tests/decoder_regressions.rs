//! Inputs the fuzz targets (`fuzz/fuzz_targets/slice_*.rs`) found, kept as
//! tests: each one a slice file the decoders once got wrong.

mod common;

use eamos_petri::net::PlaceKind;
use eamos_slicer::{slice, Slice};

fn drone2_of_experiment_b() -> Slice {
    slice(&common::paper_net("experiment_b"))
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
            for x in &mut a.args {
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
