//! Take-off: armed in the guided mode, started the autopilot's way, and
//! the climb watched until it is done.

use std::time::Duration;

use tokio::time::Instant;

use crate::api::{ActionError, CancellationToken, Vec3};
use crate::mavlink::command::CommandError;
use crate::mavlink::dialect::MavCmd;
use crate::mavlink::modes::ModeRole;
use crate::mavlink::strategy::TakeoffStart;

use super::motion::Arrival;
use super::shared::{Check, Shared};

impl Shared {
    pub(super) async fn takeoff(
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
        let strategy = self.flyable(action)?;
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
            let params = match strategy.takeoff(height) {
                TakeoffStart::SetpointAbove(up) => {
                    let above = Vec3::new(ground.x, ground.y, ground.z + up);
                    self.send_target(action, above).await;
                    break ground;
                }
                TakeoffStart::Command(params) => params,
            };
            match self
                .command_raw(action, MavCmd::MAV_CMD_NAV_TAKEOFF, params)
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
    pub(super) async fn disarmed_by_next_heartbeat(&self, cancel: &CancellationToken) -> bool {
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
    pub(super) async fn climb(
        &self,
        action: &str,
        height: f64,
        ground: Vec3,
        target: Vec3,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let guided = self.autopilot().and_then(|a| a.mode_for(ModeRole::Guided));
        let deadline = Instant::now() + self.motion_timeout(height);
        // Done at the height and settled there, not on the way up: the
        // next motion would start while the drone still climbs.
        let mut arrival = Arrival::new(self, target);
        let climbed = self
            .wait(deadline, cancel, |w| {
                if let Some(fail) = self.lost_control(action, w, guided) {
                    return Check::Fail(fail);
                }
                if arrival.arrived(w) {
                    Check::Done(())
                } else {
                    Check::Pending
                }
            })
            .await;
        self.motion_outcome(action, climbed, || {
            let z = self.telemetry.borrow().position.z;
            format!(
                "the climb to {height} m above the take-off point (now {:.2} m above it)",
                z - ground.z
            )
        })
        .await
    }
}
