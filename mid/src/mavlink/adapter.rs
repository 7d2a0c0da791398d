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
//!   failsafe takes over.

use std::collections::HashMap;
use std::fmt;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_trait::async_trait;
use mavlink::MavHeader;
use tokio::sync::watch;
use tokio::time::{sleep, sleep_until, Instant};

use eamos_geo::{LocalFrame, Ned, Wgs84};

use crate::api::{
    ActionCall, ActionError, Adapter, AdapterInfo, Axis, CancellationToken, FlightMode,
    MultirotorAction, Telemetry, Vec3,
};
use crate::clock::MissionClock;
use crate::log::{AdapterEvent, AdapterRecord, LogRecord, NullSink, SharedSink};

use super::address::{AddressError, ConnectAddress};
use super::command::{command_long, command_name, CommandError, CommandPolicy};
use super::dialect::{
    MavAutopilot, MavCmd, MavFrame, MavMessage, MavModeFlag, MavState, MavType,
    PositionTargetTypemask, HEARTBEAT_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use super::link::Link;
use super::modes::{Autopilot, ModeRole};
use super::readiness::{NotReady, Readiness};
use super::state::{Change, VehicleState};

/// How the adapter flies; the defaults suit ArduPilot SITL and a copter
/// outdoors.
#[derive(Clone)]
pub struct MavlinkOptions {
    /// The drone's home (the mission frame's origin) in the fleet frame.
    pub home: Vec3,
    /// If set, the home in the fleet frame is computed instead from where
    /// the vehicle's GPS puts it when it becomes ready, relative to this
    /// point (X north, Y east, Z up), so real drones in one fleet agree on
    /// distances without measuring their start positions.
    pub fleet_origin: Option<Wgs84>,
    /// Fly only the autopilot with this system id (several vehicles behind
    /// one router); `None` takes the first autopilot heard.
    pub target_system: Option<u8>,
    /// The identity this ground station sends with. ArduPilot's GCS
    /// failsafe listens for system 255 (`MAV_GCS_SYSID`) by default.
    pub gcs_system: u8,
    pub gcs_component: u8,
    /// How long arming waits for the vehicle to become ready.
    pub ready_timeout: Duration,
    /// Whether readiness asks for a 3D GPS fix. Indoors (motion capture,
    /// optical flow) there is none; the EKF's position and the pre-arm
    /// checks then decide, and the EKF origin must have been set.
    pub require_gps: bool,
    /// Silence from the vehicle for this long is a lost link.
    pub link_timeout: Duration,
    /// Acknowledgement timeouts and retries of every command.
    pub commands: CommandPolicy,
    /// A motion has arrived when within this distance of its target (m).
    pub arrival_tolerance: f64,
    /// The slowest the vehicle is expected to move (m/s): a motion of `d`
    /// metres times out after `motion_margin + d / min_speed`.
    pub min_speed: f64,
    pub motion_margin: Duration,
    /// Arm again for `Takeoff` when the autopilot disarmed itself after the
    /// mission armed it (see the module documentation).
    pub rearm_for_takeoff: bool,
    /// Mission time; wall time from connection unless given (a fleet shares
    /// one origin).
    pub clock: Option<MissionClock>,
    /// The adapter log.
    pub log: SharedSink,
}

impl Default for MavlinkOptions {
    fn default() -> Self {
        Self {
            home: Vec3::ZERO,
            fleet_origin: None,
            target_system: None,
            gcs_system: 255,
            gcs_component: 190,
            ready_timeout: Duration::from_secs(120),
            require_gps: true,
            link_timeout: Duration::from_secs(5),
            commands: CommandPolicy::default(),
            arrival_tolerance: 0.3,
            min_speed: 0.3,
            motion_margin: Duration::from_secs(30),
            rearm_for_takeoff: true,
            clock: None,
            log: Arc::new(NullSink),
        }
    }
}

impl fmt::Debug for MavlinkOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MavlinkOptions")
            .field("home", &self.home)
            .field("fleet_origin", &self.fleet_origin)
            .field("target_system", &self.target_system)
            .field("ready_timeout", &self.ready_timeout)
            .field("link_timeout", &self.link_timeout)
            .field("commands", &self.commands)
            .field("arrival_tolerance", &self.arrival_tolerance)
            .finish_non_exhaustive()
    }
}

/// The settings a fleet file may give one MAVLink drone, all optional:
///
/// ```toml
/// [drones.Drone1.mavlink]
/// target_system = 1          # fly only this system id
/// ready_timeout = 180        # seconds to wait for readiness when arming
/// require_gps = true         # false indoors (motion capture, optical flow)
/// link_timeout = 5           # seconds of silence that make a lost link
/// arrival_tolerance = 0.3    # metres
/// min_speed = 0.3            # m/s, for motion timeouts
/// fleet_origin = [46.6139, 14.2650, 446.0]   # lat, lon, alt: home from GPS
/// rearm_for_takeoff = true
/// ack_timeout = 1.5          # seconds to wait for a COMMAND_ACK before resending
/// command_attempts = 3       # sends of one command before giving up
/// motion_margin = 30         # seconds added to every motion's timeout
/// ```
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MavlinkSettings {
    pub target_system: Option<u8>,
    pub ready_timeout: Option<f64>,
    pub require_gps: Option<bool>,
    pub link_timeout: Option<f64>,
    pub arrival_tolerance: Option<f64>,
    pub min_speed: Option<f64>,
    pub fleet_origin: Option<[f64; 3]>,
    pub rearm_for_takeoff: Option<bool>,
    pub ack_timeout: Option<f64>,
    pub command_attempts: Option<u32>,
    pub motion_margin: Option<f64>,
}

