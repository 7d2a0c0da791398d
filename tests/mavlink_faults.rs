//! Faults first met on real autopilots, provoked on the test vehicle and
//! flown through `eamos run --fleet`:
//! - a pilot who takes the drone over keeps it: the end of the run does
//!   not take it back, until the pilot gives it back;
//! - a lost link is reported within the link timeout; the mission takes
//!   the drone back into its failsafe when the link returns, unless the
//!   autopilot's own link-loss failsafe is already bringing it down;
//! - before arming, an autopilot that would leave the drone alone on a
//!   lost link (`FS_GCS_ENABLE = 0`) is named to the crew;
//! - the square of the paper's experiment A closes on a PX4-like vehicle
//!   whose reported position wanders, as a real EKF's does: each leg
//!   starts from the last target, and each ends settled on its corner;
//! - a real vehicle's home is what its autopilot reports, in the fleet's
//!   one frame, and a fleet file that put it elsewhere is named;
//! - an abort (Ctrl-C) mid-flight lands the copter through its failsafe,
//!   exactly once.
//!
//! The vehicle runs in the test's own process, so that the test can be
//! the pilot (its RC mode switch) and the radio (silence); the mission
//! runs in an `eamos run` process of its own. Every wait is bounded;
//! nothing asserts how fast it went.

use std::io::{BufRead, BufReader};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use eamos_geo::{LocalFrame, Vec3, Wgs84};
use eamos_mid::mavlink::modes::CopterMode;
use eamos_mid::mavlink::ConnectAddress;
use eamos_vehicle::{Firmware, SimVehicle, SimVehicleOptions, VehicleSnapshot};

fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free loopback port")
        .port()
}

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

/// A copter behind a MAVLink endpoint, in this process, `speed` times as
/// fast as real time, that sends to `port` as SITL's `--out` does.
struct Copter {
    runtime: tokio::runtime::Runtime,
    vehicle: Option<SimVehicle>,
}

impl Copter {
    fn start(port: u16, speed: f64, params: &[(&str, f64)]) -> Copter {
        Copter::start_with(port, |o| {
            o.speed = speed;
            o.params = params.iter().map(|(n, v)| (n.to_string(), *v)).collect();
        })
    }

    fn start_with(port: u16, set: impl FnOnce(&mut SimVehicleOptions)) -> Copter {
        let runtime = tokio::runtime::Runtime::new().expect("a tokio runtime");
        let mut options = SimVehicleOptions {
            connect: ConnectAddress::UdpOut(format!("127.0.0.1:{port}")),
            ready_after: 2.0,
            ..SimVehicleOptions::default()
        };
        set(&mut options);
        let vehicle = runtime
            .block_on(SimVehicle::start(options))
            .expect("the test vehicle starts");
        Copter {
            runtime,
            vehicle: Some(vehicle),
        }
    }

    fn vehicle(&self) -> &SimVehicle {
        self.vehicle.as_ref().expect("the vehicle runs")
    }

    fn snapshot(&self) -> VehicleSnapshot {
        self.vehicle().snapshot()
    }

    fn mode(&self) -> Option<CopterMode> {
        CopterMode::from_custom_mode(self.snapshot().custom_mode)
    }
}

impl Drop for Copter {
    fn drop(&mut self) {
        if let Some(v) = self.vehicle.take() {
            self.runtime.block_on(v.shutdown());
        }
    }
}

/// `eamos run` flying a mission, its progress lines read as they come.
struct Flight {
    child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
    stdout: Option<JoinHandle<String>>,
}

