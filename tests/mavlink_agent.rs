//! What a drone team meets in the field, flown through the roll-out
//! (`eamos agent` on the companion computer, `eamos deploy` on the ground
//! station) as `tests/mavlink_faults.rs` flies it through `eamos run`:
//! - the agent killed with SIGKILL mid-motion and started again flies on
//!   from its journal: the motion resumes to its journaled target, no
//!   action runs twice, and the square still closes;
//! - a lost link is reported within the link timeout, and the drone taken
//!   back when the link returns;
//! - a pilot who takes the drone over keeps it until giving it back;
//! - arming refused names the autopilot's PreArm reason;
//! - the square closes within 0.3 m on a PX4-like vehicle whose reported
//!   position wanders.
//!
//! The copter is the test vehicle in this process (see `tests/common/`):
//! it outlives a killed agent as a real autopilot would, and the test can
//! be its pilot and its radio.

mod common;

use std::collections::BTreeMap;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::mavlink::*;
use common::rollout::Rollout;
use eamos_geo::{Ned, Vec3};
use eamos_mid::mavlink::modes::CopterMode;
use eamos_vehicle::Firmware;

/// `eamos deploy` running in the background, its output in files.
fn deploy(rollout: &Rollout) -> Child {
    let file =
        |name: &str| Stdio::from(std::fs::File::create(rollout.dir.path().join(name)).unwrap());
    rollout
        .deploy()
        .stdout(file("deploy.out"))
        .stderr(file("deploy.err"))
        .spawn()
        .unwrap()
}

