//! The spatial properties (`separation`, `airspace`, `flight-state`), each
//! on a mission file of `tests/space/` made to contain one finding or none,
//! with the fleet's homes and airspace given as a fleet file would.
//! Counterexamples of separation findings replay in the token game to a
//! marking where both legs are under way.

mod common;

use std::path::PathBuf;

use common::{claimed, replay};
use eamos_geo::{Airspace, Fence, Vec3};
use eamos_lang::SourceFile;
use eamos_petri::net::Net;
use eamos_verify::{
    check_net, default_home, Finding, FindingKind, Options, Property, Report, Space, Verdict,
};

fn compile(name: &str) -> (Net, SourceFile) {
    common::compile_file(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("tests/space")
            .join(name),
    )
}

/// Checks `name` in `airspace` (the default fleet's homes).
fn check_in(name: &str, airspace: Airspace) -> (Report, Net, SourceFile) {
    let (net, file) = compile(name);
    let space = Space {
        homes: (0..net.drones.len()).map(default_home).collect(),
        airspace,
    };
    let options = Options {
        space: Some(space),
        ..Options::default()
    };
    let report = check_net(&net, &eamos_profile::builtin(), Some(&file.text), &options);
    for f in &report.findings {
        if let Some(t) = &f.trace {
            assert_eq!(replay(&net, &t.steps), claimed(t), "{}", f.message);
        }
    }
    (report, net, file)
}

fn check(name: &str) -> (Report, Net, SourceFile) {
    check_in(name, Airspace::default())
}

fn verdict(r: &Report, p: Property) -> Verdict {
    r.verdict(p).cloned().expect("every property has a verdict")
}

fn lines(f: &Finding, file: &SourceFile) -> Vec<u32> {
    f.labels
        .iter()
        .map(|l| file.line_col(l.span.start).line)
        .collect()
}

fn only(r: &Report, kind: FindingKind) -> &Finding {
    let found: Vec<&Finding> = r.findings_of(kind).collect();
    assert_eq!(found.len(), 1, "{:#?}", r.findings);
    found[0]
}

#[test]
fn a_head_on_swap_at_one_height_is_found_and_names_both_legs() {
    let (r, net, file) = check("swap_one_height.go");
    assert_eq!(verdict(&r, Property::Separation), Verdict::Violated);
    let f = only(&r, FindingKind::TooClose);
    assert_eq!(lines(f, &file), vec![31, 32], "{}", f.message);
    assert!(f.message.contains("0.00 m"), "{}", f.message);
    // The counterexample ends with both legs under way.
    let t = f.trace.as_ref().expect("an interleaving");
    let reached = replay(&net, &t.steps);
    let running: Vec<&str> = reached
        .iter()
        .filter_map(|(p, _)| net.place(net.find(p)?).map(|x| x.label.as_str()))
        .filter(|l| l.contains("FlyByY"))
        .collect();
    assert_eq!(running.len(), 2, "{reached:?}");
    let g = f.geometry.as_ref().expect("where");
    let (p, _) = g.closest.expect("closest approach");
    assert!(p.z == 5.0 && (0.0..=3.0).contains(&p.y), "{p:?}");
}

#[test]
fn the_same_swap_at_two_heights_keeps_apart() {
    let (r, ..) = check("swap_two_heights.go");
    assert_eq!(
        verdict(&r, Property::Separation),
        Verdict::Holds,
        "{:#?}",
        r.findings
    );
    assert!(r.findings.is_empty(), "{:#?}", r.findings);
}

#[test]
fn a_spot_left_before_an_await_lets_the_next_drone_in() {
    let (r, ..) = check("handover_ordered.go");
    assert_eq!(
        verdict(&r, Property::Separation),
        Verdict::Holds,
        "{:#?}",
        r.findings
    );
    let (r, _, file) = check("handover_unordered.go");
    assert_eq!(verdict(&r, Property::Separation), Verdict::Violated);
    let f = only(&r, FindingKind::TooClose);
    // D1 flies to the spot (line 17) while D2 flies into it (line 27).
    assert_eq!(lines(f, &file), vec![17, 27], "{}", f.message);
}

