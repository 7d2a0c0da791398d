//! The simulated drone through the drone API, as the executor sees it.
//! Every test runs on tokio's paused clock: simulated flights of minutes
//! take milliseconds and nothing depends on the machine's speed.

use std::sync::Arc;

use tokio::time::Instant;

use super::kinematics::BatteryConfig;
use super::script::{Leg, Script};
use super::*;
use crate::api::{evaluate_property, PropertyArg};
use crate::log::{CallPhase, MemorySink, NullSink};
use crate::uniform::Uniform;

fn fleet(speed: f64) -> SimFleet {
    SimFleet::start(SimConfig {
        speed,
        ..SimConfig::default()
    })
    .unwrap()
}

fn drone(fleet: &SimFleet, name: &str, home: Vec3) -> SimDrone {
    fleet
        .add_drone(SimDroneSpec::new(name, home), Arc::new(NullSink))
        .unwrap()
}

fn call(name: &str, args: &[f64]) -> ActionCall {
    ActionCall::new(name, args.to_vec())
}

async fn run(d: &SimDrone, name: &str, args: &[f64]) -> Result<(), ActionError> {
    d.run(&call(name, args), CancellationToken::new()).await
}

async fn airborne(d: &SimDrone, height: f64) {
    run(d, "Arm", &[]).await.unwrap();
    run(d, "Takeoff", &[height]).await.unwrap();
}

fn now(d: &SimDrone) -> Telemetry {
    *d.telemetry().borrow()
}

#[tokio::test(start_paused = true)]
async fn a_fly_by_x_arrives_one_metre_north_within_tolerance() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 1.5).await;
    let before = now(&d);
    assert!(before.armed && !before.landed);
    assert!((before.position.z - 1.5).abs() <= 0.1);
    run(&d, "FlyByX", &[1.0]).await.unwrap();
    let m = d.model();
    let tol = m.config().arrival_tolerance;
    assert!(m.position().distance(Vec3::new(1.0, 0.0, 1.5)) <= tol);
    assert_eq!(m.mode(), FlightMode::Hold);
    // Telemetry of the arrival is published before the action returns.
    let t = now(&d);
    assert!(t.position.distance(Vec3::new(1.0, 0.0, 1.5)) <= tol);
    assert!(t.battery < 100.0, "flying costs battery");
}

#[tokio::test(start_paused = true)]
async fn telemetry_changes_as_the_drone_moves() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let mut rx = d.telemetry();
    rx.borrow_and_update();
    let flight = tokio::spawn({
        let d = d.clone();
        async move { run(&d, "FlyByY", &[5.0]).await }
    });
    let mut ys = Vec::new();
    while !flight.is_finished() {
        rx.changed().await.unwrap();
        ys.push(rx.borrow_and_update().position.y);
    }
    flight.await.unwrap().unwrap();
    assert!(ys.len() > 10, "only {} updates", ys.len());
    assert!(ys.windows(2).all(|w| w[1] >= w[0] - 1e-9), "y went back");
    assert!(ys.last().unwrap() > &4.8);
    // Stamped with simulated time that moves forward.
    assert!(now(&d).time > 0.0);
}

