//! The agent on a drone's companion computer: waits for its slice,
//! answers the ground station, flies each started mission.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

use eamos_exec::abort;
use eamos_exec::event::{Event, Kind, Sink};
use eamos_exec::executor::Outcome;
use eamos_exec::runner::{self, RunOptions};
use eamos_fleet::Fleet;
use eamos_profile::ProfileTable;
use eamos_seal::PublicKey;
use eamos_slicer::Slice;

use crate::flight::{self, Resumed};
use crate::gate::{Gate, Offer};
use crate::link::{open_session, rollout_options, DeployError};
use crate::sessions::Sessions;
use crate::wire::{encode, rollout_key, AgentStatus, Answer, Held, StartCommand};

/// How an agent runs.
pub struct AgentConfig {
    pub drone: String,
    /// What errors call the fleet file.
    pub fleet_name: String,
    /// The fleet as read before any mission is known
    /// ([`Fleet::load_unbound`]): checked against the mission's drones
    /// once a slice says which they are.
    pub fleet: Fleet,
    /// Slices and commands must be signed by this key when given.
    pub trusted: Option<PublicKey>,
    pub profiles: ProfileTable,
    /// Where each mission's logs go: `<out>/<mission>`.
    pub out: PathBuf,
    /// Stop after one mission.
    pub once: bool,
}

/// The line an agent prints for one of its roll-out events (`None` for
/// the events of a flight, which its mission logs keep).
pub fn describe(kind: &Kind) -> Option<String> {
    Some(match kind {
        Kind::RolloutWaiting { endpoints } => format!(
            "waiting for a slice (roll-out via {})",
            endpoints.join(", ")
        ),
        Kind::RolloutAccepted { mission, digest } => {
            format!("accepted the slice of {mission} (digest {digest})")
        }
        Kind::RolloutRefused { what, reason } => format!("refused a {what}: {reason}"),
        Kind::RolloutStarted { identity } => format!("started mission {identity}"),
        Kind::RolloutResumed { identity } => {
            format!("resumed mission {identity} from its journal")
        }
        Kind::RolloutEnded { identity, outcome } => format!("mission {identity} ended: {outcome}"),
        // The crew at the drone reads what its autopilot would do wrong.
        Kind::AdapterWarning { detail } => format!("warning: {detail}"),
        _ => return None,
    })
}

/// Says what the agent did into its sink, stamped with the seconds since
/// it started (there is no mission clock outside a flight).
struct Say {
    drone: String,
    since: Instant,
    events: Arc<dyn Sink>,
}

impl Say {
    fn say(&self, kind: Kind) {
        self.events.event(&Event {
            time: self.since.elapsed().as_secs_f64(),
            drone: self.drone.clone(),
            kind,
        });
    }
}

fn outcome_text(o: &Outcome) -> String {
    match o {
        Outcome::Completed => "completed".into(),
        Outcome::TimeLimit { waiting } => format!("time limit (waiting: {})", waiting.join("; ")),
        Outcome::Failed { reason } => format!("failed: {reason}"),
        Outcome::Stopped => "stopped".into(),
        #[allow(unreachable_patterns)]
        other => format!("{other:?}"),
    }
}

/// The slice an agent holds, and the deploy session that offered it.
struct HeldSlice {
    slice: Slice,
    digest: String,
    fleet: Fleet,
    session: String,
}

impl HeldSlice {
    fn held(&self) -> Held {
        Held {
            identity: self.slice.mission_id.clone(),
            digest: self.digest.clone(),
            session: self.session.clone(),
        }
    }
}

struct AgentState {
    held: Option<HeldSlice>,
    flying: Option<String>,
    sessions: Sessions,
}

