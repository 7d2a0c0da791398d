//! How a test vehicle is set up.

use eamos_geo::{Ned, Wgs84};
use eamos_mid::mavlink::ConnectAddress;
use eamos_mid::sim::kinematics::MultirotorConfig;

use crate::firmware::Firmware;

/// How the test vehicle is set up.
#[derive(Debug, Clone)]
pub struct SimVehicleOptions {
    /// Where it talks: `udpout:GCS` (like SITL's `--out`), `udpin:`,
    /// `tcpin:`.
    pub connect: ConnectAddress,
    pub system_id: u8,
    pub component_id: u8,
    /// Simulated seconds from boot until it is ready to arm.
    pub ready_after: f64,
    /// Simulated seconds per real second.
    pub speed: f64,
    /// Simulated seconds per step of the kinematics.
    pub step: f64,
    /// Where it stands at boot (and its home).
    pub home: Wgs84,
    /// Where the EKF origin lies from home (real EKFs set it at the first
    /// fix, rarely exactly where the copter stands when it arms).
    pub ekf_origin_offset: Ned,
    /// Simulated seconds after boot at which the RC mode switch selects
    /// STABILIZE, overwriting whatever mode was set before.
    pub rc_mode_switch_at: Option<f64>,
    /// An arming check that fails: arming is refused with this STATUSTEXT
    /// although the pre-arm checks pass ("Arm: Hardware safety switch").
    pub refuse_arming: Option<String>,
    /// Simulated seconds armed on the ground without taking off before it
    /// disarms itself.
    pub idle_disarm_after: f64,
    pub kinematics: MultirotorConfig,
    /// Whose behaviour it imitates.
    pub autopilot: Firmware,
    /// PX4: simulated seconds without a setpoint after which OFFBOARD is
    /// unavailable, or left for AUTO.LOITER (PX4's `COM_OF_LOSS_T`).
    pub offboard_loss_after: f64,
    /// Parameters set as on the autopilot (`FS_GCS_ENABLE`,
    /// `COM_OBL_RC_ACT`, ...), over the firmware's defaults.
    pub params: Vec<(String, f64)>,
    /// How far (m) the reported position of a flying copter wanders
    /// around where it is, as a real EKF's estimate does while hovering.
    pub position_noise: f64,
}

impl Default for SimVehicleOptions {
    fn default() -> Self {
        Self {
            connect: ConnectAddress::UdpOut("127.0.0.1:14550".to_string()),
            system_id: 1,
            component_id: 1,
            ready_after: 40.0,
            speed: 1.0,
            step: 0.02,
            // ArduPilot SITL's default location (CMAC, Canberra).
            home: Wgs84::new(-35.363_261, 149.165_230, 584.0),
            ekf_origin_offset: Ned::default(),
            rc_mode_switch_at: None,
            refuse_arming: None,
            idle_disarm_after: 10.0,
            kinematics: MultirotorConfig::default(),
            autopilot: Firmware::ArduPilot,
            offboard_loss_after: 1.0,
            params: Vec::new(),
            position_noise: 0.05,
        }
    }
}

impl SimVehicleOptions {
    /// Checks the numbers a command line may have got wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.speed.is_finite() && self.speed > 0.0) {
            return Err(format!("the speed must be above zero, not {}", self.speed));
        }
        if !(self.ready_after.is_finite() && self.ready_after >= 0.0) {
            return Err(format!(
                "the time to readiness must be zero or more seconds, not {}",
                self.ready_after
            ));
        }
        if !(self.step.is_finite() && (0.001..=0.1).contains(&self.step)) {
            return Err(format!(
                "the step must be between 0.001 and 0.1 s, not {}",
                self.step
            ));
        }
        if !(self.idle_disarm_after.is_finite() && self.idle_disarm_after > 0.0) {
            return Err(format!(
                "the idle disarm delay must be above zero, not {}",
                self.idle_disarm_after
            ));
        }
        if let Some(t) = self.rc_mode_switch_at {
            if !(t.is_finite() && t >= 0.0) {
                return Err(format!("the RC switch time must be zero or more, not {t}"));
            }
        }
        if !(self.offboard_loss_after.is_finite() && self.offboard_loss_after > 0.0) {
            return Err(format!(
                "the offboard loss time must be above zero, not {}",
                self.offboard_loss_after
            ));
        }
        if !(self.position_noise.is_finite() && (0.0..=5.0).contains(&self.position_noise)) {
            return Err(format!(
                "the position noise must be between 0 and 5 m, not {}",
                self.position_noise
            ));
        }
        for (name, value) in &self.params {
            if !self.autopilot.knows_param(name) {
                return Err(format!(
                    "the {} vehicle has no parameter {name} it acts on",
                    match self.autopilot {
                        Firmware::ArduPilot => "ArduPilot",
                        Firmware::Px4 => "PX4",
                    }
                ));
            }
            if !value.is_finite() {
                return Err(format!("parameter {name} must be a number, not {value}"));
            }
        }
        if self.system_id == 0 {
            return Err("system id 0 is the broadcast address".to_string());
        }
        self.kinematics.validate()
    }
}
