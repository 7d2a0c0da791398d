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

    /// PX4 leaves OFFBOARD `COM_OF_LOSS_T` seconds after the setpoint
    /// stream stops, for the mode `COM_OBL_RC_ACT` names.
    fn link_loss_params(&self) -> &'static [&'static str] {
        &["COM_OF_LOSS_T", "COM_OBL_RC_ACT"]
    }

    fn link_loss_gap(&self, values: &[f64]) -> Option<String> {
        let after = values.first().copied().unwrap_or(1.0);
        let action = values.get(1).copied()?;
        let (name, leaves) = match action as i64 {
            3 | 4 => return None,
            0 => ("Position", "holds there for a pilot's sticks"),
            1 => (
                "Altitude",
                "holds its height for a pilot's sticks and drifts",
            ),
            2 => ("Manual", "waits for a pilot's sticks"),
            5 => ("Hold", "holds there"),
            6 => ("Terminate", "stops the motors in the air"),
            7 => ("Disarm", "stops the motors in the air"),
            _ => ("unknown", "does what this PX4 version makes of it"),
        };
        Some(format!(
            "COM_OBL_RC_ACT is {action} ({name}): {after} s after the setpoint stream stops (COM_OF_LOSS_T), PX4 leaves OFFBOARD for {name} and {leaves}, with nobody in charge until the link returns (COM_OBL_RC_ACT = 3 returns it home, 4 lands it)"
        ))
    }
}
