//! A MAVLink copter flown through the roll-out, as a drone team flies one:
//! `eamos agent` on the drone's companion computer bound to its autopilot,
//! `eamos deploy` on the ground station with signed slices. The mission
//! completes; the agent tells its crew what the autopilot would do on a
//! lost link; and a ground station that aborts mid-flight (Ctrl-C on
//! `eamos deploy`) lands the copter through its failsafe, exactly once.
//!
//! The copter is the test vehicle in this process (see `tests/common/`).

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::mavlink::*;
use common::rollout::{text, Rollout};
use eamos_mid::mavlink::modes::CopterMode;

#[test]
fn a_deployed_agent_flies_its_mavlink_copter_and_tells_its_crew_of_the_link_loss_failsafe() {
    let port = free_udp_port();
    let copter = Copter::start(port, 4.0, &[]);
    let mut rollout = Rollout::start(port, "", "");
    let deployed = rollout.deploy().output().unwrap();
    assert!(deployed.status.success(), "{}", text(&deployed));
    rollout.agent_ends(Duration::from_secs(60));
    let said = rollout.agent_said();
    assert!(
        said.contains("Copter: warning: FS_GCS_ENABLE is 0"),
        "{said}"
    );
    assert!(said.contains("ended: completed"), "{said}");
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert!(
        landed.position.x.hypot(landed.position.y) <= 0.3,
        "the square did not close: {landed:?}"
    );
}

#[test]
fn ctrl_c_on_eamos_deploy_mid_flight_lands_the_copter_through_its_failsafe_once() {
    let port = free_udp_port();
    let copter = Copter::start(port, 4.0, &[]);
    let mut rollout = Rollout::start(port, "", "");
    let mut deploy = rollout
        .deploy()
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Once the copter is on its first leg, a metre north of home.
    let deadline = Instant::now() + Duration::from_secs(120);
    while copter.snapshot().position.x < 1.0 {
        assert!(
            Instant::now() < deadline,
            "the copter never set off: {:?}\n{}",
            copter.snapshot(),
            rollout.agent_said()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let interrupted = Command::new("kill")
        .args(["-INT", &deploy.id().to_string()])
        .status()
        .unwrap();
    assert!(interrupted.success());
    let _ = deploy.wait();
    rollout.agent_ends(Duration::from_secs(120));
    let landed = copter.snapshot();
    assert!(landed.on_ground && !landed.armed, "{landed:?}");
    assert_eq!(copter.mode(), Some(CopterMode::Land));
    assert!(
        landed.position.x < 3.9,
        "it flew the leg to its end: {landed:?}"
    );
    // One failsafe, flown once, in the agent's mission log.
    let log = rollout.mission_logs();
    let failsafes = mission_events(&log, "Copter", "failsafe");
    assert_eq!(failsafes.len(), 1, "{failsafes:?}");
    let finished = mission_events(&log, "Copter", "failsafe_finished");
    assert_eq!(finished.len(), 1, "{finished:?}");
    assert_eq!(finished[0]["outcome"], "ok");
}
