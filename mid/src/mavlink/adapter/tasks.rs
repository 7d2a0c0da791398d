//! The adapter's background tasks: the receiver, the ground station's
//! heartbeat, the link monitor, the setpoint stream and the telemetry
//! requests.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

use tokio::time::{sleep, Instant};

use crate::log::AdapterEvent;
use crate::mavlink::dialect::{
    MavAutopilot, MavCmd, MavMessage, MavModeFlag, MavState, MavType, HEARTBEAT_DATA,
};
use crate::mavlink::modes::Autopilot;
use crate::mavlink::state::Change;

use super::shared::Shared;

/// The messages the adapter asks for, and how often (Hz). Autopilots send
/// little more than HEARTBEAT until asked.
pub const STREAMS: &[(u32, &str, f64)] = &[
    (1, "SYS_STATUS", 2.0),
    (24, "GPS_RAW_INT", 2.0),
    (32, "LOCAL_POSITION_NED", 10.0),
    (33, "GLOBAL_POSITION_INT", 4.0),
    (193, "EKF_STATUS_REPORT", 2.0),
    (245, "EXTENDED_SYS_STATE", 2.0),
    // Where the autopilot's own home is: a real vehicle's home in the
    // fleet frame.
    (242, "HOME_POSITION", 0.5),
];

/// Folds every message from the vehicle into the watched state, logs what a
/// pilot would want to read, and publishes telemetry.
pub(super) async fn receive_task(s: Arc<Shared>) {
    let mut incoming = s.link.subscribe();
    let mut last_position_log: Option<Instant> = None;
    loop {
        let received = tokio::select! {
            _ = s.stop.cancelled() => return,
            r = incoming.recv() => match r {
                Ok(r) => r,
                Err(tokio::sync::broadcast::error::RecvError::Lagged(n)) => {
                    tracing::warn!(drone = %s.drone, "fell {n} messages behind the vehicle");
                    continue;
                }
                Err(tokio::sync::broadcast::error::RecvError::Closed) => return,
            },
        };
        let now = Instant::now();
        let mut changes = Vec::new();
        let mut came_back = false;
        let mut from_vehicle = false;
        s.watched.send_if_modified(|w| {
            changes = w.vehicle.observe(&received.header, &received.message, now);
            from_vehicle = w.vehicle.last_heard == Some(now);
            if from_vehicle {
                w.last_seen
                    .insert(mavlink::Message::message_id(&received.message), now);
                if w.link_lost {
                    w.link_lost = false;
                    came_back = true;
                }
            }
            from_vehicle
        });
        if !from_vehicle {
            continue;
        }
        if came_back {
            s.note("the link to the vehicle is back");
        }
        if let Some(boot) = boot_seconds(&received.message) {
            s.autopilot_time(boot);
        }
        let autopilot = s.autopilot();
        for change in changes {
            match change {
                Change::Found(target, ap) => {
                    s.note(format!("found {ap} vehicle ({target}) on {}", s.address))
                }
                Change::Mode(old, new) => {
                    let ap = autopilot.unwrap_or(Autopilot::Other(0));
                    s.note(match old {
                        Some(old) => format!("mode {} -> {}", ap.mode_name(old), ap.mode_name(new)),
                        None => format!("mode {}", ap.mode_name(new)),
                    });
                }
                Change::Armed(true) => s.note("armed"),
                Change::Armed(false) => s.note("disarmed"),
                Change::StatusText(t) => s.note(format!("autopilot: {t}")),
            }
        }
        if matches!(
            received.message,
            MavMessage::HEARTBEAT(_)
                | MavMessage::LOCAL_POSITION_NED(_)
                | MavMessage::SYS_STATUS(_)
                | MavMessage::EXTENDED_SYS_STATE(_)
        ) {
            s.publish_telemetry();
            let t = *s.telemetry.borrow();
            if t.armed && last_position_log.is_none_or(|at| now - at >= Duration::from_secs(1)) {
                last_position_log = Some(now);
                s.log(AdapterEvent::Position {
                    position: t.position,
                    velocity: t.velocity,
                    battery: t.battery,
                    armed: t.armed,
                    mode: t.mode,
                });
            }
        }
    }
}

/// The autopilot's own time in a message that carries it, seconds since
/// its boot.
fn boot_seconds(message: &MavMessage) -> Option<f64> {
    let ms = match message {
        MavMessage::LOCAL_POSITION_NED(m) => m.time_boot_ms,
        MavMessage::GLOBAL_POSITION_INT(m) => m.time_boot_ms,
        MavMessage::SYSTEM_TIME(m) => m.time_boot_ms,
        MavMessage::ATTITUDE(m) => m.time_boot_ms,
        _ => return None,
    };
    Some(f64::from(ms) / 1000.0)
}

