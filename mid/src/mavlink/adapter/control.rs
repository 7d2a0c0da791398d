//! Who has the drone when the mission wants it back for its failsafe: the
//! mission, a pilot (or the autopilot's own failsafe), or nobody while the
//! link is lost.
//!
//! The rules a pilot expects:
//! - A drone that a pilot took over while the mission could see it (a mode
//!   the mission did not set, from an RC switch or a second ground
//!   station) is the pilot's until the pilot gives it back by selecting
//!   the guided mode again, or brings it down.
//! - A drone whose link is lost cannot be commanded; the autopilot's own
//!   link-loss failsafe decides meanwhile. When the link returns:
//!   - a drone the autopilot is already bringing down (its land or return
//!     mode) is left to finish;
//!   - a drone holding by itself (ArduCopter in GUIDED with
//!     `FS_GCS_ENABLE = 0`, PX4 gone to HOLD when the setpoint stream
//!     stopped) has nobody in charge, so the mission takes it back and
//!     flies its failsafe;
//!   - any other mode is a pilot's, as above.

use crate::api::{ActionError, Control, FlightMode};
use crate::mavlink::modes::ModeRole;

use super::shared::{Shared, Watched};

/// Why the failsafe waits, said once each time it changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Waiting {
    ForLink,
    ForPilot(u32),
}

/// What the vehicle's state says about who has it.
enum Holder {
    Mission,
    Down,
    Link,
    Other(u32, FlightMode),
}

impl Shared {
    fn holder(&self, w: &Watched) -> Holder {
        if w.link_lost {
            return Holder::Link;
        }
        let v = &w.vehicle;
        let anchor = self.frame().anchor.unwrap_or_default();
        if !v.armed() || v.landed(anchor.down) {
            return Holder::Down;
        }
        let (Some(ap), Some(mode)) = (v.autopilot, v.custom_mode()) else {
            return Holder::Mission;
        };
        match ap.mode_for(ModeRole::Guided) {
            Some(guided) if guided != mode => Holder::Other(mode, ap.flight_mode(mode)),
            _ => Holder::Mission,
        }
    }

    /// Waits until the mission may fly the drone's failsafe (see the
    /// module documentation); `Down` when whoever had the drone landed it.
    pub(super) async fn regain_control(&self) -> Result<Control, ActionError> {
        let mut rx = self.watched.subscribe();
        // After a loss, the heartbeats counted when it was last seen lost:
        // the mode is judged only from a heartbeat that came after, since
        // the first message back may be telemetry while the last heartbeat
        // heard still shows the mode from before the loss.
        let mut lost_at: Option<u64> = None;
        let mut said: Option<Waiting> = None;
        loop {
            let waiting = {
                let w = rx.borrow_and_update();
                let stale = lost_at.is_some_and(|n| w.vehicle.heartbeats <= n);
                match self.holder(&w) {
                    Holder::Link => {
                        lost_at = Some(w.vehicle.heartbeats);
                        Waiting::ForLink
                    }
                    _ if stale => Waiting::ForLink,
                    Holder::Mission => return Ok(Control::Mission),
                    Holder::Down => return Ok(Control::Down),
                    // The autopilot's own link-loss hold, found when the
                    // link came back: nobody is in charge, so the mission
                    // takes the drone back.
                    Holder::Other(_, FlightMode::Hold) if lost_at.is_some() => {
                        return Ok(Control::Mission)
                    }
                    Holder::Other(mode, _) => Waiting::ForPilot(mode),
                }
            };
            if said != Some(waiting) {
                said = Some(waiting);
                let line = match waiting {
                    Waiting::ForLink => "the link is lost: the failsafe waits for it to return (the autopilot's own link-loss failsafe decides until then)".to_string(),
                    Waiting::ForPilot(mode) => {
                        let name = self
                            .autopilot()
                            .map_or_else(|| mode.to_string(), |ap| ap.mode_name(mode));
                        format!("the drone is in {name}, which the mission did not set: a pilot or the autopilot's failsafe has it, and keeps it until they select the guided mode again or land")
                    }
                };
                self.warn(line);
            }
            tokio::select! {
                _ = self.stop.cancelled() => {
                    return Err(ActionError::LinkLost { action: "failsafe".to_string() })
                }
                changed = rx.changed() => {
                    if changed.is_err() {
                        return Err(ActionError::LinkLost { action: "failsafe".to_string() });
                    }
                }
            }
        }
    }
}
