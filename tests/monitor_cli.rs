//! The monitor's bad input (`eamos run --monitor`, `eamos deploy
//! --monitor`, `eamos monitor --listen`): an address that is not one, and
//! a port that is taken, are refused with a clear error and exit status 2
//! before anything flies or is sent.

use std::net::TcpListener;
use std::path::PathBuf;

use assert_cmd::Command;
use predicates::prelude::*;
use predicates::str::contains;

fn mission() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_c.go")
}

#[test]
fn a_monitor_address_that_is_not_one_is_bad_input() {
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(mission())
        .args(["--monitor", "localhost:http"])
        .assert()
        .code(2)
        .stderr(contains("is not an address to listen on"));
}

#[test]
fn a_taken_monitor_port_stops_the_run_before_anything_flies() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let out = tempfile::tempdir().unwrap();
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(mission())
        .args(["--monitor", &addr, "--out"])
        .arg(out.path())
        .assert()
        .code(2)
        .stderr(contains(format!("the monitor cannot listen on {addr}")))
        .stderr(contains("started").not());
    assert!(
        !out.path().join("Drone1.mission.jsonl").exists(),
        "nothing flew"
    );
}

#[test]
fn a_taken_monitor_port_stops_a_deploy_before_any_slice_is_sent() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("deploy")
        .arg(mission())
        .args(["--monitor", &addr, "--wait", "0"])
        .assert()
        .code(2)
        .stderr(contains(format!("the monitor cannot listen on {addr}")))
        .stdout(contains("deploying").not());
}

#[test]
fn eamos_monitor_refuses_an_address_that_is_not_one() {
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("monitor")
        .arg(mission())
        .args(["--listen", "here"])
        .assert()
        .code(2)
        .stderr(contains("is not an address to listen on"));
}
