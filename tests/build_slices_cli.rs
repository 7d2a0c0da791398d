//! `eamos build` and the mission's slices: the per-drone slice table, the
//! same figures in `--json`, and `-o DIR` writing one slice per drone.

use assert_cmd::Command;
use predicates::prelude::*;
use std::path::PathBuf;

fn eamos() -> Command {
    Command::cargo_bin("eamos").unwrap()
}

fn paper(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(file)
}

#[test]
fn build_prints_the_bridges_of_every_slice() {
    eamos()
        .arg("build")
        .arg(paper("experiment_b.go"))
        .assert()
        .success()
        .stdout(predicate::str::contains("bridges in  bridges out"))
        .stdout(predicate::str::contains("16 bridges in all"));
}

#[test]
fn build_writes_one_readable_slice_per_drone_beside_the_net() {
    let dir = tempfile::tempdir().unwrap();
    eamos()
        .arg("build")
        .arg(paper("experiment_c.go"))
        .arg("-o")
        .arg(dir.path())
        .assert()
        .success();
    for drone in ["GCS", "Drone1", "Drone2", "Drone3"] {
        let bytes = std::fs::read(dir.path().join(format!("slice-{drone}.bin"))).unwrap();
        let slice = eamos_slicer::Slice::from_bytes(&bytes).unwrap();
        assert_eq!(slice.drone, drone);
        let json = std::fs::read_to_string(dir.path().join(format!("slice-{drone}.json"))).unwrap();
        assert_eq!(eamos_slicer::Slice::from_json(&json).unwrap(), slice);
        assert!(dir.path().join(format!("net-{drone}.dot")).exists());
    }
}

#[test]
fn build_json_carries_the_slice_statistics_and_the_slice_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = eamos()
        .args(["build", "--json"])
        .arg(paper("experiment_b.go"))
        .arg("-o")
        .arg(dir.path())
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).expect("valid JSON");
    let rows: Vec<(String, u64, u64)> = v["slices"]["slices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["drone"].as_str().unwrap().to_string(),
                s["bridges_in"].as_u64().unwrap(),
                s["bridges_out"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        rows,
        [
            ("GCS".to_string(), 0, 1),
            ("Drone1".to_string(), 9, 7),
            ("Drone2".to_string(), 7, 8)
        ]
    );
    // Three files per peer, and the manifest `eamos run --slices` reads.
    let written = v["slices_written"].as_array().unwrap();
    assert_eq!(written.len(), 10);
    assert!(written
        .iter()
        .any(|p| p.as_str().unwrap().ends_with("slices.json")));
}

/// A fleet file that cannot be read stops the build before it writes
/// anything: no net, no slices from a mission cut for no fleet.
#[test]
fn build_with_a_bad_fleet_file_names_it_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(&fleet, "[zenoh\n").unwrap();
    let out = dir.path().join("out");
    eamos()
        .arg("build")
        .arg(paper("experiment_c.go"))
        .arg("--fleet")
        .arg(&fleet)
        .arg("-o")
        .arg(&out)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("fleet.toml"));
    assert!(!out.exists(), "nothing is written");
}