#[tokio::test(start_paused = true)]
async fn cancelling_a_motion_returns_cancelled_at_once_and_the_drone_holds_there() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 3.0).await;
    let clock = d.clock();
    let cancel = CancellationToken::new();
    let flight = tokio::spawn({
        let d = d.clone();
        let cancel = cancel.clone();
        async move { d.run(&call("FlyTo", &[40.0, 0.0, 3.0]), cancel).await }
    });
    let t_cancel = clock.now() + 4.0;
    clock.sleep_until(t_cancel).await;
    let at_cancel = now(&d);
    assert!(at_cancel.velocity.norm() > 1.0, "was flying");
    cancel.cancel();
    let result = flight.await.unwrap();
    assert_eq!(
        result,
        Err(ActionError::Cancelled {
            action: "FlyTo".into()
        })
    );
    assert!(
        clock.now() - t_cancel <= f.config().step + 1e-9,
        "returned {} s after the cancel",
        clock.now() - t_cancel
    );
    // It brakes to a stop just past where it was and stays there.
    clock.sleep(6.0).await;
    let stopped = now(&d);
    assert!(stopped.velocity.norm() < 0.05);
    assert!(stopped.position.x >= at_cancel.position.x);
    assert!(stopped.position.x - at_cancel.position.x < 6.0);
    assert!(stopped.position.x < 30.0, "did not carry on to the target");
    assert_eq!(stopped.mode, FlightMode::Hold);
    clock.sleep(10.0).await;
    assert!(now(&d).position.distance(stopped.position) < 0.05);
    // The drone takes the next command.
    run(&d, "FlyByZ", &[1.0]).await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn dropping_a_running_motion_stops_it_like_a_cancellation() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 3.0).await;
    let clock = d.clock();
    let stopped_waiting = tokio::time::timeout(
        std::time::Duration::from_secs(3),
        run(&d, "FlyByX", &[50.0]),
    )
    .await;
    assert!(stopped_waiting.is_err(), "the flight cannot be over yet");
    assert_eq!(d.model().mode(), FlightMode::Hold);
    clock.sleep(6.0).await;
    let t = now(&d);
    assert!(t.position.x < 20.0 && t.velocity.norm() < 0.05);
    // Not busy any more.
    run(&d, "FlyByY", &[1.0]).await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn an_already_cancelled_token_starts_nothing() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    let cancel = CancellationToken::new();
    cancel.cancel();
    let r = d.run(&call("Arm", &[]), cancel).await;
    assert_eq!(r.unwrap_err().kind(), "cancelled");
    assert!(!now(&d).armed);
}

#[tokio::test(start_paused = true)]
async fn a_takeoff_when_not_armed_is_refused_and_nothing_moves() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    let err = run(&d, "Takeoff", &[1.5]).await.unwrap_err();
    assert_eq!(
        err,
        ActionError::Refused {
            action: "Takeoff".into(),
            reason: "the motors are not armed; call Arm first".into()
        }
    );
    d.clock().sleep(2.0).await;
    assert_eq!(now(&d).position, Vec3::ZERO);
}

#[tokio::test(start_paused = true)]
async fn a_disarm_in_the_air_is_refused_and_after_landing_it_is_done() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let err = run(&d, "Disarm", &[]).await.unwrap_err();
    assert_eq!(err.kind(), "refused");
    assert!(err.to_string().contains("in the air"), "{err}");
    assert!(now(&d).armed);
    run(&d, "Land", &[]).await.unwrap();
    let t = now(&d);
    assert!(t.landed && t.position.z == 0.0 && t.armed);
    run(&d, "Disarm", &[]).await.unwrap();
    assert!(!now(&d).armed);
    // Disarming and landing again are no-ops, as on an autopilot.
    run(&d, "Disarm", &[]).await.unwrap();
    run(&d, "Land", &[]).await.unwrap();
}

#[tokio::test(start_paused = true)]
async fn motions_on_the_ground_are_refused() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    run(&d, "Arm", &[]).await.unwrap();
    for (name, args) in [
        ("FlyByX", vec![1.0]),
        ("FlyTo", vec![1.0, 1.0, 1.0]),
        ("Hover", vec![1.0]),
        ("ReturnHome", vec![]),
    ] {
        let err = run(&d, name, &args).await.unwrap_err();
        assert_eq!(
            err,
            ActionError::refused(name, "the drone is on the ground; take off first")
        );
    }
}

#[tokio::test(start_paused = true)]
async fn a_target_under_the_lowest_flight_height_is_refused_with_advice() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 1.0).await;
    let err = run(&d, "FlyByZ", &[-1.0]).await.unwrap_err();
    assert_eq!(err.kind(), "refused");
    assert!(err.to_string().contains("use Land"), "{err}");
}

