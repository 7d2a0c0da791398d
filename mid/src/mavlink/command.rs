//! The command protocol: a `COMMAND_LONG` is answered by a `COMMAND_ACK`;
//! silence means the command or its answer was lost, so it is sent again
//! (with `confirmation` counting the attempts); `MAV_RESULT_IN_PROGRESS`
//! means wait longer; any other result but `ACCEPTED` is a refusal.
//!
//! A refusal is reported with the command, the result and what the
//! autopilot said about it: ArduPilot explains its refusals in a
//! STATUSTEXT sent just before the ACK ("Arm: Throttle too high"), which is
//! the one thing a pilot needs to read.

use std::fmt;
use std::time::Duration;

use tokio::sync::broadcast::error::RecvError;
use tokio::time::{timeout_at, Instant};

use super::dialect::{MavCmd, MavMessage, MavResult, MavSeverity, COMMAND_LONG_DATA};
use super::link::Link;

/// Which vehicle (system) and component a command is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Target {
    pub system: u8,
    pub component: u8,
}

/// How patiently commands are sent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandPolicy {
    /// How long to wait for an ACK before sending again.
    pub ack_timeout: Duration,
    /// How many times a command is sent before giving up.
    pub attempts: u32,
    /// How long to wait after `MAV_RESULT_IN_PROGRESS` for the final ACK.
    pub in_progress_timeout: Duration,
    /// How long to wait, after a refusal that came without explanation, for
    /// a STATUSTEXT that explains it.
    pub statustext_grace: Duration,
}

impl Default for CommandPolicy {
    fn default() -> Self {
        Self {
            ack_timeout: Duration::from_millis(1500),
            attempts: 3,
            in_progress_timeout: Duration::from_secs(10),
            statustext_grace: Duration::from_millis(300),
        }
    }
}

/// Why a command did not succeed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// The autopilot answered with a result other than `ACCEPTED`.
    #[error("{command} was refused with {result}{}", said(.statustext))]
    Refused {
        command: String,
        result: String,
        /// What the autopilot said while refusing, if anything.
        statustext: Option<String>,
        /// The attempt that was refused (1 for the first); a refusal of a
        /// resent command may mean the first one was carried out and only
        /// its ACK was lost.
        attempt: u32,
    },
    /// No ACK came back at all.
    #[error("no COMMAND_ACK for {command} after {attempts} attempts ({:.1} s)", .waited.as_secs_f64())]
    NoAck {
        command: String,
        attempts: u32,
        waited: Duration,
    },
    /// The command could not be sent (the link is closed, or a `udpin`
    /// link has not heard the vehicle yet).
    #[error("{command} could not be sent: {reason}")]
    NotSent { command: String, reason: String },
}

fn said(text: &Option<String>) -> String {
    match text {
        Some(t) => format!("; the autopilot said: \"{t}\""),
        None => String::new(),
    }
}

impl CommandError {
    pub fn command(&self) -> &str {
        match self {
            CommandError::Refused { command, .. }
            | CommandError::NoAck { command, .. }
            | CommandError::NotSent { command, .. } => command,
        }
    }
}

/// The command's name as MAVLink spells it (`MAV_CMD_COMPONENT_ARM_DISARM`).
pub fn command_name(command: MavCmd) -> String {
    format!("{command:?}")
}

/// The result's name as MAVLink spells it (`MAV_RESULT_DENIED`).
pub fn result_name(result: MavResult) -> String {
    format!("{result:?}")
}

