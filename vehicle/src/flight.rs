//! Entering a flight mode: which the vehicle refuses, and what the copter
//! does on entering one.

use eamos_geo::Vec3;
use eamos_mid::mavlink::dialect::MavResult;
use eamos_mid::mavlink::modes::{CopterMode, Px4Mode};
use eamos_mid::FlightMode;

use crate::firmware::Firmware;
use crate::mode::{Mode, Role};
use crate::px4::PX4_TAKEOFF_HEIGHT;
use crate::state::Vehicle;

impl Vehicle {
    pub(crate) fn set_mode_number(&mut self, number: u32) -> MavResult {
        let firmware = self.o.autopilot;
        let mode = Mode {
            firmware,
            custom: number,
        };
        let known = match firmware {
            Firmware::ArduPilot => CopterMode::from_custom_mode(number).is_some(),
            Firmware::Px4 => Px4Mode::from_custom_mode(number).is_some(),
        };
        if !known {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!("Flight mode change failed: no mode {number:#x}"),
            );
        }
        if Mode::role_of(firmware, number).is_none() {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!("Flight mode change failed: {} not simulated", mode.name()),
            );
        }
        if mode.needs_position() && !self.has_origin() {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!(
                    "Flight mode change failed: {} requires position",
                    mode.name()
                ),
            );
        }
        if firmware == Firmware::Px4 && mode.role() == Role::Guided && !self.setpoints_fresh() {
            // PX4 enters OFFBOARD only with setpoints already streaming.
            return self.refuse(
                MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
                "Switching to OFFBOARD is not available: no offboard setpoints",
            );
        }
        if firmware == Firmware::Px4 && mode.role() == Role::Takeoff && !self.kin.is_armed() {
            return self.refuse(
                MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
                "Takeoff denied: disarmed",
            );
        }
        self.set_mode(mode);
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// Enters a mode: what the copter does on entering it.
    pub(crate) fn set_mode(&mut self, mode: Mode) {
        if mode != self.mode {
            tracing::info!("sim-vehicle {}: mode {}", self.o.system_id, mode.name());
        }
        self.mode = mode;
        self.returning = false;
        match mode.role() {
            Role::Land => self.kin.land(),
            Role::Rtl => {
                if self.kin.is_airborne() {
                    let z = self.kin.position().z;
                    if self
                        .kin
                        .go_to(Vec3::new(0.0, 0.0, z), FlightMode::ReturnHome)
                        .is_ok()
                    {
                        self.returning = true;
                    } else {
                        self.kin.land();
                    }
                }
            }
            Role::Takeoff => {
                if !self.kin.is_airborne() {
                    let _ = self.px4_climb(PX4_TAKEOFF_HEIGHT);
                }
            }
            Role::Guided if mode.firmware == Firmware::Px4 => {
                // OFFBOARD flies the setpoint that is streaming.
                self.kin.hold();
                if let Some((_, ned)) = self.setpoint {
                    self.offboard_target(ned);
                }
            }
            // Every other mode holds where it is: GUIDED until given a
            // target, the manual ones as a pilot would with sticks centred.
            _ => {
                if self.kin.is_airborne() {
                    self.kin.hold();
                }
            }
        }
    }
}
