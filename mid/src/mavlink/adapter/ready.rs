//! Before flight: the first heartbeat, readiness, the mission frame's
//! anchor, and flight modes set and confirmed.

use std::time::Duration;

use tokio::time::{sleep_until, Instant};

use eamos_geo::LocalFrame;

use crate::api::{ActionError, CancellationToken, Vec3};
use crate::mavlink::dialect::MavCmd;
use crate::mavlink::modes::ModeRole;

use super::shared::{Check, Halt, Shared};
use super::tasks::OFFBOARD_LEAD;
use crate::mavlink::readiness::NotReady;

/// How far (m) a real vehicle's home may lie from the fleet file's before
/// the crew is told: GPS puts a copter within a metre or two.
const HOME_GAP: f64 = 2.0;

impl Shared {
    /// Waits for the autopilot's heartbeat.
    pub(super) async fn heard(
        &self,
        action: &str,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
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
    pub(super) async fn ready_wait(
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
                    self.ask_home(action).await;
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
                Err(Halt::Timeout) => {
                    self.ask_prearm_reasons(action).await;
                    let not_ready =
                        NotReady::of(&self.watched.borrow().vehicle.readiness, started.elapsed());
                    return Err(ActionError::refused(action, not_ready));
                }
                Err(halt) => {
                    return Err(self.halt_error(action, halt, || "readiness".to_string()));
                }
            }
        }
    }

    /// Asks for the autopilot's home (HOME_POSITION) when it has not come
    /// yet, and waits a moment for it: the stream asked for at connection
    /// may not have brought it by the time a fast vehicle is ready.
    pub(super) async fn ask_home(&self, action: &str) {
        if self.frame().anchor.is_some() {
            return;
        }
        if self.watched.borrow().vehicle.home.is_some() {
            return;
        }
        let asked = self
            .send_command(
                action,
                MavCmd::MAV_CMD_REQUEST_MESSAGE,
                [242.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            )
            .await;
        if !matches!(asked, Ok(Ok(()))) {
            return;
        }
        let _ = self
            .wait(
                Instant::now() + self.options.commands.ack_timeout,
                &CancellationToken::new(),
                |w| match w.vehicle.home {
                    Some(_) => Check::Done(()),
                    None => Check::Pending,
                },
            )
            .await;
    }

    /// Asks the autopilot to run its pre-arm checks now and say why they
    /// fail (`MAV_CMD_RUN_PREARM_CHECKS`): ArduPilot repeats the reason
    /// only every 30 s, so a short wait may have heard none. Waits for the
    /// acknowledgement and the text that comes with it, never longer.
    async fn ask_prearm_reasons(&self, action: &str) {
        if self
            .watched
            .borrow()
            .vehicle
            .readiness
            .prearm_text()
            .is_some()
        {
            return;
        }
        let asked = self
            .send_command(action, MavCmd::MAV_CMD_RUN_PREARM_CHECKS, [0.0; 7])
            .await;
        if !matches!(asked, Ok(Ok(()))) {
            return;
        }
        let _ = self
            .wait(
                Instant::now() + self.options.commands.statustext_grace,
                &CancellationToken::new(),
                |w| match w.vehicle.readiness.prearm_text() {
                    Some(_) => Check::Done(()),
                    None => Check::Pending,
                },
            )
            .await;
    }

    /// Finds the mission frame again when the drone is already armed and
    /// none is set: this ground station was restarted while the drone
    /// flew (an agent resumed from its journal), so no arming will set it.
    pub(super) async fn find_frame(
        &self,
        action: &str,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        if self.frame().anchor.is_some() {
            return Ok(());
        }
        self.heard(action, cancel).await?;
        if !self.watched.borrow().vehicle.armed() {
            return Ok(());
        }
        let deadline = Instant::now() + self.options.ready_timeout;
        self.wait(deadline, cancel, |w| match w.vehicle.local {
            Some(_) => Check::Done(()),
            None => Check::Pending,
        })
        .await
        .map_err(|h| self.halt_error(action, h, || "LOCAL_POSITION_NED".to_string()))?;
        self.ask_home(action).await;
        self.set_anchor();
        Ok(())
    }

    /// Fixes the mission frame on the autopilot's home (HOME_POSITION, in
    /// the EKF frame), else on the ground point where the vehicle stands
    /// the first time it is ready; and its home in the fleet frame. The
    /// autopilot's home is what a ground station restarted in flight finds
    /// again, so that a resumed motion flies to the journaled target.
    pub(super) fn set_anchor(&self) {
        let w = self.watched.borrow().clone();
        let mut frame = self.frame.lock().unwrap_or_else(|p| p.into_inner());
        if frame.anchor.is_some() {
            return;
        }
        let Some(anchor) = w.vehicle.home_local.or(w.vehicle.local.map(|l| l.position)) else {
            return;
        };
        frame.anchor = Some(anchor);
        let mut detail = format!(
            "ready; the mission frame's origin is N {:.2} E {:.2} D {:.2} in the EKF frame{}",
            anchor.north,
            anchor.east,
            anchor.down,
            if w.vehicle.home_local.is_some() {
                " (the autopilot's home)"
            } else {
                " (where it stands)"
            }
        );
        // The autopilot's own home where it has said it, else where its GPS
        // puts the drone now: the drone's home in the one fleet frame.
        let reported = w
            .vehicle
            .home
            .map(|h| (h, "HOME_POSITION"))
            .or(w.vehicle.global.map(|g| (g, "GPS")));
        let mut moved = None;
        if let (Some(origin), Some((here, source))) = (self.options.fleet_origin, reported) {
            let assumed = frame.home;
            // Where it stands on the ground the fleet file describes: GPS
            // heights are poor, and the origin need not carry the ground's.
            frame.home = Vec3 {
                z: assumed.z,
                ..LocalFrame::new(origin).to_local(here)
            };
            detail.push_str(&format!(
                "; home in the fleet frame {} from {source} {:.7}, {:.7}",
                frame.home, here.lat, here.lon
            ));
            let gap = (assumed - frame.home).horizontal_norm();
            if gap > HOME_GAP {
                moved = Some(format!(
                    "the autopilot puts the drone's home at {} in the fleet frame ({source}), {gap:.1} m from {assumed}, where the fleet file puts it and the spatial check assumed it: correct the fleet file's home and check again",
                    frame.home
                ));
            }
        }
        drop(frame);
        self.note(detail);
        if let Some(moved) = moved {
            self.warn(moved);
        }
        self.publish_telemetry();
    }

    /// Puts the autopilot in the mode for `role` and confirms from two
    /// further heartbeats that it stayed there: right after boot an RC mode
    /// switch may overwrite a mode set from the ground.
    pub(super) async fn ensure_mode(
        &self,
        action: &str,
        role: ModeRole,
        cancel: &CancellationToken,
    ) -> Result<(), ActionError> {
        let strategy = self.flyable(action)?;
        let autopilot = strategy.autopilot();
        let wanted = autopilot
            .mode_for(role)
            .expect("a flyable autopilot has every mode the adapter uses");
        let name = autopilot.mode_name(wanted);
        if self.watched.borrow().vehicle.custom_mode() == Some(wanted) {
            return Ok(());
        }
        if role == ModeRole::Guided && strategy.streams_setpoints() {
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
    pub(super) async fn start_offboard_stream(&self, action: &str) -> Result<(), ActionError> {
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
    pub(super) fn stop_offboard_stream(&self) {
        *self.offboard.lock().unwrap_or_else(|p| p.into_inner()) = None;
    }
}