impl MavlinkSettings {
    /// Checks the numbers; the message names the setting.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("ready_timeout", self.ready_timeout),
            ("link_timeout", self.link_timeout),
            ("arrival_tolerance", self.arrival_tolerance),
            ("min_speed", self.min_speed),
            ("ack_timeout", self.ack_timeout),
            ("motion_margin", self.motion_margin),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v < 1.0e6) {
                    return Err(format!("`{name}` must be a positive number, not {v}"));
                }
            }
        }
        if let Some(n) = self.command_attempts {
            if !(1..=20).contains(&n) {
                return Err(format!(
                    "`command_attempts` must be between 1 and 20, not {n}"
                ));
            }
        }
        if self.target_system == Some(0) {
            return Err("`target_system` 0 is the broadcast address, not a vehicle".to_string());
        }
        if let Some([lat, lon, alt]) = self.fleet_origin {
            Wgs84::parse(&format!("{lat},{lon},{alt}"))
                .map_err(|e| format!("`fleet_origin`: {e}"))?;
        }
        Ok(())
    }

    /// Overrides the options this fleet entry sets.
    pub fn apply(&self, options: &mut MavlinkOptions) {
        if let Some(s) = self.target_system {
            options.target_system = Some(s);
        }
        if let Some(t) = self.ready_timeout {
            options.ready_timeout = Duration::from_secs_f64(t);
        }
        if let Some(g) = self.require_gps {
            options.require_gps = g;
        }
        if let Some(t) = self.link_timeout {
            options.link_timeout = Duration::from_secs_f64(t);
        }
        if let Some(t) = self.arrival_tolerance {
            options.arrival_tolerance = t;
        }
        if let Some(v) = self.min_speed {
            options.min_speed = v;
        }
        if let Some([lat, lon, alt]) = self.fleet_origin {
            options.fleet_origin = Some(Wgs84::new(lat, lon, alt));
        }
        if let Some(r) = self.rearm_for_takeoff {
            options.rearm_for_takeoff = r;
        }
        if let Some(t) = self.ack_timeout {
            options.commands.ack_timeout = Duration::from_secs_f64(t);
        }
        if let Some(n) = self.command_attempts {
            options.commands.attempts = n;
        }
        if let Some(t) = self.motion_margin {
            options.motion_margin = Duration::from_secs_f64(t);
        }
    }

    /// Reads the settings and checks them in one go, so that a fleet
    /// file's parser reports a bad number at its line and column.
    pub fn deserialize_checked<'de, D>(deserializer: D) -> Result<Option<Self>, D::Error>
    where
        D: serde::Deserializer<'de>,
    {
        use serde::Deserialize;
        let settings = MavlinkSettings::deserialize(deserializer)?;
        settings.validate().map_err(serde::de::Error::custom)?;
        Ok(Some(settings))
    }
}

/// Why the adapter could not be created.
#[derive(Debug, thiserror::Error)]
pub enum MavlinkError {
    #[error(transparent)]
    Address(#[from] AddressError),
    /// Says nothing of the drone: whoever reports it names the drone.
    #[error("could not open {address}: {source}")]
    Open {
        drone: String,
        address: String,
        #[source]
        source: std::io::Error,
    },
}

/// The messages the adapter asks for, and how often (Hz). Autopilots send
/// little more than HEARTBEAT until asked.
pub const STREAMS: &[(u32, &str, f64)] = &[
    (1, "SYS_STATUS", 2.0),
    (24, "GPS_RAW_INT", 2.0),
    (32, "LOCAL_POSITION_NED", 10.0),
    (33, "GLOBAL_POSITION_INT", 4.0),
    (193, "EKF_STATUS_REPORT", 2.0),
    (245, "EXTENDED_SYS_STATE", 2.0),
];

/// A drone flown over MAVLink.
pub struct MavlinkAdapter {
    shared: Arc<Shared>,
}

/// What the waiting parts of an action see: the vehicle and the link.
#[derive(Clone)]
struct Watched {
    vehicle: VehicleState,
    link_lost: bool,
    /// When each message id was last received from the vehicle.
    last_seen: HashMap<u32, Instant>,
}

/// Where the mission frame sits in the EKF frame, and where home is.
#[derive(Debug, Clone, Copy, Default)]
struct FrameState {
    anchor: Option<Ned>,
    home: Vec3,
}

/// What the adapter remembers between actions.
#[derive(Debug, Clone, Copy, Default)]
struct Flight {
    /// The last position target, in the mission frame: relative motions
    /// start from it, so errors of arrival do not add up.
    last_target: Option<Vec3>,
    /// The mission armed the drone and has not disarmed it.
    mission_armed: bool,
    /// A take-off is climbing (telemetry shows `Takeoff`).
    taking_off: bool,
}

struct Shared {
    drone: String,
    address: ConnectAddress,
    options: MavlinkOptions,
    link: Link,
    clock: MissionClock,
    started: Instant,
    watched: watch::Sender<Watched>,
    telemetry: watch::Sender<Telemetry>,
    frame: Mutex<FrameState>,
    flight: Mutex<Flight>,
    /// PX4: the setpoint streamed to keep OFFBOARD alive (EKF frame), and
    /// since when the stream runs.
    offboard: Mutex<Option<(Ned, Instant)>>,
    commands: tokio::sync::Mutex<()>,
    stop: CancellationToken,
}

/// How a wait ended when it did not get what it waited for.
enum Halt {
    Cancelled,
    LinkLost,
    Timeout,
    Failed(ActionError),
}

/// What a wait's check says about the latest state.
enum Check<T> {
    Pending,
    Done(T),
    Fail(ActionError),
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
            Err(_) => Err(NotReady {
                waited: started.elapsed(),
                missing: s.watched.borrow().vehicle.readiness.missing(),
            }),
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
        let result = s.perform(action, &cancel).await;
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
        let result = s.fly_to(action.name(), target, &cancel).await;
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

impl Shared {
    fn log(&self, event: AdapterEvent) {
        self.options.log.record(LogRecord::Adapter(AdapterRecord {
            time: self.clock.now(),
            drone: self.drone.clone(),
            adapter: "mavlink".to_string(),
            event,
        }));
    }

