//! PX4: OFFBOARD lives on a setpoint stream, and a setpoint above the
//! ground is its take-off.

use super::{Strategy, TakeoffStart};
use crate::mavlink::modes::Autopilot;

/// EKF_STATUS_REPORT is ArduPilot's; PX4 never sends it.
const EKF_STATUS_REPORT: u32 = 193;

/// PX4's ways.
#[derive(Debug, Clone, Copy)]
pub struct Px4;

impl Strategy for Px4 {
    fn autopilot(&self) -> Autopilot {
        Autopilot::Px4
    }

    /// PX4 has no take-off in OFFBOARD other than a setpoint above the
    /// ground.
    fn takeoff(&self, height: f64) -> TakeoffStart {
        TakeoffStart::SetpointAbove(height)
    }

    /// OFFBOARD is refused unless setpoints stream faster than 2 Hz, and
    /// left (a failsafe) when they stop.
    fn streams_setpoints(&self) -> bool {
        true
    }

    fn sends(&self, id: u32) -> bool {
        id != EKF_STATUS_REPORT
    }
}
