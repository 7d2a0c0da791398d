//! The MAVLink flights against real autopilots, when one is at hand:
//! ArduCopter SITL (ArduPilot's own flight code and physics) and PX4 SITL
//! with its SIH quadcopter (physics inside PX4), each started here at the
//! home its fleet file names.
//!
//! - `EAMOS_SITL_ARDUCOPTER`: an `arducopter` binary built from
//!   ArduPilot's source (`./waf configure --board sitl && ./waf copter`);
//!   `EAMOS_SITL_ARDUCOPTER_DEFAULTS` its defaults file
//!   (`Tools/autotest/default_params/copter.parm`).
//! - `EAMOS_SITL_PX4`: a PX4 SITL build folder (`build/px4_sitl_default`
//!   after `make px4_sitl_default`), holding `bin/px4` and `etc`.
//!
//! Without them these tests are not run, and never reported as passed:
//! each is `#[ignore]`d, and `scripts/test` runs them (`--ignored`) only
//! when its variable is set. Run by hand with `--ignored` and no
//! variable, a test fails saying what to set.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::mavlink::*;
use common::rollout::Rollout;
use eamos_geo::Vec3;
use eamos_mid::mavlink::dialect::{
    MavAutopilot, MavCmd, MavMessage, MavModeFlag, MavState, MavType, COMMAND_LONG_DATA,
    HEARTBEAT_DATA,
};
use eamos_mid::mavlink::modes::CopterMode;
use mavlink::MavConnection;

/// ArduPilot SITL's default location (CMAC, Canberra).
const HOME: (f64, f64, f64) = (-35.363_261, 149.165_230, 584.0);

fn var(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| {
        panic!(
            "set {name} to run this test against a real autopilot (see the module documentation)"
        )
    })
}

/// An autopilot process, stopped when the test ends however it ends.
struct Autopilot {
    child: Child,
    _dir: tempfile::TempDir,
}

