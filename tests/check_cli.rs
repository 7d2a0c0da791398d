//! `eamos check` from the command line: verdicts, exit statuses and the two
//! output forms.

use std::path::PathBuf;

use assert_cmd::Command;
use predicates::prelude::*;

fn paper(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

fn fixture(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn eamos() -> Command {
    Command::cargo_bin("eamos").unwrap()
}

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const LOST_SIGNAL: &str = r#"package Lost

var D1 Quadcopter
var D2 Quadcopter

func PAR_Main() {
	SEQ_A()
	SEQ_B()
}

func SEQ_A() {
	If(D1.Battery() > 50, SEQ_Go)
	D1.Land()
}

func SEQ_Go() {
	Signal("go")
}

func SEQ_B() {
	Await("go")
	D2.Takeoff(1)
}
"#;

#[test]
fn check_of_a_clean_paper_mission_exits_0_and_says_every_property_holds() {
    eamos()
        .arg("check")
        .arg(paper("experiment_a.go"))
        .assert()
        .code(0)
        .stdout(predicate::str::contains("deadlock"))
        .stdout(predicate::str::contains("nothing found"))
        .stdout(predicate::str::contains("violated").not());
}

#[test]
fn check_of_a_mission_that_can_get_stuck_exits_1_and_points_at_the_await() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(&dir, "lost.go", LOST_SIGNAL);
    eamos()
        .arg("check")
        .arg(&m)
        .assert()
        .code(1)
        .stdout(predicate::str::contains("lost.go:21:2"))
        .stdout(predicate::str::contains("Await(\"go\")"))
        .stdout(predicate::str::contains("does not hold"));
}

#[test]
fn check_json_gives_verdicts_findings_and_steps_for_tools() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(&dir, "lost.go", LOST_SIGNAL);
    let out = eamos()
        .args(["check", "--json"])
        .arg(&m)
        .assert()
        .code(1)
        .get_output()
        .stdout
        .clone();
    let j: serde_json::Value = serde_json::from_slice(&out).expect("valid JSON");
    assert_eq!(j["schema"], "eamos-check/1");
    assert_eq!(j["found"], true);
    let deadlock = j["findings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["kind"] == "deadlock")
        .expect("a deadlock finding");
    assert!(deadlock["spans"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["line"] == 21 && s["col"] == 2));
    assert!(!deadlock["counterexample"]["steps"]
        .as_array()
        .unwrap()
        .is_empty());
}

#[test]
fn check_that_stops_at_its_memory_bound_is_not_a_proof_and_exits_3() {
    // With no memory at all the exploration stops after its first chunk of
    // markings: nothing is found, but nothing is proved either.
    eamos()
        .args(["check", "--max-memory", "0"])
        .arg(paper("experiment_c.go"))
        .assert()
        .code(3)
        .stdout(predicate::str::contains("unknown"))
        .stdout(predicate::str::contains("nothing found, but not proved"));
}

#[test]
fn check_of_a_billion_rounds_that_only_the_loop_can_count_proves_the_logic_at_once() {
    // Nothing outside the loop can tell its rounds apart, so the checker
    // explores them uncounted; the legs of a billion rounds are still too
    // many to follow, and the spatial properties say so.
    let dir = tempfile::tempdir().unwrap();
    let m = write(
        &dir,
        "billion.go",
        "package Billion\n\nvar D1 Quadcopter\n\nfunc INIT() {\n\tD1.Arm()\n\tD1.Takeoff(1)\n\tRepeatFor(1000000000, SEQ_Hop)\n\tD1.Land()\n}\n\nfunc SEQ_Hop() {\n\tD1.FlyByX(1)\n}\n",
    );
    let limit = std::time::Duration::from_secs(60);
    eamos().arg("build").arg(&m).timeout(limit).assert().code(0);
    eamos()
        .arg("check")
        .arg(&m)
        .env("NO_COLOR", "1")
        .timeout(limit)
        .assert()
        .code(3)
        .stdout(predicate::str::is_match(r"ok +deadlock").unwrap())
        .stdout(predicate::str::is_match(r"ok +dead-actions").unwrap())
        .stdout(predicate::str::contains(
            "1 `RepeatFor` loop(s) explored without counting their rounds",
        ))
        .stdout(predicate::str::contains(
            "too large to follow every drone's legs",
        ))
        .stdout(predicate::str::contains(
            "nothing found, but not proved: 2 properties undecided",
        ));
}

#[test]
fn check_of_a_billion_rounds_that_wait_on_another_drone_says_at_once_they_are_too_many() {
    // Each round waits for D2's signal: the rounds are counted, exactly,
    // one state each, and a billion would run for minutes before reaching
    // the memory bound. The checker must say so at once, at the count.
    let dir = tempfile::tempdir().unwrap();
    let m = write(
        &dir,
        "billion.go",
        "package Billion\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc SEQ_One() {\n\tD1.Arm()\n\tRepeatFor(1000000000, SEQ_Hop)\n}\n\nfunc SEQ_Hop() {\n\tAwait(\"go\")\n\tD1.TakePhoto()\n}\n\nfunc SEQ_Two() {\n\tD2.Arm()\n\tSignal(\"go\")\n}\n\nfunc PAR_Main() {\n\tSEQ_One()\n\tSEQ_Two()\n}\n",
    );
    let limit = std::time::Duration::from_secs(60);
    eamos().arg("build").arg(&m).timeout(limit).assert().code(0);
    eamos()
        .arg("check")
        .arg(&m)
        .env("NO_COLOR", "1")
        .timeout(limit)
        .assert()
        .code(3)
        .stdout(predicate::str::contains("eamos::too-large-to-explore"))
        .stdout(predicate::str::contains("billion.go:8:12"))
        .stdout(predicate::str::contains("1000000000 rounds"))
        .stdout(predicate::str::contains("without counting their rounds").not())
        .stdout(predicate::str::contains("nothing found, but not proved"));
}

#[test]
fn check_of_a_mission_with_front_end_errors_prints_them_and_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let m = write(
        &dir,
        "typo.go",
        "package Typo\n\nvar D1 Quadcopter\n\nfunc INIT() {\n\tD1.FlyByZZ(1)\n}\n",
    );
    eamos()
        .arg("check")
        .arg(&m)
        .assert()
        .code(2)
        .stderr(predicate::str::contains("typo.go:6:"));
}

