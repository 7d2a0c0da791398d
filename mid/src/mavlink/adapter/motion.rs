//! Motions: position targets, arrival, holding, hovering; and the rule
//! never to fight a pilot who took over.

use std::time::Duration;

use tokio::time::{sleep, Instant};

use eamos_geo::Ned;

use crate::api::{ActionError, CancellationToken, Vec3};
use crate::log::AdapterEvent;
use crate::mavlink::dialect::{
    MavFrame, MavMessage, PositionTargetTypemask, SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use crate::mavlink::modes::ModeRole;

use super::options::Settle;
use super::shared::{Check, Halt, Shared, Watched};

/// Whether a motion has arrived: within the tolerance of its target and
/// settled there, still for the settle time of the autopilot's own clock.
pub(super) struct Arrival {
    target: Vec3,
    tolerance: f64,
    settle: Settle,
    anchor: Ned,
    still_since: Option<f64>,
}

impl Arrival {
    pub(super) fn new(s: &Shared, target: Vec3) -> Arrival {
        Arrival {
            target,
            tolerance: s.options.arrival_tolerance,
            settle: s.options.settle,
            anchor: s.frame().anchor.unwrap_or_default(),
            still_since: None,
        }
    }

    /// Judges the latest local position.
    pub(super) fn arrived(&mut self, w: &Watched) -> bool {
        let Some(local) = w.vehicle.local else {
            return false;
        };
        let here = (local.position - self.anchor).to_mission();
        if here.distance(self.target) > self.tolerance
            || local.velocity.to_mission().norm() > self.settle.speed
        {
            self.still_since = None;
            return false;
        }
        let since = *self.still_since.get_or_insert(local.boot_time);
        local.boot_time - since >= self.settle.time
    }
}

impl Shared {
    /// Whether the mission has lost control of the drone: disarmed in the
    /// air, or moved out of the guided mode by a pilot or a failsafe.
    pub(super) fn lost_control(
        &self,
        action: &str,
        w: &Watched,
        guided: Option<u32>,
    ) -> Option<ActionError> {
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

    pub(super) fn motion_timeout(&self, distance: f64) -> Duration {
        self.options.motion_margin
            + Duration::from_secs_f64(
                (distance.abs() / self.options.min_speed.max(0.01)).min(3600.0),
            )
    }

    /// Where a relative motion starts: the last target, or where the drone
    /// is when there is none.
    pub(super) fn motion_base(&self, action: &str) -> Result<Vec3, ActionError> {
        if let Some(t) = self.flight().last_target {
            return Ok(t);
        }
        let w = self.watched.borrow();
        Self::position(&w, self.frame().anchor.unwrap_or_default()).ok_or_else(|| {
            ActionError::refused(action, "the vehicle has not reported a local position yet")
        })
    }

    /// Sends a position target (mission frame) and remembers it.
    pub(super) async fn send_target(&self, action: &str, target: Vec3) {
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

    pub(super) async fn send_ned(&self, ned: Ned) {
        if self.strategy().is_some_and(|s| s.streams_setpoints()) {
            let mut stream = self.offboard.lock().unwrap_or_else(|p| p.into_inner());
            let since = stream.map_or_else(Instant::now, |(_, since)| since);
            *stream = Some((ned, since));
        }
        self.transmit_ned(ned).await;
    }

    /// Sends one position target, remembering nothing.
    pub(super) async fn transmit_ned(&self, ned: Ned) {
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
    pub(super) async fn hold(&self, action: &str) {
        let here = {
            let w = self.watched.borrow();
            Self::position(&w, self.frame().anchor.unwrap_or_default())
        };
        if let Some(here) = here {
            self.send_target(action, here).await;
        }
    }

    /// The drone must be flying, in the guided mode, for a position target.
    pub(super) fn ready_to_move(&self, action: &str) -> Result<Option<u32>, ActionError> {
        let autopilot = self.flyable(action)?.autopilot();
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

    pub(super) async fn fly_to(
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
        let mut arrival = Arrival::new(self, target);
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
            if arrival.arrived(w) {
                Check::Done(())
            } else {
                Check::Pending
            }
        });
        let outcome = tokio::select! {
            r = arrived => r,
            _ = resend => unreachable!("resending never ends"),
        };
        self.motion_outcome(action, outcome, || {
            let p = self.telemetry.borrow().position;
            format!(
                "arrival within {tolerance} m of {target}, settled (still {:.2} m away)",
                p.distance(target)
            )
        })
        .await
    }

    /// What the wait of a motion comes to: a cancelled motion holds where
    /// it is before it says so; any other halt is an error naming what it
    /// was `waiting_for`.
    pub(super) async fn motion_outcome(
        &self,
        action: &str,
        outcome: Result<(), Halt>,
        waiting_for: impl FnOnce() -> String,
    ) -> Result<(), ActionError> {
        match outcome {
            Ok(()) => Ok(()),
            Err(Halt::Cancelled) => {
                self.hold(action).await;
                Err(ActionError::Cancelled {
                    action: action.to_string(),
                })
            }
            Err(h) => Err(self.halt_error(action, h, waiting_for)),
        }
    }

    pub(super) async fn hover(
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
}
