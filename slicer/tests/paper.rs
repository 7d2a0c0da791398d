//! The paper's missions: bridges against Table 7 and the lower bound, slice
//! files that round-trip, and damaged files that are refused.

mod common;

use eamos_slicer::bound::lower_bound;
use eamos_slicer::compose::compose;
use eamos_slicer::equivalence::{compare, Budget, Verdict};
use eamos_slicer::{slice, slice_as, DecodeError, Slice, Slices, Statistics};
use sha2::Digest as _;
use std::sync::Arc;

fn sliced(name: &str) -> Slices {
    slice(common::paper_net(name)).expect("paper missions slice")
}

/// (drone, bridges in, bridges out) of a slicing.
fn bridges(s: &Slices) -> Vec<(String, usize, usize)> {
    s.slices
        .iter()
        .map(|s| (s.drone.clone(), s.bridges_in.len(), s.bridges_out.len()))
        .collect()
}

fn in_out(s: &Slices, drone: &str) -> (usize, usize) {
    let s = s.get(drone).expect("drone has a slice");
    (s.bridges_in.len(), s.bridges_out.len())
}

#[test]
fn experiment_b_needs_no_more_bridges_per_drone_than_table_7_and_meets_the_lower_bound() {
    let s = sliced("experiment_b");
    // Table 7, column B: external arcs in / out.
    for (drone, paper) in [("Drone1", (10, 7)), ("Drone2", (7, 9))] {
        let ours = in_out(&s, drone);
        assert!(
            ours.0 <= paper.0 && ours.1 <= paper.1,
            "{drone}: {ours:?} vs paper {paper:?}"
        );
    }
    let bound = lower_bound(&common::paper_mission("experiment_b")).expect("straight-line mission");
    assert_eq!(s.bridge_count(), bound, "{:?}", bridges(&s));
}

#[test]
fn experiment_c_needs_no_more_bridges_per_drone_than_table_7_and_meets_the_lower_bound() {
    let s = sliced("experiment_c");
    // Table 7, column C: external arcs in / out.
    for (drone, paper) in [("Drone1", (8, 8)), ("Drone2", (8, 8)), ("Drone3", (15, 12))] {
        let ours = in_out(&s, drone);
        assert!(
            ours.0 <= paper.0 && ours.1 <= paper.1,
            "{drone}: {ours:?} vs paper {paper:?}"
        );
    }
    // The paper's 31 messages less the one the central Land/Disarm barrier
    // saves (each of the paper's drones waits for every landing itself).
    let bound = lower_bound(&common::paper_mission("experiment_c")).expect("straight-line mission");
    assert_eq!(bound, 30);
    assert_eq!(s.bridge_count(), bound, "{:?}", bridges(&s));
}

#[test]
fn a_mission_ends_on_every_drone_that_takes_part_in_its_last_join() {
    // Experiment C ends with all three drones disarming in parallel: each
    // ends where it disarms, and nobody sends a token to say so.
    let s = sliced("experiment_c");
    for drone in ["Drone1", "Drone2", "Drone3"] {
        let slice = s.get(drone).unwrap();
        assert!(slice.final_place.is_some(), "{drone} holds no end");
        assert_eq!(*slice.ends, ["Drone1", "Drone2", "Drone3"]);
    }
    let gcs = s.get(eamos_slicer::GCS).unwrap();
    assert_eq!(gcs.final_place, None);
    assert_eq!(*gcs.ends, ["Drone1", "Drone2", "Drone3"]);
}

#[test]
fn the_slices_cut_together_share_one_list_of_drones_and_of_ends() {
    // Each slice names every drone and every end: copied into each, a
    // fleet of N drones would hold N^2 names.
    let s = sliced("experiment_c");
    let first = &s.slices[0];
    assert_eq!(*first.drones, ["Drone1", "Drone2", "Drone3"]);
    for slice in &s.slices[1..] {
        assert!(Arc::ptr_eq(&slice.drones, &first.drones), "{}", slice.drone);
        assert!(Arc::ptr_eq(&slice.ends, &first.ends), "{}", slice.drone);
    }
}

#[test]
fn a_mission_that_ends_with_one_action_ends_on_that_drone_only() {
    let s = sliced("experiment_a");
    for slice in &s.slices {
        assert_eq!(*slice.ends, ["Drone1"], "{}", slice.drone);
        assert_eq!(slice.final_place.is_some(), slice.drone == "Drone1");
    }
}