    fn note(&self, detail: impl Into<String>) {
        let detail = detail.into();
        tracing::info!(drone = %self.drone, "{detail}");
        self.log(AdapterEvent::State { detail });
    }

    fn flight(&self) -> Flight {
        *self.flight.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn update_flight(&self, f: impl FnOnce(&mut Flight)) {
        f(&mut self.flight.lock().unwrap_or_else(|p| p.into_inner()));
        self.publish_telemetry();
    }

    fn frame(&self) -> FrameState {
        *self.frame.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn autopilot(&self) -> Option<Autopilot> {
        self.watched.borrow().vehicle.autopilot
    }

    fn position(w: &Watched, anchor: Ned) -> Option<Vec3> {
        w.vehicle.local.map(|l| (l.position - anchor).to_mission())
    }

    fn publish_telemetry(&self) {
        let w = self.watched.borrow();
        let frame = self.frame();
        let flight = self.flight();
        let anchor = frame.anchor.unwrap_or_default();
        let previous = *self.telemetry.borrow();
        let v = &w.vehicle;
        let armed = v.armed();
        let landed = v.landed(anchor.down);
        let mode = match (v.autopilot, v.custom_mode()) {
            _ if flight.taking_off => FlightMode::Takeoff,
            _ if !armed && landed => FlightMode::Standby,
            (Some(ap), Some(m)) => ap.flight_mode(m),
            _ => FlightMode::Standby,
        };
        let t = Telemetry {
            time: self.clock.now(),
            position: Self::position(&w, anchor).unwrap_or(previous.position),
            velocity: v
                .local
                .map(|l| l.velocity.to_mission())
                .unwrap_or(previous.velocity),
            battery: v.battery.unwrap_or(previous.battery),
            armed,
            landed,
            mode,
            home: frame.home,
        };
        drop(w);
        self.telemetry.send_replace(t);
    }

    /// The autopilot must be one the adapter knows how to fly.
    fn flyable(&self, action: &str) -> Result<Autopilot, ActionError> {
        match self.autopilot() {
            Some(Autopilot::ArduPilot) => Ok(Autopilot::ArduPilot),
            Some(Autopilot::Px4) => Ok(Autopilot::Px4),
            Some(Autopilot::Other(n)) => Err(ActionError::refused(
                action,
                format!("the autopilot (MAV_AUTOPILOT {n}) is neither ArduPilot nor PX4; its flight modes are unknown"),
            )),
            None => Err(ActionError::LinkLost {
                action: action.to_string(),
            }),
        }
    }

    /// Waits on the vehicle's state until `check` says done or fails, the
    /// deadline passes, the action is cancelled, or the link is lost.
    async fn wait<T>(
        &self,
        deadline: Instant,
        cancel: &CancellationToken,
        mut check: impl FnMut(&Watched) -> Check<T>,
    ) -> Result<T, Halt> {
        let mut rx = self.watched.subscribe();
        loop {
            {
                let w = rx.borrow_and_update();
                if w.link_lost {
                    return Err(Halt::LinkLost);
                }
                match check(&w) {
                    Check::Pending => {}
                    Check::Done(t) => return Ok(t),
                    Check::Fail(e) => return Err(Halt::Failed(e)),
                }
            }
            tokio::select! {
                biased;
                _ = cancel.cancelled() => return Err(Halt::Cancelled),
                _ = sleep_until(deadline) => return Err(Halt::Timeout),
                changed = rx.changed() => {
                    if changed.is_err() {
                        return Err(Halt::LinkLost);
                    }
                }
            }
        }
    }

    fn halt_error(
        &self,
        action: &str,
        halt: Halt,
        waiting_for: impl FnOnce() -> String,
    ) -> ActionError {
        match halt {
            Halt::Cancelled => ActionError::Cancelled {
                action: action.to_string(),
            },
            Halt::LinkLost => ActionError::LinkLost {
                action: action.to_string(),
            },
            Halt::Timeout => ActionError::Timeout {
                action: action.to_string(),
                what: waiting_for(),
            },
            Halt::Failed(e) => e,
        }
    }

    /// Sends one command and waits for its ACK; a lost link ends the wait
    /// at once. Commands to one vehicle go one at a time.
    async fn command_raw(
        &self,
        action: &str,
        command: MavCmd,
        params: [f32; 7],
    ) -> Result<Result<(), CommandError>, ActionError> {
        self.log(AdapterEvent::Command {
            action: action.to_string(),
            args: params.iter().map(|p| f64::from(*p)).collect(),
            detail: command_name(command),
        });
        self.send_command(action, command, params).await
    }

    /// [`Shared::command_raw`] without the log record, for the adapter's
    /// own housekeeping (stream requests).
    async fn send_command(
        &self,
        action: &str,
        command: MavCmd,
        params: [f32; 7],
    ) -> Result<Result<(), CommandError>, ActionError> {
        let link_lost = || ActionError::LinkLost {
            action: action.to_string(),
        };
        let target = self.watched.borrow().vehicle.target.ok_or_else(link_lost)?;
        let _one_at_a_time = self.commands.lock().await;
        if self.watched.borrow().link_lost {
            return Err(link_lost());
        }
        let mut rx = self.watched.subscribe();
        let lost = async {
            loop {
                if rx.borrow_and_update().link_lost {
                    return;
                }
                if rx.changed().await.is_err() {
                    return;
                }
            }
        };
        let outcome = tokio::select! {
            r = command_long(&self.link, target, command, params, &self.options.commands) => r,
            _ = lost => return Err(link_lost()),
        };
        if let Err(CommandError::NoAck { .. }) = &outcome {
            // No answer, and the vehicle silent for longer than an ACK
            // wait: a live autopilot streams telemetry several times a
            // second, so this is a lost link rather than a slow autopilot,
            // and the link monitor is about to say so. Wait for its
            // verdict; a vehicle heard again in the meantime makes it a
            // plain timeout.
            let last_heard = self.watched.borrow().vehicle.last_heard;
            let silent_since =
                last_heard.filter(|h| h.elapsed() >= self.options.commands.ack_timeout);
            if let Some(heard) = silent_since {
                let verdict = heard + self.options.link_timeout + Duration::from_secs(1);
                let silence = self
                    .wait(verdict, &CancellationToken::new(), |w| {
                        if w.vehicle.last_heard > Some(heard) {
                            Check::Done(())
                        } else {
                            Check::Pending
                        }
                    })
                    .await;
                if let Err(Halt::LinkLost) = silence {
                    return Err(link_lost());
                }
            }
        }
        Ok(outcome)
    }

    async fn command(
        &self,
        action: &str,
        command: MavCmd,
        params: [f32; 7],
    ) -> Result<(), ActionError> {
        match self.command_raw(action, command, params).await? {
            Ok(()) => Ok(()),
            Err(e) => Err(self.command_error(action, e)),
        }
    }

    fn command_error(&self, action: &str, e: CommandError) -> ActionError {
        match e {
            CommandError::Refused { .. } => ActionError::refused(action, e),
            CommandError::NoAck { .. } if self.watched.borrow().link_lost => {
                ActionError::LinkLost {
                    action: action.to_string(),
                }
            }
            CommandError::NoAck { .. } => ActionError::Timeout {
                action: action.to_string(),
                what: format!("the autopilot to acknowledge: {e}"),
            },
            CommandError::NotSent { .. } => ActionError::LinkLost {
                action: action.to_string(),
            },
        }
    }

    /// Waits for the autopilot's heartbeat.
    async fn heard(&self, action: &str, cancel: &CancellationToken) -> Result<(), ActionError> {
        let deadline = Instant::now() + self.options.ready_timeout;
        self.wait(deadline, cancel, |w| {
            if w.vehicle.heartbeat.is_some() {
                Check::Done(())
            } else {
                Check::Pending
            }
        })
        .await
        .map_err(|h| {
            self.halt_error(action, h, || {
                format!(
                    "a heartbeat from the autopilot on {} ({} s)",
                    self.address,
                    self.options.ready_timeout.as_secs()
                )
            })
        })
    }

    /// Waits until the vehicle is ready to arm, writing a progress line
    /// whenever what is missing changes (and every 10 s), and sets the
    /// mission frame's anchor the first time.
    async fn ready_wait(
        &self,
        action: &str,
        deadline: Instant,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let started = Instant::now();
        let mut last_line = String::new();
        loop {
            // Wake at least every 10 s to repeat the line while nothing
            // changes, so a long wait does not look like a hang.
            let slice_end = deadline.min(Instant::now() + Duration::from_secs(10));
            let outcome = self
                .wait(slice_end, cancel, |w| {
                    let r = &w.vehicle.readiness;
                    if r.is_ready() {
                        return Check::Done(None);
                    }
                    let line = r.progress_line();
                    if line != last_line {
                        return Check::Done(Some(line));
                    }
                    Check::Pending
                })
                .await;
            match outcome {
                Ok(None) => {
                    self.set_anchor();
                    return Ok(());
                }
                Ok(Some(line)) => {
                    last_line = line;
                    self.note(format!(
                        "not ready yet ({} s): {last_line}",
                        started.elapsed().as_secs()
                    ));
                }
                Err(Halt::Timeout) if Instant::now() < deadline => {
                    self.note(format!(
                        "not ready yet ({} s): {last_line}",
                        started.elapsed().as_secs()
                    ));
                }
                Err(halt) => {
                    let missing = self.watched.borrow().vehicle.readiness.missing();
                    return Err(self.halt_error(action, halt, || {
                        NotReady {
                            waited: started.elapsed(),
                            missing,
                        }
                        .to_string()
                    }));
                }
            }
        }
    }

    /// Fixes the mission frame on the ground point where the vehicle stands
    /// the first time it is ready, and its home in the fleet frame.
    fn set_anchor(&self) {
        let w = self.watched.borrow().clone();
        let mut frame = self.frame.lock().unwrap_or_else(|p| p.into_inner());
        if frame.anchor.is_some() {
            return;
        }
        let Some(local) = w.vehicle.local else { return };
        frame.anchor = Some(local.position);
        let mut detail = format!(
            "ready; the mission frame's origin is N {:.2} E {:.2} D {:.2} in the EKF frame",
            local.position.north, local.position.east, local.position.down
        );
        if let (Some(origin), Some(here)) = (self.options.fleet_origin, w.vehicle.global) {
            frame.home = LocalFrame::new(origin).to_local(here);
            detail.push_str(&format!(
                "; home in the fleet frame {} from GPS {:.7}, {:.7}",
                frame.home, here.lat, here.lon
            ));
        }
        drop(frame);
        self.note(detail);
        self.publish_telemetry();
    }

    /// Puts the autopilot in the mode for `role` and confirms from two
    /// further heartbeats that it stayed there: right after boot an RC mode
    /// switch may overwrite a mode set from the ground.
    async fn ensure_mode(
        &self,
        action: &str,
        role: ModeRole,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let autopilot = self.flyable(action)?;
        let wanted = autopilot
            .mode_for(role)
            .expect("a flyable autopilot has every mode the adapter uses");
        let name = autopilot.mode_name(wanted);
        if self.watched.borrow().vehicle.custom_mode() == Some(wanted) {
            return Ok(());
        }
        if autopilot == Autopilot::Px4 && role == ModeRole::Guided {
            self.start_offboard_stream(action).await?;
        }
        let mut overridden_by = None;
        for _ in 0..3 {
            self.command(
                action,
                MavCmd::MAV_CMD_DO_SET_MODE,
                autopilot.set_mode_params(wanted),
            )
            .await?;
            // The mode must show in a heartbeat and stay for two more. A
            // switch that overrides it may come before any heartbeat shows
            // it: two heartbeats in another mode after the ACK count as
            // overridden too.
            let acked_at = self.watched.borrow().vehicle.heartbeats;
            let mut seen_at = None;
            let deadline = Instant::now() + Duration::from_secs(8);
            let held = self
                .wait(deadline, cancel, |w| {
                    let v = &w.vehicle;
                    match v.custom_mode() {
                        Some(m) if m == wanted => {
                            let at = *seen_at.get_or_insert(v.heartbeats);
                            if v.heartbeats >= at + 2 {
                                return Check::Done(None);
                            }
                        }
                        Some(m) if seen_at.is_some() || v.heartbeats >= acked_at + 2 => {
                            return Check::Done(Some(m));
                        }
                        _ => {}
                    }
                    Check::Pending
                })
                .await
                .map_err(|h| {
                    self.halt_error(action, h, || format!("heartbeats confirming {name}"))
                })?;
            match held {
                None => {
                    self.note(format!("mode {name} set and confirmed"));
                    return Ok(());
                }
                Some(other) => {
                    let other = autopilot.mode_name(other);
                    self.note(format!(
                        "the autopilot left {name} for {other} right after it was set (an RC mode switch?); setting it again"
                    ));
                    overridden_by = Some(other);
                }
            }
        }
        Err(ActionError::failed(
            action,
            format!(
                "the autopilot would not stay in {name}: it switched to {} each time (is an RC mode switch or a failsafe overriding it?)",
                overridden_by.unwrap_or_default()
            ),
        ))
    }

    /// PX4 enters OFFBOARD only with setpoints already streaming: streams
    /// the last target, or the point where the drone is, and lets the
    /// stream run for a moment before the mode switch.
    async fn start_offboard_stream(&self, action: &str) -> Result<(), ActionError> {
        let since = {
            let mut stream = self.offboard.lock().unwrap_or_else(|p| p.into_inner());
            match *stream {
                Some((_, since)) => since,
                None => {
                    let here = self.watched.borrow().vehicle.local.map(|l| l.position);
                    let here = here.ok_or_else(|| {
                        ActionError::failed(
                            action,
                            "no local position to stream as an OFFBOARD setpoint",
                        )
                    })?;
                    let now = Instant::now();
                    *stream = Some((here, now));
                    now
                }
            }
        };
        sleep_until(since + OFFBOARD_LEAD).await;
        Ok(())
    }

    /// Stops streaming OFFBOARD setpoints (landed, disarmed).
    fn stop_offboard_stream(&self) {
        *self.offboard.lock().unwrap_or_else(|p| p.into_inner()) = None;
    }

    async fn perform(
        &self,
        action: MultirotorAction,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let name = action.name();
        match action {
            MultirotorAction::TurnOn => self.heard(name, cancel).await,
            MultirotorAction::PreFlightCheck => {
                let deadline = Instant::now() + self.options.ready_timeout;
                self.ready_wait(name, deadline, cancel).await
            }
            MultirotorAction::Calibrate => self.calibrate(name, cancel).await,
            MultirotorAction::Arm => self.arm(name, cancel).await,
            MultirotorAction::Disarm => self.disarm(name, cancel).await,
            MultirotorAction::Takeoff { height } => self.takeoff(name, height, cancel).await,
            MultirotorAction::Land => self.land(name, cancel).await,
            MultirotorAction::FlyTo { target } => self.fly_to(name, target, cancel).await,
            MultirotorAction::FlyBy { axis, distance } => {
                let base = self.motion_base(name)?;
                let target = base + axis.unit() * distance;
                let target = if axis == Axis::Z {
                    target
                } else {
                    Vec3 {
                        z: base.z,
                        ..target
                    }
                };
                self.fly_to(name, target, cancel).await
            }
            MultirotorAction::ReturnHome => {
                let base = self.motion_base(name)?;
                self.fly_to(name, Vec3::new(0.0, 0.0, base.z), cancel).await
            }
            MultirotorAction::Hover { seconds } => self.hover(name, seconds, cancel).await,
            MultirotorAction::TurnOnCamera => {
                // DIGICAM_CONTROL param1: session control, 1 = on.
                self.command(
                    name,
                    MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
                    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                )
                .await
            }
            MultirotorAction::AdjustCamera => {
                // DIGICAM_CONFIGURE with every setting 0: automatic.
                self.command(name, MavCmd::MAV_CMD_DO_DIGICAM_CONFIGURE, [0.0; 7])
                    .await
            }
            MultirotorAction::TakePhoto => {
                // DIGICAM_CONTROL param5: shoot once.
                self.command(
                    name,
                    MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
                    [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
                )
                .await
            }
        }
    }

    async fn calibrate(&self, action: &str, cancel: &CancellationToken) -> Result<(), ActionError> {
        self.heard(action, cancel).await?;
        if self.watched.borrow().vehicle.armed() {
            return Err(ActionError::refused(
                action,
                "the motors are armed; calibrate on the ground, disarmed",
            ));
        }
        // param3 = 1: ground pressure (barometer), the calibration that is
        // safe to repeat before every flight.
        self.command(
            action,
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        )
        .await
    }

    async fn arm(&self, action: &str, cancel: &CancellationToken) -> Result<(), ActionError> {
        let deadline = Instant::now() + self.options.ready_timeout;
        self.ready_wait(action, deadline, cancel).await?;
        self.flyable(action)?;
        if !self.watched.borrow().vehicle.armed() {
            self.ensure_mode(action, ModeRole::Guided, cancel).await?;
            self.command(
                action,
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            )
            .await?;
            self.wait(Instant::now() + Duration::from_secs(5), cancel, |w| {
                if w.vehicle.armed() {
                    Check::Done(())
                } else {
                    Check::Pending
                }
            })
            .await
            .map_err(|h| {
                self.halt_error(action, h, || {
                    "the heartbeat to show the motors armed".to_string()
                })
            })?;
        }
        self.update_flight(|f| f.mission_armed = true);
        Ok(())
    }

    async fn disarm(&self, action: &str, cancel: &CancellationToken) -> Result<(), ActionError> {
        self.heard(action, cancel).await?;
        let (armed, landed, height) = {
            let w = self.watched.borrow();
            let anchor = self.frame().anchor.unwrap_or_default();
            (
                w.vehicle.armed(),
                w.vehicle.landed(anchor.down),
                Self::position(&w, anchor).map(|p| p.z),
            )
        };
        if armed {
            if !landed {
                return Err(ActionError::refused(
                    action,
                    format!(
                        "the drone is flying ({}); land before disarming",
                        height.map_or("height unknown".to_string(), |z| format!("{z:.1} m up"))
                    ),
                ));
            }
            self.command(action, MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7])
                .await?;
            self.wait(Instant::now() + Duration::from_secs(5), cancel, |w| {
                if w.vehicle.armed() {
                    Check::Pending
                } else {
                    Check::Done(())
                }
            })
            .await
            .map_err(|h| {
                self.halt_error(action, h, || {
                    "the heartbeat to show the motors disarmed".to_string()
                })
            })?;
        }
        self.stop_offboard_stream();
        self.update_flight(|f| {
            f.mission_armed = false;
            f.last_target = None;
        });
        Ok(())
    }

    async fn takeoff(
        &self,
        action: &str,
        height: f64,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        self.heard(action, cancel).await?;
        self.flyable(action)?;
        let (armed, landed) = {
            let w = self.watched.borrow();
            let anchor = self.frame().anchor.unwrap_or_default();
            (w.vehicle.armed(), w.vehicle.landed(anchor.down))
        };
        if armed && !landed {
            // Already flying: climb or descend to the height over the spot.
            let base = self.motion_base(action)?;
            return self
                .fly_to(action, Vec3::new(base.x, base.y, height), cancel)
                .await;
        }
        let may_rearm = || self.flight().mission_armed && self.options.rearm_for_takeoff;
        let mut rearmed = false;
        let autopilot = self.flyable(action)?;
        let ground = loop {
            if !self.watched.borrow().vehicle.armed() {
                if !may_rearm() {
                    return Err(ActionError::refused(
                        action,
                        "the motors are not armed; arm before taking off",
                    ));
                }
                self.note("the autopilot disarmed itself while idle on the ground; arming again to take off");
                self.arm(action, cancel).await?;
                rearmed = true;
            }
            self.ensure_mode(action, ModeRole::Guided, cancel).await?;
            let ground = {
                let w = self.watched.borrow();
                Self::position(&w, self.frame().anchor.unwrap_or_default())
            }
            .ok_or_else(|| ActionError::failed(action, "no local position to take off from"))?;
            if autopilot == Autopilot::Px4 {
                // PX4 takes off in OFFBOARD by a setpoint above the ground.
                let above = Vec3::new(ground.x, ground.y, ground.z + height);
                self.send_target(action, above).await;
                break ground;
            }
            match self
                .command_raw(
                    action,
                    MavCmd::MAV_CMD_NAV_TAKEOFF,
                    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, height as f32],
                )
                .await?
            {
                Ok(()) => break ground,
                // A resent take-off refused because the vehicle is already
                // climbing: the first one went through, only its ACK was
                // lost.
                Err(CommandError::Refused { attempt, .. })
                    if attempt > 1 && {
                        let w = self.watched.borrow();
                        !w.vehicle
                            .landed(self.frame().anchor.unwrap_or_default().down)
                    } =>
                {
                    break ground
                }
                // Refused as not armed although the last heartbeat said
                // armed: it disarmed itself a moment ago. Arm once more.
                Err(e @ CommandError::Refused { .. }) => {
                    if !rearmed && may_rearm() && self.disarmed_by_next_heartbeat(cancel).await {
                        continue;
                    }
                    return Err(self.command_error(action, e));
                }
                Err(e) => return Err(self.command_error(action, e)),
            }
        };
        let target = Vec3::new(ground.x, ground.y, ground.z + height);
        self.update_flight(|f| f.taking_off = true);
        let result = self.climb(action, height, ground, target, cancel).await;
        self.update_flight(|f| f.taking_off = false);
        result?;
        self.send_target(action, target).await;
        Ok(())
    }

    /// Whether the next heartbeat (within 3 s) reports the motors disarmed.
    async fn disarmed_by_next_heartbeat(&self, cancel: &CancellationToken) -> bool {
        let seen = self.watched.borrow().vehicle.heartbeats;
        self.wait(Instant::now() + Duration::from_secs(3), cancel, |w| {
            if w.vehicle.heartbeats > seen {
                Check::Done(!w.vehicle.armed())
            } else {
                Check::Pending
            }
        })
        .await
        .unwrap_or(false)
    }

    /// Waits for the climb of a take-off the autopilot accepted.
    async fn climb(
        &self,
        action: &str,
        height: f64,
        ground: Vec3,
        target: Vec3,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let tolerance = self.options.arrival_tolerance;
        let guided = self.autopilot().and_then(|a| a.mode_for(ModeRole::Guided));
        let anchor = self.frame().anchor.unwrap_or_default();
        let deadline = Instant::now() + self.motion_timeout(height);
        let climbed = self
            .wait(deadline, cancel, |w| {
                if let Some(fail) = self.lost_control(action, w, guided) {
                    return Check::Fail(fail);
                }
                match Self::position(w, anchor) {
                    Some(p) if p.z >= target.z - tolerance => Check::Done(()),
                    _ => Check::Pending,
                }
            })
            .await;
        match climbed {
            Ok(()) => Ok(()),
            Err(Halt::Cancelled) => {
                self.hold(action).await;
                Err(ActionError::Cancelled {
                    action: action.to_string(),
                })
            }
            Err(h) => Err(self.halt_error(action, h, || {
                let z = self.telemetry.borrow().position.z;
                format!(
                    "the climb to {height} m above the take-off point (now {:.2} m above it)",
                    z - ground.z
                )
            })),
        }
    }

    /// Whether the mission has lost control of the drone: disarmed in the
    /// air, or moved out of the guided mode by a pilot or a failsafe.
    fn lost_control(&self, action: &str, w: &Watched, guided: Option<u32>) -> Option<ActionError> {
        let v = &w.vehicle;
        if !v.armed() {
            return Some(ActionError::failed(action, "the motors disarmed"));
        }
        match (v.custom_mode(), guided, v.autopilot) {
            (Some(m), Some(g), Some(ap)) if m != g => Some(ActionError::failed(
                action,
                format!(
                    "the autopilot switched to {} (a pilot or a failsafe); the mission no longer controls the drone",
                    ap.mode_name(m)
                ),
            )),
            _ => None,
        }
    }

    fn motion_timeout(&self, distance: f64) -> Duration {
        self.options.motion_margin
            + Duration::from_secs_f64(
                (distance.abs() / self.options.min_speed.max(0.01)).min(3600.0),
            )
    }

    /// Where a relative motion starts: the last target, or where the drone
    /// is when there is none.
    fn motion_base(&self, action: &str) -> Result<Vec3, ActionError> {
        if let Some(t) = self.flight().last_target {
            return Ok(t);
        }
        let w = self.watched.borrow();
        Self::position(&w, self.frame().anchor.unwrap_or_default()).ok_or_else(|| {
            ActionError::refused(action, "the vehicle has not reported a local position yet")
        })
    }

    /// Sends a position target (mission frame) and remembers it.
    async fn send_target(&self, action: &str, target: Vec3) {
        self.update_flight(|f| f.last_target = Some(target));
        let ned = self.frame().anchor.unwrap_or_default() + Ned::from_mission(target);
        self.log(AdapterEvent::Command {
            action: action.to_string(),
            args: vec![target.x, target.y, target.z],
            detail: format!(
                "SET_POSITION_TARGET_LOCAL_NED N {:.2} E {:.2} D {:.2}",
                ned.north, ned.east, ned.down
            ),
        });
        self.send_ned(ned).await;
    }

    async fn send_ned(&self, ned: Ned) {
        if self.autopilot() == Some(Autopilot::Px4) {
            let mut stream = self.offboard.lock().unwrap_or_else(|p| p.into_inner());
            let since = stream.map_or_else(Instant::now, |(_, since)| since);
            *stream = Some((ned, since));
        }
        self.transmit_ned(ned).await;
    }

    /// Sends one position target, remembering nothing.
    async fn transmit_ned(&self, ned: Ned) {
        let Some(target) = self.watched.borrow().vehicle.target else {
            return;
        };
        let mask = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VX_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VY_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_VZ_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AX_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AY_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_AZ_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE;
        let message =
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(SET_POSITION_TARGET_LOCAL_NED_DATA {
                time_boot_ms: self.started.elapsed().as_millis() as u32,
                x: ned.north as f32,
                y: ned.east as f32,
                z: ned.down as f32,
                type_mask: mask,
                target_system: target.system,
                target_component: target.component,
                coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
                ..Default::default()
            });
        if let Err(e) = self.link.send(&message).await {
            tracing::warn!(drone = %self.drone, "sending a position target failed: {e}");
        }
    }

    /// Holds where the drone is now (a cancelled motion).
    async fn hold(&self, action: &str) {
        let here = {
            let w = self.watched.borrow();
            Self::position(&w, self.frame().anchor.unwrap_or_default())
        };
        if let Some(here) = here {
            self.send_target(action, here).await;
        }
    }

    /// The drone must be flying, in the guided mode, for a position target.
    fn ready_to_move(&self, action: &str) -> Result<Option<u32>, ActionError> {
        let autopilot = self.flyable(action)?;
        let guided = autopilot.mode_for(ModeRole::Guided);
        let w = self.watched.borrow();
        let anchor = self.frame().anchor.unwrap_or_default();
        if w.link_lost {
            return Err(ActionError::LinkLost {
                action: action.to_string(),
            });
        }
        if !w.vehicle.armed() || w.vehicle.landed(anchor.down) {
            return Err(ActionError::refused(
                action,
                "the drone is on the ground; take off first",
            ));
        }
        if let (Some(m), Some(g)) = (w.vehicle.custom_mode(), guided) {
            if m != g {
                return Err(ActionError::refused(
                    action,
                    format!(
                        "the autopilot is in {}, not {}: a pilot or a failsafe has taken over, and the mission does not take the drone back",
                        autopilot.mode_name(m),
                        autopilot.mode_name(g)
                    ),
                ));
            }
        }
        Ok(guided)
    }

    async fn fly_to(
        &self,
        action: &str,
        target: Vec3,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let guided = self.ready_to_move(action)?;
        let anchor = self.frame().anchor.unwrap_or_default();
        let distance = {
            let w = self.watched.borrow();
            Self::position(&w, anchor).map_or(0.0, |p| p.distance(target))
        };
        self.send_target(action, target).await;
        let tolerance = self.options.arrival_tolerance;
        let deadline = Instant::now() + self.motion_timeout(distance);
        let ned = anchor + Ned::from_mission(target);
        // Resend the target every second: UDP loses packets, and a target
        // that never arrived would otherwise look like a slow drone.
        let resend = async {
            loop {
                sleep(Duration::from_secs(1)).await;
                self.send_ned(ned).await;
            }
        };
        let arrived = self.wait(deadline, cancel, |w| {
            if let Some(fail) = self.lost_control(action, w, guided) {
                return Check::Fail(fail);
            }
            match Self::position(w, anchor) {
                Some(p) if p.distance(target) <= tolerance => Check::Done(()),
                _ => Check::Pending,
            }
        });
        let outcome = tokio::select! {
            r = arrived => r,
            _ = resend => unreachable!("resending never ends"),
        };
        match outcome {
            Ok(()) => Ok(()),
            Err(Halt::Cancelled) => {
                self.hold(action).await;
                Err(ActionError::Cancelled {
                    action: action.to_string(),
                })
            }
            Err(h) => Err(self.halt_error(action, h, || {
                let p = self.telemetry.borrow().position;
                format!(
                    "arrival within {tolerance} m of {target} (still {:.2} m away)",
                    p.distance(target)
                )
            })),
        }
    }

    async fn hover(
        &self,
        action: &str,
        seconds: f64,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        self.heard(action, cancel).await?;
        let flying = {
            let w = self.watched.borrow();
            w.vehicle.armed()
                && !w
                    .vehicle
                    .landed(self.frame().anchor.unwrap_or_default().down)
        };
        let guided = if flying {
            let guided = self.ready_to_move(action)?;
            let base = self.motion_base(action)?;
            self.send_target(action, base).await;
            guided
        } else {
            None
        };
        let watch = self.wait(
            Instant::now() + Duration::from_secs(365 * 24 * 3600),
            cancel,
            |w| {
                if flying {
                    if let Some(fail) = self.lost_control(action, w, guided) {
                        return Check::Fail(fail);
                    }
                }
                Check::<()>::Pending
            },
        );
        tokio::select! {
            _ = self.clock.sleep(seconds) => Ok(()),
            halt = watch => match halt {
                Ok(()) => Ok(()),
                Err(h) => Err(self.halt_error(action, h, || "the end of the hover".to_string())),
            },
        }
    }

    async fn land(&self, action: &str, cancel: &CancellationToken) -> Result<(), ActionError> {
        self.heard(action, cancel).await?;
        let anchor = self.frame().anchor.unwrap_or_default();
        let (armed, landed, height) = {
            let w = self.watched.borrow();
            (
                w.vehicle.armed(),
                w.vehicle.landed(anchor.down),
                Self::position(&w, anchor).map_or(0.0, |p| p.z),
            )
        };
        if !armed || landed {
            return Ok(());
        }
        self.ensure_mode(action, ModeRole::Land, cancel).await?;
        let autopilot = self.flyable(action)?;
        let land_mode = autopilot.mode_for(ModeRole::Land);
        let deadline = Instant::now() + self.motion_timeout(height);
        let landed = self
            .wait(deadline, cancel, |w| {
                let v = &w.vehicle;
                if !v.armed() || v.landed(anchor.down) {
                    return Check::Done(());
                }
                match (v.custom_mode(), land_mode) {
                    (Some(m), Some(l)) if m != l => Check::Fail(ActionError::failed(
                        action,
                        format!(
                            "the autopilot switched to {} while landing (a pilot or a failsafe)",
                            autopilot.mode_name(m)
                        ),
                    )),
                    _ => Check::Pending,
                }
            })
            .await;
        match landed {
            Ok(()) => {
                let still_armed = self.watched.borrow().vehicle.armed();
                self.stop_offboard_stream();
                self.update_flight(|f| {
                    f.last_target = None;
                    f.mission_armed = still_armed;
                });
                Ok(())
            }
            Err(Halt::Cancelled) => {
                // Stop descending: back to guided, holding here (the hold
                // point first: PX4 needs it streaming to enter OFFBOARD).
                self.hold(action).await;
                let _ = self
                    .ensure_mode(action, ModeRole::Guided, &CancellationToken::new())
                    .await;
                self.hold(action).await;
                Err(ActionError::Cancelled {
                    action: action.to_string(),
                })
            }
            Err(h) => Err(self.halt_error(action, h, || {
                format!(
                    "touchdown (still {:.2} m up)",
                    self.telemetry.borrow().position.z
                )
            })),
        }
    }
}

/// Folds every message from the vehicle into the watched state, logs what a
/// pilot would want to read, and publishes telemetry.
async fn receive_task(s: Arc<Shared>) {
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

/// A ground station says it is there once a second; ArduPilot's GCS
/// failsafe counts on it, and a `udpout` link needs it to be heard first.
async fn heartbeat_task(s: Arc<Shared>) {
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
async fn monitor_task(s: Arc<Shared>) {
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
const OFFBOARD_PERIOD: Duration = Duration::from_millis(100);
const OFFBOARD_LEAD: Duration = Duration::from_millis(600);

/// Streams the OFFBOARD setpoint to a PX4 vehicle while there is one.
async fn setpoint_task(s: Arc<Shared>) {
    loop {
        tokio::select! {
            _ = s.stop.cancelled() => return,
            _ = sleep(OFFBOARD_PERIOD) => {}
        }
        if s.autopilot() != Some(Autopilot::Px4) || s.watched.borrow().link_lost {
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
async fn stream_task(s: Arc<Shared>) {
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
        let px4 = s.autopilot() == Some(Autopilot::Px4);
        for &(id, name, hz) in STREAMS {
            // PX4 has no EKF_STATUS_REPORT.
            if px4 && id == 193 {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fleet_settings_override_only_what_they_name() {
        let settings = MavlinkSettings {
            ready_timeout: Some(180.0),
            fleet_origin: Some([46.6, 14.2, 446.0]),
            ..MavlinkSettings::default()
        };
        assert_eq!(settings.validate(), Ok(()));
        let mut o = MavlinkOptions::default();
        settings.apply(&mut o);
        assert_eq!(o.ready_timeout, Duration::from_secs(180));
        assert_eq!(o.fleet_origin, Some(Wgs84::new(46.6, 14.2, 446.0)));
        assert_eq!(o.link_timeout, MavlinkOptions::default().link_timeout);
        assert_eq!(o.arrival_tolerance, 0.3);
    }

    #[test]
    fn bad_fleet_settings_name_the_setting() {
        let e = MavlinkSettings {
            link_timeout: Some(-1.0),
            ..MavlinkSettings::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("`link_timeout`"), "{e}");
        let e = MavlinkSettings {
            fleet_origin: Some([95.0, 0.0, 0.0]),
            ..MavlinkSettings::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("`fleet_origin`: latitude"), "{e}");
        let e = MavlinkSettings {
            target_system: Some(0),
            ..MavlinkSettings::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("broadcast"), "{e}");
    }
}
