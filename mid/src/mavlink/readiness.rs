//! Whether an autopilot may be armed: the checks a careful pilot makes
//! before touching the arm switch, read from what the autopilot reports.
//!
//! An ArduPilot copter takes about 40 s after boot to be ready (SITL, at
//! real time): a 3D GPS fix after about 9 s, the EKF origin after about
//! 19 s (only then does `LOCAL_POSITION_NED` exist), the EKF using GPS
//! after about 41 s, and only then do its pre-arm checks pass. Arming
//! before that is refused; flying to local targets before the origin is
//! set is impossible. So the adapter waits for all of:
//!
//! - a HEARTBEAT (the autopilot is there at all),
//! - SYS_STATUS, with the pre-arm check bit healthy where the autopilot
//!   reports that bit,
//! - a GPS fix of 3D or better (GPS_RAW_INT),
//! - an EKF position estimate: EKF_STATUS_REPORT with attitude, horizontal
//!   velocity and relative and absolute position good, not in constant
//!   position mode and no GPS glitch (ArduPilot only; PX4 does not send it),
//! - LOCAL_POSITION_NED, the frame every target is given in.
//!
//! [`Readiness`] is a pure fold over messages so that it can be tested
//! without a vehicle; [`Readiness::missing`] names what is still missing in
//! words a pilot understands.

use std::fmt;
use std::time::Duration;

use super::dialect::{EkfStatusFlags, GpsFixType, MavMessage, MavSysStatusSensor, MavType};
use super::modes::Autopilot;

/// What an autopilot has reported so far about being ready.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Readiness {
    autopilot: Option<Autopilot>,
    /// `None` until SYS_STATUS arrives; then whether the pre-arm checks
    /// pass (`None` inside when the autopilot does not report them).
    prearm: Option<Option<bool>>,
    gps: Option<(GpsFixType, u8)>,
    ekf: Option<EkfStatusFlags>,
    local_position: bool,
    /// The latest `PreArm:` STATUSTEXT, which says why the checks fail.
    prearm_text: Option<String>,
    /// Flying without GPS (indoors on motion capture or optical flow,
    /// with the EKF origin set by hand): no fix is asked for.
    without_gps: bool,
}

/// One thing the autopilot has not yet reported.
#[derive(Debug, Clone, PartialEq)]
pub enum Missing {
    Heartbeat,
    SystemStatus,
    GpsFix {
        /// The fix reported so far, if any GPS_RAW_INT arrived.
        fix: Option<GpsFixType>,
        satellites: u8,
    },
    EkfPosition {
        /// The flags reported so far, if any EKF_STATUS_REPORT arrived.
        flags: Option<EkfStatusFlags>,
    },
    LocalPosition,
    PrearmChecks {
        /// The autopilot's latest `PreArm:` message.
        reason: Option<String>,
    },
}

/// The EKF flags that together mean "I know where I am, absolutely and
/// relative to the origin".
pub fn ekf_position_flags() -> EkfStatusFlags {
    EkfStatusFlags::EKF_ATTITUDE
        | EkfStatusFlags::EKF_VELOCITY_HORIZ
        | EkfStatusFlags::EKF_POS_HORIZ_REL
        | EkfStatusFlags::EKF_POS_HORIZ_ABS
        | EkfStatusFlags::EKF_POS_VERT_ABS
}

fn ekf_bad_flags() -> EkfStatusFlags {
    EkfStatusFlags::EKF_CONST_POS_MODE
        | EkfStatusFlags::EKF_GPS_GLITCHING
        | EkfStatusFlags::EKF_UNINITIALIZED
}

impl Readiness {
    pub fn new() -> Self {
        Self::default()
    }

    /// Readiness of a vehicle that flies without GPS: the EKF's position
    /// (from motion capture, optical flow) and the pre-arm checks decide.
    pub fn without_gps() -> Self {
        Self {
            without_gps: true,
            ..Self::default()
        }
    }