#[tokio::test(start_paused = true)]
async fn an_empty_battery_refuses_to_arm() {
    let f = fleet(1.0);
    let mut spec = SimDroneSpec::new("D1", Vec3::ZERO);
    spec.vehicle.battery = BatteryConfig {
        initial: 0.0,
        ..BatteryConfig::default()
    };
    let d = f.add_drone(spec, Arc::new(NullSink)).unwrap();
    let err = run(&d, "Arm", &[]).await.unwrap_err();
    assert_eq!(err.kind(), "refused");
    assert!(err.to_string().contains("battery"), "{err}");
}

#[tokio::test(start_paused = true)]
async fn a_battery_that_runs_out_in_flight_fails_the_motion_and_lands() {
    let f = fleet(1.0);
    let mut spec = SimDroneSpec::new("D1", Vec3::ZERO);
    spec.vehicle.battery = BatteryConfig {
        initial: 2.0,
        airborne_per_second: 0.2,
        ..BatteryConfig::default()
    };
    let d = f.add_drone(spec, Arc::new(NullSink)).unwrap();
    airborne(&d, 2.0).await;
    let err = run(&d, "FlyTo", &[500.0, 0.0, 2.0]).await.unwrap_err();
    assert_eq!(err.kind(), "failed");
    assert!(err.to_string().contains("battery ran out"), "{err}");
    d.clock().sleep(20.0).await;
    let t = now(&d);
    assert!(t.landed && t.battery == 0.0);
}

#[tokio::test(start_paused = true)]
async fn a_second_motion_is_refused_while_one_runs_but_the_same_call_joins_it() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 4.0).await;
    let lands: Vec<_> = (0..3)
        .map(|_| {
            let d = d.clone();
            tokio::spawn(async move { run(&d, "Land", &[]).await })
        })
        .collect();
    tokio::task::yield_now().await;
    d.clock().sleep(0.5).await;
    let err = run(&d, "FlyByX", &[1.0]).await.unwrap_err();
    assert_eq!(
        err,
        ActionError::refused("FlyByX", "the drone is busy with Land()")
    );
    for l in lands {
        l.await.unwrap().unwrap();
    }
    assert!(now(&d).landed);
}

#[tokio::test(start_paused = true)]
async fn a_joined_motion_keeps_flying_until_its_last_caller_cancels() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let (c1, c2) = (CancellationToken::new(), CancellationToken::new());
    let spawn = |c: CancellationToken| {
        let d = d.clone();
        tokio::spawn(async move { d.run(&call("FlyByX", &[30.0]), c).await })
    };
    let (a, b) = (spawn(c1.clone()), spawn(c2.clone()));
    d.clock().sleep(1.0).await;
    c1.cancel();
    assert_eq!(a.await.unwrap().unwrap_err().kind(), "cancelled");
    d.clock().sleep(1.0).await;
    assert_eq!(d.model().mode(), FlightMode::Guided, "still flying for b");
    c2.cancel();
    assert_eq!(b.await.unwrap().unwrap_err().kind(), "cancelled");
    assert_eq!(d.model().mode(), FlightMode::Hold);
}

#[tokio::test(start_paused = true)]
async fn a_hover_holds_for_its_simulated_seconds() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let clock = d.clock();
    let t0 = clock.now();
    let p0 = now(&d).position;
    run(&d, "Hover", &[3.0]).await.unwrap();
    let dt = clock.now() - t0;
    assert!((3.0..3.0 + 2.0 * f.config().step).contains(&dt), "{dt}");
    assert!(now(&d).position.distance(p0) < 0.1);
}

#[tokio::test(start_paused = true)]
async fn return_home_flies_back_above_home_at_the_same_height() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::new(100.0, 0.0, 0.0));
    airborne(&d, 3.0).await;
    run(&d, "FlyTo", &[6.0, -8.0, 3.0]).await.unwrap();
    run(&d, "ReturnHome", &[]).await.unwrap();
    let t = now(&d);
    assert!(t.position.distance(Vec3::new(0.0, 0.0, 3.0)) <= 0.1);
    assert!(t.fleet_position().distance(Vec3::new(100.0, 0.0, 3.0)) <= 0.1);
}

