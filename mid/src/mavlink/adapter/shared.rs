//! What every part of the adapter shares: the link, the vehicle as last
//! heard, the mission frame, what the adapter remembers between actions,
//! and the one way to wait on the vehicle.

use std::collections::HashMap;
use std::sync::Mutex;

use tokio::time::{sleep_until, Instant};

use eamos_geo::Ned;

use crate::api::{ActionError, CancellationToken, FlightMode, Telemetry, Vec3};
use crate::log::{AdapterEvent, AdapterRecord, LogRecord};
use crate::mavlink::modes::Autopilot;
use crate::mavlink::strategy::{self, Strategy};

use crate::clock::MissionClock;
use crate::mavlink::address::ConnectAddress;
use crate::mavlink::link::Link;
use crate::mavlink::state::VehicleState;
use tokio::sync::watch;

use super::options::MavlinkOptions;

/// What the waiting parts of an action see: the vehicle and the link.
#[derive(Clone)]
pub(super) struct Watched {
    pub(super) vehicle: VehicleState,
    pub(super) link_lost: bool,
    /// When each message id was last received from the vehicle.
    pub(super) last_seen: HashMap<u32, Instant>,
}

/// Where the mission frame sits in the EKF frame, and where home is.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct FrameState {
    pub(super) anchor: Option<Ned>,
    pub(super) home: Vec3,
}

/// What the adapter remembers between actions.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Flight {
    /// The last position target, in the mission frame: relative motions
    /// start from it, so errors of arrival do not add up.
    pub(super) last_target: Option<Vec3>,
    /// The mission armed the drone and has not disarmed it.
    pub(super) mission_armed: bool,
    /// A take-off is climbing (telemetry shows `Takeoff`).
    pub(super) taking_off: bool,
    /// What the autopilot does on a lost link was read (once, before the
    /// first arming).
    pub(super) link_loss_read: bool,
}

pub(super) struct Shared {
    pub(super) drone: String,
    pub(super) address: ConnectAddress,
    pub(super) options: MavlinkOptions,
    pub(super) link: Link,
    pub(super) clock: MissionClock,
    pub(super) started: Instant,
    pub(super) watched: watch::Sender<Watched>,
    pub(super) telemetry: watch::Sender<Telemetry>,
    pub(super) frame: Mutex<FrameState>,
    pub(super) flight: Mutex<Flight>,
    /// PX4: the setpoint streamed to keep OFFBOARD alive (EKF frame), and
    /// since when the stream runs.
    pub(super) offboard: Mutex<Option<(Ned, Instant)>>,
    /// The autopilot's time and the mission time of the first reading,
    /// and whether a different pace was said (see `time.rs`).
    pub(super) pace: Mutex<Option<(f64, f64, bool)>>,
    pub(super) commands: tokio::sync::Mutex<()>,
    pub(super) stop: CancellationToken,
}

/// How a wait ended when it did not get what it waited for.
pub(super) enum Halt {
    Cancelled,
    LinkLost,
    Timeout,
    Failed(ActionError),
}

/// What a wait's check says about the latest state.
pub(super) enum Check<T> {
    Pending,
    Done(T),
    Fail(ActionError),
}

impl Shared {
    pub(super) fn log(&self, event: AdapterEvent) {
        self.options.log.record(LogRecord::Adapter(AdapterRecord {
            time: self.clock.now(),
            drone: self.drone.clone(),
            adapter: "mavlink".to_string(),
            event,
        }));
    }

    pub(super) fn note(&self, detail: impl Into<String>) {
        let detail = detail.into();
        tracing::info!(drone = %self.drone, "{detail}");
        self.log(AdapterEvent::State { detail });
    }

    /// A note the crew must read (see [`AdapterEvent::Warning`]).
    pub(super) fn warn(&self, detail: impl Into<String>) {
        let detail = detail.into();
        tracing::warn!(drone = %self.drone, "{detail}");
        self.log(AdapterEvent::Warning { detail });
    }

    pub(super) fn flight(&self) -> Flight {
        *self.flight.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub(super) fn update_flight(&self, f: impl FnOnce(&mut Flight)) {
        f(&mut self.flight.lock().unwrap_or_else(|p| p.into_inner()));
        self.publish_telemetry();
    }

    pub(super) fn frame(&self) -> FrameState {
        *self.frame.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub(super) fn autopilot(&self) -> Option<Autopilot> {
        self.watched.borrow().vehicle.autopilot
    }

    pub(super) fn position(w: &Watched, anchor: Ned) -> Option<Vec3> {
        w.vehicle.local.map(|l| (l.position - anchor).to_mission())
    }

    pub(super) fn publish_telemetry(&self) {
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

    /// The ways of the autopilot heard, if the adapter knows them.
    pub(super) fn strategy(&self) -> Option<&'static dyn Strategy> {
        self.autopilot().and_then(strategy::for_autopilot)
    }

    /// The autopilot must be one the adapter knows how to fly.
    pub(super) fn flyable(&self, action: &str) -> Result<&'static dyn Strategy, ActionError> {
        match self.autopilot() {
            Some(Autopilot::Other(n)) => Err(ActionError::refused(
                action,
                format!("the autopilot (MAV_AUTOPILOT {n}) is neither ArduPilot nor PX4; its flight modes are unknown"),
            )),
            Some(a) => strategy::for_autopilot(a).ok_or_else(|| {
                ActionError::refused(action, format!("the adapter does not know how to fly {a}"))
            }),
            None => Err(ActionError::LinkLost {
                action: action.to_string(),
            }),
        }
    }

    /// Waits on the vehicle's state until `check` says done or fails, the
    /// deadline passes, the action is cancelled, or the link is lost.
    pub(super) async fn wait<T>(
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

    pub(super) fn halt_error(
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
}
