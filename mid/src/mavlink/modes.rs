//! Flight modes: every autopilot encodes its own in HEARTBEAT's
//! `custom_mode`, and sets them through `MAV_CMD_DO_SET_MODE` with its own
//! parameters. This module knows ArduCopter's modes and PX4's, which mode
//! the adapter needs for each of its jobs, and how they read as the middle
//! layer's [`FlightMode`].
//!
//! # PX4
//! PX4 flies the adapter's position targets in OFFBOARD, lands in AUTO.LAND
//! and holds in AUTO.LOITER. `MAV_CMD_DO_SET_MODE` takes PX4's main mode in
//! param2 and its sub-mode in param3. How the adapter keeps OFFBOARD alive
//! (a setpoint stream from before the switch) is described in
//! [`super::adapter`].

use std::fmt;

use crate::api::FlightMode;

use super::dialect::MavAutopilot;

/// The autopilot firmware family, from HEARTBEAT's `autopilot` field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Autopilot {
    ArduPilot,
    Px4,
    /// Anything else; its modes are shown as numbers.
    Other(u8),
}

impl Autopilot {
    pub fn from_mavlink(a: MavAutopilot) -> Self {
        match a {
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => Autopilot::ArduPilot,
            MavAutopilot::MAV_AUTOPILOT_PX4 => Autopilot::Px4,
            other => Autopilot::Other(other as u8),
        }
    }

    /// The custom mode that does the job, if this autopilot has one.
    pub fn mode_for(self, role: ModeRole) -> Option<u32> {
        match self {
            Autopilot::ArduPilot => Some(
                match role {
                    ModeRole::Guided => CopterMode::Guided,
                    ModeRole::Land => CopterMode::Land,
                    ModeRole::Hold => CopterMode::Loiter,
                    ModeRole::ReturnHome => CopterMode::Rtl,
                }
                .custom_mode(),
            ),
            Autopilot::Px4 => Some(
                match role {
                    ModeRole::Guided => Px4Mode::Offboard,
                    ModeRole::Land => Px4Mode::AutoLand,
                    ModeRole::Hold => Px4Mode::AutoLoiter,
                    ModeRole::ReturnHome => Px4Mode::AutoRtl,
                }
                .custom_mode(),
            ),
            Autopilot::Other(_) => None,
        }
    }

    /// The seven parameters of `MAV_CMD_DO_SET_MODE` that select
    /// `custom_mode`: ArduPilot takes the mode number in param2, PX4 its
    /// main mode in param2 and sub-mode in param3.
    pub fn set_mode_params(self, custom_mode: u32) -> [f32; 7] {
        const CUSTOM_MODE_ENABLED: f32 = 1.0;
        match self {
            Autopilot::Px4 => [
                CUSTOM_MODE_ENABLED,
                ((custom_mode >> 16) & 0xff) as f32,
                ((custom_mode >> 24) & 0xff) as f32,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
            _ => [
                CUSTOM_MODE_ENABLED,
                custom_mode as f32,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ],
        }
    }

    /// The mode's name as the autopilot's own ground stations print it.
    pub fn mode_name(self, custom_mode: u32) -> String {
        match self {
            Autopilot::ArduPilot => CopterMode::from_custom_mode(custom_mode)
                .map(|m| m.name().to_string())
                .unwrap_or_else(|| format!("mode {custom_mode}")),
            Autopilot::Px4 => Px4Mode::from_custom_mode(custom_mode)
                .map(|m| m.name().to_string())
                .unwrap_or_else(|| format!("mode {custom_mode:#x}")),
            Autopilot::Other(_) => format!("mode {custom_mode}"),
        }
    }

    /// The mode in the middle layer's words.
    pub fn flight_mode(self, custom_mode: u32) -> FlightMode {
        match self {
            Autopilot::ArduPilot => CopterMode::from_custom_mode(custom_mode)
                .map(CopterMode::flight_mode)
                .unwrap_or(FlightMode::Other(custom_mode)),
            Autopilot::Px4 => Px4Mode::from_custom_mode(custom_mode)
                .map(Px4Mode::flight_mode)
                .unwrap_or(FlightMode::Other(custom_mode)),
            Autopilot::Other(_) => FlightMode::Other(custom_mode),
        }
    }

    /// Reads a mode name (`GUIDED`, `LAND`, `OFFBOARD`, case-insensitive).
    pub fn parse_mode(self, name: &str) -> Option<u32> {
        match self {
            Autopilot::ArduPilot => CopterMode::ALL
                .iter()
                .find(|m| m.name().eq_ignore_ascii_case(name))
                .map(|m| m.custom_mode()),
            Autopilot::Px4 => Px4Mode::ALL
                .iter()
                .find(|m| m.name().eq_ignore_ascii_case(name))
                .map(|m| m.custom_mode()),
            Autopilot::Other(_) => None,
        }
    }
}

impl fmt::Display for Autopilot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Autopilot::ArduPilot => write!(f, "ArduPilot"),
            Autopilot::Px4 => write!(f, "PX4"),
            Autopilot::Other(n) => write!(f, "autopilot type {n}"),
        }
    }
}

