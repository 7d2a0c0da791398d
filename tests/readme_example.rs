//! The README's first example is a real mission: it stays identical to
//! `examples/survey.go`, compiles, and `eamos check` finds nothing in it;
//! the README's main command flies a mission of the repository itself, so
//! that it works from a fresh clone with nothing beside it.

use std::path::Path;

use assert_cmd::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn the_readme_example_is_the_survey_example_file() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let start = readme.find("```go\n").expect("README has a Go example") + 6;
    let end = start + readme[start..].find("```").unwrap();
    let example = std::fs::read_to_string(root().join("examples/survey.go")).unwrap();
    assert!(
        example.ends_with(&readme[start..end]),
        "examples/survey.go must end with the README's example verbatim"
    );
}

#[test]
fn the_survey_example_builds_and_checks_clean() {
    let mission = root().join("examples/survey.go");
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("build")
        .arg(&mission)
        .assert()
        .success();
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("check")
        .arg(&mission)
        .assert()
        .success();
}

/// The mission the README's main command (`cargo run --release -- run
/// MISSION`) flies.
fn main_command_mission(readme: &str) -> &str {
    let line = readme
        .lines()
        .find(|l| l.starts_with("cargo run --release -- run "))
        .expect("README names the main command");
    line.trim_start_matches("cargo run --release -- run ")
        .split_whitespace()
        .next()
        .expect("the main command names a mission")
}

#[test]
fn the_readme_main_command_flies_a_mission_of_the_repository() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let mission = main_command_mission(&readme);
    assert!(
        mission.starts_with("examples/") && !mission.contains(".."),
        "the main command must fly a mission of examples/, not {mission}"
    );
    assert!(root().join(mission).is_file(), "{mission} is missing");
    let out = tempfile::tempdir().unwrap();
    Command::cargo_bin("eamos")
        .unwrap()
        .current_dir(root())
        .args(["run", mission, "--speed", "100", "--out"])
        .arg(out.path())
        .timeout(std::time::Duration::from_secs(120))
        .assert()
        .success();
}
