//! PX4's ways: take-off in AUTO.TAKEOFF or by a setpoint in OFFBOARD.

use eamos_geo::Ned;
use eamos_mid::mavlink::dialect::MavResult;
use eamos_mid::FlightMode;

use crate::firmware::Firmware;
use crate::mode::{Mode, Role};
use crate::state::Vehicle;

/// PX4's default take-off height (`MIS_TAKEOFF_ALT`), metres.
pub(crate) const PX4_TAKEOFF_HEIGHT: f64 = 2.5;

impl Vehicle {
    /// PX4 `MAV_CMD_NAV_TAKEOFF`: param7 is an altitude above sea level
    /// (NaN: the default height); it climbs in AUTO.TAKEOFF.
    pub(crate) fn px4_takeoff(&mut self, altitude: f64) -> MavResult {
        if !self.kin.is_armed() {
            return self.refuse(MavResult::MAV_RESULT_DENIED, "Takeoff denied: disarmed");
        }
        if self.kin.is_airborne() {
            return self.refuse(
                MavResult::MAV_RESULT_DENIED,
                "Takeoff denied: already flying",
            );
        }
        let height = if altitude.is_finite() {
            altitude - self.o.home.alt
        } else {
            PX4_TAKEOFF_HEIGHT
        };
        match self.px4_climb(height) {
            Ok(()) => {
                self.mode = Mode::for_role(Firmware::Px4, Role::Takeoff);
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(text) => self.refuse(MavResult::MAV_RESULT_DENIED, &text),
        }
    }

    pub(crate) fn px4_climb(&mut self, height: f64) -> Result<(), String> {
        self.kin
            .takeoff(height)
            .map_err(|e| format!("Takeoff denied: {e}"))?;
        self.idle_since = None;
        Ok(())
    }

    /// PX4 in OFFBOARD flies to a setpoint (EKF frame); on the ground, a
    /// setpoint well above it is a take-off.
    pub(crate) fn offboard_target(&mut self, ned: Ned) {
        let target = (ned + self.o.ekf_origin_offset).to_mission();
        if !self.kin.is_armed() {
            return;
        }
        if self.kin.is_airborne() {
            if self.kin.mode() == FlightMode::Takeoff && !self.kin.arrived() {
                // Still climbing from the ground: let the climb finish
                // first, as PX4's take-off ramp does.
                return;
            }
            if let Err(e) = self.kin.go_to(target, FlightMode::Guided) {
                tracing::info!("sim-vehicle {}: ignored a setpoint: {e}", self.o.system_id);
            }
        } else if target.z > self.kin.position().z + 0.5 {
            if let Err(e) = self.px4_climb(target.z) {
                tracing::info!("sim-vehicle {}: {e}", self.o.system_id);
            }
        }
    }
}
