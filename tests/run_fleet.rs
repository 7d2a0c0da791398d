//! `eamos run MISSION`: the whole fleet in one process, simulated.

use std::path::{Path, PathBuf};
use std::process::Command;

use assert_cmd::prelude::*;
use serde_json::Value;

fn paper(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

/// Bridges in and out of each peer's slice, from the library.
fn slice_bridges(mission: &str) -> Vec<(String, usize, usize)> {
    let path = paper(mission);
    let file = eamos_lang::SourceFile::new(mission, std::fs::read_to_string(path).unwrap());
    let profiles = eamos_profile::builtin();
    let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&m, &profiles);
    let slices = eamos_slicer::slice(&net).unwrap();
    slices
        .slices
        .iter()
        .map(|s| (s.drone.clone(), s.bridges_in.len(), s.bridges_out.len()))
        .collect()
}

fn mission_log(dir: &Path, drone: &str) -> Vec<Value> {
    let text = std::fs::read_to_string(dir.join(format!("{drone}.mission.jsonl")))
        .unwrap_or_else(|e| panic!("no mission log of {drone}: {e}"));
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn count(log: &[Value], event: &str) -> usize {
    log.iter().filter(|r| r["event"] == event).count()
}

/// Mission time at which `drone` logged `event` for `action` with `args`.
fn times(log: &[Value], event: &str, action: &str, args: &[f64]) -> Vec<f64> {
    log.iter()
        .filter(|r| {
            r["event"] == event
                && r["action"].as_str().is_some_and(|a| a.starts_with(action))
                && (event != "action_started"
                    || r["args"].as_array().is_some_and(|a| {
                        a.iter()
                            .map(|v| v.as_f64().unwrap())
                            .eq(args.iter().copied())
                    }))
        })
        .map(|r| r["time"].as_f64().unwrap())
        .collect()
}

fn run(mission: &str, dir: &Path, extra: &[&str]) -> std::process::Output {
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(paper(mission))
        .arg("--out")
        .arg(dir)
        .args(["--speed", "50"])
        .args(extra)
        .output()
        .unwrap()
}

fn assert_counts_match_slices(mission: &str, dir: &Path) {
    for (peer, bridges_in, bridges_out) in slice_bridges(mission) {
        let log = mission_log(dir, &peer);
        assert_eq!(
            count(&log, "bridge_received"),
            bridges_in,
            "{mission}: {peer} received"
        );
        assert_eq!(
            count(&log, "bridge_sent"),
            bridges_out,
            "{mission}: {peer} sent"
        );
    }
}

#[test]
fn every_paper_mission_without_loops_completes_with_as_many_messages_as_its_slices_have_bridges() {
    for mission in [
        "experiment_a.go",
        "experiment_b.go",
        "experiment_c.go",
        "listing01_demo.go",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = run(mission, dir.path(), &[]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{mission}: {stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(stdout.contains("completed after"), "{stdout}");
        assert_counts_match_slices(mission, dir.path());
        assert!(dir.path().join("trajectories.svg").exists());
        for (peer, _, _) in slice_bridges(mission)
            .into_iter()
            .filter(|(p, _, _)| p != "GCS")
        {
            for log in ["uniform", "adapter"] {
                let p = dir.path().join(format!("{peer}.{log}.jsonl"));
                assert!(p.exists(), "{}", p.display());
            }
        }
    }
}

#[test]
fn experiment_c_moves_the_real_drones_only_after_drone3_has_moved() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("experiment_c.go", dir.path(), &[]);
    assert!(out.status.success());
    let d3 = mission_log(dir.path(), "Drone3");
    let legs = [
        ("FlyByX", 5.0, 1.0),
        ("FlyByY", 5.0, 1.0),
        ("FlyByX", -5.0, -1.0),
        ("FlyByY", -5.0, -1.0),
    ];
    for (action, d3_arg, follower_arg) in legs {
        let d3_done = times(&d3, "action_finished", &format!("{action}({d3_arg})"), &[]);
        assert_eq!(d3_done.len(), 1, "{action}({d3_arg})");
        for follower in ["Drone1", "Drone2"] {
            let log = mission_log(dir.path(), follower);
            let started = times(&log, "action_started", action, &[follower_arg]);
            assert_eq!(started.len(), 1, "{follower} {action}({follower_arg})");
            assert!(
                started[0] >= d3_done[0],
                "{follower} {action} began before Drone3 had moved"
            );
        }
    }
    // Everyone lands only after Drone3 has landed; disarming comes last.
    let d3_land = times(&d3, "action_finished", "Land", &[])[0];
    for follower in ["Drone1", "Drone2"] {
        let log = mission_log(dir.path(), follower);
        assert!(times(&log, "action_started", "Land", &[])[0] >= d3_land);
    }
}

#[test]
fn listing_1_turns_on_all_three_before_any_preflight_check_and_the_camera_comes_last() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("listing01_demo.go", dir.path(), &[]);
    assert!(out.status.success());
    let logs: Vec<Vec<Value>> = ["Drone1", "Drone2", "Drone3"]
        .iter()
        .map(|d| mission_log(dir.path(), d))
        .collect();
    let turned_on = logs
        .iter()
        .map(|l| times(l, "action_finished", "TurnOn", &[])[0])
        .fold(0.0, f64::max);
    for l in &logs[..2] {
        assert!(times(l, "action_started", "PreFlightCheck", &[])[0] >= turned_on);
        assert!(
            times(l, "action_started", "Calibrate", &[])[0]
                >= times(l, "action_finished", "PreFlightCheck", &[])[0]
        );
    }
    let calibrated = logs[..2]
        .iter()
        .map(|l| times(l, "action_finished", "Calibrate", &[])[0])
        .fold(0.0, f64::max);
    assert!(times(&logs[1], "action_started", "TurnOnCamera", &[])[0] >= calibrated);
}

#[test]
fn the_one_process_fleet_runs_over_zenoh_on_loopback_too() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("experiment_b.go", dir.path(), &["--transport", "zenoh"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_counts_match_slices("experiment_b.go", dir.path());
}

/// Experiment D with its scripted pilot, for at most 120 s of mission time.
fn run_experiment_d(dir: &Path, extra: &[&str]) -> std::process::Output {
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(paper("experiment_d.go"))
        .arg("--fleet")
        .arg(example("experiment_d_fleet.toml"))
        .args(extra)
        .args(["--max-duration", "120", "--out"])
        .arg(dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap()
}

#[test]
fn experiment_d_is_refused_for_its_findings_and_says_which() {
    // D1 and D2 move 20 cm every time the pilot hovers D3 over a square,
    // for as long as D3 stays in the field: nothing bounds how far they go.
    let dir = tempfile::tempdir().unwrap();
    let out = run_experiment_d(dir.path(), &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("eamos::drift"), "{stderr}");
    assert!(stderr.contains("not flying it"), "{stderr}");
    assert!(stderr.contains("--allow-findings"), "{stderr}");
    // Nothing flew: no drone wrote a log.
    assert!(std::fs::read_dir(dir.path()).map_or(true, |d| d.count() == 0));
}

#[test]
fn the_ground_station_refuses_experiment_d_and_a_drone_leaves_the_check_to_it() {
    // The ground station checks, as the whole fleet does, and starts
    // nothing.
    let dir = tempfile::tempdir().unwrap();
    let out = run_experiment_d(dir.path(), &["--gcs"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("eamos::drift"), "{stderr}");
    assert!(stderr.contains("not flying it"), "{stderr}");
    assert!(std::fs::read_dir(dir.path()).map_or(true, |d| d.count() == 0));
    // A drone's agent does not check: it waits for a ground station that
    // never starts the mission, until its time limit, having flown nothing.
    let dir = tempfile::tempdir().unwrap();
    let out = run_experiment_d(dir.path(), &["--drone", "D1", "--speed", "400"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(!stderr.contains("not flying it"), "{stderr}");
    assert!(!stderr.contains("eamos::drift"), "{stderr}");
    assert!(stdout.contains("did not complete"), "{stdout}");
    let log = mission_log(dir.path(), "D1");
    assert_eq!(count(&log, "action_started"), 0, "{log:?}");
}

#[test]
fn experiment_d_with_a_scripted_pilot_lands_everyone_at_the_time_limit_and_says_what_waited() {
    let dir = tempfile::tempdir().unwrap();
    let out = run_experiment_d(dir.path(), &["--allow-findings"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("did not complete"), "{stdout}");
    // The four loops wait in their WaitUntil, on D3's position.
    assert_eq!(
        stdout.matches("waits for its condition").count(),
        4,
        "{stdout}"
    );
    assert!(stdout.contains("experiment_d.go:56:"), "{stdout}");
    // D1 and D2 moved both ways while D3 hovered over their squares.
    for drone in ["D1", "D2"] {
        let log = mission_log(dir.path(), drone);
        assert!(
            !times(&log, "action_started", "FlyByX", &[0.2]).is_empty(),
            "{drone} X+"
        );
        assert!(
            !times(&log, "action_started", "FlyByX", &[-0.2]).is_empty(),
            "{drone} X-"
        );
    }
    // Every drone is on the ground at the end.
    for drone in ["D1", "D2", "D3"] {
        let adapter =
            std::fs::read_to_string(dir.path().join(format!("{drone}.adapter.jsonl"))).unwrap();
        let last = adapter
            .lines()
            .rev()
            .filter_map(|l| serde_json::from_str::<Value>(l).ok())
            .find(|r| r["event"] == "position");
        let log = mission_log(dir.path(), drone);
        let landed = log.iter().any(|r| {
            r["event"] == "failsafe_finished" && r["failsafe"] == "land" && r["outcome"] == "ok"
        });
        assert!(landed, "{drone} did not land: last position {last:?}");
        assert!(log.iter().any(|r| r["event"] == "time_limit"));
    }
}

#[test]
fn a_drone_the_mission_does_not_have_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("experiment_b.go", dir.path(), &["--drone", "Drone9"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("Drone9") && err.contains("Drone1, Drone2"),
        "{err}"
    );
}

#[test]
fn a_fleet_file_with_a_typo_is_bad_input_naming_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(&fleet, "[drones.Drone1]\nadaptr = \"sim\"\n").unwrap();
    let out = run(
        "experiment_b.go",
        dir.path(),
        &["--fleet", fleet.to_str().unwrap()],
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("fleet.toml") && err.contains("line 2"),
        "{err}"
    );
}

#[test]
fn a_speed_of_zero_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = run("experiment_a.go", dir.path(), &["--speed", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--speed"));
}

#[test]
fn a_mission_that_does_not_compile_is_bad_input_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("broken.go");
    std::fs::write(
        &m,
        "package M\n\nvar D1 Quadcopter\n\nfunc INIT() {\n\tD1.Fly()\n}\n",
    )
    .unwrap();
    let out = Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(&m)
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("broken.go") && err.contains("6"), "{err}");
}
