//! The paper's missions, flown by the simulator in one process: every
//! mission without loops runs to its end, each drone sends and receives
//! exactly the bridge messages its slice has, and the mission logs show the
//! orderings the missions demand.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use eamos_exec::event::{Event, Kind};
use eamos_exec::log::read_mission_log;
use eamos_exec::runner::{run_fleet, RunOptions, RunReport, TransportKind};
use eamos_exec::transport::faulty::Faults;
use eamos_exec::Outcome;
use eamos_fleet::Fleet;
use eamos_lang::SourceFile;
use eamos_slicer::Slices;

fn paper(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/missions/paper")
        .join(name)
}

fn slices_of(name: &str) -> (Slices, Arc<SourceFile>) {
    let path = paper(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let file = SourceFile::new(name, text);
    let profiles = eamos_profile::builtin();
    let compiled = eamos_lang::compile(&file, &profiles).expect("paper missions compile");
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    (eamos_slicer::slice(&net).unwrap(), Arc::new(file))
}

async fn fly(
    name: &str,
    transport: TransportKind,
    faults: Option<Faults>,
) -> (Slices, RunReport, tempfile::TempDir) {
    let (slices, source) = slices_of(name);
    let dir = tempfile::tempdir().unwrap();
    let options = RunOptions {
        speed: 50.0,
        out: dir.path().to_path_buf(),
        transport,
        faults,
        source: Some(source),
        max_duration: Some(3600.0),
        ..RunOptions::default()
    };
    let profiles = eamos_profile::builtin();
    let report = run_fleet(&slices, &Fleet::default(), &profiles, &options)
        .await
        .unwrap();
    (slices, report, dir)
}

fn log_of(dir: &Path, drone: &str) -> Vec<Event> {
    read_mission_log(&dir.join(format!("{drone}.mission.jsonl"))).unwrap()
}

fn assert_completed_with_slice_counts(slices: &Slices, report: &RunReport) {
    for r in &report.reports {
        assert_eq!(
            r.outcome,
            Outcome::Completed,
            "{}: {:?}",
            r.drone,
            r.outcome
        );
        let s = slices.get(&r.drone).unwrap();
        assert_eq!(r.sent as usize, s.bridges_out.len(), "{} sent", r.drone);
        assert_eq!(
            r.received as usize,
            s.bridges_in.len(),
            "{} received",
            r.drone
        );
        assert_eq!(r.unacked, 0, "{}", r.drone);
    }
}

/// Mission times at which `drone` started each action, in order.
fn action_starts(log: &[Event]) -> Vec<(f64, String, Vec<f64>)> {
    log.iter()
        .filter_map(|r| match &r.kind {
            Kind::ActionStarted { action, args, .. } => {
                Some((r.time, action.clone(), args.clone()))
            }
            _ => None,
        })
        .collect()
}

fn action_ends(log: &[Event]) -> Vec<(f64, String)> {
    log.iter()
        .filter_map(|r| match &r.kind {
            Kind::ActionFinished {
                action, outcome, ..
            } if outcome == "ok" => Some((r.time, action.clone())),
            _ => None,
        })
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn experiment_a_flies_its_square_in_order() {
    let (slices, report, dir) = fly("experiment_a.go", TransportKind::InProcess, None).await;
    assert_completed_with_slice_counts(&slices, &report);
    let names: Vec<String> = action_starts(&log_of(dir.path(), "Drone1"))
        .into_iter()
        .map(|(_, a, _)| a)
        .collect();
    assert_eq!(
        names,
        ["Arm", "Takeoff", "FlyByX", "FlyByY", "FlyByX", "FlyByY", "Land", "Disarm"]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn experiment_b_waits_for_both_drones_at_every_corner() {
    let (slices, report, dir) = fly("experiment_b.go", TransportKind::InProcess, None).await;
    assert_completed_with_slice_counts(&slices, &report);
    let d1 = log_of(dir.path(), "Drone1");
    let d2 = log_of(dir.path(), "Drone2");
    let s1 = action_starts(&d1);
    let s2 = action_starts(&d2);
    let e1 = action_ends(&d1);
    let e2 = action_ends(&d2);
    // Each leg of the square starts only after both drones finished the
    // previous one (the logs share one mission clock in one process).
    for leg in 2..7 {
        let start = s1[leg].0.min(s2[leg].0);
        let prev_end = e1[leg - 1].0.max(e2[leg - 1].0);
        assert!(
            start >= prev_end,
            "leg {leg} started at {start} before {prev_end}"
        );
    }
    println!(
        "{:?}",
        report
            .reports
            .iter()
            .map(|r| (r.drone.clone(), r.sent, r.received))
            .collect::<Vec<_>>()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_transport_that_loses_and_duplicates_messages_still_runs_every_action_exactly_once() {
    let faults = Faults {
        drop: 0.3,
        duplicate: 0.3,
        reorder: 0.2,
        max_delay: std::time::Duration::from_millis(20),
        seed: 2024,
    };
    for mission in ["experiment_b.go", "experiment_c.go", "listing01_demo.go"] {
        let (slices, report, dir) = fly(mission, TransportKind::InProcess, Some(faults)).await;
        assert_completed_with_slice_counts(&slices, &report);
        let mut retransmitted = 0;
        let mut duplicates = 0;
        for r in &report.reports {
            let s = slices.get(&r.drone).unwrap();
            let starts = s
                .transitions
                .iter()
                .filter(|t| {
                    matches!(
                        t.transition.kind,
                        eamos_petri::net::TransitionKind::ActionStart(_)
                    )
                })
                .count();
            let mut unique = r.started_actions.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(
                unique.len(),
                r.started_actions.len(),
                "{mission}: {} ran an action twice",
                r.drone
            );
            assert_eq!(r.started_actions.len(), starts, "{mission}: {}", r.drone);
            // The uniform log agrees: one call per action.
            if r.drone != "GCS" {
                let uniform =
                    std::fs::read_to_string(dir.path().join(format!("{}.uniform.jsonl", r.drone)))
                        .unwrap();
                let calls = uniform
                    .lines()
                    .filter(|l| l.contains("\"phase\":\"started\""))
                    .count();
                assert_eq!(calls, starts, "{mission}: {} uniform calls", r.drone);
            }
            retransmitted += r.bridges.retransmissions;
            duplicates += r.bridges.duplicates;
        }
        assert!(
            retransmitted > 0,
            "{mission}: the faults should have forced retransmissions"
        );
        assert!(
            duplicates > 0,
            "{mission}: the faults should have made duplicates"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn experiment_c_runs_over_zenoh_on_loopback_in_one_process() {
    let (slices, report, _dir) = fly("experiment_c.go", TransportKind::Zenoh, None).await;
    assert_completed_with_slice_counts(&slices, &report);
}
