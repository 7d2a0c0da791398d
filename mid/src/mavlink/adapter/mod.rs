//! [`MavlinkAdapter`]: one drone flown through its autopilot over MAVLink,
//! the way a careful pilot flies it from a ground station.
//!
//! # How an action becomes MAVLink
//! | action | what the adapter does |
//! | --- | --- |
//! | `TurnOn` | waits for the autopilot's heartbeat |
//! | `PreFlightCheck` | waits until the vehicle is ready (see [`super::readiness`]) |
//! | `Calibrate` | `MAV_CMD_PREFLIGHT_CALIBRATION` (ground pressure), on the ground only |
//! | `Arm` | waits until ready, sets GUIDED (PX4: OFFBOARD) and confirms from the heartbeat that it held, `MAV_CMD_COMPONENT_ARM_DISARM`, waits for the armed flag |
//! | `Takeoff(h)` | `MAV_CMD_NAV_TAKEOFF` (PX4: a setpoint `h` metres above the ground in OFFBOARD), then waits until `h` metres above where it stood |
//! | `FlyTo`, `FlyByX/Y/Z`, `ReturnHome` | `SET_POSITION_TARGET_LOCAL_NED` (resent every second), arrival judged from `LOCAL_POSITION_NED` within the tolerance |
//! | `Hover(s)` | holds the last target for `s` seconds of mission time |
//! | `Land` | mode LAND, waits until on the ground |
//! | `Disarm` | `MAV_CMD_COMPONENT_ARM_DISARM`, on the ground only |
//! | `TurnOnCamera`, `AdjustCamera`, `TakePhoto` | `MAV_CMD_DO_DIGICAM_CONTROL` / `_CONFIGURE` |
//!
//! # Frames
//! The mission's frame of a drone has its origin where the drone stood
//! when it first became ready (X north, Y east, Z up); MAVLink's local
//! frame has its origin at the EKF origin (north, east, down). The adapter
//! keeps the EKF-frame position of that ground point (the anchor) and
//! converts every target and every reported position through it, so GPS
//! drift between EKF start and arming does not shift the mission.
//!
//! # PX4
//! PX4 flies position targets in OFFBOARD, which it enters only while
//! setpoints are streaming (more than 2 Hz) and leaves (a failsafe) as soon
//! as they stop. So for a PX4 vehicle the adapter streams its current
//! setpoint at 10 Hz from before the switch to OFFBOARD until the drone has
//! landed or is disarmed: the ground point under the drone before arming,
//! then every target. PX4 has no take-off in OFFBOARD other than a setpoint
//! above the ground, which is what `Takeoff` sends. PX4 does not send
//! EKF_STATUS_REPORT; readiness comes from the fix, the pre-arm bit of
//! SYS_STATUS and the local position.
//!
//! What differs between ArduPilot and PX4 (how a take-off starts, whether
//! the guided mode lives on a setpoint stream, which telemetry exists) is
//! each autopilot's [`Strategy`](super::strategy::Strategy): the adapter
//! asks its strategy and never tests which autopilot it flies.
//!
//! # Where things are
//! `options` (options and fleet-file settings), `shared` (the state every
//! part shares, and waiting on the vehicle), `commands`, `ready` (heartbeat,
//! readiness, frame anchor, modes), `actions` (the mission's actions, arm,
//! disarm), `takeoff`, `motion`, `land`, and `tasks` (what runs in the
//! background: receiver, heartbeat, link monitor, setpoint stream,
//! telemetry requests).
//!
//! # Safety rules it keeps
//! - Never fight the pilot: if the autopilot leaves GUIDED during a motion
//!   (an RC mode switch, a failsafe), the action fails and the mission
//!   learns that it no longer controls the drone; the adapter does not set
//!   GUIDED again.
//! - Never disarm in the air: `Disarm` while flying is refused before any
//!   command is sent.
//! - A copter armed and idle on the ground disarms itself after a few
//!   seconds (ArduPilot: `DISARM_DELAY`, 10 s). If the mission armed it and
//!   it disarmed itself before `Takeoff`, the adapter arms it again and
//!   says so in the log (`rearm_for_takeoff`); a takeoff the mission never
//!   armed for is refused.
//! - Silence for longer than `link_timeout` is a lost link: the running
//!   action fails with [`ActionError::LinkLost`] and the autopilot's own
//!   failsafe takes over. The adapter keeps listening; the mission's
//!   failsafe flies once the link returns, unless the autopilot is already
//!   bringing the drone down.
//! - The end of a run does not take a drone back from a pilot: its
//!   failsafe waits until the pilot gives the drone back (`control.rs`).

mod actions;
mod commands;
mod control;
mod land;
mod link_loss;
mod motion;
mod options;
mod ready;
mod shared;
mod takeoff;
mod tasks;
mod time;

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_trait::async_trait;
use mavlink::MavHeader;
use tokio::sync::watch;
use tokio::time::Instant;

use crate::api::{
    ActionCall, ActionError, Adapter, AdapterInfo, CancellationToken, Control, MultirotorAction,
    Telemetry, Vec3,
};
use crate::clock::MissionClock;
use crate::log::AdapterEvent;

use super::address::ConnectAddress;
use super::link::Link;
use super::readiness::{NotReady, Readiness};
use super::state::VehicleState;

pub use options::{LostLinkCheck, MavlinkError, MavlinkOptions, MavlinkSettings};
pub use tasks::STREAMS;

use shared::{Flight, FrameState, Shared, Watched};
use tasks::{heartbeat_task, monitor_task, receive_task, setpoint_task, stream_task};

/// A drone flown over MAVLink.
pub struct MavlinkAdapter {
    shared: Arc<Shared>,
}