#[tokio::test(start_paused = true)]
async fn system_and_camera_actions_take_their_simulated_time_and_can_be_cancelled() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    let clock = d.clock();
    let t0 = clock.now();
    run(&d, "Calibrate", &[]).await.unwrap();
    let took = clock.now() - t0;
    let nominal = eamos_profile::builtin().get("Quadcopter").unwrap().actions["Calibrate"]
        .nominal_duration([0.0; 3], &[], None)
        .unwrap();
    assert_eq!(nominal, 5.0);
    assert!((took - nominal).abs() <= f.config().step + 1e-9);
    let cancel = CancellationToken::new();
    let turn_on = tokio::spawn({
        let (d, c) = (d.clone(), cancel.clone());
        async move { d.run(&call("TurnOn", &[]), c).await }
    });
    clock.sleep(0.5).await;
    cancel.cancel();
    assert_eq!(turn_on.await.unwrap().unwrap_err().kind(), "cancelled");
    run(&d, "Arm", &[]).await.unwrap();
    let err = run(&d, "Calibrate", &[]).await.unwrap_err();
    assert_eq!(err.kind(), "refused");
}

#[tokio::test(start_paused = true)]
async fn distance_between_two_drones_is_computed_from_their_telemetry() {
    let f = fleet(1.0);
    let d1 = drone(&f, "D1", Vec3::ZERO);
    let d2 = drone(&f, "D2", Vec3::new(0.0, 4.0, 0.0));
    let distance = |a: &SimDrone, b: &SimDrone| {
        let (ta, tb) = (now(a), now(b));
        evaluate_property("DistanceTo", &ta, &[PropertyArg::Drone(&tb)])
            .unwrap()
            .as_number()
            .unwrap()
    };
    assert!((distance(&d1, &d2) - 4.0).abs() < 1e-9);
    airborne(&d1, 3.0).await;
    run(&d1, "FlyByX", &[4.0]).await.unwrap();
    // D1 at (4, 0, 3), D2 on the ground at (0, 4, 0) of the fleet frame.
    let expected = (16.0f64 + 16.0 + 9.0).sqrt();
    assert!((distance(&d1, &d2) - expected).abs() < 0.2);
    assert!((distance(&d2, &d1) - expected).abs() < 0.2);
    assert_eq!(
        evaluate_property("IsArmed", &now(&d2), &[]).unwrap(),
        crate::api::Value::Bool(false)
    );
}