/// What the adapter needs a mode for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeRole {
    /// Flying to position targets from the ground station.
    Guided,
    Land,
    /// Holding position by itself.
    Hold,
    ReturnHome,
}

/// ArduCopter's flight modes (`custom_mode` of HEARTBEAT).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum CopterMode {
    Stabilize = 0,
    Acro = 1,
    AltHold = 2,
    Auto = 3,
    Guided = 4,
    Loiter = 5,
    Rtl = 6,
    Circle = 7,
    Land = 9,
    Drift = 11,
    Sport = 13,
    Flip = 14,
    AutoTune = 15,
    PosHold = 16,
    Brake = 17,
    Throw = 18,
    AvoidAdsb = 19,
    GuidedNoGps = 20,
    SmartRtl = 21,
    FlowHold = 22,
    Follow = 23,
    ZigZag = 24,
    SystemId = 25,
    Autorotate = 26,
    AutoRtl = 27,
    Turtle = 28,
}

impl CopterMode {
    pub const ALL: [CopterMode; 26] = [
        CopterMode::Stabilize,
        CopterMode::Acro,
        CopterMode::AltHold,
        CopterMode::Auto,
        CopterMode::Guided,
        CopterMode::Loiter,
        CopterMode::Rtl,
        CopterMode::Circle,
        CopterMode::Land,
        CopterMode::Drift,
        CopterMode::Sport,
        CopterMode::Flip,
        CopterMode::AutoTune,
        CopterMode::PosHold,
        CopterMode::Brake,
        CopterMode::Throw,
        CopterMode::AvoidAdsb,
        CopterMode::GuidedNoGps,
        CopterMode::SmartRtl,
        CopterMode::FlowHold,
        CopterMode::Follow,
        CopterMode::ZigZag,
        CopterMode::SystemId,
        CopterMode::Autorotate,
        CopterMode::AutoRtl,
        CopterMode::Turtle,
    ];

    pub fn custom_mode(self) -> u32 {
        self as u32
    }

    pub fn from_custom_mode(m: u32) -> Option<Self> {
        Self::ALL.iter().copied().find(|c| c.custom_mode() == m)
    }

    pub fn name(self) -> &'static str {
        match self {
            CopterMode::Stabilize => "STABILIZE",
            CopterMode::Acro => "ACRO",
            CopterMode::AltHold => "ALT_HOLD",
            CopterMode::Auto => "AUTO",
            CopterMode::Guided => "GUIDED",
            CopterMode::Loiter => "LOITER",
            CopterMode::Rtl => "RTL",
            CopterMode::Circle => "CIRCLE",
            CopterMode::Land => "LAND",
            CopterMode::Drift => "DRIFT",
            CopterMode::Sport => "SPORT",
            CopterMode::Flip => "FLIP",
            CopterMode::AutoTune => "AUTOTUNE",
            CopterMode::PosHold => "POSHOLD",
            CopterMode::Brake => "BRAKE",
            CopterMode::Throw => "THROW",
            CopterMode::AvoidAdsb => "AVOID_ADSB",
            CopterMode::GuidedNoGps => "GUIDED_NOGPS",
            CopterMode::SmartRtl => "SMART_RTL",
            CopterMode::FlowHold => "FLOWHOLD",
            CopterMode::Follow => "FOLLOW",
            CopterMode::ZigZag => "ZIGZAG",
            CopterMode::SystemId => "SYSTEMID",
            CopterMode::Autorotate => "AUTOROTATE",
            CopterMode::AutoRtl => "AUTO_RTL",
            CopterMode::Turtle => "TURTLE",
        }
    }

    pub fn flight_mode(self) -> FlightMode {
        use CopterMode::*;
        match self {
            Guided | GuidedNoGps => FlightMode::Guided,
            Loiter | PosHold | Brake => FlightMode::Hold,
            Land => FlightMode::Land,
            Rtl | SmartRtl | AutoRtl => FlightMode::ReturnHome,
            Stabilize | Acro | AltHold | Drift | Sport | Flip | FlowHold | Turtle => {
                FlightMode::Piloted
            }
            other => FlightMode::Other(other.custom_mode()),
        }
    }
}

