//! What an action does to the drone as data: the flight states it may start
//! in and leaves, where it flies, and how long it takes nominally.
//!
//! These are the declarations a checker reads to find an action in the
//! wrong flight state (taking off twice, flying before take-off), that a
//! plan view reads to draw legs and timelines, and that a simulator reads
//! to run an action it has no code of its own for. They describe the
//! mission's contract, not the physics: an adapter may accept more (the
//! simulator arms an armed drone again as a no-op), and a real flight takes
//! longer than its nominal duration (it accelerates and brakes).
//!
//! This module knows nothing of profiles: it works on argument values the
//! caller looked up by parameter name.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A point of the drone's local frame: metres north, east and up of home.
pub type Point = [f64; 3];

/// Where a drone is, as far as the order of its actions is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FlightState {
    /// On the ground with the motors disarmed: how every drone starts.
    Disarmed,
    /// On the ground with the motors armed.
    Armed,
    /// In the air (armed).
    Airborne,
}

impl FlightState {
    pub const ALL: [FlightState; 3] = [
        FlightState::Disarmed,
        FlightState::Armed,
        FlightState::Airborne,
    ];
}

impl fmt::Display for FlightState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            FlightState::Disarmed => "disarmed on the ground",
            FlightState::Armed => "armed on the ground",
            FlightState::Airborne => "in the air",
        })
    }
}

/// Where a motion takes the drone, from where it starts. Each variant names
/// the parameters (in metres) it reads.
///
/// In a profile: `motion = { by_x = "distance" }`, `motion = { to = ["x",
/// "y", "z"] }`, `motion = { climb_to = "height" }`, `motion = "land"`,
/// `motion = "home"`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// Along X (north) by the parameter, from the start.
    ByX(String),
    /// Along Y (east) by the parameter.
    ByY(String),
    /// Up (down if negative) by the parameter.
    ByZ(String),
    /// To the absolute point the three parameters give.
    To([String; 3]),
    /// Straight up to the height the parameter gives (a take-off).
    ClimbTo(String),
    /// Straight down to the ground.
    Land,
    /// Back above home at the height of the start.
    Home,
}

impl Motion {
    /// The parameters the motion reads.
    pub fn params(&self) -> Vec<&str> {
        match self {
            Motion::ByX(p) | Motion::ByY(p) | Motion::ByZ(p) | Motion::ClimbTo(p) => vec![p],
            Motion::To(ps) => ps.iter().map(String::as_str).collect(),
            Motion::Land | Motion::Home => Vec::new(),
        }
    }

    /// Where the motion ends when it starts at `start`; `arg` gives the
    /// value of a parameter by name. `None` when an argument is missing.
    pub fn target(&self, start: Point, arg: impl Fn(&str) -> Option<f64>) -> Option<Point> {
        let [x, y, z] = start;
        Some(match self {
            Motion::ByX(p) => [x + arg(p)?, y, z],
            Motion::ByY(p) => [x, y + arg(p)?, z],
            Motion::ByZ(p) => [x, y, z + arg(p)?],
            Motion::To([px, py, pz]) => [arg(px)?, arg(py)?, arg(pz)?],
            Motion::ClimbTo(p) => [x, y, arg(p)?],
            Motion::Land => [x, y, 0.0],
            Motion::Home => [0.0, 0.0, z],
        })
    }
}

/// How long an action takes nominally.
///
/// In a profile: `duration = { seconds = 2.0 }`, `duration = { param =
/// "duration" }`, `duration = "flight"`. An action that declares none is
/// instant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DurationModel {
    /// A fixed time, in seconds (a photo, a calibration).
    Seconds(f64),
    /// As many seconds as the named argument says (`Hover(3)`).
    Param(String),
    /// The length of its motion at the profile's nominal speeds.
    Flight,
}

impl Default for DurationModel {
    fn default() -> Self {
        DurationModel::Seconds(0.0)
    }
}

/// The nominal speeds flights are timed at, metres per second. Nominal:
/// cruise speeds, no acceleration, so a real flight takes somewhat longer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Speeds {
    pub horizontal: f64,
    pub climb: f64,
    pub descent: f64,
}

impl Speeds {
    /// Seconds from `from` to `to` in a straight line: the horizontal and
    /// the vertical part are flown at once, each at its own speed, so the
    /// slower of the two decides.
    pub fn flight_time(&self, from: Point, to: Point) -> f64 {
        let horizontal = (to[0] - from[0]).hypot(to[1] - from[1]) / self.horizontal;
        let dz = to[2] - from[2];
        let vertical = if dz >= 0.0 {
            dz / self.climb
        } else {
            -dz / self.descent
        };
        horizontal.max(vertical)
    }

    pub(crate) fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("horizontal", self.horizontal),
            ("climb", self.climb),
            ("descent", self.descent),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("speeds.{name} must be above zero, not {v}"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_motion_ends_where_its_arguments_say_from_where_it_starts() {
        let arg = |p: &str| match p {
            "d" => Some(2.0),
            "h" => Some(5.0),
            _ => None,
        };
        let start = [1.0, 1.0, 3.0];
        assert_eq!(
            Motion::ByX("d".into()).target(start, arg),
            Some([3.0, 1.0, 3.0])
        );
        assert_eq!(
            Motion::ByZ("d".into()).target(start, arg),
            Some([1.0, 1.0, 5.0])
        );
        assert_eq!(
            Motion::ClimbTo("h".into()).target(start, arg),
            Some([1.0, 1.0, 5.0])
        );
        assert_eq!(Motion::Land.target(start, arg), Some([1.0, 1.0, 0.0]));
        assert_eq!(Motion::Home.target(start, arg), Some([0.0, 0.0, 3.0]));
        assert_eq!(Motion::ByY("nope".into()).target(start, arg), None);
    }

    #[test]
    fn a_flight_takes_as_long_as_its_slower_part() {
        let s = Speeds {
            horizontal: 5.0,
            climb: 2.0,
            descent: 1.0,
        };
        assert_eq!(s.flight_time([0.0; 3], [3.0, 4.0, 0.0]), 1.0);
        assert_eq!(s.flight_time([0.0; 3], [0.0, 0.0, 4.0]), 2.0);
        assert_eq!(s.flight_time([0.0, 0.0, 4.0], [5.0, 0.0, 0.0]), 4.0);
    }
}
