//! `eamos build` and the mission's Petri net: the size table per drone, and
//! `-o DIR` writing the net as PNML, DOT and GraphML.

use std::path::PathBuf;

use assert_cmd::Command;
use predicates::prelude::*;

fn paper(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

fn eamos() -> Command {
    let mut cmd = Command::cargo_bin("eamos").expect("the eamos binary is built");
    cmd.env("NO_COLOR", "1");
    cmd
}

#[test]
fn build_prints_the_size_of_the_net_per_drone() {
    eamos()
        .arg("build")
        .arg(paper("experiment_b.go"))
        .assert()
        .success()
        .stdout(predicate::str::contains("net of mission ExperimentB"))
        .stdout(predicate::str::is_match(r"(?m)^Drone1 +\d+ +\d+ +\d+ +\d+$").unwrap())
        .stdout(predicate::str::is_match(r"(?m)^GCS +1 +1 +2 +0$").unwrap())
        .stdout(predicate::str::is_match(r"(?m)^total +\d+ +\d+ +\d+ +\d+$").unwrap());
}

#[test]
fn build_with_an_output_directory_writes_the_net_in_three_formats() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nets/b");
    eamos()
        .arg("build")
        .arg(paper("experiment_b.go"))
        .arg("-o")
        .arg(&out)
        .assert()
        .success()
        .stdout(predicate::str::contains("wrote"));
    let pnml = std::fs::read_to_string(out.join("net.pnml")).unwrap();
    assert!(pnml.contains("http://www.pnml.org/version-2009/grammar/ptnet"));
    assert!(pnml.contains("<place id=\"final\">"));
    assert!(!pnml.contains("final_loop"));
    assert!(
        pnml.contains("experiment_b.go:9:2\""),
        "Drone1.Arm() on line 9"
    );
    let dot = std::fs::read_to_string(out.join("net.dot")).unwrap();
    assert!(dot.starts_with("digraph"));
    let graphml = std::fs::read_to_string(out.join("net.graphml")).unwrap();
    assert!(graphml.contains("<graphml"));
}

#[test]
fn the_final_loop_option_adds_the_self_loop_on_the_final_place() {
    let dir = tempfile::tempdir().unwrap();
    eamos()
        .arg("build")
        .arg(paper("experiment_a.go"))
        .args(["--pnml-final-loop", "-o"])
        .arg(dir.path())
        .assert()
        .success();
    let pnml = std::fs::read_to_string(dir.path().join("net.pnml")).unwrap();
    assert!(pnml.contains("<transition id=\"final_loop\">"));
    assert!(pnml.contains("source=\"final\" target=\"final_loop\""));
    assert!(pnml.contains("source=\"final_loop\" target=\"final\""));
}

#[test]
fn json_output_carries_the_net_statistics_and_the_files_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = eamos()
        .args(["build", "--json"])
        .arg(paper("experiment_d.go"))
        .arg("-o")
        .arg(dir.path())
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).expect("valid JSON");
    let owners: Vec<&str> = v["net"]["owners"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["owner"].as_str().unwrap())
        .collect();
    assert_eq!(owners, ["D1", "D2", "D3", "GCS", "unassigned"]);
    let total = &v["net"]["total"];
    let sum: u64 = v["net"]["owners"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["places"].as_u64().unwrap())
        .sum();
    assert_eq!(total["places"].as_u64().unwrap(), sum);
    assert_eq!(v["written"].as_array().unwrap().len(), 3);
}

#[test]
fn an_output_directory_that_cannot_be_created_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("a_file");
    std::fs::write(&blocker, "not a directory").unwrap();
    eamos()
        .arg("build")
        .arg(paper("experiment_a.go"))
        .arg("-o")
        .arg(blocker.join("sub"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot create"))
        .stderr(predicate::str::contains("a_file"));
}
