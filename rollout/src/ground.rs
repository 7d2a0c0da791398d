//! The ground station's side of the roll-out: offers each drone its
//! slice, sealed, and once every drone holds its part, the start.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;
use std::time::Duration;

use zenoh::Session;

use eamos_exec::abort;
use eamos_exec::runner::{self, RunOptions, RunReport};
use eamos_fleet::identity::{fleet_version, slice_digest};
use eamos_fleet::{Fleet, GCS};
use eamos_profile::ProfileTable;
use eamos_seal::{GroundKey, Sealed, CONTEXT_SLICE, CONTEXT_START};
use eamos_slicer::{Slice, Slices};

use crate::link::{open_session, rollout_options, DeployError};
use crate::sessions::new_session;
use crate::wire::{encode, rollout_key, AgentStatus, Answer, SliceBundle, StartCommand};

/// What happened to one drone's slice.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Delivery {
    /// Sent, verified and kept by the agent.
    Sent {
        digest: String,
    },
    /// The agent already holds this very slice.
    Unchanged {
        digest: String,
    },
    Refused {
        reason: String,
    },
}

impl fmt::Display for Delivery {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Delivery::Sent { digest } => write!(f, "sent (slice {digest})"),
            Delivery::Unchanged { digest } => write!(f, "unchanged (slice {digest})"),
            Delivery::Refused { reason } => write!(f, "refused: {reason}"),
        }
    }
}

/// The ground station's end of the roll-out link.
pub struct RollOut {
    link: Session,
    key: Option<Arc<GroundKey>>,
    fleet_digest: String,
    session: String,
}

impl RollOut {
    /// Listens on the fleet's roll-out endpoints.
    pub async fn open(fleet: &Fleet, key: Option<GroundKey>) -> Result<RollOut, DeployError> {
        let link = open_session(&rollout_options(fleet, GCS)).await?;
        Ok(RollOut {
            link,
            key: key.map(Arc::new),
            fleet_digest: fleet_version(fleet),
            session: new_session(),
        })
    }

    /// Seals the abort the ground station sends when it is stopped, with
    /// this roll-out's key (none without one).
    pub fn abort_sealer(&self) -> Option<abort::CommandSealer> {
        self.key.clone().map(abort::sealer)
    }

    /// This roll-out's deploy session: fresh for every one, named by each
    /// offer and by the start (see the module's "Replay").
    pub fn session(&self) -> &str {
        &self.session
    }

    fn seal(&self, context: &str, payload: Vec<u8>) -> Vec<u8> {
        let sealed = match &self.key {
            Some(k) => k.seal(context, payload),
            None => Sealed::unsigned(context, payload),
        };
        sealed.to_bytes()
    }

    /// Waits until the agents of `drones` are up; the ones still missing
    /// after `timeout`.
    pub async fn wait_for_agents(&self, drones: &[String], timeout: Duration) -> Vec<String> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let mut up = std::collections::BTreeSet::new();
            if let Ok(replies) = self
                .link
                .liveliness()
                .get("eamos/rollout/*/agent")
                .timeout(Duration::from_millis(500))
                .await
            {
                while let Ok(r) = replies.recv_async().await {
                    if let Ok(s) = r.result() {
                        if let Some(d) = s.key_expr().as_str().split('/').nth(2) {
                            up.insert(d.to_string());
                        }
                    }
                }
            }
            let missing: Vec<String> = drones
                .iter()
                .filter(|d| !up.contains(*d))
                .cloned()
                .collect();
            if missing.is_empty() || tokio::time::Instant::now() >= deadline {
                return missing;
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    }

    /// One query to one agent, retried a few times while the agent's
    /// queryable is not yet known here.
    async fn ask(
        &self,
        drone: &str,
        what: &str,
        payload: Option<Vec<u8>>,
    ) -> Result<Vec<u8>, String> {
        let mut last = String::from("no answer");
        for _ in 0..5 {
            let mut get = self
                .link
                .get(rollout_key(drone, what))
                .timeout(Duration::from_secs(5));
            if let Some(p) = &payload {
                get = get.payload(p.clone());
            }
            let replies = get.await.map_err(|e| e.to_string())?;
            while let Ok(r) = replies.recv_async().await {
                match r.into_result() {
                    Ok(s) => return Ok(s.payload().to_bytes().to_vec()),
                    Err(e) => last = format!("{e:?}"),
                }
            }
            tokio::time::sleep(Duration::from_millis(300)).await;
        }
        Err(format!("the agent of {drone} did not answer ({last})"))
    }

    pub async fn status(&self, drone: &str) -> Result<AgentStatus, String> {
        let bytes = self.ask(drone, "status", None).await?;
        AgentStatus::from_bytes(&bytes).map_err(|e| format!("garbled status from {drone}: {e}"))
    }

