//! The vehicle's state, owned by its one task, and the autopilot's own
//! rules that run on every step of simulated time.

use std::collections::HashMap;

use eamos_geo::Ned;
use eamos_geo::Vec3;
use eamos_mid::mavlink::dialect::{MavMessage, MavSeverity, STATUSTEXT_DATA};
use eamos_mid::sim::kinematics::Multirotor;

use crate::firmware::Firmware;
use crate::mode::{Mode, Role};
use crate::options::SimVehicleOptions;

/// What a test may check of the vehicle from outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleSnapshot {
    /// Simulated seconds since boot.
    pub time: f64,
    /// Position from home (X north, Y east, Z up).
    pub position: Vec3,
    pub armed: bool,
    pub custom_mode: u32,
    pub on_ground: bool,
    pub photos: u32,
}

/// The vehicle's state, owned by its one task.
pub(crate) struct Vehicle {
    pub(crate) o: SimVehicleOptions,
    pub(crate) kin: Multirotor,
    pub(crate) time: f64,
    pub(crate) mode: Mode,
    /// PX4: when the last position setpoint came, and where it was (EKF
    /// frame), whatever the mode.
    pub(crate) setpoint: Option<(f64, Ned)>,
    /// Requested message intervals (simulated seconds) and when each is
    /// next due.
    pub(crate) streams: HashMap<u32, (f64, f64)>,
    pub(crate) next_heartbeat: f64,
    /// When the copter was armed on the ground without taking off since.
    pub(crate) idle_since: Option<f64>,
    /// RTL: flying home before landing.
    pub(crate) returning: bool,
    /// Milestones already announced: GPS, origin, using GPS, RC switch.
    pub(crate) announced: [bool; 4],
    pub(crate) next_prearm_text: f64,
    pub(crate) photos: u32,
    /// When a ground station's heartbeat last came (ArduPilot's GCS
    /// failsafe counts from it).
    pub(crate) gcs_heard: Option<f64>,
    /// Messages to send after this step.
    pub(crate) outbox: Vec<MavMessage>,
}

impl Vehicle {
    pub(crate) fn new(o: SimVehicleOptions) -> Self {
        let kin = Multirotor::new(o.kinematics.clone());
        let boot_mode = Mode::boot(o.autopilot);
        Self {
            o,
            kin,
            time: 0.0,
            mode: boot_mode,
            setpoint: None,
            streams: HashMap::new(),
            next_heartbeat: 0.0,
            idle_since: None,
            returning: false,
            announced: [false; 4],
            // After the first heartbeats, so a ground station knows whose
            // text it is.
            next_prearm_text: 2.0,
            photos: 0,
            gcs_heard: None,
            outbox: Vec::new(),
        }
        .with_default_streams()
    }

    pub(crate) fn gps_fix_at(&self) -> f64 {
        self.o.ready_after * 0.22
    }

    pub(crate) fn origin_at(&self) -> f64 {
        self.o.ready_after * 0.46
    }

    pub(crate) fn has_fix(&self) -> bool {
        self.time >= self.gps_fix_at()
    }

    pub(crate) fn has_origin(&self) -> bool {
        self.time >= self.origin_at()
    }

    pub(crate) fn ready(&self) -> bool {
        self.time >= self.o.ready_after
    }

