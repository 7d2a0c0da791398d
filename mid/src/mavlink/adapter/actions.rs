//! The mission's actions, each mapped onto the autopilot; arming and
//! disarming.

use std::time::Duration;

use tokio::time::Instant;

use crate::api::{ActionError, Axis, CancellationToken, MultirotorAction, Vec3};
use crate::mavlink::dialect::MavCmd;
use crate::mavlink::modes::ModeRole;

use super::shared::{Check, Shared};

impl Shared {
    pub(super) async fn perform(
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

    pub(super) async fn calibrate(
        &self,
        action: &str,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
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

    pub(super) async fn arm(
        &self,
        action: &str,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let deadline = Instant::now() + self.options.ready_timeout;
        self.ready_wait(action, deadline, cancel).await?;
        self.flyable(action)?;
        self.check_link_loss(action).await?;
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

    pub(super) async fn disarm(
        &self,
        action: &str,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
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
}
