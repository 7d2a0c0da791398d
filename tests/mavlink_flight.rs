//! A MAVLink copter flown as a crew expects, on the test vehicle through
//! `eamos run --fleet`:
//! - the square of the paper's experiment A closes on a PX4-like vehicle
//!   whose reported position wanders, as a real EKF's does: each leg
//!   starts from the last target, and each ends settled on its corner;
//! - a real vehicle's home is what its autopilot reports, in the fleet's
//!   one frame, and a fleet file that put it elsewhere is named;
//! - mission time follows the autopilot's own clock, so a vehicle run at a
//!   speed-up hovers for its own seconds; and an autopilot whose clock
//!   runs at another pace than a mixed fleet's mission clock is named.

mod common;

use std::path::PathBuf;
use std::time::Duration;

use common::mavlink::*;
use eamos_geo::{LocalFrame, Vec3, Wgs84};
use eamos_vehicle::Firmware;

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

#[test]
fn mission_time_follows_the_autopilots_clock_so_a_fast_vehicle_hovers_for_its_own_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let mission = dir.path().join("hover.go");
    std::fs::write(
        &mission,
        "package Hover\n\nvar Copter Quadcopter\n\nfunc SEQ_Hover() {\n\tCopter.Arm()\n\tCopter.Takeoff(2)\n\tCopter.Hover(24)\n\tCopter.Land()\n\tCopter.Disarm()\n}\n",
    )
    .unwrap();
    let port = free_udp_port();
    // Eight times as fast as the wall clock, as a SITL run at a speed-up.
    let copter = Copter::start(port, 8.0, &[]);
    let fleet = fleet(dir.path(), port, "");
    let flight = Flight::start(&mission, &fleet, &dir.path().join("out"));
    let (code, stdout, stderr) = flight.finish(Duration::from_secs(120));
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let (mission_s, wall_s) = times(&stdout);
    // Its 24 s hover lasted 24 s of its clock, not of the wall's.
    assert!(mission_s >= 24.0, "{stdout}");
    assert!(
        wall_s < mission_s / 2.0,
        "a vehicle eight times as fast took {wall_s} s of wall time for {mission_s} s of mission time"
    );
    // One clock: no warning that the autopilot's runs at another pace.
    assert!(!stderr.contains("times the mission clock"), "{stderr}");
    drop(copter);
}

#[test]
fn an_autopilot_whose_clock_runs_at_another_pace_than_a_mixed_fleets_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let mission = dir.path().join("mixed.go");
    std::fs::write(
        &mission,
        "package Mixed\n\nvar (\n\tCopter Quadcopter\n\tSim Quadcopter\n)\n\nfunc PAR_Mixed() {\n\tSEQ_Copter()\n\tSEQ_Sim()\n}\n\nfunc SEQ_Copter() {\n\tCopter.Arm()\n\tCopter.Takeoff(2)\n\tCopter.Hover(150)\n\tCopter.Land()\n\tCopter.Disarm()\n}\n\nfunc SEQ_Sim() {\n\tSim.Arm()\n\tSim.Takeoff(2)\n\tSim.Land()\n\tSim.Disarm()\n}\n",
    )
    .unwrap();
    let port = free_udp_port();
    // The autopilot at real time, the simulated drone at ten times that.
    let copter = Copter::start(port, 1.0, &[]);
    let fleet = fleet(dir.path(), port, "");
    let mut flight = Flight::start_with(
        &mission,
        &fleet,
        &dir.path().join("out"),
        &["--speed", "10"],
    );
    let warning = flight.wait_for(
        "Copter warning: the autopilot's clock",
        Duration::from_secs(120),
    );
    assert!(
        warning.contains("runs at 0.1"),
        "a real-time autopilot in a fleet at --speed 10: {warning}"
    );
    drop(flight);
    drop(copter);
}
