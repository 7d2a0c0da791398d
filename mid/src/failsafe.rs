//! What a drone does when its mission cannot go on: the failsafes a fleet
//! file declares (`hold`, `land`, `home`), flown through the adapter's own
//! actions so that the simulator and a MAVLink autopilot do the same thing
//! in their own way (`Land` is the autopilot's LAND mode, `ReturnHome` its
//! position target above home). How an adapter flies one by default is
//! [`crate::api::fly_failsafe`], beside the trait it belongs to: this module
//! is data, so the drone API can name it without the two importing each
//! other.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A failsafe: where a drone goes when it stops flying its mission.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Failsafe {
    /// Stay where it is, in the air, waiting (a cancelled motion already
    /// holds its position, so holding flies nothing).
    Hold,
    /// Land where it is.
    #[default]
    Land,
    /// Fly back above home at the current height, then land there.
    Home,
}

impl Failsafe {
    pub fn name(self) -> &'static str {
        match self {
            Failsafe::Hold => "hold",
            Failsafe::Land => "land",
            Failsafe::Home => "home",
        }
    }
}

impl fmt::Display for Failsafe {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failsafes_are_written_in_lower_case_in_fleet_files() {
        #[derive(Deserialize)]
        struct F {
            on: Failsafe,
        }
        let f: F = toml::from_str("on = \"home\"").unwrap();
        assert_eq!(f.on, Failsafe::Home);
        assert!(toml::from_str::<F>("on = \"Home\"").is_err());
        assert_eq!(Failsafe::default().to_string(), "land");
    }
}
