//! Before the first arming: what the autopilot does when the mission's
//! link falls silent. A drone flying in the guided mode is the mission's
//! to command; if the autopilot's own link-loss failsafe would not take
//! over (ArduCopter's `FS_GCS_ENABLE` is 0 by default), a lost radio
//! leaves it hovering with nobody in charge. The crew hears of it before
//! take-off, or the drone refuses to arm, as the fleet file says.

use crate::api::ActionError;
use crate::mavlink::params::read_param;

use super::options::LostLinkCheck;
use super::shared::Shared;

impl Shared {
    /// Reads the strategy's link-loss parameters once and warns (or
    /// refuses `action`) when a lost link would leave nobody in charge.
    pub(super) async fn check_link_loss(&self, action: &str) -> Result<(), ActionError> {
        if self.options.lost_link == LostLinkCheck::Off || self.flight().link_loss_read {
            return Ok(());
        }
        let strategy = self.flyable(action)?;
        let target = self
            .watched
            .borrow()
            .vehicle
            .target
            .ok_or_else(|| ActionError::LinkLost {
                action: action.to_string(),
            })?;
        let mut values = Vec::new();
        let mut unread = None;
        for name in strategy.link_loss_params() {
            let read = read_param(
                &self.link,
                target,
                strategy.autopilot(),
                name,
                &self.options.commands,
            )
            .await;
            match read {
                Ok(v) => values.push(v),
                Err(e) => {
                    unread = Some(format!(
                        "what the autopilot does on a lost link is unknown: {e}"
                    ));
                    break;
                }
            }
        }
        self.update_flight(|f| f.link_loss_read = true);
        let read: Vec<String> = strategy
            .link_loss_params()
            .iter()
            .zip(&values)
            .map(|(n, v)| format!("{n} = {v}"))
            .collect();
        let Some(gap) = unread.or_else(|| strategy.link_loss_gap(&values)) else {
            self.note(format!(
                "on a lost link the autopilot takes the drone over ({})",
                read.join(", ")
            ));
            return Ok(());
        };
        match self.options.lost_link {
            LostLinkCheck::Refuse => Err(ActionError::refused(
                action,
                format!("{gap}; the fleet file says `lost_link = \"refuse\"`"),
            )),
            _ => {
                self.warn(gap);
                Ok(())
            }
        }
    }
}
