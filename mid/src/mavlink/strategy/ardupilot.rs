//! ArduCopter: GUIDED flies position targets as they come and takes off by
//! command.

use super::{Strategy, TakeoffStart};
use crate::mavlink::modes::Autopilot;

/// ArduCopter's ways.
#[derive(Debug, Clone, Copy)]
pub struct ArduPilot;

impl Strategy for ArduPilot {
    fn autopilot(&self) -> Autopilot {
        Autopilot::ArduPilot
    }

    /// `MAV_CMD_NAV_TAKEOFF`, param7 the height above home.
    fn takeoff(&self, height: f64) -> TakeoffStart {
        TakeoffStart::Command([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, height as f32])
    }

    /// GUIDED holds the last target without a stream.
    fn streams_setpoints(&self) -> bool {
        false
    }

    fn sends(&self, _id: u32) -> bool {
        true
    }
}