impl Drop for Autopilot {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// ArduCopter SITL instance `instance`, four times as fast as real time,
/// sending MAVLink to `port` (its first serial port as a UDP client).
/// Its TCP ports (5760 + 10 x instance and the two after) stay open for a
/// second ground station: a pilot's.
fn arducopter(instance: u32, port: u16) -> Autopilot {
    arducopter_at(instance, port, 4)
}

/// [`arducopter`] at `speedup` times real time.
fn arducopter_at(instance: u32, port: u16, speedup: u32) -> Autopilot {
    arducopter_with(instance, port, speedup, &[])
}

/// [`arducopter_at`] with `params` set over its defaults.
fn arducopter_with(instance: u32, port: u16, speedup: u32, params: &[(&str, f64)]) -> Autopilot {
    arducopter_at_home(instance, port, speedup, params, HOME)
}

/// [`arducopter_with`] with its home at `home` (latitude, longitude,
/// altitude above the sea).
fn arducopter_at_home(
    instance: u32,
    port: u16,
    speedup: u32,
    params: &[(&str, f64)],
    home: (f64, f64, f64),
) -> Autopilot {
    let binary = var("EAMOS_SITL_ARDUCOPTER");
    let mut defaults = var("EAMOS_SITL_ARDUCOPTER_DEFAULTS");
    let dir = tempfile::tempdir().unwrap();
    if !params.is_empty() {
        let extra = dir.path().join("test.parm");
        let lines: String = params.iter().map(|(n, v)| format!("{n} {v}\n")).collect();
        std::fs::write(&extra, lines).unwrap();
        defaults = format!("{defaults},{}", extra.display());
    }
    let child = Command::new(binary)
        .current_dir(dir.path())
        .args(["-w", "--model", "+", "--speedup", &speedup.to_string()])
        .arg("--defaults")
        .arg(defaults)
        .arg("--home")
        .arg(format!("{},{},{},0", home.0, home.1, home.2))
        .args(["-I", &instance.to_string(), "--sysid", "1"])
        .args(["--serial0", &format!("udpclient:127.0.0.1:{port}")])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the arducopter binary starts");
    Autopilot { child, _dir: dir }
}

/// PX4 SITL instance `instance` with its SIH quadcopter at `HOME`: its
/// offboard link sends to UDP 14540 + instance, as system instance + 1.
fn px4(instance: u32) -> Autopilot {
    px4_at_home(instance, HOME)
}

/// [`px4`] with its home at `home`.
fn px4_at_home(instance: u32, home: (f64, f64, f64)) -> Autopilot {
    let build = PathBuf::from(var("EAMOS_SITL_PX4"));
    let dir = tempfile::tempdir().unwrap();
    let child = Command::new(build.join("bin/px4"))
        .env("PX4_SIM_MODEL", "sihsim_quadx")
        .env("PX4_HOME_LAT", home.0.to_string())
        .env("PX4_HOME_LON", home.1.to_string())
        .env("PX4_HOME_ALT", home.2.to_string())
        .args(["-d", "-i", &instance.to_string(), "-w"])
        .arg(dir.path())
        .arg(build.join("etc"))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the px4 binary starts");
    Autopilot { child, _dir: dir }
}

/// A fleet file with the fleet's origin at the autopilot's home and the
/// drone's home there too.
fn fleet_at_home(dir: &Path, drone: &str, connect: &str, mavlink: &str) -> PathBuf {
    let path = dir.join("fleet.toml");
    std::fs::write(
        &path,
        format!(
            "origin = {{ lat = {lat}, lon = {lon} }}\n\n[failsafe]\non_abort = \"land\"\n\n[drones.{drone}]\nadapter = \"mavlink\"\nconnect = \"{connect}\"\nhome = {{ lat = {lat}, lon = {lon}, alt = 0.0 }}\n\n[drones.{drone}.mavlink]\nready_timeout = 180\n{mavlink}",
            lat = HOME.0,
            lon = HOME.1
        ),
    )
    .unwrap();
    path
}

/// Where the drone was last seen armed, from its adapter log.
fn last_position(out: &Path, drone: &str) -> Vec3 {
    let last = adapter_log(out, drone)
        .into_iter()
        .rfind(|r| r["event"] == "position")
        .expect("positions in the adapter log");
    let p = &last["position"];
    Vec3::new(
        p["x"].as_f64().unwrap(),
        p["y"].as_f64().unwrap(),
        p["z"].as_f64().unwrap(),
    )
}

#[test]
#[ignore = "needs a real ArduCopter SITL: EAMOS_SITL_ARDUCOPTER (see the module documentation)"]
fn sitl_arducopter_flies_the_square_example_and_the_crew_hears_of_its_gcs_failsafe() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let _sitl = arducopter(7, port);
    let fleet = fleet_at_home(dir.path(), "Copter", &format!("udpin:127.0.0.1:{port}"), "");
    let out = dir.path().join("out");
    let flight = Flight::start(&example("square.go"), &fleet, &out);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(300));
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.contains("the autopilot's clock"), "{stdout}");
    assert!(stderr.contains("warning: FS_GCS_ENABLE is 0"), "{stderr}");
    let last = last_position(&out, "Copter");
    assert!(
        last.horizontal_norm() < 0.5,
        "the square did not close: last seen at {last}"
    );
}

/// A pilot's ground station on ArduCopter's second TCP port.
fn pilot_link(instance: u32) -> mavlink::Connection<MavMessage> {
    let address = format!("tcpout:127.0.0.1:{}", 5762 + 10 * instance);
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        match mavlink::connect::<MavMessage>(&address) {
            Ok(c) => return c,
            Err(e) if Instant::now() > deadline => panic!("no pilot link on {address}: {e}"),
            Err(_) => std::thread::sleep(Duration::from_millis(200)),
        }
    }
}

fn select(link: &mavlink::Connection<MavMessage>, mode: CopterMode) {
    let header = mavlink::MavHeader {
        system_id: 254,
        component_id: 190,
        sequence: 0,
    };
    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    let _ = link.send(&header, &heartbeat);
    let set = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        command: MavCmd::MAV_CMD_DO_SET_MODE,
        param1: 1.0,
        param2: mode.custom_mode() as f32,
        target_system: 1,
        target_component: 1,
        ..Default::default()
    });
    link.send(&header, &set)
        .expect("the pilot's command leaves");
}