#[tokio::test(start_paused = true)]
async fn at_speed_twenty_ten_simulated_seconds_take_half_a_second_of_tokio_time() {
    let f = fleet(20.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let clock = d.clock();
    let (sim0, real0) = (clock.now(), Instant::now());
    run(&d, "Hover", &[10.0]).await.unwrap();
    let sim = clock.now() - sim0;
    let real = real0.elapsed().as_secs_f64();
    assert!((10.0..10.05).contains(&sim), "simulated {sim} s");
    assert!(
        (real * 20.0 - sim).abs() < 0.05,
        "{real} s real for {sim} s simulated"
    );
    // The fleet stepped exactly once per 20 ms of simulated time.
    assert_eq!(f.steps() as f64 * f.config().step, clock.now());
}

#[tokio::test(start_paused = true)]
async fn drones_of_one_fleet_share_one_simulated_clock() {
    let f = fleet(5.0);
    let d1 = drone(&f, "D1", Vec3::ZERO);
    f.clock().sleep(3.0).await;
    let d2 = drone(&f, "D2", Vec3::new(5.0, 0.0, 0.0));
    f.clock().sleep(1.0).await;
    assert_eq!(d1.clock().now(), d2.clock().now());
    let (t1, t2) = (now(&d1).time, now(&d2).time);
    assert!((t1 - t2).abs() <= f.config().telemetry_period);
    assert!(t2 >= 3.0);
}

#[tokio::test(start_paused = true)]
async fn the_adapter_log_records_commands_positions_and_outcomes() {
    let f = fleet(1.0);
    let sink = MemorySink::new();
    let d = f
        .add_drone(SimDroneSpec::new("D7", Vec3::ZERO), sink.clone())
        .unwrap();
    airborne(&d, 2.0).await;
    run(&d, "FlyByX", &[3.0]).await.unwrap();
    let records = sink.records();
    assert!(records.iter().all(|r| r.drone() == "D7"));
    let adapter: Vec<_> = records
        .iter()
        .filter_map(|r| match r {
            LogRecord::Adapter(a) => Some(a),
            _ => None,
        })
        .collect();
    let has = |pred: &dyn Fn(&AdapterEvent) -> bool| adapter.iter().any(|a| pred(&a.event));
    assert!(has(
        &|e| matches!(e, AdapterEvent::State { detail } if detail == "armed")
    ));
    assert!(has(
        &|e| matches!(e, AdapterEvent::Command { action, .. } if action == "FlyByX")
    ));
    assert!(has(
        &|e| matches!(e, AdapterEvent::Completed { action, outcome, .. } if action == "FlyByX" && outcome == "ok")
    ));
    let positions = adapter
        .iter()
        .filter(|a| matches!(a.event, AdapterEvent::Position { .. }))
        .count();
    // About one a second while armed.
    let armed_for = now(&d).time;
    assert!(positions as f64 >= armed_for - 1.0 && positions as f64 <= armed_for + 2.0);
    // Every record is one JSON line with a time stamp.
    for r in &records {
        let v: serde_json::Value = serde_json::from_str(&r.to_json_line()).unwrap();
        assert!(v["time"].is_number());
    }
    assert!(records.windows(2).all(|w| w[0].time() <= w[1].time()));
}

fn patrol() -> Script {
    Script {
        start_after: 0.0,
        legs: vec![
            Leg::At {
                t: 10.0,
                x: -15.0,
                y: -10.0,
                z: 1.0,
            },
            Leg::Hold { seconds: 3.0 },
            Leg::At {
                t: 25.0,
                x: 15.0,
                y: 8.0,
                z: 1.0,
            },
            Leg::GoTo {
                x: 40.0,
                y: 8.0,
                z: 1.0,
                speed: 3.0,
            },
        ],
    }
}

#[tokio::test(start_paused = true)]
async fn a_scripted_pilot_flies_its_waypoints_in_order_at_their_times() {
    let f = fleet(1.0);
    let sink = MemorySink::new();
    let mut spec = SimDroneSpec::new("D3", Vec3::new(0.0, 10.0, 0.0));
    spec.script = Some(patrol());
    let d = f.add_drone(spec, sink.clone()).unwrap();
    assert!(d.info().detail.contains("scripted pilot"));
    let clock = d.clock();
    // The mission arms and takes off; then the pilot takes over.
    airborne(&d, 1.0).await;
    let start = clock.now();
    clock.sleep_until(start + 10.0).await;
    let t = now(&d);
    assert!(
        t.position.distance(Vec3::new(-15.0, -10.0, 1.0)) <= 0.15,
        "at 10 s: {}",
        t.position
    );
    assert_eq!(t.mode, FlightMode::Piloted);
    clock.sleep_until(start + 12.0).await;
    assert!(
        now(&d).position.distance(Vec3::new(-15.0, -10.0, 1.0)) <= 0.15,
        "holding"
    );
    // The mission only watches: it may not steer the piloted drone.
    let err = run(&d, "FlyByX", &[1.0]).await.unwrap_err();
    assert_eq!(err.kind(), "refused");
    assert!(err.to_string().contains("flown by its pilot"), "{err}");
    clock.sleep_until(start + 25.0).await;
    assert!(
        now(&d).position.distance(Vec3::new(15.0, 8.0, 1.0)) <= 0.15,
        "at 25 s: {}",
        now(&d).position
    );
    // Past the 30 m line of experiment D on the last leg.
    let mut rx = d.telemetry();
    while rx.borrow_and_update().position.x < 30.0 {
        rx.changed().await.unwrap();
    }
    // Land takes control back from the pilot.
    run(&d, "Land", &[]).await.unwrap();
    let t = now(&d);
    assert!(t.landed && t.position.x > 30.0 && t.position.x < 40.0);
    let log: Vec<String> = sink
        .records()
        .iter()
        .filter_map(|r| match r {
            LogRecord::Adapter(AdapterRecord {
                event: AdapterEvent::State { detail },
                ..
            }) => Some(detail.clone()),
            _ => None,
        })
        .collect();
    let pos = |needle: &str| {
        log.iter()
            .position(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("no `{needle}` in {log:#?}"))
    };
    assert!(pos("the scripted pilot took over") < pos("leg 1 done"));
    assert!(pos("leg 1 done") < pos("leg 2 done"));
    assert!(pos("leg 2 done") < pos("leg 3 done"));
    assert!(pos("leg 3 done") < pos("hands control back for Land"));
}

#[tokio::test(start_paused = true)]
async fn the_fleet_refuses_a_second_drone_of_the_same_name_and_bad_settings() {
    let f = fleet(1.0);
    drone(&f, "D1", Vec3::ZERO);
    let err = f
        .add_drone(SimDroneSpec::new("D1", Vec3::ZERO), Arc::new(NullSink))
        .err()
        .unwrap();
    assert_eq!(err, SimError::Duplicate("D1".into()));
    assert!(f.drone("D1").is_some() && f.drone("D2").is_none());
    assert_eq!(
        SimFleet::start(SimConfig {
            speed: 0.0,
            ..SimConfig::default()
        })
        .err(),
        Some(SimError::BadSpeed(0.0))
    );
    let mut spec = SimDroneSpec::new("D9", Vec3::ZERO);
    spec.vehicle.climb_rate = -1.0;
    let err = f.add_drone(spec, Arc::new(NullSink)).err().unwrap();
    assert!(err.to_string().contains("climb_rate"), "{err}");
    let mut spec = SimDroneSpec::new("D9", Vec3::ZERO);
    spec.script = Some(Script {
        start_after: -1.0,
        legs: vec![],
    });
    assert!(matches!(
        f.add_drone(spec, Arc::new(NullSink)),
        Err(SimError::BadScript { .. })
    ));
}

#[test]
fn the_simulator_outside_a_runtime_is_an_error_not_a_panic() {
    assert_eq!(
        SimFleet::start(SimConfig::default()).err(),
        Some(SimError::NoRuntime)
    );
}

#[test]
fn a_fleet_drone_reads_from_toml() {
    let spec: SimDroneSpec = toml::from_str(
        r#"
        name = "D3"
        home = { x = 0.0, y = 10.0, z = 0.0 }
        [vehicle]
        max_horizontal_speed = 3.0
        [vehicle.wind]
        seed = 42
        gust = 0.3
        [script]
        start_after = 5.0
        legs = [
            { leg = "at", t = 10.0, x = -15.0, y = -10.0, z = 1.0 },
            { leg = "hold", seconds = 2.0 },
        ]
        "#,
    )
    .unwrap();
    assert_eq!(spec.vehicle.max_horizontal_speed, 3.0);
    assert_eq!(
        spec.vehicle.climb_rate,
        MultirotorConfig::default().climb_rate
    );
    assert_eq!(spec.vehicle.wind.seed, 42);
    assert_eq!(spec.script.unwrap().legs.len(), 2);
    let typo = toml::from_str::<SimDroneSpec>("name = \"D1\"\n[vehicle]\nmax_speed = 3.0\n");
    assert!(typo.is_err(), "unknown settings are errors, not ignored");
}

// The uniform layer over a real (simulated) adapter.

fn uniform(f: &SimFleet, sink: Arc<MemorySink>) -> (Uniform, SimDrone) {
    let d = drone(f, "D1", Vec3::ZERO);
    let profile = eamos_profile::builtin().get("Quadcopter").unwrap().clone();
    (Uniform::new(Arc::new(d.clone()), profile, sink), d)
}

fn uniform_records(sink: &MemorySink) -> Vec<crate::log::UniformRecord> {
    sink.records()
        .into_iter()
        .filter_map(|r| match r {
            LogRecord::Uniform(u) => Some(u),
            _ => None,
        })
        .collect()
}

#[tokio::test(start_paused = true)]
async fn the_uniform_layer_logs_each_call_with_its_outcome_and_duration() {
    let f = fleet(1.0);
    let sink = MemorySink::new();
    let (u, _d) = uniform(&f, sink.clone());
    u.run(&call("Arm", &[]), CancellationToken::new())
        .await
        .unwrap();
    u.run(&call("Takeoff", &[2.0]), CancellationToken::new())
        .await
        .unwrap();
    let recs = uniform_records(&sink);
    assert_eq!(recs.len(), 4);
    assert_eq!(
        (recs[2].action.as_str(), recs[2].phase, recs[2].call),
        ("Takeoff", CallPhase::Started, 2)
    );
    let done = &recs[3];
    assert_eq!((done.phase, done.call), (CallPhase::Finished, 2));
    assert_eq!(done.outcome.as_deref(), Some("ok"));
    assert_eq!(done.args, vec![2.0]);
    let took = done.duration.unwrap();
    // Two metres at up to 2 m/s, with acceleration and the final approach.
    assert!(took > 1.0 && took < 5.0, "{took}");
    assert!((done.time - recs[2].time - took).abs() < 1e-9);
}

#[tokio::test(start_paused = true)]
async fn the_uniform_layer_refuses_what_the_profile_does_not_offer() {
    let f = fleet(1.0);
    let sink = MemorySink::new();
    let (u, d) = uniform(&f, sink.clone());
    let err = u
        .run(&call("Fly", &[1.0]), CancellationToken::new())
        .await
        .unwrap_err();
    assert_eq!(
        err,
        ActionError::Unsupported {
            action: "Fly".into()
        }
    );
    let err = u
        .run(&call("FlyTo", &[1.0, 2.0]), CancellationToken::new())
        .await
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        "`FlyTo` was called with bad arguments: Quadcopter takes 3 arguments (x, y, z), got 2"
    );
    let err = u
        .run(&call("Takeoff", &[f64::INFINITY]), CancellationToken::new())
        .await
        .unwrap_err();
    assert_eq!(err.kind(), "bad_arguments");
    let recs = uniform_records(&sink);
    let outcomes: Vec<_> = recs.iter().filter_map(|r| r.outcome.clone()).collect();
    assert_eq!(outcomes, ["unsupported", "bad_arguments", "bad_arguments"]);
    assert!(recs[1].error.as_deref().unwrap().contains("not an action"));
    // None of it reached the drone.
    assert!(!now(&d).armed && now(&d).position == Vec3::ZERO);
    assert_eq!(u.info().kind, "sim");
}

