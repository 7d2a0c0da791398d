//! `eamos check --fleet` and `--svg`, and `eamos run` refusing a mission the
//! check finds unfit to fly: the spatial properties from the command line.

use std::path::PathBuf;

use assert_cmd::Command;
use predicates::prelude::*;

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn eamos() -> Command {
    Command::cargo_bin("eamos").unwrap()
}

#[test]
fn the_readme_survey_keeps_apart_and_inside_its_field() {
    let out = eamos()
        .arg("check")
        .arg(repo("examples/survey.go"))
        .arg("--fleet")
        .arg(repo("examples/airspace.toml"))
        .arg("--json")
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for p in ["separation", "airspace", "flight-state"] {
        let r = report["properties"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["property"] == p)
            .unwrap_or_else(|| panic!("no {p}"));
        assert_eq!(r["verdict"], "holds", "{p}: {r}");
    }
}

/// A fleet whose fence is too small for the survey's 10 m leg north.
const SMALL_FIELD: &str = r#"
[airspace]
fence = [[-2.0, -2.0], [6.0, -2.0], [6.0, 6.0], [-2.0, 6.0]]
separation = 2.0
"#;

#[test]
fn a_leg_out_of_the_fence_is_found_drawn_and_refused_for_flight() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("small.toml");
    std::fs::write(&fleet, SMALL_FIELD).unwrap();
    let svg = dir.path().join("plan.svg");
    eamos()
        .arg("check")
        .arg(repo("examples/survey.go"))
        .arg("--fleet")
        .arg(&fleet)
        .arg("--svg")
        .arg(&svg)
        .env("NO_COLOR", "1")
        .assert()
        .code(1)
        .stdout(predicate::str::contains("eamos::leaves-airspace"))
        .stdout(predicate::str::contains("leaves the fence at (6.0, 0.0"))
        .stdout(predicate::str::contains("survey.go:38:2"))
        .stdout(predicate::str::contains("survey.go:46:2"));
    let drawing = std::fs::read_to_string(&svg).unwrap();
    assert!(drawing.starts_with("<svg"), "{drawing}");
    assert!(drawing.contains(r#"class="fence""#), "{drawing}");
    assert!(drawing.contains(r#"class="leg""#), "{drawing}");
    assert!(drawing.contains(r#"class="closest""#), "{drawing}");
    assert!(drawing.contains("Scout home"), "{drawing}");

    // `run` checks first and flies nothing.
    let out = dir.path().join("out");
    eamos()
        .arg("run")
        .arg(repo("examples/survey.go"))
        .arg("--fleet")
        .arg(&fleet)
        .arg("--out")
        .arg(&out)
        .env("NO_COLOR", "1")
        .assert()
        .code(1)
        .stderr(predicate::str::contains("eamos::leaves-airspace"))
        .stderr(predicate::str::contains("not flying it"));
    assert!(!out.join("Scout.jsonl").exists());

    // Nor does `deploy`: it refuses before it sends any drone its slice.
    eamos()
        .arg("deploy")
        .arg(repo("examples/survey.go"))
        .arg("--fleet")
        .arg(&fleet)
        .env("NO_COLOR", "1")
        .timeout(std::time::Duration::from_secs(60))
        .assert()
        .code(1)
        .stderr(predicate::str::contains("eamos::leaves-airspace"))
        .stderr(predicate::str::contains("--allow-findings"));
}

#[test]
fn a_fleet_file_with_a_bad_airspace_is_refused_with_its_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("bad.toml");
    std::fs::write(&fleet, "[airspace]\nceiling = 5.0\nfloor = 10.0\n").unwrap();
    eamos()
        .arg("check")
        .arg(repo("examples/survey.go"))
        .arg("--fleet")
        .arg(&fleet)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("bad.toml:"))
        .stderr(predicate::str::contains("ceiling"));
}

#[test]
fn a_plan_view_that_cannot_be_written_is_an_error_naming_its_path() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("no-such-dir").join("plan.svg");
    eamos()
        .arg("check")
        .arg(repo("examples/survey.go"))
        .arg("--svg")
        .arg(&svg)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot write"))
        .stderr(predicate::str::contains("plan.svg"));
}