impl Flight {
    fn start(mission: &Path, fleet: &Path, out: &Path) -> Flight {
        let mut child = Command::new(env!("CARGO_BIN_EXE_eamos"))
            .arg("run")
            .arg(mission)
            .arg("--fleet")
            .arg(fleet)
            .args(["--max-duration", "600", "--out"])
            .arg(out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("eamos run starts");
        let stderr = child.stderr.take().unwrap();
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                if tx.send(line.unwrap_or_default()).is_err() {
                    break;
                }
            }
        });
        let mut stdout = child.stdout.take().unwrap();
        let stdout = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut stdout, &mut s);
            s
        });
        Flight {
            child,
            lines,
            seen: Vec::new(),
            stdout: Some(stdout),
        }
    }

    /// The first progress line containing `needle`, within `limit`.
    fn wait_for(&mut self, needle: &str, limit: Duration) -> String {
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    self.seen.push(line.clone());
                    if line.contains(needle) {
                        return line;
                    }
                }
                Err(_) => panic!(
                    "no line with `{needle}` within {limit:?}; seen:\n{}",
                    self.seen.join("\n")
                ),
            }
        }
    }

    /// Waits for the run to end; its exit code, its summary and every
    /// progress line.
    fn finish(mut self, limit: Duration) -> (Option<i32>, String, String) {
        let deadline = Instant::now() + limit;
        let code = loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                break status.code();
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!(
                    "eamos run still running after {limit:?}; seen:\n{}",
                    self.seen.join("\n")
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let stdout = self.stdout.take().unwrap().join().unwrap();
        while let Ok(line) = self.lines.recv_timeout(Duration::from_millis(500)) {
            self.seen.push(line);
        }
        (code, stdout, self.seen.join("\n"))
    }
}

