//! A fleet that joins through zenoh routers (`[zenoh] routers` in the
//! fleet file, `eamos router`) instead of a full mesh: one process per
//! drone plus the ground station, each a client of the routers. Losing a
//! router mid-mission keeps it flying: its clients join through the other
//! one, and no action is lost or run twice.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

#[path = "common/processes.rs"]
mod processes;
use processes::free_port;

/// Processes killed when the test ends, however it ends.
struct Processes(Vec<Child>);

impl Drop for Processes {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn eamos() -> Command {
    Command::new(env!("CARGO_BIN_EXE_eamos"))
}

fn experiment_c() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_c.go")
}

fn router(fleet: &Path, n: usize, dir: &Path) -> Child {
    eamos()
        .args(["router", "--fleet"])
        .arg(fleet)
        .args(["--router", &n.to_string()])
        .stdout(Stdio::from(
            std::fs::File::create(dir.join(format!("router-{n}.out"))).unwrap(),
        ))
        .stderr(Stdio::null())
        .spawn()
        .unwrap()
}

fn peer(fleet: &Path, role: &[&str], dir: &Path, tag: &str) -> Child {
    eamos()
        .arg("run")
        .arg(experiment_c())
        .arg("--fleet")
        .arg(fleet)
        .args(role)
        .args(["--speed", "2", "--max-duration", "300", "--out"])
        .arg(dir.join("logs"))
        .stdout(Stdio::from(
            std::fs::File::create(dir.join(format!("{tag}.out"))).unwrap(),
        ))
        .stderr(Stdio::from(
            std::fs::File::create(dir.join(format!("{tag}.err"))).unwrap(),
        ))
        .spawn()
        .unwrap()
}

fn started(dir: &Path) -> Vec<Value> {
    ["Drone1", "Drone2", "Drone3"]
        .iter()
        .flat_map(|d| {
            std::fs::read_to_string(dir.join("logs").join(format!("{d}.mission.jsonl")))
                .unwrap_or_default()
                .lines()
                .filter_map(|l| serde_json::from_str::<Value>(l).ok())
                .filter(|r| r["event"] == "action_started")
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn a_mission_flies_through_two_routers_and_on_through_one_when_the_other_is_killed() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let fleet = dir.join("fleet.toml");
    std::fs::write(
        &fleet,
        format!(
            "[zenoh]\nrouters = [\"tcp/127.0.0.1:{}\", \"tcp/127.0.0.1:{}\"]\n",
            free_port(),
            free_port()
        ),
    )
    .unwrap();
    // The peers start before any router, as drones powered up before the
    // ground network is: they wait for one. Then the first router comes
    // up, and every client joins through it; the second one after it.
    let mut peers = Processes(Vec::new());
    for d in ["Drone1", "Drone2", "Drone3"] {
        peers.0.push(peer(&fleet, &["--drone", d], dir, d));
    }
    peers.0.push(peer(&fleet, &["--gcs"], dir, "GCS"));
    std::thread::sleep(Duration::from_secs(2));
    let mut routers = Processes(vec![router(&fleet, 1, dir)]);
    let joined = Instant::now() + Duration::from_secs(120);
    while started(dir).is_empty() {
        assert!(Instant::now() < joined, "no peer joined through router 1");
        std::thread::sleep(Duration::from_millis(20));
    }
    routers.0.push(router(&fleet, 2, dir));

    // Kill the first router mid-mission.
    let deadline = Instant::now() + Duration::from_secs(120);
    while started(dir).len() < 4 {
        assert!(Instant::now() < deadline, "the mission never got going");
        std::thread::sleep(Duration::from_millis(20));
    }
    routers.0[0].kill().unwrap();
    routers.0[0].wait().unwrap();
    let before = started(dir).len();

    let deadline = Instant::now() + Duration::from_secs(180);
    for (tag, child) in ["Drone1", "Drone2", "Drone3", "GCS"]
        .iter()
        .zip(&mut peers.0)
    {
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            assert!(Instant::now() < deadline, "{tag} still running");
            std::thread::sleep(Duration::from_millis(50));
        };
        let out = std::fs::read_to_string(dir.join(format!("{tag}.out"))).unwrap();
        let err = std::fs::read_to_string(dir.join(format!("{tag}.err"))).unwrap();
        assert!(status.success(), "{tag}: {status}\n{out}\n{err}");
    }
    let gcs = std::fs::read_to_string(dir.join("GCS.out")).unwrap();
    assert!(gcs.starts_with("ExperimentC: completed"), "{gcs}");

    // The mission went on through the second router, and every action
    // started exactly once.
    let all = started(dir);
    assert!(
        all.len() > before,
        "nothing started after the router was lost"
    );
    let mut times: BTreeMap<(String, u64), usize> = BTreeMap::new();
    for r in &all {
        let key = (
            r["drone"].as_str().unwrap_or_default().to_string(),
            r["instance"].as_u64().unwrap(),
        );
        *times.entry(key).or_default() += 1;
    }
    assert_eq!(times.len(), 24, "{times:?}");
    assert!(times.values().all(|n| *n == 1), "{times:?}");
    let said = std::fs::read_to_string(dir.join("router-2.out")).unwrap();
    assert!(
        said.starts_with("router 2: listening on tcp/127.0.0.1:"),
        "{said}"
    );
}

/// `eamos router --fleet FLEET ARGS...`, which must refuse with exit
/// status 2: what it said.
fn refused(fleet: &Path, args: &[&str]) -> String {
    let out = eamos()
        .args(["router", "--fleet"])
        .arg(fleet)
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{err}");
    err
}

#[test]
fn a_router_the_fleet_does_not_name_or_whose_port_is_taken_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(&fleet, "[drones.D1]\n").unwrap();
    let err = refused(&fleet, &[]);
    assert!(err.contains("names no routers"), "{err}");

    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    std::fs::write(
        &fleet,
        format!("[zenoh]\nrouters = [\"tcp/127.0.0.1:{port}\"]\n"),
    )
    .unwrap();
    let err = refused(&fleet, &["--router", "2"]);
    assert!(err.contains("router 2 does not exist"), "{err}");
    let err = refused(&fleet, &[]);
    assert!(
        err.contains(&format!(
            "router 1 cannot listen on tcp/127.0.0.1:{port}: the port is taken by another program"
        )),
        "{err}"
    );
}

