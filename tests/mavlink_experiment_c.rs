//! Missions flown through `eamos run` with drones bound to MAVLink
//! vehicles by a fleet file: the paper's hybrid Experiment C (one
//! ArduPilot-like and one PX4-like copter over MAVLink, one simulated
//! drone), and what a mission reports when a vehicle refuses to arm,
//! never gets ready or falls silent in flight.
//!
//! The MAVLink vehicles are `eamos sim-vehicle` processes on loopback
//! ports; every wait is bounded, nothing asserts how fast it went.

use std::io::{BufRead, BufReader, Read};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// Kills a child process when the test ends, however it ends.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free loopback port")
        .port()
}

fn paper(mission: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(mission)
}

fn sim_vehicle(port: u16, extra: &[&str]) -> Running {
    Running(
        Command::new(env!("CARGO_BIN_EXE_eamos"))
            .args([
                "sim-vehicle",
                "--connect",
                &format!("udpout:127.0.0.1:{port}"),
            ])
            .args(extra)
            .args(["--exit-after", "300"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("eamos sim-vehicle starts"),
    )
}

fn mavlink_entry(drone: &str, port: u16, home_y: f64) -> String {
    format!(
        "[drones.{drone}]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\nhome = {{ x = 0.0, y = {home_y}, z = 0.0 }}\n\n"
    )
}

/// The mission time the summary reports (`... after 12.3 s of mission time`).
fn mission_time(stdout: &str) -> f64 {
    let after = stdout
        .split(" after ")
        .nth(1)
        .unwrap_or_else(|| panic!("no mission time in: {stdout}"));
    after
        .split(" s of mission time")
        .next()
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no mission time in: {stdout}"))
}

/// Runs `eamos run` to its end (bounded); returns exit code and stdout.
fn run_mission(
    mission: &Path,
    fleet: &Path,
    out: &Path,
    speed: &str,
) -> (Option<i32>, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_eamos"))
        .arg("run")
        .arg(mission)
        .arg("--fleet")
        .arg(fleet)
        .args(["--speed", speed, "--max-duration", "600", "--out"])
        .arg(out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("eamos run starts");
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stdout = String::new();
            let mut stderr = String::new();
            child
                .stdout
                .take()
                .unwrap()
                .read_to_string(&mut stdout)
                .unwrap();
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut stderr)
                .unwrap();
            return (status.code(), stdout, stderr);
        }
        if started.elapsed() > Duration::from_secs(240) {
            let _ = child.kill();
            panic!("eamos run did not end within 240 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn adapter_log(out: &Path, drone: &str) -> Vec<Value> {
    let text =
        std::fs::read_to_string(out.join(format!("{drone}.adapter.jsonl"))).unwrap_or_default();
    text.lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The position targets the adapter sent, in the mission frame.
fn targets(log: &[Value]) -> Vec<[f64; 3]> {
    log.iter()
        .filter(|r| {
            r["event"] == "command"
                && r["detail"]
                    .as_str()
                    .is_some_and(|d| d.starts_with("SET_POSITION_TARGET_LOCAL_NED"))
        })
        .map(|r| {
            let a = r["args"].as_array().unwrap();
            [0, 1, 2].map(|i| a[i].as_f64().unwrap())
        })
        .collect()
}

#[test]
fn experiment_c_flies_a_hybrid_fleet_of_an_ardupilot_copter_a_px4_copter_and_a_simulated_drone() {
    let dir = tempfile::tempdir().unwrap();
    let (p1, p2) = (free_udp_port(), free_udp_port());
    let vehicle_args = ["--ready-after", "10", "--speed", "5"];
    let _v1 = sim_vehicle(p1, &vehicle_args);
    // PX4's 1 s offboard-loss time is 0.2 s of wall time at five times real
    // time, close to the setpoint stream's period on a loaded machine: 3 s
    // keeps the test about the fleet, not about the machine's load.
    let _v2 = sim_vehicle(
        p2,
        &[
            &vehicle_args[..],
            &[
                "--sysid",
                "2",
                "--autopilot",
                "px4",
                "--offboard-loss-after",
                "3",
            ],
        ]
        .concat(),
    );
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!(
            "{}{}[drones.Drone3]\nhome = {{ x = 0.0, y = 6.0, z = 0.0 }}\n",
            mavlink_entry("Drone1", p1, 0.0),
            mavlink_entry("Drone2", p2, 3.0)
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let (code, stdout, stderr) = run_mission(&paper("experiment_c.go"), &fleet, &out, "5");
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.starts_with("ExperimentC: completed"), "{stdout}");
    for drone in ["Drone1", "Drone2", "Drone3"] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(drone))
            .unwrap_or_else(|| panic!("no line for {drone}: {stdout}"));
        assert!(line.contains("completed"), "{line}");
    }

    // Drone1 (ArduPilot, GUIDED) and Drone2 (PX4, OFFBOARD, which takes
    // off to a setpoint first) flew their 1 m square at 1.5 m, through
    // MAVLink position targets, and every action ended well.
    let square = [
        [0.0, 0.0, 1.5],
        [1.0, 0.0, 1.5],
        [1.0, 1.0, 1.5],
        [0.0, 1.0, 1.5],
        [0.0, 0.0, 1.5],
    ];
    for (drone, guided, takeoff_setpoints) in [("Drone1", "GUIDED", 0), ("Drone2", "OFFBOARD", 1)] {
        let log = adapter_log(&out, drone);
        assert!(log.iter().all(|r| r["adapter"] == "mavlink"));
        let sent = targets(&log);
        assert_eq!(
            sent.len(),
            square.len() + takeoff_setpoints,
            "{drone}: {sent:?}"
        );
        for (got, want) in sent[takeoff_setpoints..].iter().zip(square) {
            let d = (0..3)
                .map(|i| (got[i] - want[i]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(d < 0.1, "{drone}: target {got:?}, expected {want:?}");
        }
        let completed: Vec<(&str, &str)> = log
            .iter()
            .filter(|r| r["event"] == "completed")
            .map(|r| {
                (
                    r["action"].as_str().unwrap(),
                    r["outcome"].as_str().unwrap(),
                )
            })
            .collect();
        assert_eq!(completed.len(), 8, "{drone}: {completed:?}");
        assert!(
            completed.iter().all(|(_, o)| *o == "ok"),
            "{drone}: {completed:?}"
        );
        assert!(
            log.iter()
                .any(|r| r["detail"] == format!("mode {guided} set and confirmed")),
            "{drone}"
        );
        assert!(log.iter().any(|r| r["detail"] == "disarmed"), "{drone}");
    }
    // Drone3 flew in the simulator.
    let d3 = adapter_log(&out, "Drone3");
    assert!(!d3.is_empty() && d3.iter().all(|r| r["adapter"] == "sim"));

    // The MAVLink drones log on the fleet's one mission clock, the
    // simulator's (here five times the wall clock), not on the wall clock:
    // their last records come late in the mission's time.
    let total = mission_time(&stdout);
    for drone in ["Drone1", "Drone2"] {
        let last = adapter_log(&out, drone)
            .iter()
            .filter_map(|r| r["time"].as_f64())
            .fold(0.0, f64::max);
        assert!(
            last > 0.6 * total,
            "{drone}: last record at {last} s, the mission took {total} s of mission time"
        );
    }
}

#[test]
fn a_vehicle_that_refuses_to_arm_fails_the_mission_naming_command_result_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let p1 = free_udp_port();
    let _v1 = sim_vehicle(
        p1,
        &[
            "--ready-after",
            "2",
            "--speed",
            "5",
            "--refuse-arming",
            "Arm: Hardware safety switch",
        ],
    );
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(&fleet, mavlink_entry("Drone1", p1, 0.0)).unwrap();
    let out = dir.path().join("out");
    let (code, stdout, stderr) = run_mission(&paper("experiment_a.go"), &fleet, &out, "5");
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(
        stdout.starts_with("ExperimentA: did not complete"),
        "{stdout}"
    );
    // The drone is named once, then the typed refusal in full.
    assert!(
        stdout.contains(
            "\nDrone1: the drone refused `Arm`: MAV_CMD_COMPONENT_ARM_DISARM was refused with MAV_RESULT_FAILED; the autopilot said: \"Arm: Hardware safety switch\"\n"
        ),
        "{stdout}"
    );
    assert!(!stdout.contains("Drone1: Drone1:"), "{stdout}");
    assert!(!stderr.contains("Drone1: Drone1:"), "{stderr}");
}

#[test]
fn a_vehicle_that_never_gets_ready_fails_the_mission_in_bounded_time_naming_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    let p1 = free_udp_port();
    let _v1 = sim_vehicle(p1, &["--ready-after", "100000", "--speed", "1"]);
    // Started after the vehicle's first PreArm text (2 s after boot),
    // with the next one 30 s away, as a ground station that connects to
    // an autopilot already running: the reason must be asked for.
    std::thread::sleep(Duration::from_secs(3));
    let fleet = dir.path().join("fleet.toml");
    // The fleet file sets how long arming waits for readiness.
    std::fs::write(
        &fleet,
        format!(
            "{}[drones.Drone1.mavlink]\nready_timeout = 4\n",
            mavlink_entry("Drone1", p1, 0.0)
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let started = Instant::now();
    let (code, stdout, stderr) = run_mission(&paper("experiment_a.go"), &fleet, &out, "1");
    assert!(
        started.elapsed() < Duration::from_secs(120),
        "a 4 s readiness timeout ended the run only after {:?}",
        started.elapsed()
    );
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(
        stdout.starts_with("ExperimentA: did not complete"),
        "{stdout}"
    );
    let line = stdout
        .lines()
        .find(|l| l.starts_with("Drone1: "))
        .unwrap_or_else(|| panic!("no reason for Drone1: {stdout}"));
    assert!(
        line.starts_with(
            "Drone1: the drone refused `Arm`: the vehicle was not ready to arm after 4 s; still missing: "
        ),
        "{line}"
    );
    for missing in [
        "a 3D GPS fix (now: no fix, 0 satellites)",
        "an EKF position estimate",
        "pre-arm checks to pass (autopilot: \"PreArm: GPS 1: Bad fix\")",
    ] {
        assert!(line.contains(missing), "`{missing}` not in: {line}");
    }
    // The adapter log showed the wait as it went.
    let log = adapter_log(&out, "Drone1");
    assert!(log.iter().any(|r| r["detail"]
        .as_str()
        .is_some_and(|d| d.starts_with("not ready yet"))));
}

#[test]
fn a_mission_flies_through_a_px4_vehicle_in_offboard() {
    let dir = tempfile::tempdir().unwrap();
    let p1 = free_udp_port();
    let _v1 = sim_vehicle(
        p1,
        &["--autopilot", "px4", "--ready-after", "4", "--speed", "1"],
    );
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(&fleet, mavlink_entry("Drone1", p1, 0.0)).unwrap();
    let out = dir.path().join("out");
    let (code, stdout, stderr) = run_mission(&paper("experiment_a.go"), &fleet, &out, "1");
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.starts_with("ExperimentA: completed"), "{stdout}");
    let log = adapter_log(&out, "Drone1");
    assert!(
        log.iter().any(|r| r["detail"]
            .as_str()
            .is_some_and(|d| d.starts_with("found PX4 vehicle"))),
        "{log:?}"
    );
    assert!(
        log.iter()
            .any(|r| r["detail"] == "mode OFFBOARD set and confirmed"),
        "{log:?}"
    );
    // No take-off command: PX4 climbs to a setpoint above the ground.
    assert!(!log.iter().any(|r| r["detail"] == "MAV_CMD_NAV_TAKEOFF"));
    let sent = targets(&log);
    let square = [
        [0.0, 0.0, 1.5],
        [1.0, 0.0, 1.5],
        [1.0, 1.0, 1.5],
        [0.0, 1.0, 1.5],
        [0.0, 0.0, 1.5],
    ];
    // The take-off setpoint, then the square.
    assert!(sent.len() >= square.len(), "{sent:?}");
    for (got, want) in sent[sent.len() - square.len()..].iter().zip(square) {
        let d = (0..3)
            .map(|i| (got[i] - want[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(d < 0.1, "target {got:?}, expected {want:?}");
    }
    let completed: Vec<&str> = log
        .iter()
        .filter(|r| r["event"] == "completed")
        .map(|r| r["outcome"].as_str().unwrap())
        .collect();
    assert_eq!(completed, vec!["ok"; 8], "{log:?}");
    assert!(log.iter().any(|r| r["detail"] == "disarmed"));
}

#[test]
fn a_vehicle_falling_silent_in_flight_fails_the_mission_with_a_lost_link() {
    let dir = tempfile::tempdir().unwrap();
    let p1 = free_udp_port();
    let mut vehicle = sim_vehicle(p1, &["--ready-after", "2", "--speed", "1"]);
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(&fleet, mavlink_entry("Drone1", p1, 0.0)).unwrap();
    let out = dir.path().join("out");
    let mut child = Running(
        Command::new(env!("CARGO_BIN_EXE_eamos"))
            .arg("run")
            .arg(paper("experiment_a.go"))
            .arg("--fleet")
            .arg(&fleet)
            .args(["--speed", "1", "--max-duration", "600", "--out"])
            .arg(&out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("eamos run starts"),
    );

    // Once the drone starts its take-off, the radio goes quiet: the
    // progress lines on stderr say when.
    let stderr = child.0.stderr.take().unwrap();
    let (seen_tx, seen_rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(stderr).lines() {
            let line = line.unwrap_or_default();
            if line.contains("Drone1 started Takeoff") {
                let _ = seen_tx.send(());
            }
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let took_off = seen_rx.recv_timeout(Duration::from_secs(120));
    vehicle.0.kill().unwrap();
    took_off.expect("the drone started its take-off");

    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.0.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(120) {
            panic!("eamos run did not end within 120 s of the link going quiet");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut stdout = String::new();
    child
        .0
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut stdout)
        .unwrap();
    let stderr = reader.join().unwrap();
    assert_eq!(status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(
        stdout.starts_with("ExperimentA: did not complete"),
        "{stdout}"
    );
    assert!(
        stdout.contains("lost the link to the drone during `Takeoff`"),
        "{stdout}"
    );
    let log = adapter_log(&out, "Drone1");
    assert!(
        log.iter().any(|r| r["detail"].as_str().is_some_and(
            |d| d.starts_with("lost the link to the vehicle: nothing heard for 5.0 s")
        )),
        "the adapter log says why"
    );
    assert!(log.iter().any(|r| r["event"] == "completed"
        && r["action"] == "Takeoff"
        && r["outcome"] == "link_lost"));
}