/// Waits for `eamos deploy` to end; its exit code and what it printed.
fn deploy_ends(rollout: &Rollout, mut deploy: Child, limit: Duration) -> (Option<i32>, String) {
    let deadline = Instant::now() + limit;
    let status = loop {
        if let Some(s) = deploy.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            let _ = deploy.kill();
            panic!(
                "eamos deploy still runs; the agent said:\n{}",
                rollout.agent_said()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let read =
        |name: &str| std::fs::read_to_string(rollout.dir.path().join(name)).unwrap_or_default();
    (
        status.code(),
        format!("{}\n{}", read("deploy.out"), read("deploy.err")),
    )
}

fn started(action: &'static str) -> impl Fn(&serde_json::Value) -> bool {
    move |r| r["event"] == "action_started" && r["action"] == action
}

#[test]
fn an_agent_killed_mid_motion_resumes_from_its_journal_and_runs_nothing_twice() {
    let port = free_udp_port();
    let copter = Copter::start_with(port, |o| {
        // Real time: a 4 m leg takes seconds, long enough to be cut.
        o.speed = 1.0;
        // The EKF origin is not where the copter stands: a restarted
        // agent must find the mission frame from the autopilot's home.
        o.ekf_origin_offset = Ned::new(1.5, -2.0, 0.3);
    });
    // The ground station waits for a lost drone instead of ending the
    // mission: the agent comes back.
    let mut rollout = Rollout::start(port, "on_lost = \"hold\"\ngrace = \"600s\"\n", "");
    let flight = deploy(&rollout);

    let leg = rollout.wait_log(
        "the start of FlyByY",
        Duration::from_secs(120),
        started("FlyByY"),
    );
    rollout.kill_agent();
    let cut_at = copter.snapshot().position;
    assert!(
        !rollout
            .mission_log()
            .iter()
            .any(|r| r["event"] == "action_finished" && r["instance"] == leg["instance"]),
        "the leg had ended before the kill; the test needs it running (copter at {cut_at})"
    );
    rollout.restart_agent();

    let (code, said) = deploy_ends(&rollout, flight, Duration::from_secs(180));
    assert_eq!(
        code,
        Some(0),
        "{said}\nthe agent said:\n{}",
        rollout.agent_said()
    );
    rollout.agent_ends(Duration::from_secs(60));
    let agent = rollout.agent_said();
    assert!(agent.contains("Copter: resumed mission"), "{agent}");
    assert!(agent.contains("ended: completed"), "{agent}");

    // Every action started and finished well exactly once, over both runs.
    let log = rollout.mission_log();
    let mut starts: BTreeMap<u64, usize> = BTreeMap::new();
    let mut ends: BTreeMap<u64, usize> = BTreeMap::new();
    for r in &log {
        let Some(i) = r["instance"].as_u64() else {
            continue;
        };
        if r["event"] == "action_started" {
            *starts.entry(i).or_default() += 1;
        }
        if r["event"] == "action_finished" && r["outcome"] == "ok" {
            *ends.entry(i).or_default() += 1;
        }
    }
    assert_eq!(starts.len(), 8, "{starts:?}");
    assert!(starts.values().all(|n| *n == 1), "{starts:?}");
    assert_eq!(ends, starts, "{log:?}");

    // The leg cut short flew on to the target journaled when it started.
    let resumed: Vec<_> = log
        .iter()
        .filter(|r| r["event"] == "action_resumed")
        .collect();
    assert_eq!(resumed.len(), 1, "{resumed:?}");
    assert_eq!(resumed[0]["instance"], leg["instance"]);
    let t = &resumed[0]["target"];
    let target = [&t["x"], &t["y"], &t["z"]].map(|v| v.as_f64().unwrap());
    for (got, want) in target.iter().zip([4.0, 4.0, 2.0]) {
        assert!((got - want).abs() < 0.3, "journaled target {target:?}");
    }
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert!(
        landed.position.x.hypot(landed.position.y) <= 0.3,
        "the square did not close: landed at {}",
        landed.position
    );
    // The flight is over: a third start of the agent resumes nothing.
    assert!(!rollout.dir.path().join("agents/Copter.flight").exists());
}

#[test]
fn a_lost_link_is_reported_in_time_by_the_agent_and_the_drone_taken_back_when_it_returns() {
    let port = free_udp_port();
    let copter = Copter::start(port, 4.0, &[]);
    let mut rollout = Rollout::start(port, "", "link_timeout = 2\n");
    let flight = deploy(&rollout);

    let leg = rollout.wait_log(
        "the start of FlyByX",
        Duration::from_secs(120),
        started("FlyByX"),
    );
    copter.vehicle().set_silent(true);
    let silent_at = Instant::now();
    let lost = rollout.wait_log("the leg failing", Duration::from_secs(30), |r| {
        r["event"] == "action_finished" && r["instance"] == leg["instance"]
    });
    let reported_after = silent_at.elapsed();
    assert!(lost.to_string().contains("lost the link"), "{lost}");
    assert!(
        reported_after < Duration::from_secs(2) + Duration::from_secs(3),
        "a 2 s link timeout reported after {reported_after:?}"
    );
    // The crew at the drone reads it, and what the mission does about it.
    rollout.wait_said("Copter: warning: the link is lost", Duration::from_secs(30));
    // Meanwhile nobody commands it: it hovers in GUIDED.
    std::thread::sleep(Duration::from_secs(2));
    assert_eq!(copter.mode(), Some(CopterMode::Guided));
    assert!(!copter.snapshot().on_ground);

    // The radio is back: the mission's failsafe lands it.
    copter.vehicle().set_silent(false);
    let (code, said) = deploy_ends(&rollout, flight, Duration::from_secs(120));
    assert_eq!(code, Some(1), "{said}");
    rollout.agent_ends(Duration::from_secs(60));
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert_eq!(
        copter.mode(),
        Some(CopterMode::Land),
        "{}",
        rollout.agent_said()
    );
}

#[test]
fn a_pilot_who_takes_over_from_an_agent_keeps_the_drone_until_giving_it_back() {
    let port = free_udp_port();
    let copter = Copter::start(port, 4.0, &[]);
    let mut rollout = Rollout::start(port, "", "");
    let flight = deploy(&rollout);

    let leg = rollout.wait_log(
        "the start of FlyByY",
        Duration::from_secs(120),
        started("FlyByY"),
    );
    copter.vehicle().rc_select(CopterMode::Brake);
    let failed = rollout.wait_log("the leg failing", Duration::from_secs(30), |r| {
        r["event"] == "action_finished" && r["instance"] == leg["instance"]
    });
    assert!(failed.to_string().contains("switched to BRAKE"), "{failed}");
    rollout.wait_said(
        "Copter: warning: the drone is in BRAKE",
        Duration::from_secs(30),
    );

    // The mission is over, but the drone stays the pilot's.
    let mark = copter.snapshot().time;
    vehicle_until(&copter, Duration::from_secs(30), |s| s.time >= mark + 8.0);
    let held = copter.snapshot();
    assert_eq!(copter.mode(), Some(CopterMode::Brake), "{held:?}");
    assert!(!held.on_ground && held.armed, "{held:?}");

    // The pilot gives it back: now the mission's failsafe lands it.
    copter.vehicle().rc_select(CopterMode::Guided);
    let (code, said) = deploy_ends(&rollout, flight, Duration::from_secs(120));
    assert_eq!(code, Some(1), "{said}");
    rollout.agent_ends(Duration::from_secs(60));
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert_eq!(copter.mode(), Some(CopterMode::Land));
}

#[test]
fn an_agent_whose_autopilot_refuses_to_arm_names_the_prearm_reason() {
    let port = free_udp_port();
    let copter = Copter::start_with(port, |o| {
        o.speed = 1.0;
        o.ready_after = 100_000.0;
    });
    // Started after the vehicle's first PreArm text, as an agent that
    // connects to an autopilot already running: the reason must be asked.
    std::thread::sleep(Duration::from_secs(3));
    let mut rollout = Rollout::start(port, "", "ready_timeout = 4\n");
    let flight = deploy(&rollout);
    let (code, said) = deploy_ends(&rollout, flight, Duration::from_secs(120));
    assert_eq!(code, Some(1), "{said}");
    rollout.agent_ends(Duration::from_secs(60));
    let agent = rollout.agent_said();
    let ended = agent
        .lines()
        .find(|l| l.contains("ended:"))
        .unwrap_or_else(|| panic!("the agent never said how the mission ended:\n{agent}"));
    for reason in [
        "the drone refused `Arm`: the vehicle was not ready to arm after 4 s",
        "pre-arm checks to pass (autopilot: \"PreArm: GPS 1: Bad fix\")",
    ] {
        assert!(ended.contains(reason), "`{reason}` not in: {ended}");
    }
    assert!(copter.snapshot().on_ground);
}

#[test]
fn the_square_closes_on_a_px4_vehicle_whose_position_wanders_flown_by_its_agent() {
    let port = free_udp_port();
    let copter = Copter::start_with(port, |o| {
        o.autopilot = Firmware::Px4;
        // Twice real time: PX4's 1 s offboard-loss time stays well above
        // the 10 Hz setpoint stream.
        o.speed = 2.0;
        o.position_noise = 0.05;
    });
    let mut rollout = Rollout::start(port, "", "");
    let flight = deploy(&rollout);

    let finished = |leg: &'static str| {
        move |r: &serde_json::Value| {
            r["event"] == "action_finished" && r["action"] == leg && r["outcome"] == "ok"
        }
    };
    rollout.wait_log(
        "the take-off",
        Duration::from_secs(120),
        finished("Takeoff(2)"),
    );
    let start = copter.snapshot().position;
    let mut corner = Vec3::new(start.x, start.y, 2.0);
    for (leg, (dx, dy)) in [
        ("FlyByX(4)", (4.0, 0.0)),
        ("FlyByY(4)", (0.0, 4.0)),
        ("FlyByX(-4)", (-4.0, 0.0)),
        ("FlyByY(-4)", (0.0, -4.0)),
    ] {
        rollout.wait_log(leg, Duration::from_secs(60), finished(leg));
        corner = corner + Vec3::new(dx, dy, 0.0);
        let at = copter.snapshot().position;
        assert!(
            at.distance(corner) <= 0.3,
            "after {leg} the copter is at {at}, {:.2} m from the corner {corner}",
            at.distance(corner)
        );
    }
    let (code, said) = deploy_ends(&rollout, flight, Duration::from_secs(120));
    assert_eq!(code, Some(0), "{said}");
    rollout.agent_ends(Duration::from_secs(60));
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    let gap = (landed.position.x - start.x).hypot(landed.position.y - start.y);
    assert!(
        gap <= 0.3,
        "the square did not close: landed {gap:.2} m from where it took off"
    );
}
