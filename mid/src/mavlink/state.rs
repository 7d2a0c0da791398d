//! The vehicle as the ground station knows it: a fold over the messages it
//! sent, kept pure (no I/O, time passed in) so that every rule is tested
//! without a link.
//!
//! Which vehicle: the first HEARTBEAT from something that is an autopilot
//! (not a ground station, not a camera with `MAV_AUTOPILOT_INVALID`) picks
//! the target system and component, unless the options pinned a system
//! id. Mode and armed state are read only from that component's
//! heartbeats; a gimbal in the same system must not make the drone look
//! disarmed.

use tokio::time::Instant;

use mavlink::MavHeader;

use super::command::Target;
use super::dialect::{MavAutopilot, MavLandedState, MavMessage, MavModeFlag, MavState, MavType};
use super::modes::Autopilot;
use super::readiness::Readiness;
use eamos_geo::{Ned, Wgs84};

/// The autopilot's heartbeat, decoded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Heartbeat {
    pub custom_mode: u32,
    pub armed: bool,
    pub system_status: MavState,
}

/// Local position and velocity relative to the EKF origin.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LocalPosition {
    pub position: Ned,
    pub velocity: Ned,
    /// When the autopilot measured it, seconds since its boot (its own
    /// clock, which runs at a simulator's speed-up where there is one).
    pub boot_time: f64,
}

/// Everything the adapter knows about its vehicle.
#[derive(Debug, Clone)]
pub struct VehicleState {
    /// A system id the options pinned; `None` takes the first autopilot.
    pinned_system: Option<u8>,
    pub target: Option<Target>,
    pub autopilot: Option<Autopilot>,
    pub heartbeat: Option<Heartbeat>,
    /// Heartbeats received from the target: mode confirmation counts them.
    pub heartbeats: u64,
    pub local: Option<LocalPosition>,
    pub global: Option<Wgs84>,
    /// The autopilot's own home (HOME_POSITION), once it said it.
    pub home: Option<Wgs84>,
    /// The same home in the EKF frame: the ground point the mission frame
    /// starts from, which a restarted ground station finds again while
    /// the drone flies.
    pub home_local: Option<Ned>,
    /// Battery charge in percent, where the autopilot knows it.
    pub battery: Option<f64>,
    pub landed_state: Option<MavLandedState>,
    pub readiness: Readiness,
    /// The latest STATUSTEXT and when it came.
    pub statustext: Option<(Instant, String)>,
    /// When the target was last heard (any message).
    pub last_heard: Option<Instant>,
}

/// Something worth telling the pilot that a message changed.
#[derive(Debug, Clone, PartialEq)]
pub enum Change {
    /// The target vehicle was found.
    Found(Target, Autopilot),
    /// The autopilot's mode changed (old, new custom mode).
    Mode(Option<u32>, u32),
    Armed(bool),
    StatusText(String),
}

impl VehicleState {
    pub fn new(pinned_system: Option<u8>) -> Self {
        Self::with_readiness(pinned_system, Readiness::new())
    }

    /// A state whose readiness follows `readiness`'s rules (see
    /// [`Readiness::without_gps`]).
    pub fn with_readiness(pinned_system: Option<u8>, readiness: Readiness) -> Self {
        Self {
            pinned_system,
            target: None,
            autopilot: None,
            heartbeat: None,
            heartbeats: 0,
            local: None,
            global: None,
            home: None,
            home_local: None,
            battery: None,
            landed_state: None,
            readiness,
            statustext: None,
            last_heard: None,
        }
    }