/// PX4's flight modes: `custom_mode` holds the main mode in bits 16..24 and
/// the sub-mode in bits 24..32.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Px4Mode {
    Manual,
    AltCtl,
    PosCtl,
    AutoReady,
    AutoTakeoff,
    AutoLoiter,
    AutoMission,
    AutoRtl,
    AutoLand,
    AutoFollowTarget,
    AutoPrecLand,
    Acro,
    Offboard,
    Stabilized,
}

impl Px4Mode {
    pub const ALL: [Px4Mode; 14] = [
        Px4Mode::Manual,
        Px4Mode::AltCtl,
        Px4Mode::PosCtl,
        Px4Mode::AutoReady,
        Px4Mode::AutoTakeoff,
        Px4Mode::AutoLoiter,
        Px4Mode::AutoMission,
        Px4Mode::AutoRtl,
        Px4Mode::AutoLand,
        Px4Mode::AutoFollowTarget,
        Px4Mode::AutoPrecLand,
        Px4Mode::Acro,
        Px4Mode::Offboard,
        Px4Mode::Stabilized,
    ];

    /// (main mode, sub-mode) as PX4's `px4_custom_mode.h` numbers them.
    pub fn main_sub(self) -> (u8, u8) {
        match self {
            Px4Mode::Manual => (1, 0),
            Px4Mode::AltCtl => (2, 0),
            Px4Mode::PosCtl => (3, 0),
            Px4Mode::AutoReady => (4, 1),
            Px4Mode::AutoTakeoff => (4, 2),
            Px4Mode::AutoLoiter => (4, 3),
            Px4Mode::AutoMission => (4, 4),
            Px4Mode::AutoRtl => (4, 5),
            Px4Mode::AutoLand => (4, 6),
            Px4Mode::AutoFollowTarget => (4, 8),
            Px4Mode::AutoPrecLand => (4, 9),
            Px4Mode::Acro => (5, 0),
            Px4Mode::Offboard => (6, 0),
            Px4Mode::Stabilized => (7, 0),
        }
    }

    pub fn custom_mode(self) -> u32 {
        let (main, sub) = self.main_sub();
        (u32::from(main) << 16) | (u32::from(sub) << 24)
    }

