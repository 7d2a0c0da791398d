//! The autopilot's own clock: the mission clock when this drone keeps it
//! (a fleet of MAVLink drones only follows its first autopilot, so that a
//! SITL run at a speed-up times every `Hover` and `PauseFor` in its own
//! seconds), and a warning when it runs at another pace than the mission
//! clock (a fleet that mixes simulated drones at `--speed` with an
//! autopilot that does not run at that speed).

use super::shared::Shared;

/// Autopilot seconds over which the pace is judged.
const JUDGED_OVER: f64 = 10.0;
/// How far the paces may differ before the crew is told.
const PACE_SLACK: f64 = 1.25;

impl Shared {
    /// Takes one reading of the autopilot's clock (seconds since its boot).
    pub(super) fn autopilot_time(&self, boot: f64) {
        if let Some(feed) = &self.options.clock_feed {
            feed.lock().unwrap_or_else(|p| p.into_inner()).reading(boot);
        }
        let mission = self.clock.now();
        let mut pace = self.pace.lock().unwrap_or_else(|p| p.into_inner());
        let Some((boot0, mission0, told)) = *pace else {
            *pace = Some((boot, mission, false));
            return;
        };
        if told || boot < boot0 {
            // Said once; or it rebooted: measure again.
            if boot < boot0 {
                *pace = Some((boot, mission, false));
            }
            return;
        }
        let (autopilot, ours) = (boot - boot0, mission - mission0);
        if autopilot < JUDGED_OVER || ours <= 0.0 {
            return;
        }
        let ratio = autopilot / ours;
        *pace = Some((boot0, mission0, true));
        if !(1.0 / PACE_SLACK..=PACE_SLACK).contains(&ratio) {
            drop(pace);
            self.warn(format!(
                "the autopilot's clock runs at {ratio:.2} times the mission clock: this drone's Hover and PauseFor, and the waits on it, are timed by the mission clock; run the autopilot at the mission's speed (a simulator's speed-up, `--speed`)"
            ));
        }
    }
}
