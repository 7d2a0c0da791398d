//! The README's first example is a real mission: it stays identical to
//! `examples/survey.go`, compiles, and `eamos check` finds nothing in it.

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