#[tokio::test(start_paused = true)]
async fn the_uniform_layer_reads_properties_the_profile_offers() {
    let f = fleet(1.0);
    let (u, _d) = uniform(&f, MemorySink::new());
    assert_eq!(
        u.property("Battery", &[]).unwrap(),
        crate::api::Value::Number(100.0)
    );
    assert!(matches!(
        u.property("Temperature", &[]),
        Err(crate::api::PropertyError::Unknown { .. })
    ));
}

#[tokio::test(start_paused = true)]
async fn a_motion_resumed_towards_its_recorded_target_ends_there_not_one_move_further() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let fly = call("FlyByX", &[4.0]);
    let target = d.motion_target(&fly).unwrap();
    assert!(target.distance(Vec3::new(4.0, 0.0, 2.0)) < 1e-9);
    // The agent crashes half-way: the motion stops with its caller.
    let cancel = CancellationToken::new();
    let flight = tokio::spawn({
        let (d, fly, cancel) = (d.clone(), fly.clone(), cancel.clone());
        async move { d.run(&fly, cancel).await }
    });
    while now(&d).position.x < 1.5 {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    cancel.cancel();
    assert!(flight.await.unwrap().is_err());
    d.fly_to_target(&fly, target, CancellationToken::new())
        .await
        .unwrap();
    let tol = d.model().config().arrival_tolerance;
    assert!(now(&d).position.distance(target) <= tol);
}

