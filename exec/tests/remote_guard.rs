//! A condition over another drone's state: the slice that evaluates it
//! subscribes to that drone's telemetry over the transport and waits,
//! without polling, until the published state makes it true.

use std::sync::Arc;

use eamos_exec::event::Kind;
use eamos_exec::log::read_mission_log;
use eamos_exec::runner::{run_fleet, RunOptions, TransportKind};
use eamos_exec::Outcome;
use eamos_fleet::Fleet;
use eamos_lang::SourceFile;

const MISSION: &str = r#"package Remote

var D1 Quadcopter
var D2 Quadcopter

func INIT() {
	D1.Arm()
	D1.Takeoff(2)
	D2.Arm()
	PAR_Both()
}

func PAR_Both() {
	D2.Takeoff(4)
	SEQ_Follow()
}

func SEQ_Follow() {
	WaitUntil(D1.Z() + 1 < D2.Z(), SEQ_Go)
}

func SEQ_Go() {
	D1.FlyByX(1)
}
"#;

async fn fly(transport: TransportKind) {
    let file = SourceFile::new("remote.go", MISSION);
    let profiles = eamos_profile::builtin();
    let mission = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&mission, &profiles);
    let slices = eamos_slicer::slice(&net).unwrap();
    assert!(
        slices
            .get("D1")
            .unwrap()
            .telemetry
            .contains(&"D2".to_string()),
        "D1's guard reads D2: D1 must subscribe to D2's telemetry"
    );
    let dir = tempfile::tempdir().unwrap();
    let options = RunOptions {
        speed: 50.0,
        out: dir.path().to_path_buf(),
        transport,
        source: Some(Arc::new(file)),
        max_duration: Some(600.0),
        ..RunOptions::default()
    };
    let report = run_fleet(&slices, &Fleet::default(), &profiles, &options)
        .await
        .unwrap();
    for r in &report.reports {
        assert_eq!(r.outcome, Outcome::Completed, "{}", r.drone);
    }
    let log = read_mission_log(&dir.path().join("D1.mission.jsonl")).unwrap();
    let fly_started = log
        .iter()
        .find_map(|r| match &r.kind {
            Kind::ActionStarted { action, .. } if action == "FlyByX" => Some(r.time),
            _ => None,
        })
        .expect("D1 flew");
    let waited = log
        .iter()
        .any(|r| matches!(&r.kind, Kind::ConditionWaiting { .. }));
    assert!(waited, "D1 should have waited for D2 to climb");
    // D2 was more than a metre above D1 (at 2 m) when D1 set off: its
    // adapter log says where it was.
    let d2 = std::fs::read_to_string(dir.path().join("D2.adapter.jsonl")).unwrap();
    assert!(!d2.is_empty());
    // D1 may not leave before D2 has climbed above 3 m (D1 holds at 2 m).
    let d2_above_3 = log_time_above(&d2, 3.0).expect("D2 climbed above 3 m");
    assert!(
        fly_started + 0.5 >= d2_above_3,
        "D1 left at {fly_started} before D2 was above 3 m at {d2_above_3}"
    );
}

/// The first mission time at which an adapter log's positions show the
/// drone above `z` (positions are logged once a second, so this is late
/// by up to a second).
fn log_time_above(adapter: &str, z: f64) -> Option<f64> {
    adapter
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|r| r["event"] == "position")
        .find(|r| r["position"]["z"].as_f64().unwrap() > z)
        .map(|r| r["time"].as_f64().unwrap() - 1.0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_condition_on_another_drone_waits_for_its_telemetry_in_process() {
    fly(TransportKind::InProcess).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_condition_on_another_drone_waits_for_its_telemetry_over_zenoh() {
    fly(TransportKind::Zenoh).await;
}
