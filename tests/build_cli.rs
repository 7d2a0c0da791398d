//! `eamos build`: what a person sees when compiling a mission.

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

fn mission(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).expect("temp file");
    path
}

#[test]
fn building_a_paper_mission_prints_its_summary_and_exits_0() {
    eamos()
        .args(["build"])
        .arg(paper("experiment_d.go"))
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "mission ExperimentD (entry SEQ_Experiment_D)",
        ))
        .stdout(predicate::str::contains("  D3: Quadcopter, 7 actions"))
        .stdout(predicate::str::contains("actions: 17"))
        .stdout(predicate::str::contains("blocks: 16 (10 SEQ, 6 PAR)"))
        .stdout(predicate::str::contains(
            "control structures: 8 (RepeatWhile 4, WaitUntil 4)",
        ))
        .stderr(predicate::str::is_empty());
}

#[test]
fn every_paper_mission_builds() {
    for name in [
        "experiment_a.go",
        "experiment_b.go",
        "experiment_c.go",
        "experiment_d.go",
        "listing01_demo.go",
    ] {
        eamos().arg("build").arg(paper(name)).assert().success();
    }
}

#[test]
fn a_mission_with_errors_reports_them_with_file_line_and_column_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let path = mission(
        &dir,
        "typo.go",
        "package Typo\n\nvar Drone1 Quadcopter\n\nfunc INIT() {\n\tDrone1.FlyBX(1)\n\tDrone2.Land()\n}\n",
    );
    eamos()
        .arg("build")
        .arg(&path)
        .assert()
        .code(2)
        .stdout(predicate::str::is_empty())
        .stderr(predicate::str::contains("eamos::unknown-action"))
        .stderr(predicate::str::contains("typo.go:6:9"))
        .stderr(predicate::str::contains("did you mean `FlyByX`?"))
        .stderr(predicate::str::contains("eamos::unknown-drone"))
        .stderr(predicate::str::contains("typo.go: 2 errors"));
}

#[test]
fn a_mission_with_warnings_builds_and_shows_them_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let path = mission(
        &dir,
        "spare.go",
        "package Spare\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc INIT() {\n\tD1.Takeoff(1)\n}\n",
    );
    eamos()
        .arg("build")
        .arg(&path)
        .assert()
        .success()
        .stdout(predicate::str::contains("  D2: Quadcopter, 0 actions"))
        .stderr(predicate::str::contains(
            "drone `D2` is declared but never used",
        ));
}

#[test]
fn an_unreadable_file_is_an_error_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no_such_mission.go");
    eamos()
        .arg("build")
        .arg(&missing)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot read"))
        .stderr(predicate::str::contains("no_such_mission.go"));
}

#[test]
fn a_file_that_is_not_utf8_is_a_located_error_from_build_and_check() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("latin1.go");
    // Line 3 was saved in Latin-1: its `é` is the byte 0xE9, not UTF-8.
    std::fs::write(
        &path,
        b"package Latin\n\n// caf\xe9 first\nvar D1 Quadcopter\n\nfunc INIT() {\n\tD1.Takeoff(1)\n}\n",
    )
    .unwrap();
    for command in ["build", "check"] {
        eamos()
            .arg(command)
            .arg(&path)
            .assert()
            .code(2)
            .stdout(predicate::str::is_empty())
            .stderr(predicate::str::contains("eamos::not-utf8"))
            .stderr(predicate::str::contains("the file is not valid UTF-8"))
            .stderr(predicate::str::contains("latin1.go:3:7"))
            .stderr(predicate::str::contains("caf\u{fffd} first"))
            .stderr(predicate::str::contains("stream did not contain").not());
    }
}

#[test]
fn json_output_gives_the_summary_or_the_diagnostics_with_positions() {
    let out = eamos()
        .args(["build", "--json"])
        .arg(paper("experiment_b.go"))
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).expect("valid JSON");
    assert_eq!(v["summary"]["actions"], 18);
    assert_eq!(v["summary"]["par_blocks"], 7);

    let dir = tempfile::tempdir().unwrap();
    let path = mission(
        &dir,
        "bad.go",
        "package Bad\nfunc INIT() {\n\tRepeatFor(-1, INIT)\n",
    );
    let out = eamos()
        .args(["build", "--json"])
        .arg(&path)
        .assert()
        .code(2)
        .get_output()
        .stdout
        .clone();
    let v: serde_json::Value = serde_json::from_slice(&out).expect("valid JSON");
    let first = &v["diagnostics"][0];
    assert_eq!(first["code"], "eamos::syntax");
    assert_eq!(first["line"], 3);
}

#[test]
fn help_explains_what_build_prints_and_its_exit_status() {
    eamos()
        .args(["build", "--help"])
        .assert()
        .success()
        .stdout(predicate::str::contains("summary"))
        .stdout(predicate::str::contains("exit status is 2"))
        .stdout(predicate::str::contains("MISSION"));
}
