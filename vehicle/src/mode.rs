//! The imitated firmware's flight modes, and what each makes the copter do.

use eamos_mid::mavlink::modes::{Autopilot, CopterMode, Px4Mode};

use crate::firmware::Firmware;

/// What a mode makes the copter do, whichever firmware numbers it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Role {
    /// A pilot flies it (sticks centred: it holds).
    Manual,
    /// It holds position by itself.
    Hold,
    /// It flies position targets from the ground station (GUIDED, OFFBOARD).
    Guided,
    Land,
    Rtl,
    /// PX4's AUTO.TAKEOFF: climbs, then holds.
    Takeoff,
}

/// A flight mode of the imitated firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Mode {
    pub(crate) firmware: Firmware,
    pub(crate) custom: u32,
}

impl Mode {
    pub(crate) fn copter(m: CopterMode) -> Mode {
        Mode {
            firmware: Firmware::ArduPilot,
            custom: m.custom_mode(),
        }
    }

    pub(crate) fn px4(m: Px4Mode) -> Mode {
        Mode {
            firmware: Firmware::Px4,
            custom: m.custom_mode(),
        }
    }

    /// The mode at boot, and the one the RC switch selects.
    pub(crate) fn boot(firmware: Firmware) -> Mode {
        match firmware {
            Firmware::ArduPilot => Mode::copter(CopterMode::Stabilize),
            Firmware::Px4 => Mode::px4(Px4Mode::Manual),
        }
    }

    pub(crate) fn for_role(firmware: Firmware, role: Role) -> Mode {
        match (firmware, role) {
            (Firmware::ArduPilot, Role::Land) => Mode::copter(CopterMode::Land),
            (Firmware::ArduPilot, Role::Rtl) => Mode::copter(CopterMode::Rtl),
            (Firmware::ArduPilot, Role::Guided) => Mode::copter(CopterMode::Guided),
            (Firmware::ArduPilot, _) => Mode::copter(CopterMode::Loiter),
            (Firmware::Px4, Role::Land) => Mode::px4(Px4Mode::AutoLand),
            (Firmware::Px4, Role::Rtl) => Mode::px4(Px4Mode::AutoRtl),
            (Firmware::Px4, Role::Guided) => Mode::px4(Px4Mode::Offboard),
            (Firmware::Px4, Role::Takeoff) => Mode::px4(Px4Mode::AutoTakeoff),
            (Firmware::Px4, _) => Mode::px4(Px4Mode::AutoLoiter),
        }
    }

    /// What the mode does, or `None` when the firmware has no such mode
    /// or the test vehicle does not simulate it.
    pub(crate) fn role_of(firmware: Firmware, custom: u32) -> Option<Role> {
        match firmware {
            Firmware::ArduPilot => {
                use CopterMode::*;
                Some(match CopterMode::from_custom_mode(custom)? {
                    Stabilize | AltHold => Role::Manual,
                    Loiter | PosHold | Brake => Role::Hold,
                    Guided => Role::Guided,
                    Land => Role::Land,
                    Rtl => Role::Rtl,
                    _ => return None,
                })
            }
            Firmware::Px4 => {
                use Px4Mode::*;
                Some(match Px4Mode::from_custom_mode(custom)? {
                    Manual | AltCtl | PosCtl | Stabilized => Role::Manual,
                    AutoLoiter => Role::Hold,
                    Offboard => Role::Guided,
                    AutoLand => Role::Land,
                    AutoRtl => Role::Rtl,
                    AutoTakeoff => Role::Takeoff,
                    _ => return None,
                })
            }
        }
    }

    pub(crate) fn role(self) -> Role {
        Mode::role_of(self.firmware, self.custom).unwrap_or(Role::Manual)
    }

    pub(crate) fn name(self) -> String {
        match self.firmware {
            Firmware::ArduPilot => Autopilot::ArduPilot.mode_name(self.custom),
            Firmware::Px4 => Autopilot::Px4.mode_name(self.custom),
        }
    }

    /// Whether the mode needs the EKF's position (an origin).
    pub(crate) fn needs_position(self) -> bool {
        match self.role() {
            Role::Manual => {
                self.custom == Px4Mode::PosCtl.custom_mode() && self.firmware == Firmware::Px4
            }
            Role::Land => false,
            _ => true,
        }
    }
}
