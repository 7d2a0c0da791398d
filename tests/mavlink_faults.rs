//! Faults first met on real autopilots, provoked on the test vehicle and
//! flown through `eamos run --fleet`:
//! - a pilot who takes the drone over keeps it: the end of the run does
//!   not take it back, until the pilot gives it back;
//! - a lost link is reported within the link timeout; the mission takes
//!   the drone back into its failsafe when the link returns, unless the
//!   autopilot's own link-loss failsafe is already bringing it down;
//! - before arming, an autopilot that would leave the drone alone on a
//!   lost link (`FS_GCS_ENABLE = 0`) is named to the crew;
//! - an abort (Ctrl-C) mid-flight lands the copter through its failsafe,
//!   exactly once.
//!
//! The vehicle runs in the test's own process, so that the test can be
//! the pilot (its RC mode switch) and the radio (silence); the mission
//! runs in an `eamos run` process of its own. Every wait is bounded;
//! nothing asserts how fast it went.

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

use common::mavlink::*;
use eamos_mid::mavlink::modes::CopterMode;

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