    /// Folds in one message from the vehicle (messages from other systems
    /// must be filtered out by the caller).
    pub fn observe(&mut self, message: &MavMessage) {
        match message {
            MavMessage::HEARTBEAT(hb) if !matches!(hb.mavtype, MavType::MAV_TYPE_GCS) => {
                self.autopilot = Some(Autopilot::from_mavlink(hb.autopilot));
            }
            MavMessage::SYS_STATUS(s) => {
                let bit = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
                self.prearm = Some(
                    s.onboard_control_sensors_present
                        .contains(bit)
                        .then(|| s.onboard_control_sensors_health.contains(bit)),
                );
            }
            MavMessage::GPS_RAW_INT(g) => self.gps = Some((g.fix_type, g.satellites_visible)),
            MavMessage::EKF_STATUS_REPORT(e) => self.ekf = Some(e.flags),
            MavMessage::LOCAL_POSITION_NED(_) => self.local_position = true,
            MavMessage::STATUSTEXT(t) => {
                if let Ok(text) = t.text.to_str() {
                    // ArduPilot's pre-arm texts, and PX4's.
                    if text.starts_with("PreArm") || text.starts_with("Preflight Fail") {
                        self.prearm_text = Some(text.trim().to_string());
                    }
                }
            }
            _ => {}
        }
    }

    /// The autopilot's latest pre-arm message, if it said one.
    pub fn prearm_text(&self) -> Option<&str> {
        self.prearm_text.as_deref()
    }

    /// The autopilot family, once a heartbeat said it.
    pub fn autopilot(&self) -> Option<Autopilot> {
        self.autopilot
    }

    /// What is still missing, in the order a vehicle usually gets there.
    pub fn missing(&self) -> Vec<Missing> {
        let mut missing = Vec::new();
        if self.autopilot.is_none() {
            missing.push(Missing::Heartbeat);
        }
        match self.gps {
            _ if self.without_gps => {}
            Some((fix, _)) if fix_is_3d(fix) => {}
            Some((fix, satellites)) => missing.push(Missing::GpsFix {
                fix: Some(fix),
                satellites,
            }),
            None => missing.push(Missing::GpsFix {
                fix: None,
                satellites: 0,
            }),
        }
        // PX4 does not send EKF_STATUS_REPORT; an unknown autopilot might.
        let needs_ekf_report = !matches!(self.autopilot, Some(Autopilot::Px4));
        if needs_ekf_report && !self.ekf.is_some_and(ekf_has_position) {
            missing.push(Missing::EkfPosition { flags: self.ekf });
        }
        if !self.local_position {
            missing.push(Missing::LocalPosition);
        }
        match self.prearm {
            None => missing.push(Missing::SystemStatus),
            Some(Some(false)) => missing.push(Missing::PrearmChecks {
                reason: self.prearm_text.clone(),
            }),
            Some(Some(true)) | Some(None) => {}
        }
        missing
    }

    pub fn is_ready(&self) -> bool {
        self.missing().is_empty()
    }

    /// One line for the pilot: what is there and what is not.
    pub fn progress_line(&self) -> String {
        let missing = self.missing();
        if missing.is_empty() {
            return "ready to arm".to_string();
        }
        let mut have = Vec::new();
        if let Some(ap) = self.autopilot {
            have.push(format!("{ap} heartbeat"));
        }
        if let Some((fix, sats)) = self.gps {
            if fix_is_3d(fix) {
                have.push(format!("GPS {} ({sats} satellites)", fix_name(fix)));
            }
        }
        if self.ekf.is_some_and(ekf_has_position) {
            have.push("EKF position".to_string());
        }
        if self.local_position {
            have.push("local position".to_string());
        }
        let waiting = missing
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("; ");
        if have.is_empty() {
            format!("waiting for {waiting}")
        } else {
            format!("have {}; waiting for {waiting}", have.join(", "))
        }
    }
}

fn fix_is_3d(fix: GpsFixType) -> bool {
    (fix as u8) >= (GpsFixType::GPS_FIX_TYPE_3D_FIX as u8)
}

fn ekf_has_position(flags: EkfStatusFlags) -> bool {
    flags.contains(ekf_position_flags()) && !flags.intersects(ekf_bad_flags())
}