/// Runs the agent of one drone: waits for its slice, answers the ground
/// station, flies each started mission with [`runner::run_peer`]. Returns
/// after one mission when `once`, otherwise when `stop` is cancelled.
/// What it does, and what each flight does, goes to `events`: one stream.
pub async fn run_agent(
    config: AgentConfig,
    events: Arc<dyn Sink>,
    stop: CancellationToken,
) -> Result<(), DeployError> {
    let say = Arc::new(Say {
        drone: config.drone.clone(),
        since: Instant::now(),
        events,
    });
    if config.drone.is_empty()
        || config
            .drone
            .chars()
            .any(|c| matches!(c, '/' | '*' | '$' | '?' | '#' | '@') || c.is_whitespace())
    {
        return Err(DeployError::Setup(format!(
            "`{}` cannot be a drone name",
            config.drone
        )));
    }
    let options = rollout_options(&config.fleet, &config.drone);
    let session = open_session(&options).await?;
    let gate = Arc::new(Gate {
        drone: config.drone.clone(),
        fleet: config.fleet.clone(),
        fleet_name: config.fleet_name.clone(),
        trusted: config.trusted.clone(),
    });
    std::fs::create_dir_all(&config.out)
        .map_err(|e| DeployError::Setup(format!("cannot create {}: {e}", config.out.display())))?;
    let mut sessions = Sessions::load(&config.out.join(format!("{}.sessions", config.drone)))
        .map_err(DeployError::Setup)?;
    let kept = flight::record_path(&config.out, &config.drone);
    let resumed = flight::resume(&kept, &gate, &mut sessions).map_err(DeployError::Setup)?;
    let state = Arc::new(Mutex::new(AgentState {
        held: None,
        flying: None,
        sessions,
    }));
    let zerr = |e: zenoh::Error| DeployError::Open(e.to_string());
    let status_q = session
        .declare_queryable(rollout_key(&config.drone, "status"))
        .await
        .map_err(zerr)?;
    let slice_q = session
        .declare_queryable(rollout_key(&config.drone, "slice"))
        .await
        .map_err(zerr)?;
    let start_q = session
        .declare_queryable(rollout_key(&config.drone, "start"))
        .await
        .map_err(zerr)?;
    let _token = session
        .liveliness()
        .declare_token(rollout_key(&config.drone, "agent"))
        .await
        .map_err(zerr)?;
    say.say(Kind::RolloutWaiting {
        endpoints: options.connect.clone(),
    });
    let (ended_tx, mut ended_rx) = mpsc::unbounded_channel::<()>();
    let config = Arc::new(config);
    // A flight this agent started before it was killed flies on at once:
    // the other drones are in the air, and no second start will come.
    if let Some(Resumed {
        start,
        slice,
        digest,
    }) = resumed
    {
        let mut s = state.lock().expect("agent state");
        s.held = Some(HeldSlice {
            slice: slice.clone(),
            digest,
            fleet: config.fleet.clone(),
            session: start.session.clone(),
        });
        s.flying = Some(start.identity.clone());
        say.say(Kind::RolloutResumed {
            identity: start.identity.clone(),
        });
        let fleet = config.fleet.clone();
        tokio::spawn(fly(
            config.clone(),
            slice,
            fleet,
            start,
            state.clone(),
            say.clone(),
            ended_tx.clone(),
            stop.clone(),
        ));
    }
    loop {
        tokio::select! {
            _ = stop.cancelled() => return Ok(()),
            Some(()) = ended_rx.recv() => {
                if config.once {
                    return Ok(());
                }
            }
            Ok(q) = status_q.recv_async() => {
                let status = {
                    let s = state.lock().expect("agent state");
                    AgentStatus {
                        drone: config.drone.clone(),
                        fleet: gate.fleet_digest(),
                        trusts: gate.trusted.as_ref().map(PublicKey::fingerprint),
                        holds: s.held.as_ref().map(HeldSlice::held),
                        flying: s.flying.clone(),
                    }
                };
                let _ = q.reply(q.key_expr().clone(), encode(&status)).await;
            }
            Ok(q) = slice_q.recv_async() => {
                let bytes = q.payload().map(|p| p.to_bytes().to_vec()).unwrap_or_default();
                let answer = {
                    let mut s = state.lock().expect("agent state");
                    let flying = s.flying.clone();
                    let held = s.held.as_ref().map(HeldSlice::held);
                    match (flying, gate.check_slice(&bytes, held.as_ref(), &s.sessions)) {
                        (Some(m), _) => Answer::Refused { reason: format!("busy: flying {m}") },
                        (None, Err(reason)) => Answer::Refused { reason },
                        (None, Ok(Offer::New { slice, digest, fleet, session })) => {
                            say.say(Kind::RolloutAccepted {
                                mission: slice.mission_id.clone(),
                                digest: digest.clone(),
                            });
                            s.held = Some(HeldSlice { slice: *slice, digest: digest.clone(), fleet: *fleet, session });
                            Answer::Accepted { digest }
                        }
                        (None, Ok(Offer::Keep { digest, session })) => {
                            if let Some(h) = s.held.as_mut() {
                                h.session = session;
                            }
                            Answer::Accepted { digest }
                        }
                    }
                };
                if let Answer::Refused { reason } = &answer {
                    say.say(Kind::RolloutRefused { what: "slice".into(), reason: reason.clone() });
                }
                let _ = q.reply(q.key_expr().clone(), encode(&answer)).await;
            }
            Ok(q) = start_q.recv_async() => {
                let bytes = q.payload().map(|p| p.to_bytes().to_vec()).unwrap_or_default();
                let answer = {
                    let mut s = state.lock().expect("agent state");
                    let held = s.held.as_ref().map(HeldSlice::held);
                    let flying = s.flying.clone();
                    let checked = match flying {
                        Some(m) => Err(format!("busy: flying {m}")),
                        None => gate
                            .check_start(&bytes, held.as_ref(), &s.sessions)
                            .and_then(|start| {
                                let h = s.held.as_mut().expect("checked: a slice is held");
                                // The slice kept from an earlier version joins this one.
                                h.slice.mission_id = start.identity.clone();
                                let flown = (h.slice.clone(), h.digest.clone(), h.fleet.clone());
                                // Kept before the session is recorded: a crash
                                // between the two still resumes (and records it).
                                flight::keep(&kept, &bytes, &flown.0)?;
                                s.sessions.record(&start.session, &start.identity)?;
                                Ok((start, flown))
                            }),
                    };
                    match checked {
                        Err(reason) => Answer::Refused { reason },
                        Ok((start, (slice, digest, fleet))) => {
                            s.flying = Some(start.identity.clone());
                            say.say(Kind::RolloutStarted { identity: start.identity.clone() });
                            tokio::spawn(fly(
                                config.clone(), slice, fleet, start, state.clone(),
                                say.clone(), ended_tx.clone(), stop.clone(),
                            ));
                            Answer::Accepted { digest }
                        }
                    }
                };
                if let Answer::Refused { reason } = &answer {
                    say.say(Kind::RolloutRefused { what: "start command".into(), reason: reason.clone() });
                }
                let _ = q.reply(q.key_expr().clone(), encode(&answer)).await;
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
async fn fly(
    config: Arc<AgentConfig>,
    slice: Slice,
    fleet: Fleet,
    start: StartCommand,
    state: Arc<Mutex<AgentState>>,
    say: Arc<Say>,
    ended: mpsc::UnboundedSender<()>,
    stop: CancellationToken,
) {
    let options = RunOptions {
        speed: start.speed,
        max_duration: start.max_duration,
        seed: start.seed,
        out: config.out.join(&slice.mission),
        // One journal per deploy session: a session flies once, so a
        // journal found there is this flight's, interrupted.
        journal: Some(flight::journal_dir(
            &config.out,
            &slice.mission,
            &start.session,
        )),
        stop: stop.child_token(),
        // The flight's events join the agent's own stream.
        events: Some(say.events.clone()),
        // The flight begins when the ground station issued its start: an
        // abort issued before that is a recording of an earlier flight's.
        abort_opener: config
            .trusted
            .clone()
            .map(|k| abort::opener_since(k, start.issued_at_ms)),
        ..RunOptions::default()
    };
    let outcome = match runner::run_peer(&slice, &fleet, &config.profiles, &options).await {
        Ok(r) => r
            .reports
            .first()
            .map(|r| outcome_text(&r.outcome))
            .unwrap_or_else(|| "no report".into()),
        Err(e) => format!("failed: {e}"),
    };
    let outcome = match flight::forget(&flight::record_path(&config.out, &config.drone)) {
        Ok(()) => outcome,
        Err(e) => format!("{outcome} ({e})"),
    };
    state.lock().expect("agent state").flying = None;
    say.say(Kind::RolloutEnded {
        identity: start.identity,
        outcome,
    });
    let _ = ended.send(());
}