#[tokio::test(start_paused = true)]
async fn a_resumed_motion_on_the_ground_is_refused_like_any_motion() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    let e = d
        .fly_to_target(
            &call("FlyByX", &[1.0]),
            Vec3::new(1.0, 0.0, 2.0),
            CancellationToken::new(),
        )
        .await
        .unwrap_err();
    assert_eq!(e.kind(), "refused");
}

#[tokio::test(start_paused = true)]
async fn a_restored_airframe_holds_in_the_air_where_it_was_recorded() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 3.0).await;
    run(&d, "FlyByY", &[2.0]).await.unwrap();
    let recorded = d.airframe();
    assert!(recorded.armed);

    // The agent restarts: a new simulation, its clock at the recorded time.
    let f2 = SimFleet::start_at(SimConfig::default(), recorded.time).unwrap();
    assert!(f2.clock().now() >= recorded.time - 1e-9);
    let d2 = drone(&f2, "D1", Vec3::ZERO);
    d2.restore(&recorded).unwrap();
    let t = now(&d2);
    assert!(t.armed && !t.landed);
    assert!(t.position.distance(recorded.position) < 1e-9);
    tokio::time::sleep(Duration::from_secs(2)).await;
    let tol = d2.model().config().arrival_tolerance;
    assert!(
        now(&d2).position.distance(recorded.position) <= tol,
        "it holds"
    );
    // Take-off is refused in the air, as on the first run.
    assert_eq!(
        run(&d2, "Takeoff", &[3.0]).await.unwrap_err().kind(),
        "refused"
    );
}