fn fix_name(fix: GpsFixType) -> &'static str {
    match fix {
        GpsFixType::GPS_FIX_TYPE_NO_GPS => "no GPS",
        GpsFixType::GPS_FIX_TYPE_NO_FIX => "no fix",
        GpsFixType::GPS_FIX_TYPE_2D_FIX => "2D fix",
        GpsFixType::GPS_FIX_TYPE_3D_FIX => "3D fix",
        GpsFixType::GPS_FIX_TYPE_DGPS => "DGPS fix",
        GpsFixType::GPS_FIX_TYPE_RTK_FLOAT => "RTK float",
        GpsFixType::GPS_FIX_TYPE_RTK_FIXED => "RTK fixed",
        GpsFixType::GPS_FIX_TYPE_STATIC => "static fix",
        GpsFixType::GPS_FIX_TYPE_PPP => "PPP fix",
    }
}

fn ekf_flag_names(flags: EkfStatusFlags) -> Vec<&'static str> {
    [
        (EkfStatusFlags::EKF_ATTITUDE, "attitude"),
        (EkfStatusFlags::EKF_VELOCITY_HORIZ, "horizontal velocity"),
        (
            EkfStatusFlags::EKF_POS_HORIZ_REL,
            "relative horizontal position",
        ),
        (
            EkfStatusFlags::EKF_POS_HORIZ_ABS,
            "absolute horizontal position",
        ),
        (
            EkfStatusFlags::EKF_POS_VERT_ABS,
            "absolute vertical position",
        ),
    ]
    .into_iter()
    .filter(|(f, _)| !flags.contains(*f))
    .map(|(_, n)| n)
    .collect()
}

impl fmt::Display for Missing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Missing::Heartbeat => write!(f, "a heartbeat from the autopilot"),
            Missing::SystemStatus => write!(f, "SYS_STATUS (pre-arm check state)"),
            Missing::GpsFix { fix: None, .. } => {
                write!(f, "a 3D GPS fix (no GPS_RAW_INT received)")
            }
            Missing::GpsFix {
                fix: Some(fix),
                satellites,
            } => write!(
                f,
                "a 3D GPS fix (now: {}, {satellites} satellites)",
                fix_name(*fix)
            ),
            Missing::EkfPosition { flags: None } => {
                write!(
                    f,
                    "an EKF position estimate (no EKF_STATUS_REPORT received)"
                )
            }
            Missing::EkfPosition { flags: Some(flags) } => {
                let lacking = ekf_flag_names(*flags);
                let mut problems: Vec<String> = Vec::new();
                if !lacking.is_empty() {
                    problems.push(format!("lacks {}", lacking.join(", ")));
                }
                if flags.contains(EkfStatusFlags::EKF_CONST_POS_MODE) {
                    problems.push("is in constant position mode".to_string());
                }
                if flags.contains(EkfStatusFlags::EKF_GPS_GLITCHING) {
                    problems.push("reports a GPS glitch".to_string());
                }
                if flags.contains(EkfStatusFlags::EKF_UNINITIALIZED) {
                    problems.push("was never initialised".to_string());
                }
                write!(
                    f,
                    "an EKF position estimate (the EKF {})",
                    problems.join(" and ")
                )
            }
            Missing::LocalPosition => {
                write!(f, "LOCAL_POSITION_NED (the EKF origin is not set yet)")
            }
            Missing::PrearmChecks { reason: None } => write!(f, "pre-arm checks to pass"),
            Missing::PrearmChecks {
                reason: Some(reason),
            } => write!(f, "pre-arm checks to pass (autopilot: \"{reason}\")"),
        }
    }
}

/// The vehicle did not become ready in time.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the vehicle was not ready to arm after {} s; still missing: {}{}", .waited.as_secs(), list(.missing), says(.missing, .autopilot_says))]
pub struct NotReady {
    pub waited: Duration,
    pub missing: Vec<Missing>,
    /// The autopilot's latest pre-arm message, which says in its own words
    /// what stops it, whatever else is missing.
    pub autopilot_says: Option<String>,
}

impl NotReady {
    /// What `readiness` still lacks after waiting `waited`.
    pub fn of(readiness: &Readiness, waited: Duration) -> NotReady {
        NotReady {
            waited,
            missing: readiness.missing(),
            autopilot_says: readiness.prearm_text().map(str::to_string),
        }
    }
}

/// The autopilot's words, unless a missing item already quotes them.
fn says(missing: &[Missing], text: &Option<String>) -> String {
    let quoted = missing
        .iter()
        .any(|m| matches!(m, Missing::PrearmChecks { reason: Some(_) }));
    match text {
        Some(t) if !quoted => format!("; the autopilot says: \"{t}\""),
        _ => String::new(),
    }
}

