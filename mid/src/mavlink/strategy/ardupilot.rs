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

    /// `FS_GCS_ENABLE` is 0 by default: ArduCopter then does nothing when
    /// the ground station falls silent, and a copter in GUIDED hovers on.
    fn link_loss_params(&self) -> &'static [&'static str] {
        &["FS_GCS_ENABLE", "FS_GCS_TIMEOUT"]
    }

    fn link_loss_gap(&self, values: &[f64]) -> Option<String> {
        let enable = values.first().copied()?;
        let after = values.get(1).copied().unwrap_or(5.0);
        (enable == 0.0).then(|| {
            format!(
                "FS_GCS_ENABLE is 0: ArduCopter does nothing when the ground link is lost, so the drone would hover in GUIDED with nobody in charge until the link returns (FS_GCS_ENABLE = 1 returns it home, 5 lands it, {after} s after the link falls silent: FS_GCS_TIMEOUT)"
            )
        })
    }
}