#[tokio::test(start_paused = true)]
async fn an_airframe_with_a_position_that_is_not_finite_is_refused() {
    let f = fleet(1.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    let bad = Airframe {
        time: 0.0,
        position: Vec3::new(f64::NAN, 0.0, 1.0),
        armed: true,
        battery: 90.0,
    };
    assert!(d.restore(&bad).is_err());
    assert!(now(&d).landed);
}

/// Counts the publications of the fleet's simulated time from now on.
fn count_publications(fleet: &SimFleet) -> Arc<std::sync::atomic::AtomicUsize> {
    let n = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut time = fleet.world.time_tx.subscribe();
    let counter = n.clone();
    tokio::spawn(async move {
        while time.changed().await.is_ok() {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    });
    n
}

#[tokio::test(start_paused = true)]
async fn a_fleet_where_nothing_moves_steps_in_batches_and_wakes_its_sleepers_on_time() {
    let f = fleet(20.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    airborne(&d, 2.0).await;
    let steps = f.steps();
    let published = count_publications(&f);
    // Ten simulated seconds of holding: 500 steps, half a second of
    // tokio time, in a handful of wake-ups rather than one per step.
    let clock = d.clock();
    let until = clock.now() + 10.01;
    clock.sleep_until(until).await;
    let n = published.load(std::sync::atomic::Ordering::Relaxed);
    assert!(n <= 20, "the time was published {n} times");
    assert_eq!(f.steps() - steps, 501);
    // The sleeper woke at the step that reached its time, not later.
    assert!(clock.now() >= until && clock.now() < until + f.config().step);
    // Every step was taken: it still holds where it took off.
    let tol = d.model().config().arrival_tolerance;
    assert!(now(&d).position.distance(Vec3::new(0.0, 0.0, 2.0)) <= tol);
}

#[tokio::test(start_paused = true)]
async fn a_command_after_a_quiet_spell_starts_at_the_present_step() {
    let f = fleet(20.0);
    let d = drone(&f, "D1", Vec3::ZERO);
    // Nobody waits on the clock: the world may lag the wall clock.
    tokio::time::sleep(Duration::from_millis(1_003)).await;
    run(&d, "Arm", &[]).await.unwrap();
    let t = now(&d);
    assert!(t.armed);
    // 1.003 s at twenty times: 20.06 s, the step of the present.
    assert!((t.time - 20.06).abs() < 1e-9, "armed at {}", t.time);
}