#[test]
#[ignore = "needs a real ArduCopter SITL: EAMOS_SITL_ARDUCOPTER (see the module documentation)"]
fn sitl_arducopter_switched_to_brake_by_a_pilot_stays_the_pilots_until_given_back() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let instance = 8;
    let _sitl = arducopter(instance, port);
    let fleet = fleet_at_home(dir.path(), "Copter", &format!("udpin:127.0.0.1:{port}"), "");
    let mut flight = Flight::start(&example("square.go"), &fleet, &dir.path().join("out"));
    let pilot = pilot_link(instance);
    flight.wait_for("Copter started FlyByY", Duration::from_secs(240));
    select(&pilot, CopterMode::Brake);
    let failed = flight.wait_for("Copter failed FlyByY", Duration::from_secs(30));
    assert!(failed.contains("BRAKE"), "{failed}");
    flight.wait_for(
        "Copter warning: the drone is in BRAKE",
        Duration::from_secs(30),
    );
    // Nothing lands it behind the pilot's back.
    std::thread::sleep(Duration::from_secs(5));
    assert!(!flight
        .child
        .try_wait()
        .unwrap()
        .is_some_and(|s| s.success()));
    select(&pilot, CopterMode::Guided);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(180));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(stderr.contains("Copter failsafe: land"), "{stderr}");
}

#[test]
#[ignore = "needs a real PX4 SITL: EAMOS_SITL_PX4 (see the module documentation)"]
fn sitl_px4_closes_the_square_of_experiment_a_in_offboard() {
    let dir = tempfile::tempdir().unwrap();
    let instance = 6;
    let _sitl = px4(instance);
    // PX4's SIH copter holds its setpoint only to some tens of centimetres
    // (measured here: it wanders by up to 0.4 m, and drifts as much again
    // while AUTO.LAND descends), so the fleet file asks for what it can do,
    // as a crew would, and the square closes within that accuracy.
    let fleet = fleet_at_home(
        dir.path(),
        "Drone1",
        &format!("udpin:127.0.0.1:{}", 14540 + instance),
        "arrival_tolerance = 0.4\nsettle_speed = 0.5\n",
    );
    let out = dir.path().join("out");
    let mission =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_a.go");
    let flight = Flight::start(&mission, &fleet, &out);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(300));
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let last = last_position(&out, "Drone1");
    assert!(
        last.horizontal_norm() <= 0.8,
        "the square did not close: last seen at {last}"
    );
}

#[test]
#[ignore = "needs a real ArduCopter SITL: EAMOS_SITL_ARDUCOPTER (see the module documentation)"]
fn sitl_arducopter_agent_killed_mid_motion_resumes_from_its_journal() {
    let port = free_udp_port();
    // Real time: a 4 m leg lasts long enough to be cut.
    let _sitl = arducopter_at(9, port, 1);
    let mut rollout = Rollout::start_fleet(
        &format!("origin = {{ lat = {}, lon = {} }}\n\n", HOME.0, HOME.1),
        "on_lost = \"hold\"\ngrace = \"600s\"\n",
        &format!(
            "[drones.Copter]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\nhome = {{ lat = {}, lon = {}, alt = 0.0 }}\n\n[drones.Copter.mavlink]\nready_timeout = 180\n",
            HOME.0, HOME.1
        ),
    );
    let mut deploy = rollout
        .deploy()
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let leg = rollout.wait_log("the start of FlyByY", Duration::from_secs(240), |r| {
        r["event"] == "action_started" && r["action"] == "FlyByY"
    });
    rollout.kill_agent();
    assert!(
        !rollout
            .mission_log()
            .iter()
            .any(|r| r["event"] == "action_finished" && r["instance"] == leg["instance"]),
        "the leg had ended before the kill"
    );
    rollout.restart_agent();
    let deadline = Instant::now() + Duration::from_secs(240);
    let status = loop {
        if let Some(s) = deploy.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "{}", rollout.agent_said());
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(status.success(), "{}", rollout.agent_said());
    rollout.agent_ends(Duration::from_secs(60));
    assert!(rollout.agent_said().contains("resumed mission"));
    let log = rollout.mission_log();
    let starts = log
        .iter()
        .filter(|r| r["event"] == "action_started")
        .count();
    let resumed = log
        .iter()
        .filter(|r| r["event"] == "action_resumed")
        .count();
    assert_eq!((starts, resumed), (8, 1), "{log:?}");
    let last = last_position(&rollout.mission_logs(), "Copter");
    assert!(
        last.horizontal_norm() < 0.5,
        "the square did not close: last seen at {last}"
    );
}