fn list(missing: &[Missing]) -> String {
    missing
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::dialect::{
        MavAutopilot, MavModeFlag, MavSeverity, MavState, EKF_STATUS_REPORT_DATA, GPS_RAW_INT_DATA,
        HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA, STATUSTEXT_DATA, SYS_STATUS_DATA,
    };

    fn heartbeat(autopilot: MavAutopilot) -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    fn gps(fix: GpsFixType, sats: u8) -> MavMessage {
        MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
            fix_type: fix,
            satellites_visible: sats,
            ..Default::default()
        })
    }

    fn ekf(flags: EkfStatusFlags) -> MavMessage {
        MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
            flags,
            ..Default::default()
        })
    }

    fn sys_status(prearm_present: bool, prearm_healthy: bool) -> MavMessage {
        let bit = MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
        let base = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO;
        MavMessage::SYS_STATUS(SYS_STATUS_DATA {
            onboard_control_sensors_present: if prearm_present { base | bit } else { base },
            onboard_control_sensors_enabled: if prearm_present { base | bit } else { base },
            onboard_control_sensors_health: if prearm_healthy { base | bit } else { base },
            battery_remaining: 100,
            ..Default::default()
        })
    }

    fn statustext(text: &str) -> MavMessage {
        MavMessage::STATUSTEXT(STATUSTEXT_DATA {
            severity: MavSeverity::MAV_SEVERITY_CRITICAL,
            text: text.into(),
        })
    }

    fn local_position() -> MavMessage {
        MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA::default())
    }

    /// Feeds the messages of a freshly booted ArduPilot copter as SITL
    /// sends them over its first 40 seconds.
    fn arducopter_until(stage: u8) -> Readiness {
        let mut r = Readiness::new();
        r.observe(&heartbeat(MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA));
        r.observe(&sys_status(true, false));
        r.observe(&gps(GpsFixType::GPS_FIX_TYPE_NO_FIX, 0));
        r.observe(&ekf(
            EkfStatusFlags::EKF_ATTITUDE | EkfStatusFlags::EKF_CONST_POS_MODE
        ));
        r.observe(&statustext("PreArm: Need Position Estimate"));
        if stage >= 1 {
            r.observe(&gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 10));
        }
        if stage >= 2 {
            r.observe(&ekf(EkfStatusFlags::EKF_ATTITUDE
                | EkfStatusFlags::EKF_VELOCITY_HORIZ
                | EkfStatusFlags::EKF_POS_HORIZ_REL));
            r.observe(&local_position());
        }
        if stage >= 3 {
            r.observe(&ekf(
                ekf_position_flags() | EkfStatusFlags::EKF_VELOCITY_VERT
            ));
            r.observe(&sys_status(true, true));
        }
        r
    }

    #[test]
    fn nothing_received_means_everything_is_missing() {
        let r = Readiness::new();
        let m = r.missing();
        assert_eq!(m.first(), Some(&Missing::Heartbeat));
        assert!(m.contains(&Missing::SystemStatus));
        assert!(m.contains(&Missing::LocalPosition));
        assert!(!r.is_ready());
    }

    #[test]
    fn a_copter_becomes_ready_only_once_gps_ekf_origin_and_prearm_are_all_there() {
        assert_eq!(arducopter_until(0).missing().len(), 4);
        let r = arducopter_until(1);
        assert!(!r
            .missing()
            .iter()
            .any(|m| matches!(m, Missing::GpsFix { .. })));
        let r = arducopter_until(2);
        assert!(!r.missing().contains(&Missing::LocalPosition));
        assert!(r
            .missing()
            .iter()
            .any(|m| matches!(m, Missing::EkfPosition { .. })));
        let r = arducopter_until(3);
        assert!(r.is_ready(), "{:?}", r.missing());
        assert_eq!(r.progress_line(), "ready to arm");
    }

    #[test]
    fn the_missing_pieces_are_named_in_a_pilots_words() {
        let r = arducopter_until(0);
        let line = r.progress_line();
        assert!(
            line.contains("a 3D GPS fix (now: no fix, 0 satellites)"),
            "{line}"
        );
        assert!(
            line.contains("EKF position estimate (the EKF lacks horizontal velocity"),
            "{line}"
        );
        assert!(line.contains("constant position mode"), "{line}");
        assert!(
            line.contains("LOCAL_POSITION_NED (the EKF origin is not set yet)"),
            "{line}"
        );
        assert!(
            line.contains("pre-arm checks to pass (autopilot: \"PreArm: Need Position Estimate\")"),
            "{line}"
        );
        let line = arducopter_until(2).progress_line();
        assert!(
            line.starts_with(
                "have ArduPilot heartbeat, GPS 3D fix (10 satellites), local position; waiting for"
            ),
            "{line}"
        );
    }

    #[test]
    fn a_gps_glitch_withdraws_the_ekf_position() {
        let mut r = arducopter_until(3);
        r.observe(&ekf(
            ekf_position_flags() | EkfStatusFlags::EKF_GPS_GLITCHING
        ));
        let m = r.missing();
        assert_eq!(m.len(), 1);
        assert!(m[0].to_string().contains("GPS glitch"));
    }

    #[test]
    fn a_2d_fix_is_not_enough() {
        let mut r = arducopter_until(3);
        r.observe(&gps(GpsFixType::GPS_FIX_TYPE_2D_FIX, 5));
        assert_eq!(
            r.missing(),
            vec![Missing::GpsFix {
                fix: Some(GpsFixType::GPS_FIX_TYPE_2D_FIX),
                satellites: 5
            }]
        );
        r.observe(&gps(GpsFixType::GPS_FIX_TYPE_RTK_FIXED, 20));
        assert!(r.is_ready());
    }

    #[test]
    fn an_autopilot_that_does_not_report_prearm_state_is_not_held_back_by_it() {
        let mut r = arducopter_until(3);
        r.observe(&sys_status(false, false));
        assert!(r.is_ready());
    }

    #[test]
    fn a_vehicle_flown_without_gps_is_not_asked_for_a_fix() {
        let mut r = Readiness::without_gps();
        r.observe(&heartbeat(MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA));
        r.observe(&gps(GpsFixType::GPS_FIX_TYPE_NO_GPS, 0));
        r.observe(&ekf(ekf_position_flags()));
        r.observe(&local_position());
        r.observe(&sys_status(true, true));
        assert!(r.is_ready(), "{:?}", r.missing());
        assert!(!arducopter_until(2).is_ready());
    }

    #[test]
    fn px4_is_not_asked_for_ardupilots_ekf_report() {
        let mut r = Readiness::new();
        r.observe(&heartbeat(MavAutopilot::MAV_AUTOPILOT_PX4));
        r.observe(&sys_status(true, true));
        r.observe(&gps(GpsFixType::GPS_FIX_TYPE_3D_FIX, 12));
        r.observe(&local_position());
        assert!(r.is_ready(), "{:?}", r.missing());
    }

    #[test]
    fn a_ground_station_heartbeat_does_not_count_as_the_autopilot() {
        let mut r = Readiness::new();
        r.observe(&MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            mavtype: MavType::MAV_TYPE_GCS,
            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
            ..Default::default()
        }));
        assert_eq!(r.missing().first(), Some(&Missing::Heartbeat));
    }

    #[test]
    fn not_ready_says_how_long_it_waited_and_what_is_missing() {
        let e = NotReady::of(&arducopter_until(2), Duration::from_secs(90));
        let s = e.to_string();
        assert!(s.starts_with("the vehicle was not ready to arm after 90 s; still missing: an EKF position estimate"), "{s}");
        assert!(s.contains("pre-arm checks to pass"), "{s}");
    }

    #[test]
    fn the_autopilots_prearm_words_are_quoted_whatever_else_is_missing() {
        // No SYS_STATUS yet, so the pre-arm checks are not among what is
        // missing; the autopilot's reason is still the most telling line.
        let mut r = Readiness::new();
        r.observe(&heartbeat(MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA));
        r.observe(&statustext("PreArm: Need Position Estimate"));
        let s = NotReady::of(&r, Duration::from_secs(4)).to_string();
        assert!(
            s.ends_with("; the autopilot says: \"PreArm: Need Position Estimate\""),
            "{s}"
        );
        // Quoted once when the missing pre-arm checks already quote it.
        let s = NotReady::of(&arducopter_until(2), Duration::from_secs(4)).to_string();
        assert_eq!(s.matches("PreArm").count(), 1, "{s}");
    }
}