    /// Why the pre-arm checks fail, in the firmware's manner.
    pub(crate) fn prearm_failure(&self) -> Option<&'static str> {
        let px4 = self.o.autopilot == Firmware::Px4;
        if !self.has_fix() {
            Some(if px4 {
                "Preflight Fail: GPS fix too low"
            } else {
                "PreArm: GPS 1: Bad fix"
            })
        } else if !self.ready() {
            Some(if px4 {
                "Preflight Fail: horizontal position unstable"
            } else {
                "PreArm: Need Position Estimate"
            })
        } else {
            None
        }
    }

    pub(crate) fn snapshot(&self) -> VehicleSnapshot {
        VehicleSnapshot {
            time: self.time,
            position: self.kin.position(),
            armed: self.kin.is_armed(),
            custom_mode: self.mode.custom,
            on_ground: self.kin.on_ground(),
            photos: self.photos,
        }
    }

    pub(crate) fn say(&mut self, severity: MavSeverity, text: &str) {
        tracing::info!("sim-vehicle {}: {text}", self.o.system_id);
        self.outbox.push(MavMessage::STATUSTEXT(STATUSTEXT_DATA {
            severity,
            text: text.into(),
        }));
    }

    /// One step of simulated time: the copter moves, and the autopilot's
    /// own rules run (readiness milestones, RC switch, auto-disarm, LAND).
    pub(crate) fn step(&mut self) {
        let dt = self.o.step;
        let events = self.kin.step(dt);
        self.time += dt;

        if self.has_fix() && !self.announced[0] {
            self.announced[0] = true;
            self.say(
                MavSeverity::MAV_SEVERITY_INFO,
                "GPS 1: detected u-blox, 3D fix",
            );
        }
        if self.has_origin() && !self.announced[1] {
            self.announced[1] = true;
            self.say(MavSeverity::MAV_SEVERITY_INFO, "EKF3 IMU0 origin set");
        }
        if self.ready() && !self.announced[2] {
            self.announced[2] = true;
            self.say(MavSeverity::MAV_SEVERITY_INFO, "EKF3 IMU0 is using GPS");
        }
        if let Some(at) = self.o.rc_mode_switch_at {
            if self.time >= at && !self.announced[3] {
                self.announced[3] = true;
                let manual = Mode::boot(self.o.autopilot);
                if self.mode != manual {
                    tracing::info!(
                        "sim-vehicle {}: the RC mode switch selects {} over {}",
                        self.o.system_id,
                        manual.name(),
                        self.mode.name()
                    );
                }
                self.set_mode(manual);
            }
        }
        if let Some(text) = self.prearm_failure() {
            if self.time >= self.next_prearm_text {
                self.next_prearm_text = self.time + 30.0;
                self.say(MavSeverity::MAV_SEVERITY_CRITICAL, text);
            }
        }

        let landing_mode = matches!(self.mode.role(), Role::Land | Role::Rtl);
        if events.touched_down && self.kin.is_armed() && landing_mode {
            let _ = self.kin.disarm();
            self.say(MavSeverity::MAV_SEVERITY_INFO, "Land complete; disarming");
        }
        if events.lifted_off {
            self.idle_since = None;
        }
        if self.kin.is_armed() && self.kin.on_ground() {
            let since = *self.idle_since.get_or_insert(self.time);
            if self.time - since >= self.o.idle_disarm_after {
                let _ = self.kin.disarm();
                self.idle_since = None;
                self.say(
                    MavSeverity::MAV_SEVERITY_INFO,
                    "Disarming motors (auto disarm)",
                );
            }
        } else if !self.kin.is_armed() {
            self.idle_since = None;
        }
        if self.returning && self.kin.arrived() {
            self.returning = false;
            self.kin.land();
        }
        if self.mode.role() == Role::Takeoff && self.kin.is_airborne() && self.kin.arrived() {
            self.say(MavSeverity::MAV_SEVERITY_INFO, "Takeoff complete: holding");
            self.set_mode(Mode::for_role(self.o.autopilot, Role::Hold));
        }
        // PX4's offboard-loss failsafe: OFFBOARD without a fresh setpoint
        // is left for the mode COM_OBL_RC_ACT names.
        if self.mode.firmware == Firmware::Px4
            && self.mode.role() == Role::Guided
            && !self.setpoints_fresh()
        {
            self.offboard_lost();
        }
        self.gcs_failsafe();
    }

    /// PX4 leaves OFFBOARD for `COM_OBL_RC_ACT`'s mode. Without RC sticks
    /// the pilot's modes are unavailable and it holds instead.
    fn offboard_lost(&mut self) {
        let action = self.param("COM_OBL_RC_ACT").unwrap_or(0.0) as i64;
        let (role, name) = match action {
            3 => (Role::Rtl, "Return"),
            4 => (Role::Land, "Land"),
            6 | 7 => {
                self.say(
                    MavSeverity::MAV_SEVERITY_EMERGENCY,
                    "Failsafe: offboard setpoints lost, disarming",
                );
                self.kin
                    .place(Vec3::new(self.kin.position().x, self.kin.position().y, 0.0));
                let _ = self.kin.disarm();
                self.set_mode(Mode::for_role(self.o.autopilot, Role::Hold));
                return;
            }
            _ => (Role::Hold, "Hold"),
        };
        self.say(
            MavSeverity::MAV_SEVERITY_CRITICAL,
            &format!("Failsafe: offboard setpoints lost, switching to {name}"),
        );
        self.set_mode(Mode::for_role(self.o.autopilot, role));
    }

    /// ArduCopter's GCS failsafe: with `FS_GCS_ENABLE` on, a flying copter
    /// that has heard no ground station for `FS_GCS_TIMEOUT` returns home
    /// or lands. A copter already landing or returning carries on.
    fn gcs_failsafe(&mut self) {
        if self.o.autopilot != Firmware::ArduPilot || !self.kin.is_airborne() {
            return;
        }
        let enable = self.param("FS_GCS_ENABLE").unwrap_or(0.0) as i64;
        let timeout = self.param("FS_GCS_TIMEOUT").unwrap_or(5.0);
        let Some(heard) = self.gcs_heard else { return };
        if enable == 0
            || self.time - heard < timeout
            || matches!(self.mode.role(), Role::Land | Role::Rtl)
        {
            return;
        }
        let role = match enable {
            4 | 5 | 7 => Role::Land,
            _ => Role::Rtl,
        };
        self.say(MavSeverity::MAV_SEVERITY_CRITICAL, "GCS Failsafe");
        self.set_mode(Mode::for_role(self.o.autopilot, role));
    }

    /// PX4: whether a setpoint came within the offboard loss time.
    pub(crate) fn setpoints_fresh(&self) -> bool {
        self.setpoint
            .is_some_and(|(at, _)| self.time - at <= self.o.offboard_loss_after)
    }
}
