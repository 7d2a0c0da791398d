//! The autopilot firmware a test vehicle imitates, and the parameters
//! each serves (its names, defaults and types): what the options are
//! checked against and what the vehicle answers a ground station with.

use eamos_mid::mavlink::dialect::MavParamType;

/// The autopilot firmware a test vehicle imitates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Firmware {
    #[default]
    ArduPilot,
    Px4,
}

impl Firmware {
    /// The firmware's defaults for what the vehicle acts on.
    pub(crate) fn params(self) -> &'static [(&'static str, f64, MavParamType)] {
        use MavParamType::*;
        match self {
            // FS_GCS_ENABLE 0: nothing happens when the ground link is lost.
            Firmware::ArduPilot => &[
                ("FS_GCS_ENABLE", 0.0, MAV_PARAM_TYPE_INT8),
                ("FS_GCS_TIMEOUT", 5.0, MAV_PARAM_TYPE_REAL32),
            ],
            // COM_OBL_RC_ACT 0: Position mode, which holds without sticks.
            Firmware::Px4 => &[
                ("COM_OF_LOSS_T", 1.0, MAV_PARAM_TYPE_REAL32),
                ("COM_OBL_RC_ACT", 0.0, MAV_PARAM_TYPE_INT32),
            ],
        }
    }

    /// Whether `name` is a parameter this firmware serves.
    pub(crate) fn knows_param(self, name: &str) -> bool {
        self.params().iter().any(|(n, ..)| *n == name)
    }
}
