//! `eamos view` from the command line: the report of experiment C and of a
//! planted collision, and every way bad input is refused (with the same
//! located diagnostics as `eamos check`, exit status 2, no report written).

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::prelude::*;

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn experiment_c() -> PathBuf {
    repo("../shared/missions/paper/experiment_c.go")
}

fn eamos() -> Command {
    let mut c = Command::cargo_bin("eamos").unwrap();
    c.env("NO_COLOR", "1");
    c
}

/// The model embedded in a report page.
fn model_of(page: &Path) -> serde_json::Value {
    let html = std::fs::read_to_string(page).unwrap();
    let start = html
        .find(r#"id="eamos-model">"#)
        .expect("the model's script")
        + r#"id="eamos-model">"#.len();
    let end = start + html[start..].find("</script>").unwrap();
    serde_json::from_str(&html[start..end]).unwrap()
}

#[test]
fn the_report_of_experiment_c_has_three_drones_legs_lanes_and_its_graph() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("c.html");
    eamos()
        .arg("view")
        .arg(experiment_c())
        .arg("-o")
        .arg(&page)
        .assert()
        .success()
        .stderr(predicate::str::contains("report written to"));
    let m = model_of(&page);
    assert_eq!(m["schema"], "eamos-view/1");
    assert_eq!(m["drones"].as_array().unwrap().len(), 3);
    for d in 0..3 {
        let legs = m["legs"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|l| l["drone"] == d)
            .count();
        // Take-off, four sides of a square, landing.
        assert_eq!(legs, 6, "drone {d}");
    }
    assert_eq!(m["timeline"]["lanes"].as_array().unwrap().len(), 3);
    assert!(!m["timeline"]["waits"].as_array().unwrap().is_empty());
    let nodes = m["graph"]["nodes"].as_array().unwrap();
    assert!(nodes.len() > 50, "{}", nodes.len());
    assert!(nodes.iter().any(|n| n["line"] == 12));
    assert!(m["findings"].as_array().unwrap().is_empty());
}

#[test]
fn the_report_of_a_planted_collision_carries_the_findings_to_draw() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("crossing.html");
    eamos()
        .arg("view")
        .arg(repo("tests/view/crossing.go"))
        .arg("--fleet")
        .arg(repo("tests/view/crossing_fleet.toml"))
        .arg("--output")
        .arg(&page)
        .assert()
        .success()
        .stderr(predicate::str::contains("2 finding(s)"));
    let m = model_of(&page);
    let findings = m["findings"].as_array().unwrap();
    let close = findings.iter().find(|f| f["kind"] == "too-close").unwrap();
    assert_eq!(close["legs"].as_array().unwrap().len(), 2);
    assert!(close["closest"].is_array());
    assert_eq!(close["line"], 32);
    let out = findings
        .iter()
        .find(|f| f["kind"] == "leaves-airspace")
        .unwrap();
    assert_eq!(out["legs"][0]["drone"], 0);
    assert_eq!(out["closest"][0][0], 15.0);
    assert_eq!(m["airspace"]["fence"].as_array().unwrap().len(), 4);
    assert_eq!(m["airspace"]["ceiling"], 30.0);
}

#[test]
fn without_an_output_the_report_is_named_after_the_mission() {
    let dir = tempfile::tempdir().unwrap();
    eamos()
        .current_dir(dir.path())
        .arg("view")
        .arg(experiment_c())
        .assert()
        .success();
    assert!(dir.path().join("experiment_c.html").exists());
}

#[test]
fn a_mission_that_does_not_compile_is_refused_at_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let mission = dir.path().join("bad.go");
    std::fs::write(
        &mission,
        "package Bad\n\nvar D Quadcopter\n\nfunc SEQ_M() {\n\tD.Arm()\n\tD.Takeof(5)\n}\n",
    )
    .unwrap();
    let page = dir.path().join("bad.html");
    eamos()
        .arg("view")
        .arg(&mission)
        .arg("-o")
        .arg(&page)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("bad.go:7:"))
        .stderr(predicate::str::contains("Takeof"))
        .stderr(predicate::str::contains("panicked").not());
    assert!(!page.exists());
}

#[test]
fn a_mission_that_is_not_utf8_is_refused_at_its_place() {
    let dir = tempfile::tempdir().unwrap();
    let mission = dir.path().join("bytes.go");
    std::fs::write(&mission, b"package B\n// \xff\xfe\n").unwrap();
    eamos()
        .arg("view")
        .arg(&mission)
        .arg("-o")
        .arg(dir.path().join("b.html"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("bytes.go:2:"));
}

#[test]
fn a_missing_mission_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    eamos()
        .arg("view")
        .arg(dir.path().join("nowhere.go"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot read"))
        .stderr(predicate::str::contains("nowhere.go"));
}

#[test]
fn a_bad_fleet_file_is_refused_at_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("bad.toml");
    std::fs::write(&fleet, "[airspace]\nceiling = 5.0\nfloor = 10.0\n").unwrap();
    eamos()
        .arg("view")
        .arg(experiment_c())
        .arg("--fleet")
        .arg(&fleet)
        .arg("-o")
        .arg(dir.path().join("c.html"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("bad.toml:"))
        .stderr(predicate::str::contains("ceiling"));
    let typo = dir.path().join("typo.toml");
    std::fs::write(
        &typo,
        "[drones.Drone1]\nhome = { x = 0.0, y = 0.0, z = 0.0 }\nhomme = 3\n",
    )
    .unwrap();
    eamos()
        .arg("view")
        .arg(experiment_c())
        .arg("--fleet")
        .arg(&typo)
        .arg("-o")
        .arg(dir.path().join("c.html"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("typo.toml"))
        .stderr(predicate::str::contains("line 3"));
    assert!(!dir.path().join("c.html").exists());
}

#[test]
fn a_report_that_cannot_be_written_is_an_error_naming_its_path() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("no-such-dir").join("c.html");
    eamos()
        .arg("view")
        .arg(experiment_c())
        .arg("-o")
        .arg(&page)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot write"))
        .stderr(predicate::str::contains("c.html"));
}