#[test]
#[ignore = "needs a real ArduCopter SITL: EAMOS_SITL_ARDUCOPTER (see the module documentation)"]
fn sitl_arducopter_with_a_low_battery_refuses_to_arm_naming_its_prearm_reason() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    // Its simulated battery holds 12.6 V: under 20 V it must not arm.
    let _sitl = arducopter_with(10, port, 1, &[("BATT_ARM_VOLT", 20.0)]);
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!("[drones.Copter]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\n\n[drones.Copter.mavlink]\nready_timeout = 30\n"),
    )
    .unwrap();
    let flight = Flight::start(&example("square.go"), &fleet, &dir.path().join("out"));
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(180));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    let line = stdout
        .lines()
        .find(|l| l.starts_with("Copter: "))
        .unwrap_or_else(|| panic!("no reason for Copter: {stdout}"));
    assert!(
        line.starts_with(
            "Copter: the drone refused `Arm`: the vehicle was not ready to arm after 30 s"
        ),
        "{line}"
    );
    assert!(
        line.contains("(autopilot: \"PreArm: Battery 1 below minimum arming voltage\")"),
        "{line}"
    );
}

/// A radio between the autopilot and eamos that the test can silence:
/// what the autopilot sends to `from` goes to eamos on `to`, and eamos's
/// answers go back, unless `silent`.
struct Radio {
    silent: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl Radio {
    fn start(from: u16, to: u16) -> Radio {
        use std::net::UdpSocket;
        use std::sync::atomic::{AtomicBool, Ordering};
        use std::sync::{Arc, Mutex};
        let silent = Arc::new(AtomicBool::new(false));
        let air = UdpSocket::bind(("127.0.0.1", from)).unwrap();
        let ground = UdpSocket::bind("127.0.0.1:0").unwrap();
        ground.connect(("127.0.0.1", to)).unwrap();
        let autopilot = Arc::new(Mutex::new(None));
        let (a, g, s, ap) = (
            air.try_clone().unwrap(),
            ground.try_clone().unwrap(),
            silent.clone(),
            autopilot.clone(),
        );
        std::thread::spawn(move || {
            let mut buf = [0u8; 2048];
            while let Ok((n, peer)) = a.recv_from(&mut buf) {
                *ap.lock().unwrap() = Some(peer);
                if !s.load(Ordering::Relaxed) {
                    let _ = g.send(&buf[..n]);
                }
            }
        });
        let s = silent.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 2048];
            loop {
                let n = match ground.recv(&mut buf) {
                    Ok(n) => n,
                    // Nobody listens on `to` yet: eamos is starting.
                    Err(_) => {
                        std::thread::sleep(Duration::from_millis(50));
                        continue;
                    }
                };
                let peer = *autopilot.lock().unwrap();
                if let (false, Some(peer)) = (s.load(Ordering::Relaxed), peer) {
                    let _ = air.send_to(&buf[..n], peer);
                }
            }
        });
        Radio { silent }
    }

    fn set_silent(&self, silent: bool) {
        self.silent
            .store(silent, std::sync::atomic::Ordering::Relaxed);
    }
}

#[test]
#[ignore = "needs a real ArduCopter SITL: EAMOS_SITL_ARDUCOPTER (see the module documentation)"]
fn sitl_arducopter_lost_link_is_reported_in_time_and_the_drone_taken_back_when_it_returns() {
    let dir = tempfile::tempdir().unwrap();
    let (air, port) = (free_udp_port(), free_udp_port());
    let radio = Radio::start(air, port);
    let _sitl = arducopter_at(11, air, 1);
    let fleet = fleet_at_home(
        dir.path(),
        "Copter",
        &format!("udpin:127.0.0.1:{port}"),
        "link_timeout = 2\n",
    );
    let mut flight = Flight::start(&example("square.go"), &fleet, &dir.path().join("out"));
    flight.wait_for("Copter started FlyByX(4)", Duration::from_secs(240));
    radio.set_silent(true);
    let silent_at = Instant::now();
    let lost = flight.wait_for("Copter failed FlyByX(4)", Duration::from_secs(30));
    assert!(lost.contains("lost the link"), "{lost}");
    assert!(
        silent_at.elapsed() < Duration::from_secs(2) + Duration::from_secs(3),
        "a 2 s link timeout reported after {:?}",
        silent_at.elapsed()
    );
    flight.wait_for("Copter warning: the link is lost", Duration::from_secs(30));
    std::thread::sleep(Duration::from_secs(3));
    radio.set_silent(false);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(240));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(stderr.contains("Copter failsafe: land"), "{stderr}");
}