/// Sends `command` with `params` to `target` and waits for its ACK,
/// following `policy`. Only the ACK for this command from the target
/// system counts. Callers serialise commands to one vehicle: autopilots
/// handle one at a time, and ACKs carry no sequence number to tell two
/// commands of the same kind apart.
pub async fn command_long(
    link: &Link,
    target: Target,
    command: MavCmd,
    params: [f32; 7],
    policy: &CommandPolicy,
) -> Result<(), CommandError> {
    let name = command_name(command);
    let mut incoming = link.subscribe();
    let started = Instant::now();
    let mut explanation: Option<(MavSeverity, String)> = None;
    let attempts = policy.attempts.max(1);
    for attempt in 0..attempts {
        let message = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: params[0],
            param2: params[1],
            param3: params[2],
            param4: params[3],
            param5: params[4],
            param6: params[5],
            param7: params[6],
            command,
            target_system: target.system,
            target_component: target.component,
            confirmation: attempt.min(255) as u8,
        });
        match link.send(&message).await {
            Ok(true) => {}
            Ok(false) => {
                return Err(CommandError::NotSent {
                    command: name,
                    reason: "the vehicle has not been heard on this link".to_string(),
                })
            }
            Err(e) => {
                return Err(CommandError::NotSent {
                    command: name,
                    reason: e.to_string(),
                })
            }
        }
        let mut deadline = Instant::now() + policy.ack_timeout;
        loop {
            let received = match timeout_at(deadline, incoming.recv()).await {
                Err(_) => break,
                Ok(Err(RecvError::Lagged(_))) => continue,
                Ok(Err(RecvError::Closed)) => {
                    return Err(CommandError::NotSent {
                        command: name,
                        reason: "the link closed".to_string(),
                    })
                }
                Ok(Ok(r)) => r,
            };
            if received.header.system_id != u32::from(target.system) {
                continue;
            }
            match &received.message {
                MavMessage::STATUSTEXT(t) => {
                    note_statustext(&mut explanation, t.severity, &t.text);
                }
                MavMessage::COMMAND_ACK(ack) if ack.command == command => match ack.result {
                    MavResult::MAV_RESULT_ACCEPTED => return Ok(()),
                    MavResult::MAV_RESULT_IN_PROGRESS => {
                        deadline = Instant::now() + policy.in_progress_timeout;
                    }
                    refusal => {
                        if explanation.is_none() {
                            wait_for_explanation(&mut incoming, target, policy, &mut explanation)
                                .await;
                        }
                        return Err(CommandError::Refused {
                            command: name,
                            result: result_name(refusal),
                            statustext: explanation.map(|(_, t)| t),
                            attempt: attempt + 1,
                        });
                    }
                },
                _ => {}
            }
        }
    }
    Err(CommandError::NoAck {
        command: name,
        attempts,
        waited: started.elapsed(),
    })
}

/// Keeps the most telling STATUSTEXT: the latest warning or worse, else
/// the latest of any severity.
fn note_statustext(
    slot: &mut Option<(MavSeverity, String)>,
    severity: MavSeverity,
    text: &mavlink::types::CharArray<50>,
) {
    let Ok(text) = text.to_str() else { return };
    let text = text.trim().to_string();
    if text.is_empty() {
        return;
    }
    let serious = |s: MavSeverity| (s as u8) <= (MavSeverity::MAV_SEVERITY_WARNING as u8);
    match slot {
        Some((held, _)) if serious(*held) && !serious(severity) => {}
        _ => *slot = Some((severity, text)),
    }
}

