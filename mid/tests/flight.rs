//! The adapter flying the test vehicle over real loopback sockets: the
//! whole protocol path, each failure a pilot meets in the field.
//!
//! Every wait is bounded by a generous timeout (a stuck test fails instead
//! of hanging); nothing asserts how fast anything happened.

use std::sync::Arc;
use std::time::Duration;

use mavlink::MavHeader;
use tokio::time::timeout;

use eamos_geo::{LocalFrame, Ned};
use eamos_mid::api::{ActionCall, ActionError, Adapter, CancellationToken, FlightMode, Vec3};
use eamos_mid::log::{AdapterEvent, LogRecord, MemorySink};
use eamos_mid::mavlink::adapter::{LostLinkCheck, MavlinkAdapter, MavlinkOptions};
use eamos_mid::mavlink::address::ConnectAddress;
use eamos_mid::mavlink::command::{command_long, CommandError, CommandPolicy, Target};
use eamos_mid::mavlink::dialect::MavMessage;
use eamos_mid::mavlink::dialect::{
    MavCmd, MavFrame, PositionTargetTypemask, SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use eamos_mid::mavlink::link::Link;
use eamos_mid::mavlink::modes::{Autopilot, CopterMode, Px4Mode};
use eamos_mid::mavlink::readiness::Missing;
use eamos_vehicle::{Firmware, SimVehicle, SimVehicleOptions, VehicleSnapshot};

/// Long enough for any action here on a loaded machine.
const BOUND: Duration = Duration::from_secs(90);

struct Rig {
    adapter: MavlinkAdapter,
    vehicle: SimVehicle,
    log: Arc<MemorySink>,
}

async fn rig(
    vehicle: impl FnOnce(&mut SimVehicleOptions),
    adapter: impl FnOnce(&mut MavlinkOptions),
) -> Rig {
    let log = MemorySink::new();
    let mut ao = MavlinkOptions {
        log: log.clone(),
        ready_timeout: Duration::from_secs(60),
        link_timeout: Duration::from_secs(2),
        ..MavlinkOptions::default()
    };
    adapter(&mut ao);
    let a = MavlinkAdapter::connect("Drone1", "udpin:127.0.0.1:0", ao)
        .await
        .expect("a loopback listener opens");
    let port = a.local_addr().unwrap().port();
    let mut vo = SimVehicleOptions {
        connect: ConnectAddress::UdpOut(format!("127.0.0.1:{port}")),
        ready_after: 2.0,
        speed: 10.0,
        // The EKF origin is not where the copter stands: the mission frame
        // must still start where it stands.
        ekf_origin_offset: Ned::new(1.5, -2.0, 0.3),
        ..SimVehicleOptions::default()
    };
    vehicle(&mut vo);
    let v = SimVehicle::start(vo).await.expect("the vehicle boots");
    Rig {
        adapter: a,
        vehicle: v,
        log,
    }
}

async fn run(a: &MavlinkAdapter, name: &str, args: &[f64]) -> Result<(), ActionError> {
    timeout(
        BOUND,
        a.run(
            &ActionCall::new(name, args.to_vec()),
            CancellationToken::new(),
        ),
    )
    .await
    .unwrap_or_else(|_| panic!("{name} did not end within {BOUND:?}"))
}

async fn vehicle_until(
    v: &SimVehicle,
    what: &str,
    f: impl Fn(&VehicleSnapshot) -> bool,
) -> VehicleSnapshot {
    let mut rx = v.watch();
    let s = timeout(BOUND, rx.wait_for(|s| f(s)))
        .await
        .unwrap_or_else(|_| panic!("the vehicle never got to: {what}"))
        .expect("the vehicle runs");
    *s
}

fn near(a: Vec3, b: Vec3, tol: f64) -> bool {
    a.distance(b) <= tol
}

fn warnings(log: &MemorySink) -> Vec<String> {
    log.records()
        .into_iter()
        .filter_map(|r| match r {
            LogRecord::Adapter(a) => match a.event {
                AdapterEvent::Warning { detail } => Some(detail),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

fn notes(log: &MemorySink) -> Vec<String> {
    log.records()
        .into_iter()
        .filter_map(|r| match r {
            LogRecord::Adapter(a) => match a.event {
                AdapterEvent::State { detail } => Some(detail),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

#[tokio::test]
async fn the_adapter_arms_takes_off_flies_a_box_lands_and_disarms() {
    let r = rig(|_| {}, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    assert!(v.snapshot().armed);
    assert_eq!(v.snapshot().custom_mode, CopterMode::Guided.custom_mode());

    run(a, "Takeoff", &[2.0]).await.unwrap();
    let t = *a.telemetry().borrow();
    assert!((t.position.z - 2.0).abs() <= 0.3, "{t:?}");
    assert!((v.snapshot().position.z - 2.0).abs() <= 0.3);

    for (action, args, expected) in [
        ("FlyByX", vec![3.0], Vec3::new(3.0, 0.0, 2.0)),
        ("FlyByY", vec![-2.0], Vec3::new(3.0, -2.0, 2.0)),
        ("FlyTo", vec![1.0, 1.0, 3.0], Vec3::new(1.0, 1.0, 3.0)),
        ("FlyByZ", vec![-1.0], Vec3::new(1.0, 1.0, 2.0)),
        ("ReturnHome", vec![], Vec3::new(0.0, 0.0, 2.0)),
    ] {
        run(a, action, &args).await.unwrap();
        // Arrival is judged from the autopilot's report, within 0.3 m.
        let seen = a.telemetry().borrow().position;
        assert!(
            near(seen, expected, 0.3),
            "{action}: telemetry at {seen}, expected {expected}"
        );
        // The vehicle really is there, in the frame it started in,
        // although its EKF origin lies elsewhere.
        let there = v.snapshot().position;
        assert!(
            near(there, expected, 0.4),
            "{action}: vehicle at {there}, expected {expected}"
        );
    }

    run(a, "Land", &[]).await.unwrap();
    assert!(v.snapshot().on_ground);
    run(a, "Disarm", &[]).await.unwrap();
    assert!(!v.snapshot().armed);
    let t = *a.telemetry().borrow();
    assert!(t.landed && !t.armed);
    assert_eq!(t.mode, FlightMode::Standby);

    let notes = notes(&r.log);
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("found ArduPilot vehicle")),
        "{notes:?}"
    );
    assert!(
        notes.iter().any(|n| n == "mode GUIDED set and confirmed"),
        "{notes:?}"
    );
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("ready; the mission frame's origin is N -1.50 E 2.00")),
        "{notes:?}"
    );
}

#[tokio::test]
async fn arming_a_vehicle_that_never_gets_ready_is_refused_naming_what_is_missing() {
    let r = rig(
        |v| v.ready_after = 1.0e6,
        |a| a.ready_timeout = Duration::from_secs(3),
    )
    .await;
    let e = run(&r.adapter, "Arm", &[]).await.unwrap_err();
    let ActionError::Refused {
        action,
        reason: what,
    } = &e
    else {
        panic!("expected a refusal, got {e:?}");
    };
    assert_eq!(action, "Arm");
    assert!(
        what.starts_with("the vehicle was not ready to arm after"),
        "{what}"
    );
    for missing in [
        "a 3D GPS fix (now: no fix, 0 satellites)",
        "an EKF position estimate (the EKF lacks horizontal velocity",
        "LOCAL_POSITION_NED (the EKF origin is not set yet)",
        "pre-arm checks to pass (autopilot: \"PreArm: GPS 1: Bad fix\")",
    ] {
        assert!(what.contains(missing), "`{missing}` not in: {what}");
    }
    // Nothing was armed and no mode was set.
    assert!(!r.vehicle.snapshot().armed);
    assert_eq!(
        r.vehicle.snapshot().custom_mode,
        CopterMode::Stabilize.custom_mode()
    );
    // The pilot saw progress while waiting.
    assert!(notes(&r.log).iter().any(|n| n.starts_with("not ready yet")));
    // The same answer, typed, from waiting up front.
    let not_ready = r
        .adapter
        .wait_ready(Duration::from_millis(500))
        .await
        .unwrap_err();
    assert!(not_ready
        .missing
        .iter()
        .any(|m| matches!(m, Missing::GpsFix { .. })));
    assert!(not_ready.missing.contains(&Missing::LocalPosition));
}

#[tokio::test]
async fn a_refused_arming_names_the_command_the_result_and_the_autopilots_words() {
    let r = rig(
        |v| v.refuse_arming = Some("Arm: Hardware safety switch".to_string()),
        |_| {},
    )
    .await;
    let e = run(&r.adapter, "Arm", &[]).await.unwrap_err();
    assert_eq!(
        e,
        ActionError::Refused {
            action: "Arm".into(),
            reason: "MAV_CMD_COMPONENT_ARM_DISARM was refused with MAV_RESULT_FAILED; the autopilot said: \"Arm: Hardware safety switch\"".into(),
        }
    );
    assert!(!r.vehicle.snapshot().armed);
}

#[tokio::test]
async fn losing_the_link_mid_flight_fails_the_motion_with_link_lost() {
    let r = rig(|_| {}, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    run(a, "Takeoff", &[2.0]).await.unwrap();
    let far = ActionCall::new("FlyTo", [60.0, 0.0, 2.0]);
    let flight = a.run(&far, CancellationToken::new());
    let cut = async {
        vehicle_until(v, "moving north", |s| s.position.x > 1.0).await;
        v.set_silent(true);
        std::future::pending::<()>().await
    };
    let result = timeout(BOUND, async {
        tokio::select! {
            r = flight => r,
            _ = cut => unreachable!(),
        }
    })
    .await
    .expect("a lost link ends the motion in bounded time");
    assert_eq!(
        result,
        Err(ActionError::LinkLost {
            action: "FlyTo".into()
        })
    );
    assert!(notes(&r.log)
        .iter()
        .any(|n| n.starts_with("lost the link to the vehicle")));
    // Every further action fails the same way at once, without waiting for
    // acknowledgements that cannot come.
    assert_eq!(
        run(a, "Land", &[]).await,
        Err(ActionError::LinkLost {
            action: "Land".into()
        })
    );
    // When the vehicle is heard again, the adapter says so and flies on.
    v.set_silent(false);
    timeout(BOUND, async {
        while !notes(&r.log)
            .iter()
            .any(|n| n == "the link to the vehicle is back")
        {
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    })
    .await
    .expect("the link comes back");
    run(a, "Land", &[]).await.unwrap();
    assert!(v.snapshot().on_ground);
}

#[tokio::test]
async fn a_command_unanswered_on_a_silent_link_fails_as_a_lost_link_not_a_timeout() {
    // A link timeout longer than the command's retries: the command gives
    // up first, and the adapter waits for the link's verdict.
    let r = rig(|_| {}, |a| a.link_timeout = Duration::from_secs(6)).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    run(a, "Takeoff", &[2.0]).await.unwrap();
    v.set_silent(true);
    assert_eq!(
        run(a, "Land", &[]).await,
        Err(ActionError::LinkLost {
            action: "Land".into()
        })
    );
}

#[tokio::test]
async fn an_rc_switch_that_overrides_guided_right_after_it_was_set_is_met_by_setting_it_again() {
    // At real time, so that heartbeats come once a second.
    let r = rig(
        |v| {
            v.speed = 1.0;
            v.ready_after = 0.5;
        },
        |_| {},
    )
    .await;
    let v = &r.vehicle;
    let arm_call = ActionCall::new("Arm", []);
    let arm = r.adapter.run(&arm_call, CancellationToken::new());
    let pilot = async {
        vehicle_until(v, "GUIDED set", |s| {
            s.custom_mode == CopterMode::Guided.custom_mode()
        })
        .await;
        v.rc_select(CopterMode::Stabilize);
        std::future::pending::<()>().await
    };
    let result = timeout(BOUND, async {
        tokio::select! {
            r = arm => r,
            _ = pilot => unreachable!(),
        }
    })
    .await
    .expect("arming ends");
    assert_eq!(result, Ok(()));
    let s = v.snapshot();
    assert!(s.armed);
    assert_eq!(s.custom_mode, CopterMode::Guided.custom_mode());
    assert!(
        notes(&r.log)
            .iter()
            .any(|n| n.contains("left GUIDED for STABILIZE right after it was set")),
        "{:?}",
        notes(&r.log)
    );
}

#[tokio::test]
async fn a_pilot_taking_over_mid_flight_ends_the_motion_and_is_not_fought() {
    let r = rig(|_| {}, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    run(a, "Takeoff", &[2.0]).await.unwrap();
    let far = ActionCall::new("FlyTo", [60.0, 0.0, 2.0]);
    let flight = a.run(&far, CancellationToken::new());
    let pilot = async {
        vehicle_until(v, "moving north", |s| s.position.x > 1.0).await;
        v.rc_select(CopterMode::Loiter);
        std::future::pending::<()>().await
    };
    let result = timeout(BOUND, async {
        tokio::select! {
            r = flight => r,
            _ = pilot => unreachable!(),
        }
    })
    .await
    .unwrap();
    let e = result.unwrap_err();
    assert_eq!(e.kind(), "failed");
    assert!(e.to_string().contains("switched to LOITER"), "{e}");
    // The next motion is refused rather than taking the drone back.
    let e = run(a, "FlyByX", &[1.0]).await.unwrap_err();
    assert_eq!(e.kind(), "refused");
    assert!(e.to_string().contains("in LOITER, not GUIDED"), "{e}");
    assert_eq!(v.snapshot().custom_mode, CopterMode::Loiter.custom_mode());
}

#[tokio::test]
async fn a_cancelled_motion_returns_promptly_and_the_drone_holds_where_it_was() {
    let r = rig(|_| {}, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    run(a, "Takeoff", &[2.0]).await.unwrap();
    let cancel = CancellationToken::new();
    let far = ActionCall::new("FlyTo", [60.0, 0.0, 2.0]);
    let flight = a.run(&far, cancel.clone());
    let stop = async {
        vehicle_until(v, "well on its way", |s| s.position.x > 3.0).await;
        cancel.cancel();
        std::future::pending::<()>().await
    };
    let result = timeout(BOUND, async {
        tokio::select! {
            r = flight => r,
            _ = stop => unreachable!(),
        }
    })
    .await
    .unwrap();
    assert_eq!(
        result,
        Err(ActionError::Cancelled {
            action: "FlyTo".into()
        })
    );
    let at_cancel = a.telemetry().borrow().position;
    // It comes to rest near where it was cancelled, far short of 60 m.
    let mut rx = v.watch();
    let mut last = rx.borrow().position;
    let settled = timeout(BOUND, async {
        loop {
            tokio::time::sleep(Duration::from_millis(500)).await;
            let now = rx.borrow_and_update().position;
            if now.distance(last) < 0.05 {
                return now;
            }
            last = now;
        }
    })
    .await
    .expect("the drone comes to rest");
    assert!(
        settled.distance(at_cancel) < 1.0,
        "held at {settled}, cancelled at {at_cancel}"
    );
    assert!(settled.x < 20.0);
    // Relative motions go on from the hold point.
    run(a, "FlyByY", &[1.0]).await.unwrap();
    let p = v.snapshot().position;
    assert!(
        (p.y - 1.0).abs() < 0.4 && (p.x - settled.x).abs() < 0.5,
        "{p}"
    );
}

#[tokio::test]
async fn a_copter_that_disarmed_itself_while_idle_is_armed_again_for_takeoff() {
    // ArduPilot's DISARM_DELAY of 10 s, at ten times real time.
    let r = rig(|v| v.idle_disarm_after = 10.0, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    vehicle_until(v, "auto disarm", |s| !s.armed).await;
    run(a, "Takeoff", &[1.5]).await.unwrap();
    assert!(v.snapshot().armed && !v.snapshot().on_ground);
    assert!(notes(&r.log)
        .iter()
        .any(|n| n.starts_with("the autopilot disarmed itself while idle")));
}

#[tokio::test]
async fn takeoff_without_arming_first_is_refused_and_nothing_moves() {
    let r = rig(|_| {}, |_| {}).await;
    run(&r.adapter, "PreFlightCheck", &[]).await.unwrap();
    let e = run(&r.adapter, "Takeoff", &[2.0]).await.unwrap_err();
    assert_eq!(
        e,
        ActionError::Refused {
            action: "Takeoff".into(),
            reason: "the motors are not armed; arm before taking off".into()
        }
    );
    assert!(r.vehicle.snapshot().on_ground);
}

#[tokio::test]
async fn disarming_in_the_air_is_refused_before_anything_is_sent() {
    let r = rig(|_| {}, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    run(a, "Takeoff", &[2.0]).await.unwrap();
    let e = run(a, "Disarm", &[]).await.unwrap_err();
    assert_eq!(e.kind(), "refused");
    assert!(e.to_string().contains("land before disarming"), "{e}");
    assert!(v.snapshot().armed);
    // Motions on the ground are refused too.
    run(a, "Land", &[]).await.unwrap();
    let e = run(a, "FlyByX", &[1.0]).await.unwrap_err();
    assert!(
        e.to_string().contains("on the ground; take off first"),
        "{e}"
    );
}

#[tokio::test]
async fn camera_actions_are_acknowledged_commands() {
    let r = rig(|_| {}, |_| {}).await;
    run(&r.adapter, "TurnOn", &[]).await.unwrap();
    run(&r.adapter, "TurnOnCamera", &[]).await.unwrap();
    run(&r.adapter, "AdjustCamera", &[]).await.unwrap();
    run(&r.adapter, "TakePhoto", &[]).await.unwrap();
    run(&r.adapter, "TakePhoto", &[]).await.unwrap();
    vehicle_until(&r.vehicle, "two photos", |s| s.photos == 2).await;
    run(&r.adapter, "Calibrate", &[]).await.unwrap();
}

#[tokio::test]
async fn a_fleet_origin_puts_the_home_where_the_gps_says() {
    let r = rig(
        |_| {},
        |a| {
            let home = SimVehicleOptions::default().home;
            a.fleet_origin = Some(LocalFrame::new(home).to_wgs84(Vec3::new(-10.0, 4.0, 0.0)));
        },
    )
    .await;
    run(&r.adapter, "PreFlightCheck", &[]).await.unwrap();
    let home = r.adapter.telemetry().borrow().home;
    assert!(near(home, Vec3::new(10.0, -4.0, 0.0), 0.01), "{home}");
}

#[tokio::test]
async fn the_adapter_flies_over_tcp_to_a_listening_vehicle() {
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let v = SimVehicle::start(SimVehicleOptions {
        connect: ConnectAddress::TcpIn(format!("127.0.0.1:{port}")),
        ready_after: 1.0,
        speed: 10.0,
        ..SimVehicleOptions::default()
    })
    .await
    .unwrap();
    // The listener may need a moment to be up: connect with retries.
    let a = timeout(BOUND, async {
        loop {
            match MavlinkAdapter::connect(
                "Drone2",
                &format!("tcpout:127.0.0.1:{port}"),
                MavlinkOptions::default(),
            )
            .await
            {
                Ok(a) => return a,
                Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
            }
        }
    })
    .await
    .unwrap();
    run(&a, "Arm", &[]).await.unwrap();
    run(&a, "Takeoff", &[1.0]).await.unwrap();
    assert!((v.snapshot().position.z - 1.0).abs() < 0.3);
    run(&a, "Land", &[]).await.unwrap();
}

/// A PX4 test vehicle at twice real time: its offboard-loss time (1 s
/// simulated) stays well above the adapter's 10 Hz setpoint period.
fn px4(v: &mut SimVehicleOptions) {
    v.autopilot = Firmware::Px4;
    v.speed = 2.0;
}

fn px4_mode(m: Px4Mode) -> u32 {
    m.custom_mode()
}

#[tokio::test]
async fn a_px4_vehicle_is_flown_in_offboard_with_setpoints_streaming_before_the_switch() {
    let r = rig(px4, |_| {}).await;
    let (a, v) = (&r.adapter, &r.vehicle);
    run(a, "Arm", &[]).await.unwrap();
    assert!(v.snapshot().armed);
    assert_eq!(v.snapshot().custom_mode, px4_mode(Px4Mode::Offboard));

    // No take-off command: a setpoint above the ground in OFFBOARD.
    run(a, "Takeoff", &[2.0]).await.unwrap();
    assert!(
        (v.snapshot().position.z - 2.0).abs() <= 0.3,
        "{:?}",
        v.snapshot()
    );
    for (action, args, expected) in [
        ("FlyByX", vec![2.0], Vec3::new(2.0, 0.0, 2.0)),
        ("FlyTo", vec![1.0, -1.0, 3.0], Vec3::new(1.0, -1.0, 3.0)),
        ("Hover", vec![2.0], Vec3::new(1.0, -1.0, 3.0)),
        ("ReturnHome", vec![], Vec3::new(0.0, 0.0, 3.0)),
    ] {
        run(a, action, &args).await.unwrap();
        let there = v.snapshot().position;
        assert!(
            near(there, expected, 0.4),
            "{action}: vehicle at {there}, expected {expected}"
        );
        // Still in OFFBOARD: the stream never lapsed.
        assert_eq!(v.snapshot().custom_mode, px4_mode(Px4Mode::Offboard));
    }
    run(a, "Land", &[]).await.unwrap();
    assert!(v.snapshot().on_ground);
    assert_eq!(v.snapshot().custom_mode, px4_mode(Px4Mode::AutoLand));
    run(a, "Disarm", &[]).await.unwrap();
    assert!(!v.snapshot().armed);

    let notes = notes(&r.log);
    assert!(
        notes.iter().any(|n| n.starts_with("found PX4 vehicle")),
        "{notes:?}"
    );
    assert!(
        notes.iter().any(|n| n == "mode OFFBOARD set and confirmed"),
        "{notes:?}"
    );
    // Nothing was refused on the way: no take-off command, no OFFBOARD
    // switch before the stream.
    assert!(
        !notes.iter().any(|n| n.contains("not available")),
        "{notes:?}"
    );
}

#[tokio::test]
async fn the_px4_vehicle_refuses_offboard_without_a_setpoint_stream() {
    let gcs = Link::open(
        &ConnectAddress::UdpIn("127.0.0.1:0".to_string()),
        MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        },
    )
    .await
    .unwrap();
    let port = gcs.local_addr().unwrap().port();
    let v = SimVehicle::start(
        SimVehicleOptions {
            connect: ConnectAddress::UdpOut(format!("127.0.0.1:{port}")),
            ready_after: 0.5,
            ..SimVehicleOptions::default()
        }
        .tap(px4),
    )
    .await
    .unwrap();
    vehicle_until(&v, "ready", |s| s.time > 1.0).await;
    // Wait for its heartbeat, so that the listener knows where to answer.
    let mut rx = gcs.subscribe();
    timeout(BOUND, async {
        loop {
            if let Ok(r) = rx.recv().await {
                if matches!(r.message, MavMessage::HEARTBEAT(_)) {
                    return;
                }
            }
        }
    })
    .await
    .expect("a heartbeat");
    let target = Target {
        system: 1,
        component: 1,
    };
    let offboard = Autopilot::Px4.set_mode_params(px4_mode(Px4Mode::Offboard));
    let e = command_long(
        &gcs,
        target,
        MavCmd::MAV_CMD_DO_SET_MODE,
        offboard,
        &CommandPolicy::default(),
    )
    .await
    .unwrap_err();
    let CommandError::Refused {
        result, statustext, ..
    } = &e
    else {
        panic!("expected a refusal, got {e:?}");
    };
    assert_eq!(result, "MAV_RESULT_TEMPORARILY_REJECTED");
    assert!(
        statustext
            .as_deref()
            .is_some_and(|t| t.contains("OFFBOARD")),
        "{e}"
    );
    assert_eq!(v.snapshot().custom_mode, px4_mode(Px4Mode::Manual));
    // With setpoints streaming, the same switch is accepted.
    let stream = async {
        loop {
            let _ = gcs
                .send(&MavMessage::SET_POSITION_TARGET_LOCAL_NED(
                    SET_POSITION_TARGET_LOCAL_NED_DATA {
                        target_system: 1,
                        target_component: 1,
                        coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
                        type_mask: PositionTargetTypemask::from_bits_truncate(3576),
                        ..Default::default()
                    },
                ))
                .await;
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    };
    let switched = async {
        tokio::time::sleep(Duration::from_millis(500)).await;
        command_long(
            &gcs,
            target,
            MavCmd::MAV_CMD_DO_SET_MODE,
            offboard,
            &CommandPolicy::default(),
        )
        .await
    };
    let result = tokio::select! {
        r = switched => r,
        _ = stream => unreachable!(),
    };
    assert_eq!(result, Ok(()));
    vehicle_until(&v, "OFFBOARD", |s| {
        s.custom_mode == px4_mode(Px4Mode::Offboard)
    })
    .await;
    // The stream stopped: the offboard-loss failsafe leaves OFFBOARD.
    vehicle_until(&v, "the offboard-loss failsafe", |s| {
        s.custom_mode == px4_mode(Px4Mode::AutoLoiter)
    })
    .await;
}

#[tokio::test]
async fn when_the_ground_station_stops_streaming_a_flying_px4_vehicle_leaves_offboard_and_holds() {
    let r = rig(px4, |_| {}).await;
    run(&r.adapter, "Arm", &[]).await.unwrap();
    run(&r.adapter, "Takeoff", &[2.0]).await.unwrap();
    let Rig {
        adapter, vehicle, ..
    } = r;
    // The ground station goes away: its setpoint stream with it.
    drop(adapter);
    let s = vehicle_until(&vehicle, "the offboard-loss failsafe", |s| {
        s.custom_mode == px4_mode(Px4Mode::AutoLoiter)
    })
    .await;
    assert!(s.armed && !s.on_ground, "it holds in the air: {s:?}");
}

#[tokio::test]
async fn a_px4_vehicle_told_to_land_on_offboard_loss_lands_and_the_adapter_says_nothing_before_arming(
) {
    let r = rig(
        |v| {
            px4(v);
            v.params = vec![("COM_OBL_RC_ACT".into(), 4.0)];
        },
        |_| {},
    )
    .await;
    run(&r.adapter, "Arm", &[]).await.unwrap();
    // Read before arming: COM_OBL_RC_ACT = 4 lands, so nothing to warn of.
    assert!(warnings(&r.log).is_empty(), "{:?}", warnings(&r.log));
    assert!(
        notes(&r.log)
            .iter()
            .any(|n| n == "on a lost link the autopilot takes the drone over (COM_OF_LOSS_T = 1, COM_OBL_RC_ACT = 4)"),
        "{:?}",
        notes(&r.log)
    );
    run(&r.adapter, "Takeoff", &[2.0]).await.unwrap();
    let Rig {
        adapter, vehicle, ..
    } = r;
    drop(adapter);
    let s = vehicle_until(&vehicle, "landed by the offboard-loss failsafe", |s| {
        s.on_ground && !s.armed
    })
    .await;
    assert_eq!(s.custom_mode, px4_mode(Px4Mode::AutoLand));
}

#[tokio::test]
async fn arming_an_autopilot_that_would_leave_the_drone_alone_on_a_lost_link_warns_or_is_refused() {
    // PX4 as it ships: COM_OBL_RC_ACT = 0 (Position mode), which without a
    // pilot on the sticks holds in the air for nobody.
    let r = rig(px4, |_| {}).await;
    run(&r.adapter, "Arm", &[]).await.unwrap();
    let w = warnings(&r.log);
    assert!(
        w.len() == 1 && w[0].starts_with("COM_OBL_RC_ACT is 0 (Position): 1 s after"),
        "{w:?}"
    );
    // Asked only once: a second arming reads nothing again.
    run(&r.adapter, "Disarm", &[]).await.unwrap();
    run(&r.adapter, "Arm", &[]).await.unwrap();
    assert_eq!(warnings(&r.log).len(), 1);

    let r = rig(|_| {}, |a| a.lost_link = LostLinkCheck::Refuse).await;
    let e = run(&r.adapter, "Arm", &[]).await.unwrap_err();
    let ActionError::Refused { reason, .. } = &e else {
        panic!("expected a refusal, got {e:?}");
    };
    assert!(reason.starts_with("FS_GCS_ENABLE is 0"), "{reason}");
    assert!(!r.vehicle.snapshot().armed);
}

#[tokio::test]
async fn a_px4_takeoff_command_climbs_in_auto_takeoff_and_then_holds() {
    let gcs = Link::open(
        &ConnectAddress::UdpIn("127.0.0.1:0".to_string()),
        MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        },
    )
    .await
    .unwrap();
    let port = gcs.local_addr().unwrap().port();
    let v = SimVehicle::start(
        SimVehicleOptions {
            connect: ConnectAddress::UdpOut(format!("127.0.0.1:{port}")),
            ready_after: 0.5,
            ..SimVehicleOptions::default()
        }
        .tap(px4),
    )
    .await
    .unwrap();
    vehicle_until(&v, "ready", |s| s.time > 1.0).await;
    let mut rx = gcs.subscribe();
    timeout(BOUND, async {
        while !matches!(
            rx.recv().await.map(|r| r.message.clone()),
            Ok(MavMessage::HEARTBEAT(_))
        ) {}
    })
    .await
    .expect("a heartbeat");
    let target = Target {
        system: 1,
        component: 1,
    };
    let policy = CommandPolicy::default();
    let takeoff = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f32::NAN];
    // Not armed: refused.
    let e = command_long(&gcs, target, MavCmd::MAV_CMD_NAV_TAKEOFF, takeoff, &policy)
        .await
        .unwrap_err();
    assert!(e.to_string().contains("disarmed"), "{e}");
    command_long(
        &gcs,
        target,
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        &policy,
    )
    .await
    .unwrap();
    command_long(&gcs, target, MavCmd::MAV_CMD_NAV_TAKEOFF, takeoff, &policy)
        .await
        .unwrap();
    vehicle_until(&v, "AUTO.TAKEOFF", |s| {
        s.custom_mode == px4_mode(Px4Mode::AutoTakeoff)
    })
    .await;
    let s = vehicle_until(&v, "AUTO.LOITER at the default height", |s| {
        s.custom_mode == px4_mode(Px4Mode::AutoLoiter)
    })
    .await;
    assert!((s.position.z - 2.5).abs() < 0.3, "{s:?}");
}

trait Tap: Sized {
    fn tap(mut self, f: impl FnOnce(&mut Self)) -> Self {
        f(&mut self);
        self
    }
}

impl Tap for SimVehicleOptions {}
