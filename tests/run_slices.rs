//! `eamos run --slices DIR --drone D`: a drone's agent flies the slice that
//! `eamos build --fleet FLEET --out DIR` cut for it, without compiling the
//! mission, beside a ground station that compiled (and checked) it; and
//! refuses, naming the file, slices cut for another fleet or damaged.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;

#[path = "common/processes.rs"]
mod processes;
use processes::{free_port, Processes};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

fn eamos() -> Command {
    Command::cargo_bin("eamos").unwrap()
}

/// A fleet file for the survey example with ports of its own, so that no
/// other test's peers meet these.
fn fleet(dir: &Path) -> PathBuf {
    let path = dir.join("fleet.toml");
    let text = format!(
        "[gcs]\nlisten = [\"tcp/127.0.0.1:{}\"]\n\n\
         [drones.Scout]\nzenoh = {{ listen = [\"tcp/127.0.0.1:{}\"] }}\n\n\
         [drones.Camera]\nzenoh = {{ listen = [\"tcp/127.0.0.1:{}\"] }}\n",
        free_port(),
        free_port(),
        free_port()
    );
    std::fs::write(&path, text).unwrap();
    path
}

fn build(fleet: Option<&Path>, out: &Path) -> Output {
    let mut cmd = eamos();
    cmd.arg("build")
        .arg(example("survey.go"))
        .arg("--out")
        .arg(out);
    if let Some(f) = fleet {
        cmd.arg("--fleet").arg(f);
    }
    cmd.output().unwrap()
}

fn run_slice(slices: &Path, drone: &str, fleet: Option<&Path>) -> Output {
    let mut cmd = eamos();
    cmd.arg("run")
        .arg("--slices")
        .arg(slices)
        .args(["--drone", drone]);
    if let Some(f) = fleet {
        cmd.arg("--fleet").arg(f);
    }
    // Its logs, should it fly, stay in the test's directory.
    cmd.args(["--max-duration", "1"])
        .arg("--out")
        .arg(slices.join("logs"))
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn drones_fly_their_slices_beside_a_ground_station_that_compiled_the_mission() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = fleet(dir.path());
    let slices = dir.path().join("slices");
    let built = build(Some(&fleet), &slices);
    assert!(built.status.success(), "{}", stderr(&built));
    assert!(slices.join("slices.json").exists());

    let logs = dir.path().join("logs");
    let mut procs = Processes(Vec::new());
    for role in [
        vec!["--slices", slices.to_str().unwrap(), "--drone", "Scout"],
        vec!["--slices", slices.to_str().unwrap(), "--drone", "Camera"],
        vec![example("survey.go").to_str().unwrap(), "--gcs"],
    ] {
        let tag = role.last().unwrap().trim_start_matches('-').to_string();
        let child = eamos()
            .arg("run")
            .args(&role)
            .arg("--fleet")
            .arg(&fleet)
            .arg("--out")
            .arg(&logs)
            .args(["--speed", "50", "--max-duration", "4500"])
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.path().join(format!("{tag}.err"))).unwrap())
            .spawn()
            .unwrap();
        procs.0.push((tag, child));
    }
    let start = Instant::now();
    for (tag, child) in &mut procs.0 {
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "{tag} did not finish within 120 s"
            );
            std::thread::sleep(Duration::from_millis(50));
        };
        let err = std::fs::read_to_string(dir.path().join(format!("{tag}.err"))).unwrap();
        assert!(status.success(), "{tag} failed ({status}):\n{err}");
    }
    for peer in ["Scout", "Camera", "GCS"] {
        let log = std::fs::read_to_string(logs.join(format!("{peer}.mission.jsonl"))).unwrap();
        assert!(
            log.contains("\"event\":\"mission_ended\""),
            "{peer} never saw the mission end:\n{log}"
        );
    }
}

#[test]
fn slices_cut_for_another_fleet_are_refused_with_the_file_and_the_remedy() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = fleet(dir.path());
    let slices = dir.path().join("slices");
    // Cut for the default fleet, flown with a fleet file: its peers would
    // speak another identity than this drone's.
    assert!(build(None, &slices).status.success());
    let o = run_slice(&slices, "Scout", Some(&fleet));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("slice-Scout.bin"), "{err}");
    assert!(
        err.contains("was not built for the fleet file given"),
        "{err}"
    );
    assert!(err.contains("--fleet FLEET.toml"), "{err}");

    // And the other way round.
    let slices = dir.path().join("slices-fleet");
    assert!(build(Some(&fleet), &slices).status.success());
    let err = stderr(&run_slice(&slices, "Scout", None));
    assert!(err.contains("not built for the default fleet"), "{err}");
}

#[test]
fn a_directory_without_a_manifest_or_with_a_damaged_slice_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let o = run_slice(dir.path(), "Scout", None);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("slices.json"), "{err}");
    assert!(err.contains("eamos build MISSION --out"), "{err}");

    std::fs::write(dir.path().join("slices.json"), "{\n  \"mission\": 3\n}\n").unwrap();
    let err = stderr(&run_slice(dir.path(), "Scout", None));
    assert!(err.contains("slices.json:2:"), "{err}");

    let slices = dir.path().join("slices");
    assert!(build(None, &slices).status.success());
    std::fs::write(slices.join("slice-Scout.bin"), b"not a slice").unwrap();
    let o = run_slice(&slices, "Scout", None);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("slice-Scout.bin"), "{}", stderr(&o));
    // A slice file renamed to another drone's name is not that drone's.
    std::fs::copy(
        slices.join("slice-Camera.bin"),
        slices.join("slice-Scout.bin"),
    )
    .unwrap();
    let err = stderr(&run_slice(&slices, "Scout", None));
    assert!(
        err.contains("is the slice of Camera, not of Scout"),
        "{err}"
    );
}

#[test]
fn a_drone_the_mission_does_not_have_is_named_with_the_ones_it_has() {
    let dir = tempfile::tempdir().unwrap();
    assert!(build(None, dir.path()).status.success());
    let o = run_slice(dir.path(), "D9", None);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("`D9` is not a drone of Survey"), "{err}");
    assert!(err.contains("Scout"), "{err}");
}

#[test]
fn slices_need_a_drone_and_exclude_a_mission_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    for args in [
        vec!["run", "--slices", d],
        vec!["run", "--slices", d, "--gcs"],
        vec!["run", "--slices", d, "--drone", "Scout", "m.go"],
    ] {
        let o = eamos().args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn a_drone_whose_router_is_down_stops_on_ctrl_c_having_flown_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // A router nobody runs: the drone's agent keeps trying it.
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!("[zenoh]\nrouters = [\"tcp/127.0.0.1:{}\"]\n", free_port()),
    )
    .unwrap();
    let slices = dir.path().join("slices");
    assert!(build(Some(&fleet), &slices).status.success());
    let mut procs = Processes(Vec::new());
    let child = eamos()
        .arg("run")
        .arg("--slices")
        .arg(&slices)
        .args(["--drone", "Scout", "--fleet"])
        .arg(&fleet)
        .arg("--out")
        .arg(dir.path().join("logs"))
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.path().join("Scout.err")).unwrap())
        .spawn()
        .unwrap();
    let pid = child.id().to_string();
    procs.0.push(("Scout".into(), child));
    std::thread::sleep(Duration::from_secs(2));
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = procs.0[0].1.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "the agent did not stop within 10 s of Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let err = std::fs::read_to_string(dir.path().join("Scout.err")).unwrap();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(
        err.contains("stopped before Scout joined the mission's network"),
        "{err}"
    );
}