impl Drop for Flight {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn fleet(dir: &Path, port: u16, mavlink: &str) -> PathBuf {
    fleet_of(dir, "Copter", port, mavlink)
}

fn fleet_of(dir: &Path, drone: &str, port: u16, mavlink: &str) -> PathBuf {
    let path = dir.join("fleet.toml");
    std::fs::write(
        &path,
        format!(
            "[failsafe]\non_abort = \"land\"\n\n[drones.{drone}]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\n\n[drones.{drone}.mavlink]\n{mavlink}"
        ),
    )
    .unwrap();
    path
}

/// Waits until the vehicle's state satisfies `done`.
fn vehicle_until(copter: &Copter, limit: Duration, done: impl Fn(&VehicleSnapshot) -> bool) {
    let deadline = Instant::now() + limit;
    while !done(&copter.snapshot()) {
        assert!(
            Instant::now() < deadline,
            "the vehicle did not get there within {limit:?}: {:?}",
            copter.snapshot()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_pilot_who_takes_over_keeps_the_drone_until_giving_it_back() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let copter = Copter::start(port, 4.0, &[]);
    let fleet = fleet(dir.path(), port, "");
    let mut flight = Flight::start(&example("square.go"), &fleet, &dir.path().join("out"));

    flight.wait_for("Copter started FlyByY", Duration::from_secs(120));
    copter.vehicle().rc_select(CopterMode::Brake);
    let failed = flight.wait_for("Copter failed FlyByY", Duration::from_secs(30));
    assert!(failed.contains("switched to BRAKE"), "{failed}");
    let waiting = flight.wait_for(
        "Copter warning: the drone is in BRAKE",
        Duration::from_secs(30),
    );
    assert!(
        waiting.contains("select the guided mode again"),
        "{waiting}"
    );

    // The run is over for the mission, but the drone stays the pilot's:
    // nothing lands it behind the pilot's back.
    let mark = copter.snapshot().time;
    vehicle_until(&copter, Duration::from_secs(30), |s| s.time >= mark + 8.0);
    let held = copter.snapshot();
    assert_eq!(copter.mode(), Some(CopterMode::Brake), "{held:?}");
    assert!(!held.on_ground && held.armed, "{held:?}");

    // The pilot gives it back: now the mission's failsafe lands it.
    copter.vehicle().rc_select(CopterMode::Guided);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(stdout.starts_with("Square: did not complete"), "{stdout}");
    assert!(stderr.contains("Copter failsafe: land"), "{stderr}");
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert_eq!(copter.mode(), Some(CopterMode::Land));
}

#[test]
fn a_lost_link_is_reported_in_time_and_the_drone_taken_back_when_it_returns() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    // ArduCopter as it ships: FS_GCS_ENABLE = 0, nothing happens on its
    // side when the ground station falls silent.
    let copter = Copter::start(port, 4.0, &[]);
    let fleet = fleet(dir.path(), port, "link_timeout = 2\n");
    let mut flight = Flight::start(&example("square.go"), &fleet, &dir.path().join("out"));

    // Before take-off the crew reads what a lost link would do.
    let warning = flight.wait_for(
        "Copter warning: FS_GCS_ENABLE is 0",
        Duration::from_secs(120),
    );
    assert!(warning.contains("nobody in charge"), "{warning}");

    flight.wait_for("Copter started FlyByX(4)", Duration::from_secs(120));
    copter.vehicle().set_silent(true);
    let silent_at = Instant::now();
    let lost = flight.wait_for("Copter failed FlyByX(4)", Duration::from_secs(30));
    assert!(lost.contains("lost the link"), "{lost}");
    let reported_after = silent_at.elapsed();
    assert!(
        reported_after < Duration::from_secs(2) + Duration::from_secs(3),
        "a 2 s link timeout reported after {reported_after:?}"
    );
    flight.wait_for("Copter warning: the link is lost", Duration::from_secs(30));

    // Meanwhile nobody commands it: it hovers in GUIDED.
    std::thread::sleep(Duration::from_secs(2));
    assert_eq!(copter.mode(), Some(CopterMode::Guided));
    assert!(!copter.snapshot().on_ground);

    // The radio is back: the mission's failsafe lands it.
    copter.vehicle().set_silent(false);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert_eq!(copter.mode(), Some(CopterMode::Land), "{stderr}");
}

#[test]
fn an_autopilot_that_returns_home_on_a_lost_link_is_left_to_finish() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    // The GCS failsafe on: 5 s of its own time without the ground
    // station's heartbeat (sent once a second of wall time, so the copter
    // runs only twice as fast here), and it returns home.
    let copter = Copter::start(port, 2.0, &[("FS_GCS_ENABLE", 1.0)]);
    let fleet = fleet(dir.path(), port, "link_timeout = 2\n");
    let mut flight = Flight::start(&example("square.go"), &fleet, &dir.path().join("out"));

    flight.wait_for("Copter started FlyByY(4)", Duration::from_secs(120));
    copter.vehicle().set_silent(true);
    flight.wait_for("Copter failed FlyByY(4)", Duration::from_secs(30));
    vehicle_until(&copter, Duration::from_secs(30), |s| {
        CopterMode::from_custom_mode(s.custom_mode) == Some(CopterMode::Rtl)
    });
    copter.vehicle().set_silent(false);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    // No warning before flight: this autopilot takes over by itself.
    assert!(!stderr.contains("FS_GCS_ENABLE is 0"), "{stderr}");
    // Its RTL brought it home; the mission never switched it to LAND.
    let home = copter.snapshot();
    assert!(home.on_ground && !home.armed, "{home:?}");
    assert_eq!(copter.mode(), Some(CopterMode::Rtl), "{stderr}");
    assert!(
        home.position.x.hypot(home.position.y) < 0.5,
        "landed at {:?}, not home",
        home.position
    );
}

#[test]
fn the_square_of_experiment_a_closes_on_a_px4_vehicle_whose_position_wanders() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let copter = Copter::start_with(port, |o| {
        o.autopilot = Firmware::Px4;
        // Twice real time: PX4's 1 s offboard-loss time stays well above
        // the 10 Hz setpoint stream.
        o.speed = 2.0;
        o.position_noise = 0.05;
    });
    let fleet = fleet_of(dir.path(), "Drone1", port, "");
    let mission =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_a.go");
    let mut flight = Flight::start(&mission, &fleet, &dir.path().join("out"));

    flight.wait_for("Drone1 finished Takeoff(1.5)", Duration::from_secs(120));
    let start = copter.snapshot().position;
    let mut corner = Vec3::new(start.x, start.y, 1.5);
    for (leg, (dx, dy)) in [
        ("FlyByX(1)", (1.0, 0.0)),
        ("FlyByY(1)", (0.0, 1.0)),
        ("FlyByX(-1)", (-1.0, 0.0)),
        ("FlyByY(-1)", (0.0, -1.0)),
    ] {
        flight.wait_for(&format!("Drone1 finished {leg}"), Duration::from_secs(60));
        corner = corner + Vec3::new(dx, dy, 0.0);
        let at = copter.snapshot().position;
        assert!(
            at.distance(corner) <= 0.3,
            "after {leg} the copter is at {at}, {:.2} m from the corner {corner}",
            at.distance(corner)
        );
    }
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    let gap = (landed.position.x - start.x).hypot(landed.position.y - start.y);
    assert!(
        gap <= 0.3,
        "the square did not close: landed {gap:.2} m from where it took off"
    );
}

