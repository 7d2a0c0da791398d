//! An independent MAVLink client flies `eamos sim-vehicle`: the pymavlink
//! script in `tests/py/fly_sim_vehicle.py` does what a ground-station
//! script does with an ArduPilot copter and reports what it saw as JSON;
//! this test checks the report.
//!
//! pymavlink is a test requirement (`scripts/test-requirements.txt`): if
//! python3 or pymavlink is missing the test fails, it does not skip.

use std::net::UdpSocket;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

use eamos_geo::{LocalFrame, Vec3, Wgs84};
use serde_json::Value;

/// Kills the vehicle when the test ends, however it ends.
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

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/py/fly_sim_vehicle.py")
}

fn require_pymavlink() {
    let probe = Command::new("python3")
        .args(["-c", "import pymavlink.mavutil"])
        .output()
        .unwrap_or_else(|e| {
            panic!("python3 is needed to run the pymavlink test (install it, then `pip install -r scripts/test-requirements.txt`): {e}")
        });
    assert!(
        probe.status.success(),
        "pymavlink is needed for this test: `pip install -r scripts/test-requirements.txt`\n{}",
        String::from_utf8_lossy(&probe.stderr)
    );
}

fn num(v: &Value, path: &[&str]) -> f64 {
    let mut at = v;
    for p in path {
        at = &at[*p];
    }
    at.as_f64()
        .unwrap_or_else(|| panic!("{} is not a number in {v}", path.join(".")))
}

#[test]
fn a_pymavlink_ground_station_flies_the_sim_vehicle_like_an_ardupilot_copter() {
    require_pymavlink();
    let port = free_udp_port();
    let home = "-35.3632621,149.1652374,584";
    let vehicle = Command::new(env!("CARGO_BIN_EXE_eamos"))
        .args([
            "sim-vehicle",
            "--connect",
            &format!("udpout:127.0.0.1:{port}"),
            "--ready-after",
            "40",
            "--speed",
            "8",
            "--home",
            home,
            "--exit-after",
            "300",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("eamos sim-vehicle starts");
    let _vehicle = Running(vehicle);

    let out = Command::new("python3")
        .arg(script())
        .args([
            "--connect",
            &format!("udpin:127.0.0.1:{port}"),
            "--timeout",
            "150",
        ])
        .output()
        .expect("the script runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report: Value = serde_json::from_str(stdout.trim()).unwrap_or_else(|e| {
        panic!(
            "the script printed no JSON ({e}):\n{stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    assert!(out.status.success(), "the script failed: {report}");

    // An ArduPilot quadcopter, system 1.
    assert_eq!(report["system"], 1);
    assert_eq!(report["autopilot"], 3, "MAV_AUTOPILOT_ARDUPILOTMEGA");
    assert_eq!(report["vehicle_type"], 2, "MAV_TYPE_QUADROTOR");

    // Streams only when asked.
    let unrequested: Vec<&str> = report["unrequested"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(
        unrequested
            .iter()
            .all(|t| ["HEARTBEAT", "STATUSTEXT"].contains(t)),
        "sent before any request: {unrequested:?}"
    );

    // Refusals come with MAV_RESULT_FAILED and a STATUSTEXT saying why.
    assert_eq!(report["arm_before_ready"]["result"], 4);
    assert!(
        report["arm_before_ready"]["text"]
            .as_str()
            .is_some_and(|t| t.starts_with("PreArm:")),
        "{report}"
    );
    assert_eq!(report["takeoff_disarmed"]["result"], 4);
    assert_eq!(
        report["takeoff_disarmed"]["text"],
        "Takeoff: motors not armed"
    );

    // GUIDED, armed, took off.
    assert_eq!(report["mode"], 4);
    assert_eq!(report["arm"], 0);
    assert_eq!(report["takeoff"], 0);

    // Positions in local NED from the EKF origin (at home here), Z down.
    let ground = &report["ground"];
    assert!(num(ground, &["z"]).abs() < 0.05, "{ground}");
    let up = &report["after_takeoff"];
    assert!((num(up, &["z"]) + 3.0).abs() < 0.3, "{up}");
    assert!(
        num(up, &["x"]).abs() < 0.2 && num(up, &["y"]).abs() < 0.2,
        "{up}"
    );
    let moved = &report["after_move"];
    assert!((num(moved, &["x"]) - 5.0).abs() < 0.2, "{moved}");
    assert!((num(moved, &["y"]) - 2.0).abs() < 0.2, "{moved}");
    assert!((num(moved, &["z"]) + 3.0).abs() < 0.2, "{moved}");

    // The global position agrees with --home and the local offset.
    let expected = LocalFrame::new(Wgs84::parse(home).unwrap()).to_wgs84(Vec3::new(5.0, 2.0, 3.0));
    let g = &report["global_after_move"];
    let here = Wgs84::new(num(g, &["lat"]), num(g, &["lon"]), expected.alt);
    let off = LocalFrame::new(expected).to_local(here);
    assert!(
        off.x.abs() < 0.3 && off.y.abs() < 0.3,
        "{g} is {off:?} from {expected:?}"
    );
    assert!((num(g, &["relative_alt"]) - 3.0).abs() < 0.3, "{g}");

    // LAND came down and disarmed on touchdown.
    let down = &report["after_land"];
    assert!(num(down, &["z"]).abs() < 0.05, "{down}");
    assert_eq!(report["armed_after_land"], false);
    let texts: Vec<&str> = report["texts"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(Value::as_str)
        .collect();
    assert!(texts.contains(&"EKF3 IMU0 is using GPS"), "{texts:?}");
    assert!(
        texts.iter().any(|t| t.starts_with("Land complete")),
        "{texts:?}"
    );
}

#[test]
fn sim_vehicle_rejects_bad_options_with_exit_status_2() {
    for (args, needle) in [
        (vec!["--connect", "bogus"], "is not a MAVLink connection"),
        (
            vec!["--connect", "tcpout:127.0.0.1:5760"],
            "use udpout:, udpin: or tcpin:",
        ),
        (vec!["--home", "91,0,0"], "latitude"),
        (vec!["--speed", "0"], "speed must be above zero"),
        (vec!["--exit-after", "0"], "--exit-after"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_eamos"))
            .arg("sim-vehicle")
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