#[test]
fn a_collision_in_one_branch_of_an_if_is_found() {
    let (r, _, file) = check("branch.go");
    let f = only(&r, FindingKind::TooClose);
    // The branch that goes across (line 36), against D2's leg (line 32).
    assert_eq!(lines(f, &file), vec![36, 32], "{}", f.message);
}

/// An L: the notch north-east of (5, 5) is outside.
fn l_fence() -> Fence {
    Fence::new(vec![
        [-2.0, -2.0],
        [20.0, -2.0],
        [20.0, 5.0],
        [5.0, 5.0],
        [5.0, 20.0],
        [-2.0, 20.0],
    ])
    .unwrap()
}

#[test]
fn a_diagonal_leg_between_two_inside_waypoints_can_cut_a_concave_fence() {
    let fenced = Airspace {
        fence: Some(l_fence()),
        ..Airspace::default()
    };
    let (r, _, file) = check_in("notch.go", fenced);
    assert_eq!(verdict(&r, Property::Airspace), Verdict::Violated);
    let f = only(&r, FindingKind::LeavesAirspace);
    assert_eq!(lines(f, &file), vec![11], "{}", f.message);
    let (p, _) = f.geometry.as_ref().unwrap().closest.unwrap();
    assert!(
        (p.x - 5.0).abs() < 1e-6 || (p.y - 5.0).abs() < 1e-6,
        "{p:?}"
    );
    // Without the fence the same mission is clean.
    let (r, ..) = check("notch.go");
    assert_eq!(verdict(&r, Property::Airspace), Verdict::Holds);
}

#[test]
fn a_loop_that_drifts_leaves_the_fence_after_so_many_rounds() {
    let fenced = Airspace {
        fence: Some(
            Fence::new(vec![[-5.0, -5.0], [22.0, -5.0], [22.0, 5.0], [-5.0, 5.0]]).unwrap(),
        ),
        ..Airspace::default()
    };
    let (r, _, file) = check_in("drift.go", fenced);
    let f = only(&r, FindingKind::Drift);
    assert_eq!(lines(f, &file), vec![14], "{}", f.message);
    // 5 m a round from x = 0: the fifth round, from 20 to 25 m, leaves
    // the fence at 22 m.
    assert!(
        f.message
            .contains("in round 5 it leaves the airspace at (22.0, 0.0, 5.0)"),
        "{}",
        f.message
    );
    // Without a fence it still cannot stay in any.
    let (r, ..) = check("drift.go");
    assert!(only(&r, FindingKind::Drift)
        .message
        .contains("without bound"));
}

#[test]
fn a_counted_loop_is_followed_round_by_round() {
    // A field 12 m north, `east` m east of D1's home.
    let field = |east: f64| Airspace {
        fence: Some(
            Fence::new(vec![[-1.0, -1.0], [11.0, -1.0], [11.0, east], [-1.0, east]]).unwrap(),
        ),
        ..Airspace::default()
    };
    // Three rounds of 4 m east end at 12 m: inside a field 13 m wide ...
    let (r, ..) = check_in("lawnmower.go", field(13.0));
    assert_eq!(
        verdict(&r, Property::Airspace),
        Verdict::Holds,
        "{:#?}",
        r.findings
    );
    assert!(r.findings.is_empty(), "{:#?}", r.findings);
    // ... not inside one 9 m wide, which the third round leaves.
    let (r, ..) = check_in("lawnmower.go", field(9.0));
    let f = only(&r, FindingKind::LeavesAirspace);
    assert!(f.message.contains("round 3"), "{}", f.message);
}

#[test]
fn a_climb_above_the_ceiling_is_found() {
    let capped = Airspace {
        ceiling: Some(30.0),
        ..Airspace::default()
    };
    let (r, _, file) = check_in("ceiling.go", capped);
    let f = only(&r, FindingKind::LeavesAirspace);
    assert_eq!(lines(f, &file), vec![9]);
    assert!(
        f.message.contains("45.0 m, above the ceiling of 30 m"),
        "{}",
        f.message
    );
}