#[test]
fn experiment_d_needs_no_more_bridges_per_drone_than_table_7() {
    let s = sliced("experiment_d");
    for (drone, paper) in [("D1", (6, 4)), ("D2", (5, 5)), ("D3", (6, 7))] {
        let ours = in_out(&s, drone);
        assert!(
            ours.0 <= paper.0 && ours.1 <= paper.1,
            "{drone}: {ours:?} vs paper {paper:?}"
        );
    }
}

#[test]
fn the_slicer_never_claims_fewer_bridges_than_the_lower_bound() {
    for name in common::PAPER {
        let mission = common::paper_mission(name);
        let s = sliced(name);
        match lower_bound(&mission) {
            Some(b) => assert!(
                s.bridge_count() >= b,
                "{name}: {} < bound {b}",
                s.bridge_count()
            ),
            None => assert_eq!(*name, "experiment_d", "only D has conditions"),
        }
    }
}

#[test]
fn single_drone_missions_cross_only_from_the_ground_station() {
    let s = sliced("experiment_a");
    assert_eq!(s.bridge_count(), 1);
    assert_eq!(in_out(&s, "Drone1"), (1, 0));
    assert_eq!(lower_bound(&common::paper_mission("experiment_a")), Some(1));
}

#[test]
fn every_paper_mission_sliced_behaves_exactly_like_its_net() {
    for name in common::PAPER {
        let net = common::paper_net(name);
        let s = slice(&net).unwrap();
        let composed = compose(&s.slices).unwrap();
        let budget = Budget {
            pairs: 200_000,
            markings: 1_000_000,
        };
        let verdict = compare(&net, &composed, budget);
        assert!(
            matches!(verdict, Verdict::Equivalent { .. }),
            "{name}: {verdict:?}"
        );
    }
}

#[test]
fn the_net_hash_names_one_net_and_only_that_net() {
    let net = common::paper_net("experiment_c");
    let id = eamos_slicer::net_id(&net);
    assert_eq!(id.len(), 64, "{id}");
    assert!(id
        .bytes()
        .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase()));
    // It is SHA-256 of the net's postcard form, as written whole.
    let whole = postcard::to_allocvec(&net).unwrap();
    let expected: String = sha2::Sha256::digest(&whole)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(id, expected);
    // The same mission compiled again is the same mission.
    assert_eq!(eamos_slicer::net_id(&common::paper_net("experiment_c")), id);
    // Every slice carries it.
    let s = slice(&net).unwrap();
    assert_eq!(s.mission_id, id);
    assert!(s.slices.iter().all(|slice| slice.mission_id == id));
    // Another mission, or this one with one label changed, is another.
    assert_ne!(eamos_slicer::net_id(&common::paper_net("experiment_b")), id);
    let mut edited = net.clone();
    let v = edited.graph.node_indices().next_back().unwrap();
    match &mut edited.graph[v] {
        eamos_petri::net::Node::Place(p) => p.label = format!("{}'", p.label).into(),
        eamos_petri::net::Node::Transition(t) => t.label = format!("{}'", t.label).into(),
    }
    assert_ne!(eamos_slicer::net_id(&edited), id);
}

#[test]
fn every_paper_slice_round_trips_through_json_and_binary() {
    for name in common::PAPER {
        for s in &sliced(name).slices {
            assert_eq!(
                &Slice::from_json(&s.to_json()).unwrap(),
                s,
                "{name} {} json",
                s.drone
            );
            assert_eq!(
                &Slice::from_bytes(&s.to_bytes()).unwrap(),
                s,
                "{name} {} binary",
                s.drone
            );
        }
    }
}

fn some_binary() -> Vec<u8> {
    sliced("experiment_b").get("Drone2").unwrap().to_bytes()
}

#[test]
fn a_truncated_binary_slice_is_an_error_at_every_length() {
    let bytes = some_binary();
    for n in 0..bytes.len() {
        let err = Slice::from_bytes(&bytes[..n]).unwrap_err();
        assert!(
            matches!(err, DecodeError::NotASlice | DecodeError::Truncated { .. }),
            "{n}: {err}"
        );
    }
}

#[test]
fn a_binary_slice_with_any_byte_altered_is_an_error() {
    let bytes = some_binary();
    for i in 0..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0x5a;
        assert!(
            Slice::from_bytes(&b).is_err(),
            "altering byte {i} went unnoticed"
        );
    }
}

#[test]
fn a_binary_slice_of_another_version_or_with_bytes_appended_is_refused() {
    let mut b = some_binary();
    b[8] = b[8].wrapping_add(1);
    assert!(matches!(
        Slice::from_bytes(&b),
        Err(DecodeError::Version { .. })
    ));
    let mut b = some_binary();
    b.push(0);
    let err = Slice::from_bytes(&b).unwrap_err();
    assert!(
        matches!(err, DecodeError::TrailingBytes { extra: 1 }),
        "{err}"
    );
    assert!(matches!(
        Slice::from_bytes(b"{\"format\"}"),
        Err(DecodeError::NotASlice)
    ));
}

