//! The commands and messages the vehicle answers.

use eamos_geo::{Ned, Vec3};
use eamos_mid::mavlink::dialect::{
    MavCmd, MavDataStream, MavFrame, MavMessage, MavResult, MavSeverity, MavType,
    PositionTargetTypemask, COMMAND_ACK_DATA, COMMAND_LONG_DATA,
    SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use eamos_mid::mavlink::link::Received;
use eamos_mid::mavlink::modes::CopterMode;
use eamos_mid::FlightMode;

use crate::firmware::Firmware;
use crate::mode::{Mode, Role};
use crate::state::Vehicle;
use crate::telemetry::STREAMABLE;

/// ArduPilot's magic number that forces a disarm in flight.
const FORCE_DISARM: f32 = 21196.0;

impl Vehicle {
    pub(crate) fn for_me(&self, system: u8, component: u8) -> bool {
        (system == 0 || system == self.o.system_id)
            && (component == 0 || component == self.o.component_id)
    }

    pub(crate) fn handle(&mut self, r: &Received) {
        match &r.message {
            MavMessage::COMMAND_LONG(c) if self.for_me(c.target_system, c.target_component) => {
                let result = self.command(c);
                self.outbox.push(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                    command: c.command,
                    result,
                }));
            }
            MavMessage::SET_MODE(m) if self.for_me(m.target_system, 0) => {
                let result = self.set_mode_number(m.custom_mode);
                self.outbox.push(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                    command: MavCmd::MAV_CMD_DO_SET_MODE,
                    result,
                }));
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(t)
                if self.for_me(t.target_system, t.target_component) =>
            {
                self.position_target(t);
            }
            MavMessage::PARAM_REQUEST_READ(p)
                if self.for_me(p.target_system, p.target_component) =>
            {
                self.answer_param(p);
            }
            MavMessage::HEARTBEAT(h) if h.mavtype == MavType::MAV_TYPE_GCS => {
                self.gcs_heard = Some(self.time);
            }
            MavMessage::REQUEST_DATA_STREAM(r)
                if self.for_me(r.target_system, r.target_component) =>
            {
                let all = r.req_stream_id == MavDataStream::MAV_DATA_STREAM_ALL;
                for (id, group) in STREAMABLE {
                    if !self.streamable(*id) {
                        continue;
                    }
                    if all || *group == r.req_stream_id {
                        if r.start_stop == 0 || r.req_message_rate == 0 {
                            self.streams.remove(id);
                        } else {
                            let interval = 1.0 / f64::from(r.req_message_rate);
                            self.streams.insert(*id, (interval, self.time));
                        }
                    }
                }
            }
            _ => {}
        }
        // Answer messages queued while handling go out with the next step.
    }

    pub(crate) fn refuse(&mut self, result: MavResult, text: &str) -> MavResult {
        self.say(MavSeverity::MAV_SEVERITY_CRITICAL, text);
        result
    }

    pub(crate) fn command(&mut self, c: &COMMAND_LONG_DATA) -> MavResult {
        use MavResult::*;
        match c.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if c.param1 == 1.0 => self.arm(),
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if c.param1 == 0.0 => {
                if self.kin.is_airborne() && c.param2 != FORCE_DISARM {
                    return self.refuse(MAV_RESULT_FAILED, "Disarm: vehicle is flying");
                }
                if self.kin.is_airborne() {
                    // A forced disarm in the air: the copter falls.
                    self.kin
                        .place(Vec3::new(self.kin.position().x, self.kin.position().y, 0.0));
                }
                let _ = self.kin.disarm();
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_SET_MODE => {
                if c.param1 as u32 & 1 == 0 {
                    return MAV_RESULT_UNSUPPORTED;
                }
                let custom = match self.o.autopilot {
                    Firmware::ArduPilot => c.param2 as u32,
                    // PX4: main mode in param2, sub-mode in param3.
                    Firmware::Px4 => {
                        ((c.param2 as u32 & 0xff) << 16) | ((c.param3 as u32 & 0xff) << 24)
                    }
                };
                self.set_mode_number(custom)
            }
            MavCmd::MAV_CMD_NAV_TAKEOFF => match self.o.autopilot {
                Firmware::ArduPilot => self.takeoff(f64::from(c.param7)),
                Firmware::Px4 => self.px4_takeoff(f64::from(c.param7)),
            },
            MavCmd::MAV_CMD_NAV_LAND => {
                self.set_mode_number(Mode::for_role(self.o.autopilot, Role::Land).custom)
            }
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => {
                self.set_mode_number(Mode::for_role(self.o.autopilot, Role::Rtl).custom)
            }
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                let id = c.param1 as u32;
                if id == 0 {
                    // HEARTBEAT goes out at 1 Hz regardless.
                    return MAV_RESULT_ACCEPTED;
                }
                if !self.streamable(id) {
                    return MAV_RESULT_UNSUPPORTED;
                }
                let us = c.param2;
                if us < 0.0 {
                    self.streams.remove(&id);
                } else {
                    // 0 asks for the default rate: ArduPilot's is 4 Hz for
                    // these.
                    let interval = if us == 0.0 {
                        0.25
                    } else {
                        f64::from(us) * 1e-6
                    };
                    self.streams.insert(id, (interval.max(0.01), self.time));
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let id = c.param1 as u32;
                if id == 0 {
                    let hb = self.heartbeat();
                    self.outbox.push(hb);
                    return MAV_RESULT_ACCEPTED;
                }
                match self.message(id) {
                    Some(m) => {
                        self.outbox.push(m);
                        MAV_RESULT_ACCEPTED
                    }
                    None if self.streamable(id) => MAV_RESULT_FAILED,
                    None => MAV_RESULT_UNSUPPORTED,
                }
            }
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION => {
                if self.kin.is_armed() {
                    return self.refuse(MAV_RESULT_DENIED, "Calibration: vehicle is armed");
                }
                if c.param3 == 1.0 {
                    self.say(
                        MavSeverity::MAV_SEVERITY_INFO,
                        "Barometer calibration complete",
                    );
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_DIGICAM_CONTROL => {
                if c.param5 == 1.0 {
                    self.photos += 1;
                }
                MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_DO_DIGICAM_CONFIGURE => MAV_RESULT_ACCEPTED,
            MavCmd::MAV_CMD_RUN_PREARM_CHECKS => {
                if let Some(text) = self.prearm_failure() {
                    self.say(MavSeverity::MAV_SEVERITY_CRITICAL, text);
                }
                MAV_RESULT_ACCEPTED
            }
            _ => MAV_RESULT_UNSUPPORTED,
        }
    }

    pub(crate) fn arm(&mut self) -> MavResult {
        if self.kin.is_armed() {
            return MavResult::MAV_RESULT_ACCEPTED;
        }
        if let Some(text) = self.prearm_failure() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, text);
        }
        if let Some(text) = self.o.refuse_arming.clone() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, &text);
        }
        if matches!(self.mode.role(), Role::Land | Role::Rtl) {
            return self.refuse(MavResult::MAV_RESULT_FAILED, "Arm: Mode not armable");
        }
        match self.kin.arm() {
            Ok(()) => {
                tracing::info!("sim-vehicle {}: armed", self.o.system_id);
                self.idle_since = Some(self.time);
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(e) => self.refuse(MavResult::MAV_RESULT_FAILED, &format!("Arm: {e}")),
        }
    }

    pub(crate) fn takeoff(&mut self, height: f64) -> MavResult {
        if !self.kin.is_armed() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, "Takeoff: motors not armed");
        }
        if self.mode != Mode::copter(CopterMode::Guided) {
            return self.refuse(
                MavResult::MAV_RESULT_FAILED,
                &format!("Takeoff: not in GUIDED (in {})", self.mode.name()),
            );
        }
        if self.kin.is_airborne() {
            return self.refuse(MavResult::MAV_RESULT_FAILED, "Takeoff: already flying");
        }
        match self.kin.takeoff(height) {
            Ok(()) => {
                self.idle_since = None;
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(e) => self.refuse(MavResult::MAV_RESULT_FAILED, &format!("Takeoff: {e}")),
        }
    }

    pub(crate) fn position_target(&mut self, t: &SET_POSITION_TARGET_LOCAL_NED_DATA) {
        if t.coordinate_frame != MavFrame::MAV_FRAME_LOCAL_NED {
            return;
        }
        let ignore_position = PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Y_IGNORE
            | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Z_IGNORE;
        if t.type_mask.intersects(ignore_position) {
            // Velocity and acceleration targets are not simulated.
            return;
        }
        let setpoint = Ned::new(f64::from(t.x), f64::from(t.y), f64::from(t.z));
        if self.o.autopilot == Firmware::Px4 {
            // Every setpoint keeps the offboard stream alive, in any mode.
            self.setpoint = Some((self.time, setpoint));
            if self.mode.role() == Role::Guided {
                self.offboard_target(setpoint);
            }
            return;
        }
        if self.mode.role() != Role::Guided || !self.kin.is_airborne() {
            return;
        }
        let ned = setpoint + self.o.ekf_origin_offset;
        let target = ned.to_mission();
        if let Err(e) = self.kin.go_to(target, FlightMode::Guided) {
            tracing::info!(
                "sim-vehicle {}: ignored a position target: {e}",
                self.o.system_id
            );
        }
    }
}
