//! How the adapter flies: its options, and the settings a fleet file may
//! give one MAVLink drone.

use std::fmt;
use std::sync::Arc;
use std::time::Duration;

use eamos_geo::Wgs84;

use crate::api::Vec3;
use crate::clock::{ClockFeed, MissionClock};
use crate::log::{NullSink, SharedSink};
use crate::mavlink::address::AddressError;
use crate::mavlink::command::CommandPolicy;

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
    /// A motion has arrived when within this distance of its target (m)
    /// and settled there (see [`Settle`]).
    pub arrival_tolerance: f64,
    /// How still the drone must be before a motion counts as done, so
    /// that the next motion does not cut the corner and `Land` does not
    /// start while the drone still moves.
    pub settle: Settle,
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
    /// Feeds the autopilot's time stamps to a clock that follows it (see
    /// [`MissionClock::following`]): the fleet's mission clock when this
    /// drone's autopilot keeps it.
    pub clock_feed: Option<Arc<std::sync::Mutex<ClockFeed>>>,
    /// What to do before the first arming when a lost link would leave
    /// the drone with nobody in charge (see `link_loss.rs`).
    pub lost_link: LostLinkCheck,
    /// The adapter log.
    pub log: SharedSink,
}

/// A drone has settled when its speed stayed at most `speed` for `time`
/// seconds of the autopilot's own clock (so a simulator's speed-up does
/// not shorten it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settle {
    /// m/s; above a hovering copter's velocity noise.
    pub speed: f64,
    /// Seconds.
    pub time: f64,
}

impl Default for Settle {
    fn default() -> Self {
        Settle {
            speed: 0.3,
            time: 0.5,
        }
    }
}

/// What the adapter does, before the first arming, about an autopilot
/// whose own link-loss failsafe would not take the drone over.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LostLinkCheck {
    /// Say so to the crew, and fly.
    #[default]
    Warn,
    /// Refuse to arm, naming the parameter.
    Refuse,
    /// Do not read the parameters (an autopilot that does not serve them).
    Off,
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
            arrival_tolerance: 0.2,
            settle: Settle::default(),
            min_speed: 0.3,
            motion_margin: Duration::from_secs(30),
            rearm_for_takeoff: true,
            clock: None,
            clock_feed: None,
            lost_link: LostLinkCheck::Warn,
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
            .field("settle", &self.settle)
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
/// arrival_tolerance = 0.2    # metres from the target
/// settle_speed = 0.3         # m/s: a motion is done once this still ...
/// settle_time = 0.5          # ... for this many seconds of the autopilot's clock
/// min_speed = 0.3            # m/s, for motion timeouts
/// fleet_origin = [46.6139, 14.2650, 446.0]   # lat, lon, alt: home from GPS
/// rearm_for_takeoff = true
/// ack_timeout = 1.5          # seconds to wait for a COMMAND_ACK before resending
/// command_attempts = 3       # sends of one command before giving up
/// motion_margin = 30         # seconds added to every motion's timeout
/// lost_link = "warn"         # "refuse" to arm, or "off", when a lost link would leave nobody in charge
/// ```
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MavlinkSettings {
    pub target_system: Option<u8>,
    pub ready_timeout: Option<f64>,
    pub require_gps: Option<bool>,
    pub link_timeout: Option<f64>,
    pub arrival_tolerance: Option<f64>,
    pub settle_speed: Option<f64>,
    pub settle_time: Option<f64>,
    pub min_speed: Option<f64>,
    pub fleet_origin: Option<[f64; 3]>,
    pub rearm_for_takeoff: Option<bool>,
    pub ack_timeout: Option<f64>,
    pub command_attempts: Option<u32>,
    pub motion_margin: Option<f64>,
    pub lost_link: Option<LostLinkCheck>,
}

impl MavlinkSettings {
    /// Checks the numbers; the message names the setting.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("ready_timeout", self.ready_timeout),
            ("link_timeout", self.link_timeout),
            ("arrival_tolerance", self.arrival_tolerance),
            ("settle_speed", self.settle_speed),
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
        if let Some(t) = self.settle_time {
            if !(t.is_finite() && (0.0..=60.0).contains(&t)) {
                return Err(format!(
                    "`settle_time` must be between 0 and 60 seconds, not {t}"
                ));
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
        if let Some(v) = self.settle_speed {
            options.settle.speed = v;
        }
        if let Some(t) = self.settle_time {
            options.settle.time = t;
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
        if let Some(c) = self.lost_link {
            options.lost_link = c;
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
        assert_eq!(o.arrival_tolerance, 0.2);
        assert_eq!(o.settle, Settle::default());
        assert_eq!(o.lost_link, LostLinkCheck::Warn);
        let settle = MavlinkSettings {
            settle_speed: Some(0.1),
            settle_time: Some(2.0),
            lost_link: Some(LostLinkCheck::Refuse),
            ..MavlinkSettings::default()
        };
        settle.apply(&mut o);
        assert_eq!(
            o.settle,
            Settle {
                speed: 0.1,
                time: 2.0
            }
        );
        assert_eq!(o.lost_link, LostLinkCheck::Refuse);
        let e = MavlinkSettings {
            settle_time: Some(-1.0),
            ..MavlinkSettings::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.contains("`settle_time`"), "{e}");
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