/// Starts `cmd` with its standard error written to `err`; killed when
/// the test ends.
fn started_into(cmd: &mut Command, err: &Path) -> Processes {
    Processes(vec![cmd
        .stdout(Stdio::null())
        .stderr(Stdio::from(std::fs::File::create(err).unwrap()))
        .spawn()
        .unwrap()])
}

/// Runs `cmd` to its end, or fails the test if it is still running after
/// a minute (it hangs): what it wrote on stderr, and its exit status.
fn ended(cmd: &mut Command) -> (Option<i32>, String) {
    let dir = tempfile::tempdir().unwrap();
    let err = dir.path().join("stderr");
    let mut child = started_into(cmd, &err);
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.0[0].try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "still waiting after a minute");
        std::thread::sleep(Duration::from_millis(50));
    };
    (status.code(), std::fs::read_to_string(err).unwrap())
}

/// A fleet file whose one router nobody runs.
fn fleet_without_its_router(dir: &Path) -> (PathBuf, String) {
    let router = format!("tcp/127.0.0.1:{}", free_port());
    let fleet = dir.join("fleet.toml");
    std::fs::write(&fleet, format!("[zenoh]\nrouters = [\"{router}\"]\n")).unwrap();
    (fleet, router)
}

#[test]
fn a_ground_station_whose_routers_never_answer_says_so_within_its_start_up_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let (fleet, router) = fleet_without_its_router(dir.path());
    let (status, err) = ended(
        eamos()
            .arg("run")
            .arg(experiment_c())
            .arg("--fleet")
            .arg(&fleet)
            .args(["--gcs", "--startup-timeout", "1", "--out"])
            .arg(dir.path().join("logs")),
    );
    assert_eq!(status, Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "GCS reached none of the fleet's routers ({router}) within 1s"
        )),
        "{err}"
    );
    assert!(err.contains("eamos router --fleet"), "{err}");
}

#[test]
fn an_abort_whose_routers_never_answer_says_so_within_its_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let (fleet, router) = fleet_without_its_router(dir.path());
    let (status, err) = ended(
        eamos()
            .arg("abort")
            .arg(experiment_c())
            .arg("--fleet")
            .arg(&fleet)
            .args(["--timeout", "1"]),
    );
    assert_eq!(status, Some(2), "{err}");
    assert!(
        err.contains("cannot join the mission's network: abort-"),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "reached none of the fleet's routers ({router}) within 1s"
        )),
        "{err}"
    );
}

#[test]
fn a_drone_whose_routers_never_answer_keeps_trying_and_says_so_once() {
    let dir = tempfile::tempdir().unwrap();
    let (fleet, router) = fleet_without_its_router(dir.path());
    let err = dir.path().join("stderr");
    let mut drone = started_into(
        eamos()
            .arg("run")
            .arg(experiment_c())
            .arg("--fleet")
            .arg(&fleet)
            .args(["--drone", "Drone1", "--startup-timeout", "1", "--out"])
            .arg(dir.path().join("logs")),
        &err,
    );
    let said = format!("Drone1 none of the fleet's routers answers yet ({router}); still trying");
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let text = std::fs::read_to_string(&err).unwrap();
        if text.contains(&said) {
            break;
        }
        assert!(Instant::now() < deadline, "never said it waits:\n{text}");
        std::thread::sleep(Duration::from_millis(50));
    }
    // Still waiting (not given up), and said once.
    std::thread::sleep(Duration::from_secs(2));
    assert!(
        drone.0[0].try_wait().unwrap().is_none(),
        "the drone gave up"
    );
    let text = std::fs::read_to_string(&err).unwrap();
    assert_eq!(text.matches("still trying").count(), 1, "{text}");
}