impl MavlinkAdapter {
    /// Opens the connection (`udpin:0.0.0.0:14550`, `tcpout:127.0.0.1:5760`,
    /// `/dev/ttyACM0:57600`, ...) and starts listening. It does not wait for
    /// the vehicle: the first action that needs it does (see
    /// [`MavlinkAdapter::wait_ready`] to wait up front).
    pub async fn connect(
        drone: impl Into<String>,
        connect: &str,
        options: MavlinkOptions,
    ) -> Result<Self, MavlinkError> {
        let drone = drone.into();
        let address = ConnectAddress::parse(connect)?;
        let own = MavHeader {
            system_id: u32::from(options.gcs_system),
            component_id: options.gcs_component,
            sequence: 0,
        };
        let link = Link::open(&address, own)
            .await
            .map_err(|source| MavlinkError::Open {
                drone: drone.clone(),
                address: address.to_string(),
                source,
            })?;
        let clock = options.clock.clone().unwrap_or_else(MissionClock::wall);
        let home = options.home;
        let (watched, _) = watch::channel(Watched {
            vehicle: VehicleState::with_readiness(
                options.target_system,
                if options.require_gps {
                    Readiness::new()
                } else {
                    Readiness::without_gps()
                },
            ),
            link_lost: false,
            last_seen: HashMap::new(),
        });
        let (telemetry, _) = watch::channel(Telemetry {
            time: clock.now(),
            ..Telemetry::at_home(home)
        });
        let shared = Arc::new(Shared {
            drone,
            address,
            options,
            link,
            clock,
            started: Instant::now(),
            watched,
            telemetry,
            frame: Mutex::new(FrameState { anchor: None, home }),
            flight: Mutex::new(Flight::default()),
            offboard: Mutex::new(None),
            pace: Mutex::new(None),
            commands: tokio::sync::Mutex::new(()),
            stop: CancellationToken::new(),
        });
        tokio::spawn(receive_task(shared.clone()));
        tokio::spawn(heartbeat_task(shared.clone()));
        tokio::spawn(monitor_task(shared.clone()));
        tokio::spawn(stream_task(shared.clone()));
        tokio::spawn(setpoint_task(shared.clone()));
        Ok(MavlinkAdapter { shared })
    }

    /// The local address of a listening connection (`udpin`), so a peer
    /// can be told where to send.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.shared.link.local_addr()
    }

    /// What the vehicle has reported about being ready, right now.
    pub fn readiness(&self) -> Readiness {
        self.shared.watched.borrow().vehicle.readiness.clone()
    }

    /// Waits until the vehicle is ready to arm, with progress in the log,
    /// or `timeout` passes.
    pub async fn wait_ready(&self, timeout: Duration) -> Result<(), NotReady> {
        let s = &self.shared;
        let started = Instant::now();
        match s
            .ready_wait(
                "PreFlightCheck",
                started + timeout,
                &CancellationToken::new(),
            )
            .await
        {
            Ok(()) => Ok(()),
            Err(_) => Err(NotReady::of(
                &s.watched.borrow().vehicle.readiness,
                started.elapsed(),
            )),
        }
    }
}

impl Drop for MavlinkAdapter {
    fn drop(&mut self) {
        self.shared.stop.cancel();
    }
}

#[async_trait]
impl Adapter for MavlinkAdapter {
    fn info(&self) -> AdapterInfo {
        AdapterInfo {
            kind: "mavlink".to_string(),
            drone: self.shared.drone.clone(),
            detail: self.shared.address.to_string(),
        }
    }

    fn telemetry(&self) -> watch::Receiver<Telemetry> {
        self.shared.telemetry.subscribe()
    }

    fn clock(&self) -> MissionClock {
        self.shared.clock.clone()
    }

    async fn run(&self, call: &ActionCall, cancel: CancellationToken) -> Result<(), ActionError> {
        let action = MultirotorAction::parse(call)?;
        let s = &self.shared;
        let result = match s.find_frame(action.name(), &cancel).await {
            Ok(()) => s.perform(action, &cancel).await,
            Err(e) => Err(e),
        };
        s.log(AdapterEvent::Completed {
            action: call.name.clone(),
            outcome: match &result {
                Ok(()) => "ok".to_string(),
                Err(e) => e.kind().to_string(),
            },
            detail: match &result {
                Ok(()) => String::new(),
                Err(e) => e.to_string(),
            },
        });
        result
    }

    /// A pilot's drone stays the pilot's, and a lost link is waited out
    /// (see `control.rs`).
    async fn regain_control(&self) -> Result<Control, ActionError> {
        self.shared.regain_control().await
    }

    /// Relative moves start from the last position target sent, else from
    /// where the vehicle is (as `FlyByX` computes its target).
    fn motion_reference(&self) -> Result<Vec3, ActionError> {
        self.shared.motion_base("a relative move")
    }

    /// A resumed motion is a position target like `FlyTo`'s: the autopilot
    /// flies it in GUIDED and the call ends within the arrival tolerance.
    async fn fly_to_target(
        &self,
        call: &ActionCall,
        target: Vec3,
        cancel: CancellationToken,
    ) -> Result<(), ActionError> {
        let action = MultirotorAction::parse(call)?;
        if !target.is_finite() {
            return Err(ActionError::bad_arguments(
                &call.name,
                format!("the target {target} is not finite"),
            ));
        }
        let s = &self.shared;
        let result = match s.find_frame(action.name(), &cancel).await {
            Ok(()) => s.fly_to(action.name(), target, &cancel).await,
            Err(e) => Err(e),
        };
        s.log(AdapterEvent::Completed {
            action: call.name.clone(),
            outcome: match &result {
                Ok(()) => "ok".to_string(),
                Err(e) => e.kind().to_string(),
            },
            detail: format!("resumed towards {target}"),
        });
        result
    }
}
