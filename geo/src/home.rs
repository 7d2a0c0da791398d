//! A drone's home, as a fleet file gives it: local metres, or WGS84.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::{LocalFrame, Vec3, Wgs84};

/// Where a drone starts: in local metres of the fleet frame
/// (`{ x = .., y = .., z = .. }`) or on the earth (`{ lat = .., lon = .., alt = .. }`),
/// which needs the fleet's origin to become a point of the frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Home {
    Local(LocalHome),
    Wgs84(Wgs84),
}

/// A home in local metres; unknown keys are refused so that a misspelt
/// geographic home is not read as a local one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LocalHome {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// Why a home is not a point of the fleet frame.
#[derive(Debug, Clone, PartialEq)]
pub enum HomeError {
    /// A WGS84 home in a fleet without a geographic origin.
    NoOrigin,
    /// Not finite, or latitude or longitude out of range.
    Invalid(String),
}

impl fmt::Display for HomeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HomeError::NoOrigin => write!(
                f,
                "a home in latitude and longitude needs the fleet's `origin` (lat, lon) to place it"
            ),
            HomeError::Invalid(why) => write!(f, "the home is not a point: {why}"),
        }
    }
}

impl std::error::Error for HomeError {}

impl From<Vec3> for Home {
    fn from(v: Vec3) -> Self {
        Home::Local(LocalHome {
            x: v.x,
            y: v.y,
            z: v.z,
        })
    }
}

/// Where a drone that no fleet file places starts: the drones of a mission
/// stand in a row along Y (east), 3 m apart, in declaration order, so that
/// their paths can be told apart (the simulator, the checker and the plot
/// all place them so).
pub fn default_home(index: usize) -> Vec3 {
    Vec3::new(0.0, 3.0 * index as f64, 0.0)
}

impl Home {
    /// The home as a point of the fleet frame, `frame` being the fleet's
    /// geographic origin if it has one.
    pub fn resolve(&self, frame: Option<&LocalFrame>) -> Result<Vec3, HomeError> {
        match *self {
            Home::Local(LocalHome { x, y, z }) => {
                let v = Vec3::new(x, y, z);
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(HomeError::Invalid(format!("{v} is not finite")))
                }
            }
            Home::Wgs84(p) => {
                let p = p.validated().map_err(HomeError::Invalid)?;
                let frame = frame.ok_or(HomeError::NoOrigin)?;
                Ok(frame.to_local(p))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    struct Entry {
        home: Home,
    }

    fn read(text: &str) -> Result<Home, toml::de::Error> {
        toml::from_str::<Entry>(text).map(|e| e.home)
    }

    #[test]
    fn a_home_reads_in_local_metres_or_in_wgs84() {
        assert_eq!(
            read("home = { x = 1.0, y = 2.0, z = 0.0 }").unwrap(),
            Home::from(Vec3::new(1.0, 2.0, 0.0))
        );
        assert_eq!(
            read("home = { lat = 46.6, lon = 14.2, alt = 446.0 }").unwrap(),
            Home::Wgs84(Wgs84::new(46.6, 14.2, 446.0))
        );
        assert!(read("home = { x = 1.0, y = 2.0, z = 0.0, lat = 3.0 }").is_err());
        assert!(read("home = { lat = 46.6, lon = 14.2 }").is_err());
    }

    #[test]
    fn a_wgs84_home_lands_in_the_fleet_frame_and_needs_its_origin() {
        let origin = Wgs84::new(46.6139, 14.2650, 446.0);
        let frame = LocalFrame::new(origin);
        let there = frame.to_wgs84(Vec3::new(10.0, -4.0, 0.0));
        let home = Home::Wgs84(there).resolve(Some(&frame)).unwrap();
        assert!(home.distance(Vec3::new(10.0, -4.0, 0.0)) < 1e-3, "{home}");
        assert_eq!(Home::Wgs84(there).resolve(None), Err(HomeError::NoOrigin));
        let bad = Home::Wgs84(Wgs84::new(95.0, 0.0, 0.0)).resolve(Some(&frame));
        assert!(matches!(bad, Err(HomeError::Invalid(w)) if w.contains("latitude")));
        let local = Home::from(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(local.resolve(None), Ok(Vec3::new(1.0, 2.0, 3.0)));
    }
}
