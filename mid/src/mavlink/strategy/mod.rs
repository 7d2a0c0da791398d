//! What differs between the autopilots the adapter flies, as one small
//! strategy per autopilot: the adapter asks its strategy and never tests
//! which autopilot it talks to.
//!
//! Their flight modes (numbers, names, which does what) are tables in
//! [`super::modes`]; what is here is behaviour: how a take-off starts,
//! whether the guided mode needs a setpoint stream, which telemetry the
//! autopilot sends at all.

mod ardupilot;
mod px4;

use super::modes::Autopilot;

pub use ardupilot::ArduPilot;
pub use px4::Px4;

/// How a take-off starts, armed in the guided mode on the ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TakeoffStart {
    /// `MAV_CMD_NAV_TAKEOFF` with these parameters.
    Command([f32; 7]),
    /// A position setpoint this far above the ground point.
    SetpointAbove(f64),
}

/// One autopilot's ways.
pub trait Strategy: Send + Sync {
    fn autopilot(&self) -> Autopilot;

    /// How to take off to `height` metres above the ground.
    fn takeoff(&self, height: f64) -> TakeoffStart;

    /// Whether the guided mode is entered only while position setpoints
    /// stream, and left as soon as they stop (PX4's OFFBOARD): the adapter
    /// then streams its setpoint from before the switch until the drone is
    /// down.
    fn streams_setpoints(&self) -> bool;

    /// Whether the autopilot sends message `id` at all, so that asking for
    /// it is not repeated forever.
    fn sends(&self, id: u32) -> bool;

    /// The parameters that decide what the autopilot does when the
    /// mission's link goes silent while it flies in the guided mode.
    fn link_loss_params(&self) -> &'static [&'static str];

    /// Given those parameters' values (in that order), why a lost link
    /// would leave the drone with nobody in charge, naming the parameter;
    /// `None` when the autopilot itself would bring it down or home.
    fn link_loss_gap(&self, values: &[f64]) -> Option<String>;
}

/// The strategy for `autopilot`, if the adapter knows how to fly it.
pub fn for_autopilot(autopilot: Autopilot) -> Option<&'static dyn Strategy> {
    match autopilot {
        Autopilot::ArduPilot => Some(&ArduPilot),
        Autopilot::Px4 => Some(&Px4),
        Autopilot::Other(_) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_known_autopilot_has_its_own_strategy() {
        for a in [Autopilot::ArduPilot, Autopilot::Px4] {
            assert_eq!(for_autopilot(a).map(|s| s.autopilot()), Some(a));
        }
        assert!(for_autopilot(Autopilot::Other(3)).is_none());
    }

    #[test]
    fn ardupilot_takes_off_by_command_and_px4_by_setpoint() {
        assert_eq!(
            ArduPilot.takeoff(1.5),
            TakeoffStart::Command([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.5])
        );
        assert_eq!(Px4.takeoff(1.5), TakeoffStart::SetpointAbove(1.5));
        assert!(!ArduPilot.streams_setpoints() && Px4.streams_setpoints());
        assert!(ArduPilot.sends(193) && !Px4.sends(193) && Px4.sends(32));
    }

    #[test]
    fn a_link_loss_that_leaves_nobody_in_charge_names_the_parameter() {
        let gap = ArduPilot.link_loss_gap(&[0.0, 5.0]).unwrap();
        assert!(gap.starts_with("FS_GCS_ENABLE is 0"), "{gap}");
        assert_eq!(ArduPilot.link_loss_gap(&[1.0, 5.0]), None);
        assert_eq!(ArduPilot.link_loss_gap(&[5.0, 5.0]), None);
        let gap = Px4.link_loss_gap(&[1.0, 5.0]).unwrap();
        assert!(gap.starts_with("COM_OBL_RC_ACT is 5 (Hold)"), "{gap}");
        let gap = Px4.link_loss_gap(&[1.0, 0.0]).unwrap();
        assert!(gap.starts_with("COM_OBL_RC_ACT is 0 (Position)"), "{gap}");
        assert!(Px4.link_loss_gap(&[1.0, 7.0]).unwrap().contains("motors"));
        assert_eq!(Px4.link_loss_gap(&[1.0, 3.0]), None);
        assert_eq!(Px4.link_loss_gap(&[1.0, 4.0]), None);
    }
}