/// `HOME` moved `east` metres east.
fn east_of_home(east: f64) -> (f64, f64, f64) {
    let metres_per_degree = 111_320.0 * HOME.0.to_radians().cos();
    (HOME.0, HOME.1 + east / metres_per_degree, HOME.2)
}

#[test]
#[ignore = "needs real ArduCopter and PX4 SITLs: EAMOS_SITL_ARDUCOPTER and EAMOS_SITL_PX4 (see the module documentation)"]
fn sitl_arducopter_and_px4_fly_experiment_c_beside_a_simulated_drone() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let instance = 5;
    let _ardu = arducopter_at_home(12, port, 1, &[], HOME);
    let _px4 = px4_at_home(instance, east_of_home(3.0));
    let home =
        |(lat, lon, _): (f64, f64, f64)| format!("{{ lat = {lat}, lon = {lon}, alt = 0.0 }}");
    let fleet = dir.path().join("fleet.toml");
    std::fs::write(
        &fleet,
        format!(
            "origin = {{ lat = {}, lon = {} }}\n\n[drones.Drone1]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\nhome = {}\n\n[drones.Drone1.mavlink]\nready_timeout = 180\n\n[drones.Drone2]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{}\"\nhome = {}\n\n[drones.Drone2.mavlink]\nready_timeout = 180\narrival_tolerance = 0.4\nsettle_speed = 0.5\n\n[drones.Drone3]\nhome = {}\n",
            HOME.0,
            HOME.1,
            home(HOME),
            14540 + instance,
            home(east_of_home(3.0)),
            home(east_of_home(6.0)),
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let mission =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_c.go");
    let flight = Flight::start_with(&mission, &fleet, &out, &["--speed", "1"]);
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(400));
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.starts_with("ExperimentC: completed"), "{stdout}");
    // Each real copter closed its 1 m square where it took off (PX4's SIH
    // to its accuracy, see the PX4 test above).
    for (drone, within) in [("Drone1", 0.5), ("Drone2", 0.8)] {
        let last = last_position(&out, drone);
        assert!(
            last.horizontal_norm() <= within,
            "{drone}: the square did not close: last seen at {last}"
        );
    }
}

#[test]
#[ignore = "needs a real ArduCopter SITL: EAMOS_SITL_ARDUCOPTER (see the module documentation)"]
fn sitl_arducopter_aborted_mid_flight_lands_through_its_failsafe_exactly_once() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_udp_port();
    let _sitl = arducopter_at(13, port, 1);
    let fleet = fleet_at_home(dir.path(), "Copter", &format!("udpin:127.0.0.1:{port}"), "");
    let out = dir.path().join("out");
    let mut flight = Flight::start(&example("square.go"), &fleet, &out);
    flight.wait_for("Copter started FlyByX(4)", Duration::from_secs(240));
    let interrupted = Command::new("kill")
        .args(["-INT", &flight.child.id().to_string()])
        .status()
        .unwrap();
    assert!(interrupted.success());
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(240));
    assert_eq!(code, Some(1), "{stdout}\n{stderr}");
    assert!(stderr.contains("Copter failsafe: land"), "{stderr}");
    let failsafes = mission_events(&out, "Copter", "failsafe");
    assert_eq!(failsafes.len(), 1, "{failsafes:?}");
    let finished = mission_events(&out, "Copter", "failsafe_finished");
    assert_eq!(finished.len(), 1, "{finished:?}");
    assert_eq!(finished[0]["outcome"], "ok");
    // It landed where the abort found it, short of the leg's end.
    let last = last_position(&out, "Copter");
    assert!(
        last.x < 3.5,
        "it flew the leg to its end: last seen at {last}"
    );
}
