//! Commands to the autopilot, one at a time, each with its ACK.

use std::time::Duration;

use crate::api::{ActionError, CancellationToken};
use crate::log::AdapterEvent;
use crate::mavlink::command::{command_long, command_name, CommandError};
use crate::mavlink::dialect::MavCmd;

use super::shared::{Check, Halt, Shared};

impl Shared {
    /// Sends one command and waits for its ACK; a lost link ends the wait
    /// at once. Commands to one vehicle go one at a time.
    pub(super) async fn command_raw(
        &self,
        action: &str,
        command: MavCmd,
        params: [f32; 7],
    ) -> Result<Result<(), CommandError>, ActionError> {
        self.log(AdapterEvent::Command {
            action: action.to_string(),
            args: params.iter().map(|p| f64::from(*p)).collect(),
            detail: command_name(command),
        });
        self.send_command(action, command, params).await
    }

    /// [`Shared::command_raw`] without the log record, for the adapter's
    /// own housekeeping (stream requests).
    pub(super) async fn send_command(
        &self,
        action: &str,
        command: MavCmd,
        params: [f32; 7],
    ) -> Result<Result<(), CommandError>, ActionError> {
        let link_lost = || ActionError::LinkLost {
            action: action.to_string(),
        };
        let target = self.watched.borrow().vehicle.target.ok_or_else(link_lost)?;
        let _one_at_a_time = self.commands.lock().await;
        if self.watched.borrow().link_lost {
            return Err(link_lost());
        }
        let mut rx = self.watched.subscribe();
        let lost = async {
            loop {
                if rx.borrow_and_update().link_lost {
                    return;
                }
                if rx.changed().await.is_err() {
                    return;
                }
            }
        };
        let outcome = tokio::select! {
            r = command_long(&self.link, target, command, params, &self.options.commands) => r,
            _ = lost => return Err(link_lost()),
        };
        if let Err(CommandError::NoAck { .. }) = &outcome {
            // No answer, and the vehicle silent for longer than an ACK
            // wait: a live autopilot streams telemetry several times a
            // second, so this is a lost link rather than a slow autopilot,
            // and the link monitor is about to say so. Wait for its
            // verdict; a vehicle heard again in the meantime makes it a
            // plain timeout.
            let last_heard = self.watched.borrow().vehicle.last_heard;
            let silent_since =
                last_heard.filter(|h| h.elapsed() >= self.options.commands.ack_timeout);
            if let Some(heard) = silent_since {
                let verdict = heard + self.options.link_timeout + Duration::from_secs(1);
                let silence = self
                    .wait(verdict, &CancellationToken::new(), |w| {
                        if w.vehicle.last_heard > Some(heard) {
                            Check::Done(())
                        } else {
                            Check::Pending
                        }
                    })
                    .await;
                if let Err(Halt::LinkLost) = silence {
                    return Err(link_lost());
                }
            }
        }
        Ok(outcome)
    }

    pub(super) async fn command(
        &self,
        action: &str,
        command: MavCmd,
        params: [f32; 7],
    ) -> Result<(), ActionError> {
        match self.command_raw(action, command, params).await? {
            Ok(()) => Ok(()),
            Err(e) => Err(self.command_error(action, e)),
        }
    }

    pub(super) fn command_error(&self, action: &str, e: CommandError) -> ActionError {
        match e {
            CommandError::Refused { .. } => ActionError::refused(action, e),
            CommandError::NoAck { .. } if self.watched.borrow().link_lost => {
                ActionError::LinkLost {
                    action: action.to_string(),
                }
            }
            CommandError::NoAck { .. } => ActionError::Timeout {
                action: action.to_string(),
                what: format!("the autopilot to acknowledge: {e}"),
            },
            CommandError::NotSent { .. } => ActionError::LinkLost {
                action: action.to_string(),
            },
        }
    }
}