async fn wait_for_explanation(
    incoming: &mut tokio::sync::broadcast::Receiver<std::sync::Arc<super::link::Received>>,
    target: Target,
    policy: &CommandPolicy,
    explanation: &mut Option<(MavSeverity, String)>,
) {
    let deadline = Instant::now() + policy.statustext_grace;
    while explanation.is_none() {
        match timeout_at(deadline, incoming.recv()).await {
            Err(_) | Ok(Err(RecvError::Closed)) => return,
            Ok(Err(RecvError::Lagged(_))) => continue,
            Ok(Ok(r)) => {
                if r.header.system_id == u32::from(target.system) {
                    if let MavMessage::STATUSTEXT(t) = &r.message {
                        note_statustext(explanation, t.severity, &t.text);
                    }
                }
            }
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "system {} component {}", self.system, self.component)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mavlink::address::ConnectAddress;
    use crate::mavlink::dialect::{COMMAND_ACK_DATA, STATUSTEXT_DATA};
    use mavlink::MavHeader;
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::sync::Arc;

    /// A vehicle end that answers COMMAND_LONGs with `answer(attempt)`
    /// (None: stay silent), preceded by a STATUSTEXT when given one.
    async fn pair(
        answer: impl Fn(u32, &COMMAND_LONG_DATA) -> Vec<MavMessage> + Send + Sync + 'static,
    ) -> (Link, Arc<AtomicU32>, tokio::task::JoinHandle<()>) {
        let gcs = Link::open(
            &ConnectAddress::parse("udpin:127.0.0.1:0").unwrap(),
            MavHeader {
                system_id: 255,
                component_id: 190,
                sequence: 0,
            },
        )
        .await
        .unwrap();
        let port = gcs.local_addr().unwrap().port();
        let vehicle = Link::open(
            &ConnectAddress::parse(&format!("udpout:127.0.0.1:{port}")).unwrap(),
            MavHeader {
                system_id: 1,
                component_id: 1,
                sequence: 0,
            },
        )
        .await
        .unwrap();
        let seen = Arc::new(AtomicU32::new(0));
        let mut rx = vehicle.subscribe();
        let mut at_gcs = gcs.subscribe();
        // Introduce the vehicle so the udpin end can answer.
        vehicle
            .send(&MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity: MavSeverity::MAV_SEVERITY_INFO,
                text: "hello".into(),
            }))
            .await
            .unwrap();
        tokio::time::timeout(Duration::from_secs(10), at_gcs.recv())
            .await
            .unwrap()
            .unwrap();
        let counter = seen.clone();
        let task = tokio::spawn(async move {
            while let Ok(r) = rx.recv().await {
                if let MavMessage::COMMAND_LONG(c) = &r.message {
                    let n = counter.fetch_add(1, Ordering::SeqCst) + 1;
                    for m in answer(n, c) {
                        vehicle.send(&m).await.unwrap();
                    }
                }
            }
        });
        (gcs, seen, task)
    }

    fn ack(command: MavCmd, result: MavResult) -> MavMessage {
        MavMessage::COMMAND_ACK(COMMAND_ACK_DATA { command, result })
    }

    fn text(severity: MavSeverity, t: &str) -> MavMessage {
        MavMessage::STATUSTEXT(STATUSTEXT_DATA {
            severity,
            text: t.into(),
        })
    }

    fn fast() -> CommandPolicy {
        CommandPolicy {
            ack_timeout: Duration::from_millis(300),
            attempts: 3,
            in_progress_timeout: Duration::from_secs(5),
            statustext_grace: Duration::from_millis(300),
        }
    }

    const VEHICLE: Target = Target {
        system: 1,
        component: 1,
    };

    #[tokio::test]
    async fn an_accepted_command_returns_ok() {
        let (gcs, seen, task) =
            pair(|_, c| vec![ack(c.command, MavResult::MAV_RESULT_ACCEPTED)]).await;
        let r = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &fast(),
        )
        .await;
        assert_eq!(r, Ok(()));
        assert_eq!(seen.load(Ordering::SeqCst), 1);
        task.abort();
    }

    #[tokio::test]
    async fn a_lost_ack_is_retried_with_the_confirmation_counted_up() {
        let (gcs, seen, task) = pair(|n, c| {
            assert_eq!(u32::from(c.confirmation), n - 1);
            if n < 3 {
                vec![]
            } else {
                vec![ack(c.command, MavResult::MAV_RESULT_ACCEPTED)]
            }
        })
        .await;
        let r = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &fast(),
        )
        .await;
        assert_eq!(r, Ok(()));
        assert_eq!(seen.load(Ordering::SeqCst), 3);
        task.abort();
    }

    #[tokio::test]
    async fn silence_after_every_attempt_is_no_ack() {
        let (gcs, seen, task) = pair(|_, _| vec![]).await;
        let e = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0],
            &fast(),
        )
        .await
        .unwrap_err();
        assert!(
            matches!(e, CommandError::NoAck { attempts: 3, .. }),
            "{e:?}"
        );
        assert!(e
            .to_string()
            .starts_with("no COMMAND_ACK for MAV_CMD_NAV_TAKEOFF after 3 attempts"));
        assert_eq!(seen.load(Ordering::SeqCst), 3);
        task.abort();
    }

    #[tokio::test]
    async fn a_refusal_names_command_result_and_what_the_autopilot_said() {
        let (gcs, _, task) = pair(|_, c| {
            vec![
                text(MavSeverity::MAV_SEVERITY_INFO, "Mode change"),
                text(MavSeverity::MAV_SEVERITY_CRITICAL, "Arm: Throttle too high"),
                text(MavSeverity::MAV_SEVERITY_INFO, "something chatty"),
                ack(c.command, MavResult::MAV_RESULT_FAILED),
            ]
        })
        .await;
        let e = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &fast(),
        )
        .await
        .unwrap_err();
        assert_eq!(
            e,
            CommandError::Refused {
                command: "MAV_CMD_COMPONENT_ARM_DISARM".into(),
                result: "MAV_RESULT_FAILED".into(),
                statustext: Some("Arm: Throttle too high".into()),
                attempt: 1,
            }
        );
        assert_eq!(
            e.to_string(),
            "MAV_CMD_COMPONENT_ARM_DISARM was refused with MAV_RESULT_FAILED; the autopilot said: \"Arm: Throttle too high\""
        );
        task.abort();
    }

    #[tokio::test]
    async fn an_explanation_that_follows_the_refusal_is_still_caught() {
        let (gcs, _, task) = pair(|_, c| {
            vec![
                ack(c.command, MavResult::MAV_RESULT_DENIED),
                text(MavSeverity::MAV_SEVERITY_WARNING, "Takeoff: not armed"),
            ]
        })
        .await;
        let e = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0; 7],
            &fast(),
        )
        .await
        .unwrap_err();
        assert!(
            matches!(&e, CommandError::Refused { statustext: Some(t), result, .. } if t == "Takeoff: not armed" && result == "MAV_RESULT_DENIED"),
            "{e:?}"
        );
        task.abort();
    }

    #[tokio::test]
    async fn in_progress_waits_for_the_final_answer() {
        let (gcs, seen, task) = pair(|_, c| {
            vec![
                ack(c.command, MavResult::MAV_RESULT_IN_PROGRESS),
                ack(c.command, MavResult::MAV_RESULT_ACCEPTED),
            ]
        })
        .await;
        let r = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            &fast(),
        )
        .await;
        assert_eq!(r, Ok(()));
        assert_eq!(seen.load(Ordering::SeqCst), 1);
        task.abort();
    }

    #[tokio::test]
    async fn an_ack_for_another_command_does_not_answer_this_one() {
        let (gcs, seen, task) = pair(|n, c| {
            if n == 1 {
                vec![ack(
                    MavCmd::MAV_CMD_DO_SET_MODE,
                    MavResult::MAV_RESULT_ACCEPTED,
                )]
            } else {
                vec![ack(c.command, MavResult::MAV_RESULT_ACCEPTED)]
            }
        })
        .await;
        let r = command_long(
            &gcs,
            VEHICLE,
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &fast(),
        )
        .await;
        assert_eq!(r, Ok(()));
        assert_eq!(seen.load(Ordering::SeqCst), 2);
        task.abort();
    }

    #[tokio::test]
    async fn a_command_on_a_link_that_never_heard_the_vehicle_is_not_sent() {
        let gcs = Link::open(
            &ConnectAddress::parse("udpin:127.0.0.1:0").unwrap(),
            MavHeader::default(),
        )
        .await
        .unwrap();
        let e = command_long(&gcs, VEHICLE, MavCmd::MAV_CMD_NAV_LAND, [0.0; 7], &fast())
            .await
            .unwrap_err();
        assert!(matches!(e, CommandError::NotSent { .. }), "{e:?}");
        assert!(e.to_string().contains("has not been heard"), "{e}");
    }
}
