//! A drone's process killed with SIGKILL in the middle of a motion while
//! its MAVLink copter flies on, and started again with its journal: the
//! restarted process finds the mission frame again from the autopilot's
//! home (not from where the copter happens to be in the air), resumes the
//! motion towards its journaled target, runs no action twice, and the
//! square still closes where the copter took off.
//!
//! One process for the drone and one for the ground station
//! (`eamos run --drone` / `--gcs`, the per-peer runner an agent uses), over
//! zenoh on loopback; the copter is the test vehicle, in this process, so
//! that it outlives the killed process as a real autopilot would.

use std::collections::BTreeMap;
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use eamos_geo::Ned;
use eamos_mid::mavlink::ConnectAddress;
use eamos_vehicle::{SimVehicle, SimVehicleOptions};
use serde_json::Value;

struct Peers(Vec<(String, Child)>);

impl Drop for Peers {
    fn drop(&mut self) {
        for (_, c) in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free loopback port")
        .port()
}

fn mission() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/square.go")
}

fn start(dir: &Path, fleet: &Path, role: &[&str], tag: &str) -> Child {
    Command::new(env!("CARGO_BIN_EXE_eamos"))
        .arg("run")
        .arg(mission())
        .args(role)
        .arg("--out")
        .arg(dir.join("logs"))
        .arg("--journal")
        .arg(dir.join("journal"))
        .arg("--fleet")
        .arg(fleet)
        .args(["--max-duration", "600"])
        .stdout(Stdio::from(
            std::fs::File::create(dir.join(format!("{tag}.out"))).unwrap(),
        ))
        .stderr(Stdio::from(
            std::fs::File::create(dir.join(format!("{tag}.err"))).unwrap(),
        ))
        .spawn()
        .expect("eamos run starts")
}

fn log(dir: &Path, peer: &str, kind: &str) -> Vec<Value> {
    std::fs::read_to_string(dir.join("logs").join(format!("{peer}.{kind}.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

fn wait_until(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < limit, "never saw {what} within {limit:?}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn a_drone_process_killed_mid_motion_over_mavlink_resumes_to_its_journaled_target() {
    let dir = tempfile::tempdir().unwrap();
    let runtime = tokio::runtime::Runtime::new().unwrap();
    let port = free_udp_port();
    let copter = runtime
        .block_on(SimVehicle::start(SimVehicleOptions {
            connect: ConnectAddress::UdpOut(format!("127.0.0.1:{port}")),
            ready_after: 2.0,
            // Real time: a 4 m leg takes seconds, long enough to be cut.
            speed: 1.0,
            // The EKF origin is not where the copter stands: a restarted
            // process that took the EKF origin, or the point it finds the
            // copter at, for the mission frame would fly elsewhere.
            ekf_origin_offset: Ned::new(1.5, -2.0, 0.3),
            ..SimVehicleOptions::default()
        }))
        .unwrap();
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!(
            "[failsafe]\non_lost = \"hold\"\ngrace = \"600s\"\n\n[drones.Copter]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\n"
        ),
    )
    .unwrap();
    let mut peers = Peers(vec![
        (
            "copter-1".into(),
            start(dir.path(), &fleet, &["--drone", "Copter"], "copter-1"),
        ),
        ("gcs".into(), start(dir.path(), &fleet, &["--gcs"], "gcs")),
    ]);

    wait_until("the start of FlyByY", Duration::from_secs(120), || {
        log(dir.path(), "Copter", "mission")
            .iter()
            .any(|r| r["event"] == "action_started" && r["action"] == "FlyByY")
    });
    let (_, mut first) = peers.0.remove(0);
    first.kill().unwrap();
    first.wait().unwrap();
    let was = copter.snapshot().position;
    assert!(
        !log(dir.path(), "Copter", "mission")
            .iter()
            .any(|r| r["event"] == "action_finished" && r["action"] == "FlyByY(4)"),
        "the motion had ended before the kill; the test needs it running (copter at {was})"
    );
    peers.0.push((
        "copter-2".into(),
        start(dir.path(), &fleet, &["--drone", "Copter"], "copter-2"),
    ));

    let deadline = Instant::now() + Duration::from_secs(180);
    for (tag, child) in &mut peers.0 {
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            assert!(Instant::now() < deadline, "{tag} still running");
            std::thread::sleep(Duration::from_millis(50));
        };
        let err = std::fs::read_to_string(dir.path().join(format!("{tag}.err"))).unwrap();
        assert!(status.success(), "{tag}: {status}\n{err}");
    }

    let mission = log(dir.path(), "Copter", "mission");
    // Every action started and finished well exactly once, over both runs.
    let mut started: BTreeMap<u64, usize> = BTreeMap::new();
    let mut finished: BTreeMap<u64, usize> = BTreeMap::new();
    for r in &mission {
        let Some(i) = r["instance"].as_u64() else {
            continue;
        };
        if r["event"] == "action_started" {
            *started.entry(i).or_default() += 1;
        }
        if r["event"] == "action_finished" && r["outcome"] == "ok" {
            *finished.entry(i).or_default() += 1;
        }
    }
    assert_eq!(started.len(), 8, "{started:?}");
    assert!(started.values().all(|n| *n == 1), "{started:?}");
    assert_eq!(finished, started, "{mission:?}");

    let resumed: Vec<&Value> = mission
        .iter()
        .filter(|r| r["event"] == "action_resumed")
        .collect();
    assert_eq!(resumed.len(), 1, "{resumed:?}");
    assert_eq!(resumed[0]["action"], "FlyByY");
    let target = &resumed[0]["target"];
    let t = [&target["x"], &target["y"], &target["z"]].map(|v| v.as_f64().unwrap());
    for (got, want) in t.iter().zip([4.0, 4.0, 2.0]) {
        assert!((got - want).abs() < 0.3, "journaled target {t:?}");
    }
    // The restarted process took the frame from the autopilot's home.
    assert!(
        log(dir.path(), "Copter", "adapter")
            .iter()
            .any(|r| r["detail"]
                .as_str()
                .is_some_and(|d| d.contains("(the autopilot's home)"))),
        "no frame from the autopilot's home"
    );
    // Where it stood after the resumed leg, and where it landed.
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    let gap = landed.position.x.hypot(landed.position.y);
    assert!(
        gap <= 0.3,
        "the square did not close: landed at {}",
        landed.position
    );
    runtime.block_on(copter.shutdown());
}
