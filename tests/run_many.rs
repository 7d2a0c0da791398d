//! A large fleet, one process per drone, on one computer: `eamos gen`'s
//! mission of [`DRONES`] drones, each flown by its own `eamos run --drone`,
//! the ground station by `eamos run --gcs`, all joined through one zenoh
//! router (`[zenoh] routers`, `eamos router`).
//!
//! Start-up must scale: a drone's agent compiles and slices the mission but
//! leaves its check to the ground station, and waits only to see the few
//! peers it exchanges tokens or telemetry with, the ground station only for
//! every drone's `ready` token. (When every agent also checked the whole
//! mission and the ground station waited until every two peers saw each
//! other, this fleet did not start within the time below: a check per
//! process, and n² liveliness tokens each heard by n peers.)
//!
//! Sized for a debug build on a 2-core machine: 50 drones. A hundred debug
//! processes cost some 100 × 0.4 s of compile and slicing and 100 zenoh
//! sessions before anything flies, more than this test's budget;
//! `eamos bench-report --fleets` measures 100 and 250 with a release build.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// Drones of the mission, one process each.
const DRONES: usize = 50;
/// How long the ground station waits for every drone to be ready. The
/// mission must have started by then, counted from the launch.
const STARTUP: Duration = Duration::from_secs(45);

/// Processes killed when the test ends, however it ends.
struct Processes(Vec<(String, Child)>);

impl Drop for Processes {
    fn drop(&mut self) {
        for (_, c) in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn eamos() -> Command {
    Command::new(env!("CARGO_BIN_EXE_eamos"))
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn log(dir: &Path, peer: &str) -> Vec<Value> {
    std::fs::read_to_string(dir.join("logs").join(format!("{peer}.mission.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .collect()
}

fn count(log: &[Value], event: &str) -> usize {
    log.iter().filter(|r| r["event"] == event).count()
}

#[test]
fn fifty_drones_in_a_process_each_start_within_the_startup_timeout_and_complete() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let mission = dir.join("fleet.go");
    let out = eamos()
        .args(["gen", "--drones", &DRONES.to_string()])
        .args(["--nodes", &(DRONES * 10).to_string(), "--seed", "12"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    std::fs::write(&mission, &out.stdout).unwrap();
    let fleet = dir.join("fleet.toml");
    std::fs::write(
        &fleet,
        format!("[zenoh]\nrouters = [\"tcp/127.0.0.1:{}\"]\n", free_port()),
    )
    .unwrap();
    let file = |name: &str| Stdio::from(std::fs::File::create(dir.join(name)).unwrap());

    let launched = Instant::now();
    let mut procs = Processes(Vec::new());
    let router = eamos()
        .args(["router", "--fleet"])
        .arg(&fleet)
        .args(["--router", "1"])
        .stdout(Stdio::null())
        .stderr(file("router.err"))
        .spawn()
        .unwrap();
    procs.0.push(("router".into(), router));
    let mut peers: Vec<(String, Vec<String>)> = (1..=DRONES)
        .map(|k| (format!("D{k}"), vec!["--drone".into(), format!("D{k}")]))
        .collect();
    peers.push(("GCS".into(), vec!["--gcs".into()]));
    for (tag, role) in &peers {
        let child = eamos()
            .arg("run")
            .arg(&mission)
            .arg("--fleet")
            .arg(&fleet)
            .args(role)
            // Each drone counts its time limit from its own start and then
            // waits for the ground station's start: generous, the start-up
            // is bounded by the ground station's timeout below.
            .args(["--speed", "50", "--max-duration", "6000"])
            .args(["--startup-timeout", &STARTUP.as_secs().to_string()])
            .arg("--out")
            .arg(dir.join("logs"))
            .stdout(file(&format!("{tag}.out")))
            .stderr(file(&format!("{tag}.err")))
            .spawn()
            .unwrap();
        procs.0.push((tag.clone(), child));
    }

    // The ground station starts the mission (sends its first token) once
    // every drone is ready.
    let started = loop {
        if count(&log(dir, "GCS"), "bridge_sent") > 0 {
            break launched.elapsed();
        }
        let gcs = &mut procs.0.last_mut().unwrap().1;
        if let Some(status) = gcs.try_wait().unwrap() {
            let err = std::fs::read_to_string(dir.join("GCS.err")).unwrap();
            panic!("the ground station ended before the mission started ({status}): {err}");
        }
        assert!(
            launched.elapsed() < STARTUP + Duration::from_secs(30),
            "the mission did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    };

    let deadline = Instant::now() + Duration::from_secs(120);
    let (_, peers_and_router) = procs.0.split_first_mut().unwrap();
    for (tag, child) in peers_and_router.iter_mut() {
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
    let done = launched.elapsed();
    let gcs = std::fs::read_to_string(dir.join("GCS.out")).unwrap();
    assert!(gcs.starts_with("Stress: completed"), "{gcs}");
    // Every drone flew its part: each action it started also finished.
    for k in 1..=DRONES {
        let log = log(dir, &format!("D{k}"));
        let started = count(&log, "action_started");
        assert!(started > 0, "D{k} started nothing");
        assert_eq!(started, count(&log, "action_finished"), "D{k}");
    }
    eprintln!(
        "{DRONES} drones: the mission started {:.1} s after the launch, completed after {:.1} s",
        started.as_secs_f64(),
        done.as_secs_f64()
    );
}