    /// Folds in one received message; returns what changed that a pilot
    /// would want to read in the log.
    pub fn observe(
        &mut self,
        header: &MavHeader,
        message: &MavMessage,
        now: Instant,
    ) -> Vec<Change> {
        let mut changes = Vec::new();
        let Ok(system) = u8::try_from(header.system_id) else {
            return changes;
        };
        if self.target.is_none() {
            if let MavMessage::HEARTBEAT(hb) = message {
                let is_autopilot = !matches!(
                    hb.mavtype,
                    MavType::MAV_TYPE_GCS | MavType::MAV_TYPE_ONBOARD_CONTROLLER
                ) && hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID;
                if is_autopilot && self.pinned_system.is_none_or(|s| s == system) {
                    let target = Target {
                        system,
                        component: header.component_id,
                    };
                    let autopilot = Autopilot::from_mavlink(hb.autopilot);
                    self.target = Some(target);
                    self.autopilot = Some(autopilot);
                    changes.push(Change::Found(target, autopilot));
                }
            }
        }
        let Some(target) = self.target else {
            return changes;
        };
        if system != target.system {
            return changes;
        }
        self.last_heard = Some(now);
        match message {
            MavMessage::HEARTBEAT(hb) => {
                if header.component_id != target.component {
                    return changes;
                }
                let new = Heartbeat {
                    custom_mode: hb.custom_mode,
                    armed: hb
                        .base_mode
                        .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED),
                    system_status: hb.system_status,
                };
                let old = self.heartbeat.replace(new);
                if old.map(|o| o.custom_mode) != Some(new.custom_mode) {
                    changes.push(Change::Mode(old.map(|o| o.custom_mode), new.custom_mode));
                }
                if old.map(|o| o.armed) != Some(new.armed) && (old.is_some() || new.armed) {
                    changes.push(Change::Armed(new.armed));
                }
                self.heartbeats += 1;
            }
            MavMessage::LOCAL_POSITION_NED(p) => {
                self.local = Some(LocalPosition {
                    position: Ned::new(f64::from(p.x), f64::from(p.y), f64::from(p.z)),
                    velocity: Ned::new(f64::from(p.vx), f64::from(p.vy), f64::from(p.vz)),
                    boot_time: f64::from(p.time_boot_ms) / 1000.0,
                });
            }
            MavMessage::GLOBAL_POSITION_INT(g) => {
                self.global = Some(Wgs84::from_e7(g.lat, g.lon, g.alt));
            }
            MavMessage::HOME_POSITION(h) => {
                self.home = Some(Wgs84::from_e7(h.latitude, h.longitude, h.altitude));
                self.home_local = Some(Ned::new(f64::from(h.x), f64::from(h.y), f64::from(h.z)));
            }
            MavMessage::SYS_STATUS(s) if s.battery_remaining >= 0 => {
                self.battery = Some(f64::from(s.battery_remaining));
            }
            MavMessage::EXTENDED_SYS_STATE(e)
                if e.landed_state != MavLandedState::MAV_LANDED_STATE_UNDEFINED =>
            {
                self.landed_state = Some(e.landed_state);
            }
            MavMessage::STATUSTEXT(t) => {
                if let Ok(text) = t.text.to_str() {
                    let text = text.trim().to_string();
                    self.statustext = Some((now, text.clone()));
                    changes.push(Change::StatusText(text));
                }
            }
            _ => {}
        }
        self.readiness.observe(message);
        changes
    }

    pub fn armed(&self) -> bool {
        self.heartbeat.is_some_and(|h| h.armed)
    }

    pub fn custom_mode(&self) -> Option<u32> {
        self.heartbeat.map(|h| h.custom_mode)
    }

    /// On the ground: the autopilot's landed state where it reports one
    /// (ArduPilot does once EXTENDED_SYS_STATE is requested); otherwise a
    /// disarmed copter is on the ground and an armed one is judged by
    /// height above the ground it stood on and vertical speed.
    pub fn landed(&self, ground_down: f64) -> bool {
        match self.landed_state {
            Some(MavLandedState::MAV_LANDED_STATE_ON_GROUND) => true,
            Some(_) => false,
            None => {
                if !self.armed() {
                    return true;
                }
                match self.local {
                    Some(l) => ground_down - l.position.down < 0.2 && l.velocity.down.abs() < 0.1,
                    None => true,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::dialect::{
        MavVtolState, EXTENDED_SYS_STATE_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA,
        SYS_STATUS_DATA,
    };

    fn from(system: u32, component: u8) -> MavHeader {
        MavHeader {
            system_id: system,
            component_id: component,
            sequence: 0,
        }
    }

    fn heartbeat(mavtype: MavType, autopilot: MavAutopilot, mode: u32, armed: bool) -> MavMessage {
        let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
        if armed {
            base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
        }
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: mode,
            mavtype,
            autopilot,
            base_mode: base,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    fn copter(mode: u32, armed: bool) -> MavMessage {
        heartbeat(
            MavType::MAV_TYPE_QUADROTOR,
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            mode,
            armed,
        )
    }

    #[test]
    fn the_first_autopilot_heartbeat_picks_the_vehicle_and_others_are_ignored() {
        let now = Instant::now();
        let mut s = VehicleState::new(None);
        // A ground station and a camera are heard first.
        s.observe(
            &from(255, 190),
            &heartbeat(
                MavType::MAV_TYPE_GCS,
                MavAutopilot::MAV_AUTOPILOT_INVALID,
                0,
                false,
            ),
            now,
        );
        s.observe(
            &from(1, 100),
            &heartbeat(
                MavType::MAV_TYPE_CAMERA,
                MavAutopilot::MAV_AUTOPILOT_INVALID,
                0,
                false,
            ),
            now,
        );
        assert_eq!(s.target, None);
        let changes = s.observe(&from(1, 1), &copter(0, false), now);
        assert_eq!(
            changes[0],
            Change::Found(
                Target {
                    system: 1,
                    component: 1
                },
                Autopilot::ArduPilot
            )
        );
        // Another vehicle on the same link does not move our position.
        s.observe(
            &from(2, 1),
            &MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                x: 9.0,
                ..Default::default()
            }),
            now,
        );
        assert_eq!(s.local, None);
        // The camera's heartbeat does not change mode or armed state.
        s.observe(&from(1, 1), &copter(4, true), now);
        s.observe(
            &from(1, 100),
            &heartbeat(
                MavType::MAV_TYPE_CAMERA,
                MavAutopilot::MAV_AUTOPILOT_INVALID,
                0,
                false,
            ),
            now,
        );
        assert!(s.armed());
        assert_eq!(s.custom_mode(), Some(4));
        assert_eq!(s.heartbeats, 2);
    }

    #[test]
    fn a_pinned_system_id_waits_for_that_vehicle() {
        let now = Instant::now();
        let mut s = VehicleState::new(Some(2));
        s.observe(&from(1, 1), &copter(0, false), now);
        assert_eq!(s.target, None);
        s.observe(&from(2, 1), &copter(0, false), now);
        assert_eq!(s.target.map(|t| t.system), Some(2));
    }

    #[test]
    fn mode_and_arming_changes_are_reported_once() {
        let now = Instant::now();
        let mut s = VehicleState::new(None);
        s.observe(&from(1, 1), &copter(0, false), now);
        assert!(s.observe(&from(1, 1), &copter(0, false), now).is_empty());
        assert_eq!(
            s.observe(&from(1, 1), &copter(4, false), now),
            vec![Change::Mode(Some(0), 4)]
        );
        assert_eq!(
            s.observe(&from(1, 1), &copter(4, true), now),
            vec![Change::Armed(true)]
        );
    }

    #[test]
    fn local_position_is_read_in_ned_and_battery_when_known() {
        let now = Instant::now();
        let mut s = VehicleState::new(None);
        s.observe(&from(1, 1), &copter(4, true), now);
        s.observe(
            &from(1, 1),
            &MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                x: 1.0,
                y: 2.0,
                z: -3.0,
                vz: -0.5,
                ..Default::default()
            }),
            now,
        );
        let l = s.local.unwrap();
        assert_eq!(l.position, Ned::new(1.0, 2.0, -3.0));
        assert_eq!(l.velocity.down, -0.5);
        s.observe(
            &from(1, 1),
            &MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                battery_remaining: -1,
                ..Default::default()
            }),
            now,
        );
        assert_eq!(s.battery, None, "-1 means the autopilot does not know");
        s.observe(
            &from(1, 1),
            &MavMessage::SYS_STATUS(SYS_STATUS_DATA {
                battery_remaining: 76,
                ..Default::default()
            }),
            now,
        );
        assert_eq!(s.battery, Some(76.0));
    }

    #[test]
    fn landed_follows_the_autopilots_landed_state_when_it_reports_one() {
        let now = Instant::now();
        let mut s = VehicleState::new(None);
        s.observe(&from(1, 1), &copter(4, true), now);
        // Without EXTENDED_SYS_STATE: an armed copter 3 m up is flying.
        s.observe(
            &from(1, 1),
            &MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
                z: -3.0,
                ..Default::default()
            }),
            now,
        );
        assert!(!s.landed(0.0));
        s.observe(
            &from(1, 1),
            &MavMessage::EXTENDED_SYS_STATE(EXTENDED_SYS_STATE_DATA {
                vtol_state: MavVtolState::MAV_VTOL_STATE_UNDEFINED,
                landed_state: MavLandedState::MAV_LANDED_STATE_ON_GROUND,
            }),
            now,
        );
        assert!(s.landed(0.0));
    }
}
