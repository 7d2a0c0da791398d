//! Landing in the autopilot's land mode, watched until touchdown.

use tokio::time::Instant;

use crate::api::{ActionError, CancellationToken};
use crate::mavlink::modes::ModeRole;

use super::shared::{Check, Halt, Shared};

impl Shared {
    pub(super) async fn land(
        &self,
        action: &str,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
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
        let autopilot = self.flyable(action)?.autopilot();
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