/// A ground station says it is there once a second; ArduPilot's GCS
/// failsafe counts on it, and a `udpout` link needs it to be heard first.
pub(super) async fn heartbeat_task(s: Arc<Shared>) {
    let message = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    });
    loop {
        if let Err(e) = s.link.send(&message).await {
            tracing::debug!(drone = %s.drone, "heartbeat not sent: {e}");
        }
        tokio::select! {
            _ = s.stop.cancelled() => return,
            _ = sleep(Duration::from_secs(1)) => {}
        }
    }
}

/// Declares the link lost after `link_timeout` of silence from a vehicle
/// that had been heard.
pub(super) async fn monitor_task(s: Arc<Shared>) {
    let tick =
        (s.options.link_timeout / 10).clamp(Duration::from_millis(20), Duration::from_millis(250));
    loop {
        tokio::select! {
            _ = s.stop.cancelled() => return,
            _ = sleep(tick) => {}
        }
        let now = Instant::now();
        let mut lost = false;
        s.watched.send_if_modified(|w| {
            let silent = w
                .vehicle
                .last_heard
                .is_some_and(|at| now - at >= s.options.link_timeout);
            if silent && !w.link_lost {
                w.link_lost = true;
                lost = true;
            }
            lost
        });
        if lost {
            s.note(format!(
                "lost the link to the vehicle: nothing heard for {:.1} s; the autopilot's failsafe decides what it does now",
                s.options.link_timeout.as_secs_f64()
            ));
            s.publish_telemetry();
        }
    }
}

/// How often OFFBOARD setpoints are streamed to PX4 (it needs more than
/// 2 Hz), and how long the stream runs before the switch to OFFBOARD.
pub(super) const OFFBOARD_PERIOD: Duration = Duration::from_millis(100);
pub(super) const OFFBOARD_LEAD: Duration = Duration::from_millis(600);

/// Streams the setpoint to an autopilot whose guided mode lives on a stream
/// (PX4's OFFBOARD) while there is one.
pub(super) async fn setpoint_task(s: Arc<Shared>) {
    loop {
        tokio::select! {
            _ = s.stop.cancelled() => return,
            _ = sleep(OFFBOARD_PERIOD) => {}
        }
        let streams = s.strategy().is_some_and(|st| st.streams_setpoints());
        if !streams || s.watched.borrow().link_lost {
            continue;
        }
        let setpoint = s
            .offboard
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .map(|(ned, _)| ned);
        if let Some(ned) = setpoint {
            s.transmit_ned(ned).await;
        }
    }
}

/// Asks for the messages the adapter needs, and asks again for any that
/// stop coming (an autopilot that rebooted forgets what it was asked).
pub(super) async fn stream_task(s: Arc<Shared>) {
    let mut asked: HashMap<u32, Instant> = HashMap::new();
    loop {
        tokio::select! {
            _ = s.stop.cancelled() => return,
            _ = sleep(Duration::from_millis(500)) => {}
        }
        let (target, link_lost, last_seen) = {
            let w = s.watched.borrow();
            (w.vehicle.target, w.link_lost, w.last_seen.clone())
        };
        if target.is_none() || link_lost {
            continue;
        }
        let now = Instant::now();
        let strategy = s.strategy();
        for &(id, name, hz) in STREAMS {
            if strategy.is_some_and(|st| !st.sends(id)) {
                continue;
            }
            let period = Duration::from_secs_f64(1.0 / hz);
            let stale_after = (period * 3).max(Duration::from_secs(3));
            let flowing = last_seen.get(&id).is_some_and(|at| now - *at < stale_after);
            let recently_asked = asked
                .get(&id)
                .is_some_and(|at| now - *at < Duration::from_secs(5));
            if flowing || recently_asked {
                continue;
            }
            asked.insert(id, now);
            let interval_us = period.as_micros() as f32;
            match s
                .send_command(
                    "streams",
                    MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                    [id as f32, interval_us, 0.0, 0.0, 0.0, 0.0, 0.0],
                )
                .await
            {
                Ok(Ok(())) => tracing::debug!(drone = %s.drone, "asked for {name} at {hz} Hz"),
                Ok(Err(e)) => tracing::info!(drone = %s.drone, "asking for {name} failed: {e}"),
                Err(_) => break,
            }
        }
    }
}