#[test]
fn a_json_slice_that_is_cut_short_names_the_line_and_column() {
    let json = sliced("experiment_b").get("Drone1").unwrap().to_json();
    let err = Slice::from_json(&json[..json.len() / 2]).unwrap_err();
    assert!(matches!(err, DecodeError::Json(_)), "{err}");
    assert!(err.to_string().contains("line"), "{err}");
}

#[test]
fn a_json_slice_pointing_outside_itself_is_inconsistent() {
    let s = sliced("experiment_b").get("Drone1").unwrap().clone();
    let mut v: serde_json::Value = serde_json::from_str(&s.to_json()).unwrap();
    v["slice"]["bridges_in"][0]["inbox"] = serde_json::json!(9999);
    let err = Slice::from_json(&v.to_string()).unwrap_err();
    assert!(matches!(err, DecodeError::Inconsistent(_)), "{err}");
    let mut v: serde_json::Value = serde_json::from_str(&s.to_json()).unwrap();
    v["slice"]["peers"] = serde_json::json!(["Drone7"]);
    assert!(matches!(
        Slice::from_json(&v.to_string()),
        Err(DecodeError::Inconsistent(_))
    ));
}

#[test]
fn a_json_file_of_another_kind_or_version_is_refused() {
    let s = sliced("experiment_a").get("Drone1").unwrap().clone();
    let mut v: serde_json::Value = serde_json::from_str(&s.to_json()).unwrap();
    v["format"] = serde_json::json!("pnml");
    assert!(matches!(Slice::from_json(&v.to_string()), Err(DecodeError::Format(f)) if f == "pnml"));
    let mut v: serde_json::Value = serde_json::from_str(&s.to_json()).unwrap();
    v["version"] = serde_json::json!(99);
    assert!(matches!(
        Slice::from_json(&v.to_string()),
        Err(DecodeError::Version { found: 99, .. })
    ));
}

#[test]
fn statistics_count_every_bridge_once_on_each_side() {
    let s = sliced("experiment_c");
    let stats = Statistics::of(&s);
    let ins: usize = stats.slices.iter().map(|s| s.bridges_in).sum();
    let outs: usize = stats.slices.iter().map(|s| s.bridges_out).sum();
    assert_eq!((ins, outs), (stats.bridges, stats.bridges));
    let table = stats.table();
    assert!(table.lines().count() == 1 + s.slices.len() + 1, "{table}");
    let json = serde_json::to_string(&stats).unwrap();
    assert_eq!(serde_json::from_str::<Statistics>(&json).unwrap(), stats);
}

#[test]
fn the_files_of_a_slicing_are_written_one_set_per_drone() {
    let dir = tempfile::tempdir().unwrap();
    let s = sliced("experiment_c");
    let written = eamos_slicer::write_dir(&s, dir.path()).unwrap();
    assert_eq!(written.len(), 4);
    for w in &written {
        let back = Slice::from_bytes(&std::fs::read(&w.binary).unwrap()).unwrap();
        assert_eq!(&back, s.get(&w.drone).unwrap());
        let json = std::fs::read_to_string(&w.json).unwrap();
        assert_eq!(&Slice::from_json(&json).unwrap(), s.get(&w.drone).unwrap());
        let dot = std::fs::read_to_string(&w.dot).unwrap();
        assert!(dot.starts_with(&format!("digraph \"net-{}\"", w.drone)));
        assert!(dot.contains("style=dashed"), "bridges are dashed");
    }
}

/// The slicer frees a net handed over to it once distributed; what it cuts
/// is the same as from the net lent, with or without an identity.
#[test]
fn a_net_handed_over_to_the_slicer_is_cut_as_the_same_net_lent() {
    for name in common::PAPER {
        let net = common::paper_net(name);
        let lent = slice(&net).expect("paper missions slice");
        let given = slice(net.clone()).expect("paper missions slice");
        assert_eq!(given.slices, lent.slices, "{name}");
        assert_eq!(
            (
                &given.mission,
                &given.mission_id,
                &given.drones,
                &given.profiles
            ),
            (
                &lent.mission,
                &lent.mission_id,
                &lent.drones,
                &lent.profiles
            ),
            "{name}"
        );
        let lent = slice_as(&net, "Mission-1").expect("paper missions slice");
        let given = slice_as(net, "Mission-1").expect("paper missions slice");
        assert_eq!(given.slices, lent.slices, "{name}");
        assert_eq!(given.mission_id, "Mission-1");
    }
}