    pub fn from_custom_mode(m: u32) -> Option<Self> {
        let main = ((m >> 16) & 0xff) as u8;
        let sub = ((m >> 24) & 0xff) as u8;
        // Outside AUTO the sub-mode is not part of the mode's identity
        // (POSCTL's sub-mode 1 is ORBIT, a variant of position control).
        Self::ALL.iter().copied().find(|p| {
            let (pm, ps) = p.main_sub();
            pm == main && (main != 4 || ps == sub)
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Px4Mode::Manual => "MANUAL",
            Px4Mode::AltCtl => "ALTCTL",
            Px4Mode::PosCtl => "POSCTL",
            Px4Mode::AutoReady => "AUTO.READY",
            Px4Mode::AutoTakeoff => "AUTO.TAKEOFF",
            Px4Mode::AutoLoiter => "AUTO.LOITER",
            Px4Mode::AutoMission => "AUTO.MISSION",
            Px4Mode::AutoRtl => "AUTO.RTL",
            Px4Mode::AutoLand => "AUTO.LAND",
            Px4Mode::AutoFollowTarget => "AUTO.FOLLOW_TARGET",
            Px4Mode::AutoPrecLand => "AUTO.PRECLAND",
            Px4Mode::Acro => "ACRO",
            Px4Mode::Offboard => "OFFBOARD",
            Px4Mode::Stabilized => "STABILIZED",
        }
    }

    pub fn flight_mode(self) -> FlightMode {
        match self {
            Px4Mode::Offboard => FlightMode::Guided,
            Px4Mode::AutoLoiter => FlightMode::Hold,
            Px4Mode::AutoLand | Px4Mode::AutoPrecLand => FlightMode::Land,
            Px4Mode::AutoRtl => FlightMode::ReturnHome,
            Px4Mode::AutoTakeoff => FlightMode::Takeoff,
            Px4Mode::Manual
            | Px4Mode::AltCtl
            | Px4Mode::PosCtl
            | Px4Mode::Acro
            | Px4Mode::Stabilized => FlightMode::Piloted,
            other => FlightMode::Other(other.custom_mode()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arducopter_numbers_its_modes_as_the_firmware_does() {
        assert_eq!(CopterMode::Guided.custom_mode(), 4);
        assert_eq!(CopterMode::Loiter.custom_mode(), 5);
        assert_eq!(CopterMode::Rtl.custom_mode(), 6);
        assert_eq!(CopterMode::Land.custom_mode(), 9);
        assert_eq!(CopterMode::from_custom_mode(16), Some(CopterMode::PosHold));
        assert_eq!(CopterMode::from_custom_mode(8), None);
    }

    #[test]
    fn every_copter_mode_round_trips_through_its_number_and_name() {
        for m in CopterMode::ALL {
            assert_eq!(CopterMode::from_custom_mode(m.custom_mode()), Some(m));
            assert_eq!(
                Autopilot::ArduPilot.parse_mode(m.name()),
                Some(m.custom_mode())
            );
        }
        for m in Px4Mode::ALL {
            assert_eq!(Px4Mode::from_custom_mode(m.custom_mode()), Some(m));
            assert_eq!(Autopilot::Px4.parse_mode(m.name()), Some(m.custom_mode()));
        }
    }

    #[test]
    fn the_adapter_flies_arducopter_in_guided_and_lands_in_land() {
        let ap = Autopilot::ArduPilot;
        assert_eq!(ap.mode_for(ModeRole::Guided), Some(4));
        assert_eq!(ap.mode_for(ModeRole::Land), Some(9));
        assert_eq!(ap.mode_for(ModeRole::ReturnHome), Some(6));
        assert_eq!(ap.mode_for(ModeRole::Hold), Some(5));
        assert_eq!(ap.set_mode_params(4), [1.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn px4_packs_main_and_sub_mode_into_the_custom_mode() {
        assert_eq!(Px4Mode::Offboard.custom_mode(), 6 << 16);
        assert_eq!(Px4Mode::AutoLand.custom_mode(), (4 << 16) | (6 << 24));
        assert_eq!(
            Autopilot::Px4.set_mode_params(Px4Mode::AutoLand.custom_mode()),
            [1.0, 4.0, 6.0, 0.0, 0.0, 0.0, 0.0]
        );
        assert_eq!(Autopilot::Px4.mode_for(ModeRole::Guided), Some(6 << 16));
        // POSCTL with the ORBIT sub-mode is still position control.
        assert_eq!(
            Px4Mode::from_custom_mode((3 << 16) | (1 << 24)),
            Some(Px4Mode::PosCtl)
        );
    }

    #[test]
    fn modes_read_in_the_middle_layers_words() {
        let ap = Autopilot::ArduPilot;
        assert_eq!(ap.flight_mode(4), FlightMode::Guided);
        assert_eq!(ap.flight_mode(5), FlightMode::Hold);
        assert_eq!(ap.flight_mode(9), FlightMode::Land);
        assert_eq!(ap.flight_mode(6), FlightMode::ReturnHome);
        assert_eq!(ap.flight_mode(0), FlightMode::Piloted);
        assert_eq!(ap.flight_mode(3), FlightMode::Other(3));
        assert_eq!(ap.flight_mode(99), FlightMode::Other(99));
        assert_eq!(Autopilot::Px4.flight_mode(6 << 16), FlightMode::Guided);
        assert_eq!(Autopilot::Other(0).flight_mode(4), FlightMode::Other(4));
    }

    #[test]
    fn unknown_modes_are_named_by_number() {
        assert_eq!(Autopilot::ArduPilot.mode_name(4), "GUIDED");
        assert_eq!(Autopilot::ArduPilot.mode_name(42), "mode 42");
        assert_eq!(Autopilot::Px4.mode_name(6 << 16), "OFFBOARD");
        assert_eq!(Autopilot::Other(7).mode_name(3), "mode 3");
    }
}