/// The adapter log's lines, as JSON.
fn adapter_log(out: &Path, drone: &str) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join(format!("{drone}.adapter.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

#[test]
fn a_real_vehicles_home_is_where_its_autopilot_says_in_the_fleets_one_frame() {
    let origin = Wgs84::new(-35.363_261, 149.165_230, 584.0);
    // The copter stands 10 m north of the fleet's origin.
    let stands = LocalFrame::new(origin).to_wgs84(Vec3::new(10.0, 0.0, 0.0));
    for (fleet_home, warned) in [
        // The fleet file puts it at the origin: the check assumed a home
        // 10 m off, and the crew is told before take-off.
        ("x = 0.0, y = 0.0, z = 0.0".to_string(), true),
        // The fleet file names where it stands: nothing to say.
        (
            format!(
                "lat = {:.8}, lon = {:.8}, alt = 0.0",
                stands.lat, stands.lon
            ),
            false,
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let port = free_udp_port();
        let copter = Copter::start_with(port, |o| {
            o.speed = 4.0;
            o.home = stands;
        });
        let fleet = dir.path().join("fleet.toml");
        std::fs::write(
            &fleet,
            format!(
                "origin = {{ lat = {}, lon = {} }}\n\n[drones.Copter]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\nhome = {{ {fleet_home} }}\n",
                origin.lat, origin.lon
            ),
        )
        .unwrap();
        let out = dir.path().join("out");
        let flight = Flight::start(&example("square.go"), &fleet, &out);
        let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
        assert_eq!(code, Some(0), "{stdout}\n{stderr}");
        assert_eq!(
            stderr.contains("Copter warning: the autopilot puts the drone's home at (10.00, "),
            warned,
            "{stderr}"
        );
        if warned {
            assert!(
                stderr.contains("10.0 m from (0.00, 0.00, 0.00)"),
                "{stderr}"
            );
        }
        let noted = adapter_log(&out, "Copter").iter().any(|r| {
            r["detail"].as_str().is_some_and(|d| {
                d.contains("home in the fleet frame (10.00, ") && d.contains(" from HOME_POSITION ")
            })
        });
        assert!(noted, "no home from HOME_POSITION in the adapter log");
        drop(copter);
    }
}

/// The mission log's records of `event`.
fn mission_events(out: &Path, drone: &str, event: &str) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join(format!("{drone}.mission.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|r| r["event"] == event)
        .collect()
}

#[test]
fn an_abort_mid_flight_lands_the_copter_through_its_failsafe_exactly_once() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let copter = Copter::start(port, 4.0, &[]);
    let fleet = fleet(dir.path(), port, "");
    let out = dir.path().join("out");
    let mut flight = Flight::start(&example("square.go"), &fleet, &out);
    flight.wait_for("Copter started FlyByX(4)", Duration::from_secs(120));
    let interrupted = Command::new("kill")
        .args(["-INT", &flight.child.id().to_string()])
        .status()
        .unwrap();
    assert!(interrupted.success());
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert_eq!(copter.mode(), Some(CopterMode::Land));
    // Short of the far corner: it landed where it was, not after the leg.
    assert!(landed.position.x < 3.9, "{landed:?}");
    let failsafes = mission_events(&out, "Copter", "failsafe");
    assert_eq!(failsafes.len(), 1, "{failsafes:?}");
    assert_eq!(failsafes[0]["failsafe"], "land");
    let finished = mission_events(&out, "Copter", "failsafe_finished");
    assert_eq!(finished.len(), 1, "{finished:?}");
    assert_eq!(finished[0]["outcome"], "ok");
    // One switch to LAND (custom mode 9) was commanded, no more.
    let lands = adapter_log(&out, "Copter")
        .into_iter()
        .filter(|r| {
            r["event"] == "command"
                && r["detail"] == "MAV_CMD_DO_SET_MODE"
                && r["args"][1].as_f64() == Some(f64::from(CopterMode::Land.custom_mode()))
        })
        .count();
    assert_eq!(lands, 1);
}