#[test]
fn flying_before_take_off_and_taking_off_disarmed_are_found() {
    let (r, _, file) = check("before_takeoff.go");
    assert_eq!(verdict(&r, Property::FlightState), Verdict::Violated);
    let states: Vec<(u32, &str)> = r
        .findings_of(FindingKind::FlightState)
        .map(|f| (lines(f, &file)[0], f.message.as_str()))
        .collect();
    assert!(
        states
            .iter()
            .any(|(l, m)| *l == 16 && m.contains("armed on the ground")),
        "{states:?}"
    );
    assert!(
        states
            .iter()
            .any(|(l, m)| *l == 22 && m.contains("disarmed on the ground")),
        "{states:?}"
    );
    let args = only(&r, FindingKind::ArgumentRange);
    assert_eq!(lines(args, &file), vec![23]);
}

#[test]
fn a_take_off_above_the_ceiling_is_an_argument_out_of_range() {
    let (r, _, file) = check_in(
        "swap_two_heights.go",
        Airspace {
            ceiling: Some(6.0),
            ..Airspace::default()
        },
    );
    let f = only(&r, FindingKind::ArgumentRange);
    assert_eq!(lines(f, &file), vec![27]);
    assert!(f.message.contains("ceiling"), "{}", f.message);
}

#[test]
fn homes_closer_than_the_separation_are_found_before_anything_moves() {
    let (net, file) = compile("swap_two_heights.go");
    let space = Space {
        homes: vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)],
        airspace: Airspace::default(),
    };
    let options = Options {
        space: Some(space),
        ..Options::default()
    };
    let r = check_net(&net, &eamos_profile::builtin(), Some(&file.text), &options);
    assert!(r
        .findings_of(FindingKind::TooClose)
        .any(|f| f.message.contains("start 1.00 m apart")));
}

#[test]
fn the_spatial_properties_are_named_so_in_json() {
    let (r, _, file) = check("swap_one_height.go");
    let json = r.to_json(&file);
    let names: Vec<&str> = json["properties"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["property"].as_str().unwrap())
        .collect();
    for p in ["separation", "airspace", "flight-state"] {
        assert!(names.contains(&p), "{names:?}");
    }
    let f = &json["findings"][0];
    assert_eq!(f["property"], "separation");
    assert_eq!(f["geometry"]["legs"].as_array().unwrap().len(), 2);
}

#[test]
fn a_loop_that_ends_on_the_drones_own_height_is_followed_until_it_ends() {
    // Up to 10 m, and half a metre more for where a drone really stops.
    let capped = |ceiling: f64| Airspace {
        ceiling: Some(ceiling),
        ..Airspace::default()
    };
    let (r, ..) = check_in("climb.go", capped(11.0));
    assert!(r.findings.is_empty(), "{:#?}", r.findings);
    assert_eq!(verdict(&r, Property::Airspace), Verdict::Holds);
    assert_eq!(verdict(&r, Property::Separation), Verdict::Holds);
    // A ceiling at the height the loop aims for is too low for that margin.
    let (r, ..) = check_in("climb.go", capped(10.0));
    let f = only(&r, FindingKind::LeavesAirspace);
    assert!(f.message.contains("10.5 m"), "{}", f.message);
}

#[test]
fn a_climbing_leg_is_any_of_its_heights_along_its_line() {
    let (r, _, file) = check("bow.go");
    let f = only(&r, FindingKind::TooClose);
    // D1's climb north (line 21) while D2 rests where its leg ended (31).
    assert_eq!(lines(f, &file), vec![21, 31], "{}", f.message);
    assert!(f.message.contains("0.00 m"), "{}", f.message);
}

#[test]
fn rests_beside_a_loop_on_the_drones_own_height_leave_no_drone_stuck() {
    // D2 comes near D1 resting between two climbs, so where D1 rests is
    // recorded; each climb starts from every rest the loop's guard, free
    // to hold or not, leads to, not only from those it leads to at one
    // height (which would leave D1 stuck between climbs).
    let (r, ..) = check("climb_beside.go");
    assert_eq!(verdict(&r, Property::Deadlock), Verdict::Holds);
    assert_eq!(verdict(&r, Property::Separation), Verdict::Violated);
    only(&r, FindingKind::TooClose);
}
