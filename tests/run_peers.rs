//! `eamos run MISSION --drone D` and `--gcs`: one process per drone plus one
//! for the ground station, talking zenoh on loopback, as on real companion
//! computers. Each process has a time limit; all are killed if one fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use serde_json::Value;

#[path = "common/processes.rs"]
mod processes;
use processes::Processes;

fn paper(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

fn peers(mission: &str) -> (Vec<String>, Vec<(String, usize, usize)>) {
    let file =
        eamos_lang::SourceFile::new(mission, std::fs::read_to_string(paper(mission)).unwrap());
    let profiles = eamos_profile::builtin();
    let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&m, &profiles);
    let slices = eamos_slicer::slice(&net).unwrap();
    let bridges = slices
        .slices
        .iter()
        .map(|s| (s.drone.clone(), s.bridges_in.len(), s.bridges_out.len()))
        .collect();
    (net.drones.clone(), bridges)
}

fn count(dir: &Path, peer: &str, event: &str) -> usize {
    std::fs::read_to_string(dir.join(format!("{peer}.mission.jsonl")))
        .unwrap()
        .lines()
        .filter(|l| serde_json::from_str::<Value>(l).unwrap()["event"] == event)
        .count()
}

/// Starts the drones first and the ground station last (the order a crew
/// would use; the ground station waits for its peers anyway), waits for
/// every process within `limit`.
fn fly_as_separate_processes(mission: &str, limit: Duration) {
    let (drones, bridges) = peers(mission);
    let dir = tempfile::tempdir().unwrap();
    let mut procs = Processes(Vec::new());
    let mut roles: Vec<Vec<String>> = drones
        .iter()
        .map(|d| vec!["--drone".to_string(), d.clone()])
        .collect();
    roles.push(vec!["--gcs".to_string()]);
    for role in roles {
        let child = Command::cargo_bin("eamos")
            .unwrap()
            .arg("run")
            .arg(paper(mission))
            .args(&role)
            .arg("--out")
            .arg(dir.path())
            // A drone counts its time limit from its own start, and waits there
            // until every peer is connected: at 50x, a few seconds of process
            // starts and connection retries on a loaded machine are minutes of
            // mission time (600 s was once used up before the start token came);
            // 4500 s is 90 s of wall clock, inside the 120 s this test waits.
            .args(["--speed", "50", "--max-duration", "4500"])
            .stdout(Stdio::from(
                std::fs::File::create(dir.path().join(format!("{}.out", role.join("")))).unwrap(),
            ))
            .stderr(Stdio::from(
                std::fs::File::create(dir.path().join(format!("{}.err", role.join("")))).unwrap(),
            ))
            .spawn()
            .unwrap();
        procs.0.push((role.join(" "), child));
    }
    let start = Instant::now();
    let mut done = vec![false; procs.0.len()];
    while done.iter().any(|d| !d) {
        assert!(
            start.elapsed() < limit,
            "{mission}: not all peers finished within {limit:?}"
        );
        for (i, (role, child)) in procs.0.iter_mut().enumerate() {
            if done[i] {
                continue;
            }
            if let Some(status) = child.try_wait().unwrap() {
                done[i] = true;
                if !status.success() {
                    let tag = role.replace(' ', "");
                    let out = std::fs::read_to_string(dir.path().join(format!("{tag}.out")));
                    let err = std::fs::read_to_string(dir.path().join(format!("{tag}.err")));
                    panic!("{mission}: `{role}` failed ({status}):\n{out:?}\n{err:?}");
                }
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    for (peer, bridges_in, bridges_out) in bridges {
        assert_eq!(
            count(dir.path(), &peer, "bridge_received"),
            bridges_in,
            "{mission}: {peer} received"
        );
        assert_eq!(
            count(dir.path(), &peer, "bridge_sent"),
            bridges_out,
            "{mission}: {peer} sent"
        );
        assert_eq!(
            count(dir.path(), &peer, "mission_ended"),
            1,
            "{mission}: {peer}"
        );
    }
}

#[test]
fn experiment_a_runs_as_one_process_per_peer_over_zenoh() {
    fly_as_separate_processes("experiment_a.go", Duration::from_secs(120));
}

#[test]
fn experiment_b_runs_as_one_process_per_peer_over_zenoh() {
    fly_as_separate_processes("experiment_b.go", Duration::from_secs(120));
}

#[test]
fn experiment_c_runs_as_one_process_per_peer_over_zenoh() {
    fly_as_separate_processes("experiment_c.go", Duration::from_secs(120));
}

#[test]
fn listing_1_runs_as_one_process_per_peer_over_zenoh() {
    fly_as_separate_processes("listing01_demo.go", Duration::from_secs(120));
}

#[test]
fn a_peer_whose_port_is_taken_says_which_port_and_where_the_fleet_file_sets_it() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!("[gcs]\nlisten = [\"tcp/127.0.0.1:{port}\"]\n"),
    )
    .unwrap();
    let out = Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(paper("experiment_b.go"))
        .arg("--fleet")
        .arg(&fleet)
        .args(["--transport", "zenoh", "--out"])
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "GCS cannot listen on tcp/127.0.0.1:{port}: the port is taken by another program (this mission has 3 peers)"
        )),
        "{stderr}"
    );
    assert!(stderr.contains("`[gcs] listen = [...]`"), "{stderr}");
    // Not zenoh's own words, which name its source files.
    assert!(!stderr.contains(".rs:"), "{stderr}");
}