    /// Sends each drone of `slices` its slice unless it holds it already.
    pub async fn deliver(&self, slices: &Slices) -> BTreeMap<String, Delivery> {
        let mut out = BTreeMap::new();
        for drone in &slices.drones {
            let slice = slices.get(drone).expect("every drone has a slice");
            let digest = slice_digest(slice);
            let d = match self.status(drone).await {
                Err(reason) => Delivery::Refused { reason },
                Ok(st) if st.flying.is_some() => Delivery::Refused {
                    reason: format!("busy: flying {}", st.flying.unwrap_or_default()),
                },
                Ok(st)
                    if st.fleet == self.fleet_digest
                        && st.holds.as_ref().is_some_and(|h| h.digest == digest) =>
                {
                    // Told to keep it for this session; sent in full if the
                    // agent lost it meanwhile.
                    match self.send_offer(slices, slice, false).await {
                        Delivery::Sent { digest } => Delivery::Unchanged { digest },
                        _ => self.send_offer(slices, slice, true).await,
                    }
                }
                Ok(_) => self.send_slice(slices, slice).await,
            };
            out.insert(drone.clone(), d);
        }
        out
    }

    /// Sends one slice and reports what the agent answered.
    pub async fn send_slice(&self, slices: &Slices, slice: &Slice) -> Delivery {
        self.send_offer(slices, slice, true).await
    }

    /// The offer of `slice` in this session: with the slice, or telling
    /// the agent to keep the one it holds.
    pub fn offer(&self, slices: &Slices, slice: &Slice, with_slice: bool) -> SliceBundle {
        SliceBundle {
            identity: slices.mission_id.clone(),
            fleet: self.fleet_digest.clone(),
            session: self.session.clone(),
            digest: slice_digest(slice),
            slice: with_slice.then(|| slice.to_bytes()),
        }
    }

    /// The sealed envelope of `offer`, as the agents receive it.
    pub fn seal_offer(&self, offer: &SliceBundle) -> Vec<u8> {
        self.seal(CONTEXT_SLICE, encode(offer))
    }

    async fn send_offer(&self, slices: &Slices, slice: &Slice, with_slice: bool) -> Delivery {
        let sealed = self.seal_offer(&self.offer(slices, slice, with_slice));
        self.send_sealed_slice(&slice.drone, sealed).await
    }

    /// Sends an already sealed slice envelope (tests send altered ones).
    pub async fn send_sealed_slice(&self, drone: &str, sealed: Vec<u8>) -> Delivery {
        match self.ask(drone, "slice", Some(sealed)).await {
            Err(reason) => Delivery::Refused { reason },
            Ok(bytes) => match Answer::from_bytes(&bytes) {
                Ok(Answer::Accepted { digest }) => Delivery::Sent { digest },
                Ok(Answer::Refused { reason }) => Delivery::Refused { reason },
                Err(e) => Delivery::Refused {
                    reason: format!("garbled answer: {e}"),
                },
            },
        }
    }

    /// The start command of `slices`.
    pub fn start_command(&self, slices: &Slices, run: &RunOptions) -> StartCommand {
        StartCommand {
            identity: slices.mission_id.clone(),
            fleet: self.fleet_digest.clone(),
            session: self.session.clone(),
            issued_at_ms: abort::unix_ms(),
            digests: slices
                .drones
                .iter()
                .filter_map(|d| slices.get(d).map(|s| (d.clone(), slice_digest(s))))
                .collect(),
            speed: run.speed,
            max_duration: run.max_duration,
            seed: run.seed,
        }
    }

    /// Sends the start command to every drone; what each answered.
    pub async fn start(&self, slices: &Slices, run: &RunOptions) -> BTreeMap<String, Answer> {
        let sealed = self.seal_start(&self.start_command(slices, run));
        self.send_start(&slices.drones, sealed).await
    }

    /// The sealed envelope of `start`, as the agents receive it.
    pub fn seal_start(&self, start: &StartCommand) -> Vec<u8> {
        self.seal(CONTEXT_START, encode(start))
    }

    /// Sends a sealed start envelope to `drones` (tests send forged ones).
    pub async fn send_start(&self, drones: &[String], sealed: Vec<u8>) -> BTreeMap<String, Answer> {
        let mut out = BTreeMap::new();
        for d in drones {
            let a = match self.ask(d, "start", Some(sealed.clone())).await {
                Err(reason) => Answer::Refused { reason },
                Ok(bytes) => Answer::from_bytes(&bytes).unwrap_or_else(|e| Answer::Refused {
                    reason: format!("garbled answer: {e}"),
                }),
            };
            out.insert(d.clone(), a);
        }
        out
    }

    pub async fn close(self) {
        let _ = self.link.close().await;
    }
}

/// The ground station's part of a deployed mission, once started: the same
/// as `eamos run --gcs`.
pub async fn fly_ground_station(
    slices: &Slices,
    fleet: &Fleet,
    profiles: &ProfileTable,
    run: &RunOptions,
) -> Result<RunReport, runner::RunError> {
    let gcs = slices
        .get(GCS)
        .expect("every mission has a ground station slice");
    runner::run_peer(gcs, fleet, profiles, run).await
}
