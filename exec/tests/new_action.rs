//! The profile's promise: a new action is a TOML edit. `Spray(seconds)` and
//! `Hop(distance)` are declared only in a profile's text, nowhere in Rust;
//! the front end checks their arity, the compiler puts them in the net, and
//! the simulator runs them from their declarations: `Spray` as a wait of
//! its nominal duration (its argument), refused on the ground as its flight
//! states say, `Hop` as the motion it declares.

use std::sync::Arc;

use eamos_exec::event::Kind;
use eamos_exec::log::read_mission_log;
use eamos_exec::runner::{run_fleet, RunOptions};
use eamos_exec::Outcome;
use eamos_fleet::Fleet;
use eamos_lang::SourceFile;
use eamos_mid::{
    ActionCall, Adapter, CancellationToken, NullSink, SimConfig, SimDroneSpec, SimFleet, Vec3,
};
use eamos_profile::ProfileTable;

/// The built-in quadcopter under another name, with two more actions.
fn sprayer() -> ProfileTable {
    let quadcopter = include_str!("../../profile/profiles/quadcopter.toml");
    let text = quadcopter.replace("name = \"Quadcopter\"", "name = \"Sprayer\"")
        + r#"
[actions.Spray]
params = [{ name = "seconds", kind = "seconds" }]
resources = ["nozzle"]
flight = { airborne = "airborne" }
duration = { param = "seconds" }
description = "Spray for `seconds` seconds."
[actions.Hop]
params = [{ name = "distance", kind = "metres" }]
resources = ["motion"]
flight = { airborne = "airborne" }
motion = { by_y = "distance" }
duration = "flight"
"#;
    eamos_profile::with_extra(&[&text]).expect("the sprayer profile is valid")
}

const MISSION: &str = "package Spray

var D1 Sprayer

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(2)
	D1.Spray(4)
	D1.Hop(3)
	D1.Land()
	D1.Disarm()
}
";

#[test]
fn the_front_end_checks_a_declared_action_s_arity() {
    let profiles = sprayer();
    let file = SourceFile::new("spray.go", MISSION.replace("Spray(4)", "Spray()"));
    let diags = eamos_lang::compile(&file, &profiles).unwrap_err();
    assert!(
        format!("{diags:?}").contains("Spray"),
        "the wrong arity is named: {diags:?}"
    );
    let file = SourceFile::new("spray.go", MISSION);
    let mission = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&mission, &profiles);
    assert!(
        net.places().any(|(_, p)| p.label.contains("Spray"))
            || net.transitions().any(|(_, t)| t.label.contains("Spray")),
        "the net runs Spray"
    );
}

#[tokio::test(start_paused = true)]
async fn a_mission_with_actions_declared_only_in_toml_flies_in_the_simulator() {
    let profiles = sprayer();
    let file = SourceFile::new("spray.go", MISSION);
    let mission = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&mission, &profiles);
    let slices = eamos_slicer::slice(&net).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let options = RunOptions {
        speed: 50.0,
        out: dir.path().to_path_buf(),
        source: Some(Arc::new(file)),
        max_duration: Some(600.0),
        ..RunOptions::default()
    };
    let report = run_fleet(&slices, &Fleet::default(), &profiles, &options)
        .await
        .unwrap();
    for r in &report.reports {
        assert_eq!(
            r.outcome,
            Outcome::Completed,
            "{}: {:?}",
            r.drone,
            r.outcome
        );
    }
    let log = read_mission_log(&dir.path().join("D1.mission.jsonl")).unwrap();
    let at = |event: &str, name: &str| {
        log.iter()
            .find_map(|r| match &r.kind {
                Kind::ActionStarted { action, .. } if event == "start" && action == name => {
                    Some(r.time)
                }
                Kind::ActionFinished {
                    action, outcome, ..
                } if event == "end"
                    && action.starts_with(&format!("{name}("))
                    && outcome == "ok" =>
                {
                    Some(r.time)
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("no {event} of {name} in {log:?}"))
    };
    let sprayed = at("end", "Spray") - at("start", "Spray");
    // Paused time: it ends at the first step (0.02 s) at or after 4 s.
    assert!((4.0..4.02).contains(&sprayed), "Spray(4) took {sprayed} s");
    let hopped = at("end", "Hop") - at("start", "Hop");
    assert!(hopped >= 3.0 / 5.0, "Hop(3) flew for {hopped} s");
    let path = &report.trajectories["D1"];
    assert!(
        path.iter().any(|p| (p.y - 3.0).abs() < 0.2 && p.z > 1.5),
        "Hop(3) flew 3 m east in the air"
    );
}

#[tokio::test(start_paused = true)]
async fn the_simulator_refuses_a_declared_action_in_a_flight_state_its_profile_forbids() {
    let profile = sprayer().get("Sprayer").unwrap().clone();
    let fleet = SimFleet::start(SimConfig {
        speed: 20.0,
        ..SimConfig::default()
    })
    .unwrap();
    let d = fleet
        .add_drone_with_profile(
            SimDroneSpec::new("D1", Vec3::ZERO),
            profile,
            Arc::new(NullSink),
        )
        .unwrap();
    let run = |name: &str, args: &[f64]| {
        let d = d.clone();
        let call = ActionCall::new(name, args.to_vec());
        async move { d.run(&call, CancellationToken::new()).await }
    };
    let err = run("Spray", &[1.0]).await.unwrap_err();
    assert_eq!(err.kind(), "refused", "{err}");
    assert!(err.to_string().contains("in the air"), "{err}");
    let err = run("Spray", &[]).await.unwrap_err();
    assert_eq!(err.kind(), "bad_arguments", "{err}");
    run("Arm", &[]).await.unwrap();
    run("Takeoff", &[2.0]).await.unwrap();
    let clock = d.clock();
    let t0 = clock.now();
    run("Spray", &[2.5]).await.unwrap();
    let took = clock.now() - t0;
    // Paused time: the action ends at the first step (0.02 s) at or after 2.5 s.
    assert!((2.5..2.52).contains(&took), "Spray(2.5) took {took} s");
    // A drone of the built-in profile does not offer it.
    let plain = fleet
        .add_drone(
            SimDroneSpec::new("D2", Vec3::new(0.0, 5.0, 0.0)),
            Arc::new(NullSink),
        )
        .unwrap();
    let err = plain
        .run(
            &ActionCall::new("Spray", vec![1.0]),
            CancellationToken::new(),
        )
        .await
        .unwrap_err();
    assert_eq!(err.kind(), "unsupported");
}