#[test]
fn check_of_a_file_that_cannot_be_read_exits_2() {
    eamos()
        .args(["check", "no/such/mission.go"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot read"));
}

#[test]
fn check_of_a_malformed_pnml_file_names_line_and_column_and_exits_2() {
    eamos()
        .arg("check")
        .arg(fixture("verify/tests/pnml/malformed_arc.pnml"))
        .assert()
        .code(2)
        .stderr(predicate::str::contains("malformed_arc.pnml:6:5"));
}

#[test]
fn check_of_a_pnml_net_reports_its_deadlock_and_exits_1() {
    eamos()
        .arg("check")
        .arg(fixture("verify/tests/pnml/philosophers_deadlock.pnml"))
        .assert()
        .code(1)
        .stdout(predicate::str::contains("dead marking"));
    eamos()
        .arg("check")
        .arg(fixture("verify/tests/pnml/mutex_no_deadlock.pnml"))
        .assert()
        .code(0);
}

#[test]
fn check_json_of_bad_input_is_an_error_object() {
    let out = eamos()
        .args(["check", "--json"])
        .arg(fixture("verify/tests/pnml/malformed_arc.pnml"))
        .assert()
        .code(2)
        .get_output()
        .stdout
        .clone();
    let j: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(j["error"]["line"], 6);
    assert_eq!(j["error"]["col"], 5);
}

/// The benchmark family of model checkers, written by `eamos gen`: the
/// symmetric table deadlocks (all holding their left fork, `n` steps from
/// the start), the asymmetric one does not; asked only about deadlocks,
/// check answers that alone.
#[test]
fn check_only_deadlock_finds_the_philosophers_deadlock_and_proves_the_asymmetric_table_free() {
    let dir = tempfile::tempdir().unwrap();
    let net = |n: &str, asym: bool| {
        let path = dir.path().join(format!("phil-{n}-{asym}.pnml"));
        let mut gen = eamos();
        gen.args(["gen", "--philosophers", n, "-o"]).arg(&path);
        if asym {
            gen.arg("--asymmetric");
        }
        gen.assert().success();
        path
    };
    let report = |path: &PathBuf, extra: &[&str], code: i32| -> serde_json::Value {
        let out = eamos()
            .args(["check", "--json", "--only", "deadlock"])
            .args(extra)
            .arg(path)
            .assert()
            .code(code)
            .get_output()
            .stdout
            .clone();
        serde_json::from_slice(&out).unwrap()
    };
    // Depth-first on a large table; breadth-first (whose frontier grows
    // exponentially with the table) on a small one, for the shortest.
    for (n, extra, shortest) in [(200, &[][..], false), (10, &["--shortest"][..], true)] {
        let j = report(&net(&n.to_string(), false), extra, 1);
        assert_eq!(j["properties"].as_array().unwrap().len(), 1, "{j}");
        assert_eq!(j["properties"][0]["verdict"], "violated");
        let trace = j["findings"][0]["counterexample"]["steps"]
            .as_array()
            .unwrap();
        assert!(trace.len() >= n, "every philosopher takes a fork");
        if shortest {
            assert_eq!(trace.len(), n);
        }
    }
    // Small enough to search to its end; large enough that only the place
    // invariants answer at once.
    for n in ["6", "100"] {
        let j = report(&net(n, true), &[], 0);
        assert_eq!(j["properties"][0]["verdict"], "holds", "{j}");
    }
}
