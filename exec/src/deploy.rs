//! The roll-out, the paper's deployment step: each drone's agent waits on
//! its companion computer for its slice; the ground station compiles the
//! mission, signs each drone's slice, sends it, and once every drone holds
//! and has verified its part, sends the signed start.
//!
//! Agents and the ground station meet on the fleet's *roll-out* endpoints
//! (`[rollout]` in the fleet file, or a loopback port derived from the
//! fleet file): the ground station listens, agents connect. There is no
//! mission yet, so nothing here is scoped by a mission identity; the
//! messages name drones:
//!
//! | key | what |
//! | --- | --- |
//! | `eamos/rollout/<drone>/agent` | liveliness token: the agent of `drone` waits |
//! | `eamos/rollout/<drone>/status` | query: which slice the agent holds ([`AgentStatus`]) |
//! | `eamos/rollout/<drone>/slice` | query with a sealed [`SliceBundle`]: [`Answer`] |
//! | `eamos/rollout/<drone>/start` | query with a sealed [`StartCommand`]: [`Answer`] |
//!
//! Every exchange is a query and its reply, so the ground station knows that
//! each agent got its slice *and verified it* (or why it refused). An agent
//! configured with the ground station's public key (`[keys] gcs`) refuses
//! unsigned envelopes, envelopes signed by another key and altered ones;
//! and, signed or not, a slice built with another fleet file or a start
//! command for another version of the mission than the slice it holds.
//!
//! Partial redeployment: an agent reports the digest of the slice it holds
//! ([`crate::identity::slice_digest`]); a drone whose new slice has the same
//! digest is not sent anything, and the start command binds the slice it
//! keeps to the new mission identity. The start command lists every drone's
//! digest, so an agent holding any other slice refuses to start.
//!
//! # Replay
//!
//! A signature says who sent a message, not when: a recorded signed start
//! would fly the mission again, and a recorded abort would end a later
//! flight of the same version. So every `eamos deploy` is a *deploy
//! session* with a fresh random id ([`RollOut::session`]): each slice
//! offer (a new slice, or, for a drone whose part did not change, a
//! [`SliceBundle`] without one that says "keep yours") and the start name
//! it, inside the signature. An agent starts only the session its slice
//! was offered in, and never starts one session twice: it writes each
//! session it starts to `<out>/<drone>.sessions` before it answers, so a
//! restarted agent refuses it too. Sessions rather than clocks, because a
//! drone's clock and the ground station's need not agree for this; the
//! only time compared is the abort's against the start, both issued by the
//! ground station (see [`crate::abort::opener_since`]).

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;
use zenoh::Session;

use eamos_petri::net::Net;
use eamos_profile::ProfileTable;
use eamos_seal::{GroundKey, PublicKey, Sealed, CONTEXT_SLICE, CONTEXT_START};

use crate::abort;
use eamos_slicer::{Slice, Slices};

use crate::executor::Outcome;
use crate::fleet::{loopback_port, Fleet};
use crate::identity::{fleet_version, slice_digest};
use crate::runner::{self, RunOptions, RunReport};
use crate::transport::zenoh::{config, ZenohOptions};
use crate::transport::GCS;

pub use tokio_util::sync::CancellationToken;

/// The key expression of `what` for the agent of `drone`.
pub fn rollout_key(drone: &str, what: &str) -> String {
    format!("eamos/rollout/{drone}/{what}")
}

/// A drone's slice as the ground station offers it, inside a sealed
/// envelope of context [`CONTEXT_SLICE`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SliceBundle {
    /// The mission identity the slice was cut for.
    pub identity: String,
    /// The digest of the fleet file it was built with.
    pub fleet: String,
    /// The deploy session offering it: the only one whose start the agent
    /// will obey with this slice.
    pub session: String,
    /// The digest of the slice offered.
    pub digest: String,
    /// The slice in its binary form (with its own checksum); `None` when
    /// the agent already holds the slice of `digest` and is to keep it for
    /// this session (partial redeployment).
    pub slice: Option<Vec<u8>>,
}

/// Start the mission: sealed with context [`CONTEXT_START`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StartCommand {
    pub identity: String,
    pub fleet: String,
    /// The deploy session whose slices are to fly; started at most once.
    pub session: String,
    /// When the ground station issued it (milliseconds since the Unix
    /// epoch, on its clock): abort commands issued well before it belong
    /// to an earlier flight.
    pub issued_at_ms: u64,
    /// The digest of every drone's slice in this version of the mission.
    pub digests: BTreeMap<String, String>,
    /// Simulated seconds per real second.
    pub speed: f64,
    pub max_duration: Option<f64>,
    pub seed: u64,
}

impl SliceBundle {
    pub fn to_bytes(&self) -> Vec<u8> {
        encode(self)
    }

    /// Never panics: bytes that are not a bundle are an error.
    pub fn from_bytes(bytes: &[u8]) -> Result<SliceBundle, String> {
        decode(bytes).map_err(|e| format!("not a slice bundle: {e}"))
    }
}

impl StartCommand {
    pub fn to_bytes(&self) -> Vec<u8> {
        encode(self)
    }

    /// Never panics: bytes that are not a start command are an error.
    pub fn from_bytes(bytes: &[u8]) -> Result<StartCommand, String> {
        decode(bytes).map_err(|e| format!("not a start command: {e}"))
    }
}

impl AgentStatus {
    /// Never panics: what an agent answered, or why it is garbled.
    pub fn from_bytes(bytes: &[u8]) -> Result<AgentStatus, String> {
        decode(bytes).map_err(|e| e.to_string())
    }
}

impl Answer {
    /// Never panics: what an agent answered, or why it is garbled.
    pub fn from_bytes(bytes: &[u8]) -> Result<Answer, String> {
        decode(bytes).map_err(|e| e.to_string())
    }
}

/// Decodes a whole message: trailing bytes are an error, so that one
/// message has one encoding.
fn decode<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Result<T, String> {
    let (v, rest) = postcard::take_from_bytes(bytes).map_err(|e| e.to_string())?;
    if !rest.is_empty() {
        return Err(format!("{} bytes after the message", rest.len()));
    }
    Ok(v)
}

/// What an agent holds, as it tells the ground station.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentStatus {
    pub drone: String,
    /// The digest of the agent's fleet file.
    pub fleet: String,
    /// The fingerprint of the key the agent trusts, if any.
    pub trusts: Option<String>,
    pub holds: Option<Held>,
    /// The identity of the mission it is flying, if any.
    pub flying: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Held {
    pub identity: String,
    pub digest: String,
    /// The deploy session that offered it last.
    pub session: String,
}

/// An agent's reply to a slice or a start command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Answer {
    Accepted { digest: String },
    Refused { reason: String },
}

fn encode<T: Serialize>(v: &T) -> Vec<u8> {
    postcard::to_stdvec(v).expect("roll-out messages always serialise")
}

#[derive(Debug, thiserror::Error)]
pub enum DeployError {
    #[error("cannot open the roll-out link: {0}")]
    Open(String),
    #[error("{0}")]
    Setup(String),
}

/// Where the ground station listens for agents, and where agents connect.
pub fn rollout_endpoints(fleet: &Fleet) -> (Vec<String>, Vec<String>) {
    let listen = if fleet.rollout.listen.is_empty() {
        // Slot 63 of the fleet's block: a mission's peers use the first
        // slots of their own block, so the two do not meet.
        let scope = format!("rollout-{}", fleet_version(fleet));
        vec![format!("tcp/127.0.0.1:{}", loopback_port(&scope, 63))]
    } else {
        fleet.rollout.listen.clone()
    };
    let connect = if fleet.rollout.connect.is_empty() {
        listen.clone()
    } else {
        fleet.rollout.connect.clone()
    };
    (listen, connect)
}

/// The zenoh options of the roll-out link: the fleet's settings for `peer`
/// (scouting, and whatever else the fleet says about links) with the
/// roll-out endpoints.
fn rollout_options(fleet: &Fleet, peer: &str) -> ZenohOptions {
    let (listen, connect) = rollout_endpoints(fleet);
    let peers = vec![GCS.to_string(), peer.to_string()];
    let base = fleet.zenoh_options("rollout", &peers, peer);
    if peer == GCS {
        ZenohOptions {
            listen,
            connect: Vec::new(),
            ..base
        }
    } else {
        ZenohOptions {
            listen: Vec::new(),
            connect,
            ..base
        }
    }
}

async fn open_session(options: &ZenohOptions) -> Result<Session, DeployError> {
    zenoh::open(config(options).map_err(|e| DeployError::Open(e.to_string()))?)
        .await
        .map_err(|e| DeployError::Open(e.to_string()))
}

/// The ground station's public key named by the fleet file, relative to
/// the fleet file's directory.
pub fn trusted_key(fleet: &Fleet, fleet_path: Option<&Path>) -> Result<Option<PublicKey>, String> {
    let Some(p) = &fleet.keys.gcs else {
        return Ok(None);
    };
    let path = resolve(fleet_path, p);
    PublicKey::load(&path)
        .map(Some)
        .map_err(|e| format!("[keys] gcs: {e}"))
}

/// The ground station's secret key: `explicit` (a `--key` option), or the
/// sibling with the extension `.key` of the public key the fleet names.
/// A fleet that names a public key needs the matching secret key, or every
/// agent would refuse what the ground station sends: that is an error
/// here, before anything is sent.
pub fn ground_key(
    fleet: &Fleet,
    fleet_path: Option<&Path>,
    explicit: Option<&Path>,
) -> Result<Option<GroundKey>, String> {
    let path = match (explicit, &fleet.keys.gcs) {
        (Some(k), _) => k.to_path_buf(),
        (None, Some(public)) => resolve(fleet_path, public).with_extension("key"),
        (None, None) => return Ok(None),
    };
    let key = GroundKey::load(&path).map_err(|e| e.to_string())?;
    if let Some(trusted) = trusted_key(fleet, fleet_path)? {
        if trusted != key.public() {
            return Err(format!(
                "{} is the secret key of {}, but the fleet file trusts {}: the agents would refuse whatever it signs",
                path.display(),
                key.public().fingerprint(),
                trusted.fingerprint()
            ));
        }
    }
    Ok(Some(key))
}

/// A path of the fleet file, relative to its directory.
pub fn resolve(fleet_path: Option<&Path>, p: &Path) -> PathBuf {
    match fleet_path.and_then(Path::parent) {
        Some(dir) if p.is_relative() => dir.join(p),
        _ => p.to_path_buf(),
    }
}

/// Reads an agent's fleet file before any mission is known: checked
/// against the drones it names itself; against the mission's drones once a
/// slice says which they are.
pub fn agent_fleet(text: &str, name: &str) -> Result<Fleet, crate::fleet::FleetError> {
    let named: Vec<String> = toml::from_str::<toml::Table>(text)
        .ok()
        .and_then(|t| t.get("drones").and_then(|d| d.as_table()).cloned())
        .map(|d| d.keys().cloned().collect())
        .unwrap_or_default();
    Fleet::parse(text, name, "the fleet", &named)
}

// ---------------------------------------------------------------- agent --

/// How an agent runs.
pub struct AgentConfig {
    pub drone: String,
    /// The fleet file's text and name: read again against the mission's
    /// drones once a slice says which they are.
    pub fleet_text: String,
    pub fleet_name: String,
    /// The fleet as read before any mission is known.
    pub fleet: Fleet,
    /// Slices and commands must be signed by this key when given.
    pub trusted: Option<PublicKey>,
    pub profiles: ProfileTable,
    /// Where each mission's logs go: `<out>/<mission>`.
    pub out: PathBuf,
    /// Stop after one mission.
    pub once: bool,
}

/// What an agent did, for the command line to print.
#[derive(Debug, Clone, PartialEq)]
pub enum AgentEvent {
    Waiting { endpoints: Vec<String> },
    Accepted { mission: String, digest: String },
    Refused { what: &'static str, reason: String },
    Started { identity: String },
    Ended { identity: String, outcome: String },
}

impl fmt::Display for AgentEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AgentEvent::Waiting { endpoints } => {
                write!(
                    f,
                    "waiting for a slice (roll-out via {})",
                    endpoints.join(", ")
                )
            }
            AgentEvent::Accepted { mission, digest } => {
                write!(f, "accepted the slice of {mission} (digest {digest})")
            }
            AgentEvent::Refused { what, reason } => write!(f, "refused a {what}: {reason}"),
            AgentEvent::Started { identity } => write!(f, "started mission {identity}"),
            AgentEvent::Ended { identity, outcome } => {
                write!(f, "mission {identity} ended: {outcome}")
            }
        }
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

/// The deploy sessions an agent has started. Kept on the agent's disk, so
/// that a restarted agent, which holds no slice and no memory, still
/// refuses a recorded offer and start played back to it.
#[derive(Debug, Default)]
pub struct Sessions {
    path: Option<PathBuf>,
    started: std::collections::BTreeSet<String>,
}

impl Sessions {
    /// The sessions recorded in `path` (none if it does not exist yet).
    pub fn load(path: &Path) -> Result<Sessions, String> {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(format!("cannot read {}: {e}", path.display())),
        };
        Ok(Sessions {
            path: Some(path.to_path_buf()),
            started: text
                .lines()
                .filter_map(|l| l.split_whitespace().next())
                .map(str::to_string)
                .collect(),
        })
    }

    pub fn contains(&self, session: &str) -> bool {
        self.started.contains(session)
    }

    /// Records `session` as started, on the disk first: a start that
    /// cannot be recorded is not obeyed.
    pub fn record(&mut self, session: &str, identity: &str) -> Result<(), String> {
        if let Some(path) = &self.path {
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .and_then(|mut f| {
                    writeln!(f, "{session} {identity}")?;
                    Ok(f)
                })
                .map_err(|e| format!("cannot record the session in {}: {e}", path.display()))?;
            f.flush()
                .and_then(|()| f.sync_all())
                .map_err(|e| format!("cannot record the session in {}: {e}", path.display()))?;
        }
        self.started.insert(session.to_string());
        Ok(())
    }
}

/// A deploy session id as the ground station makes them: 32 hex digits.
/// Anything else is refused before it is compared or written down.
fn check_session(session: &str) -> Result<(), String> {
    if session.len() == 32 && session.bytes().all(|b| b.is_ascii_hexdigit()) {
        Ok(())
    } else {
        Err(format!(
            "malformed deploy session `{}`: a session is 32 hex digits",
            session.escape_debug()
        ))
    }
}

/// A fresh deploy session id.
pub fn new_session() -> String {
    format!("{:032x}", rand::random::<u128>())
}

/// What a slice offer asks of an agent.
#[derive(Debug)]
pub enum Offer {
    /// Hold this slice, for this session.
    New {
        slice: Box<Slice>,
        digest: String,
        fleet: Box<Fleet>,
        session: String,
    },
    /// Keep the slice held (it did not change), for this session.
    Keep { digest: String, session: String },
}

/// The part of an agent that judges what it is sent: pure, so that every
/// refusal can be tested without a network.
pub struct Gate {
    pub drone: String,
    pub fleet_text: String,
    pub fleet_name: String,
    pub fleet_digest: String,
    pub trusted: Option<PublicKey>,
}

impl Gate {
    fn wrong_fleet(&self, theirs: &str) -> String {
        format!(
            "wrong mission version: it was built with another fleet file (digest {}) than this agent's {} (digest {}); give the ground station and every agent the same fleet file",
            short(theirs),
            self.fleet_name,
            short(&self.fleet_digest)
        )
    }

    /// Checks a sealed slice offer against the slice held and the sessions
    /// already started.
    pub fn check_slice(
        &self,
        bytes: &[u8],
        held: Option<&Held>,
        started: &Sessions,
    ) -> Result<Offer, String> {
        let sealed = Sealed::from_bytes(bytes).map_err(|e| e.to_string())?;
        let payload = sealed
            .open_with(self.trusted.as_ref(), CONTEXT_SLICE)
            .map_err(|e| e.to_string())?;
        let bundle = SliceBundle::from_bytes(payload)?;
        if bundle.fleet != self.fleet_digest {
            return Err(self.wrong_fleet(&bundle.fleet));
        }
        check_session(&bundle.session)?;
        if started.contains(&bundle.session) {
            return Err(format!(
                "replayed slice: deploy session {} was started before by this agent, and a session flies once; every `eamos deploy` offers slices in a fresh session",
                bundle.session
            ));
        }
        let Some(bytes) = bundle.slice else {
            return match held {
                Some(h) if h.digest == bundle.digest => Ok(Offer::Keep {
                    digest: bundle.digest,
                    session: bundle.session,
                }),
                Some(h) => Err(format!(
                    "no such slice: told to keep slice {}, but this agent holds {} (of {})",
                    bundle.digest, h.digest, h.identity
                )),
                None => Err(format!(
                    "no slice: told to keep slice {}, but this agent holds none",
                    bundle.digest
                )),
            };
        };
        let slice = Slice::from_bytes(&bytes).map_err(|e| format!("damaged slice: {e}"))?;
        if slice.drone != self.drone {
            return Err(format!(
                "this is {}'s slice, and this agent flies {}",
                slice.drone, self.drone
            ));
        }
        if slice.mission_id != bundle.identity {
            return Err(format!(
                "wrong mission version: the slice belongs to {} but was sent for {}",
                slice.mission_id, bundle.identity
            ));
        }
        let digest = slice_digest(&slice);
        if digest != bundle.digest {
            return Err(format!(
                "damaged slice: its digest is {digest}, and the offer says {}",
                bundle.digest
            ));
        }
        let fleet = Fleet::parse(
            &self.fleet_text,
            &self.fleet_name,
            &slice.mission,
            &slice.drones,
        )
        .map_err(|e| e.to_string())?;
        Ok(Offer::New {
            slice: Box::new(slice),
            digest,
            fleet: Box::new(fleet),
            session: bundle.session,
        })
    }

    /// Checks a sealed start command against the slice held and the
    /// sessions already started.
    pub fn check_start(
        &self,
        bytes: &[u8],
        held: Option<&Held>,
        started: &Sessions,
    ) -> Result<StartCommand, String> {
        let sealed = Sealed::from_bytes(bytes).map_err(|e| e.to_string())?;
        let payload = sealed
            .open_with(self.trusted.as_ref(), CONTEXT_START)
            .map_err(|e| e.to_string())?;
        let start = StartCommand::from_bytes(payload)?;
        if start.fleet != self.fleet_digest {
            return Err(self.wrong_fleet(&start.fleet));
        }
        check_session(&start.session)?;
        if started.contains(&start.session) {
            return Err(format!(
                "replayed start command: deploy session {} of {} was started before by this agent, and a session flies once",
                start.session, start.identity
            ));
        }
        let Some(held) = held else {
            return Err(format!(
                "no slice: this agent holds no slice of {} yet",
                start.identity
            ));
        };
        match start.digests.get(&self.drone) {
            None => {
                return Err(format!(
                    "wrong mission version: {} has no part for {}",
                    start.identity, self.drone
                ))
            }
            Some(d) if *d != held.digest => {
                return Err(format!(
                "wrong mission version: {} gives {} the slice {}, and this agent holds {} (of {})",
                start.identity, self.drone, d, held.digest, held.identity
            ))
            }
            Some(_) => {}
        }
        if start.session != held.session {
            return Err(format!(
                "start command of another deploy: it starts session {}, and this agent's slice was offered in session {}; an agent starts only the session that offered its slice (a recorded start played back is refused so)",
                start.session, held.session
            ));
        }
        if !(start.speed.is_finite() && start.speed > 0.0) {
            return Err(format!("the speed {} is not above zero", start.speed));
        }
        Ok(start)
    }
}

fn short(digest: &str) -> &str {
    &digest[..digest.len().min(16)]
}

/// The view of one slice that [`runner::run_peer`] runs: the mission's
/// peers and this drone's profile, nothing of the other drones' parts.
fn single(slice: &Slice) -> Slices {
    let profiles = slice
        .drones
        .iter()
        .map(|d| {
            if *d == slice.drone {
                slice.profile.clone().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .collect();
    Slices {
        mission: slice.mission.clone(),
        mission_id: slice.mission_id.clone(),
        slices: vec![slice.clone()],
        distributed: Net::new(slice.mission.clone(), slice.drones.clone(), profiles),
    }
}

/// Runs the agent of one drone: waits for its slice, answers the ground
/// station, flies each started mission with [`runner::run_peer`]. Returns
/// after one mission when `once`, otherwise when `stop` is cancelled.
pub async fn run_agent(
    config: AgentConfig,
    events: mpsc::UnboundedSender<AgentEvent>,
    stop: CancellationToken,
) -> Result<(), DeployError> {
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
        fleet_text: config.fleet_text.clone(),
        fleet_name: config.fleet_name.clone(),
        fleet_digest: fleet_version(&config.fleet),
        trusted: config.trusted.clone(),
    });
    std::fs::create_dir_all(&config.out)
        .map_err(|e| DeployError::Setup(format!("cannot create {}: {e}", config.out.display())))?;
    let sessions = Sessions::load(&config.out.join(format!("{}.sessions", config.drone)))
        .map_err(DeployError::Setup)?;
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
    let _ = events.send(AgentEvent::Waiting {
        endpoints: options.connect.clone(),
    });
    let (ended_tx, mut ended_rx) = mpsc::unbounded_channel::<()>();
    let config = Arc::new(config);
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
                        fleet: gate.fleet_digest.clone(),
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
                            let _ = events.send(AgentEvent::Accepted {
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
                    let _ = events.send(AgentEvent::Refused { what: "slice", reason: reason.clone() });
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
                                s.sessions.record(&start.session, &start.identity)?;
                                Ok(start)
                            }),
                    };
                    match checked {
                        Err(reason) => Answer::Refused { reason },
                        Ok(start) => {
                            let (slice, digest, fleet) = {
                                let h = s.held.as_mut().expect("checked: a slice is held");
                                // The slice kept from an earlier version joins this one.
                                h.slice.mission_id = start.identity.clone();
                                (h.slice.clone(), h.digest.clone(), h.fleet.clone())
                            };
                            s.flying = Some(start.identity.clone());
                            let _ = events.send(AgentEvent::Started { identity: start.identity.clone() });
                            tokio::spawn(fly(
                                config.clone(), slice, fleet, start, state.clone(),
                                events.clone(), ended_tx.clone(), stop.clone(),
                            ));
                            Answer::Accepted { digest }
                        }
                    }
                };
                if let Answer::Refused { reason } = &answer {
                    let _ = events.send(AgentEvent::Refused { what: "start command", reason: reason.clone() });
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
    events: mpsc::UnboundedSender<AgentEvent>,
    ended: mpsc::UnboundedSender<()>,
    stop: CancellationToken,
) {
    let slices = single(&slice);
    let options = RunOptions {
        speed: start.speed,
        max_duration: start.max_duration,
        seed: start.seed,
        out: config.out.join(&slice.mission),
        stop: stop.child_token(),
        // The flight begins when the ground station issued its start: an
        // abort issued before that is a recording of an earlier flight's.
        abort_opener: config
            .trusted
            .clone()
            .map(|k| abort::opener_since(k, start.issued_at_ms)),
        ..RunOptions::default()
    };
    let outcome =
        match runner::run_peer(&slices, &fleet, &config.profiles, &config.drone, &options).await {
            Ok(r) => r
                .reports
                .first()
                .map(|r| outcome_text(&r.outcome))
                .unwrap_or_else(|| "no report".into()),
            Err(e) => format!("failed: {e}"),
        };
    state.lock().expect("agent state").flying = None;
    let _ = events.send(AgentEvent::Ended {
        identity: start.identity,
        outcome,
    });
    let _ = ended.send(());
}

// ------------------------------------------------------- ground station --

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
        for drone in &slices.distributed.drones {
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
                .distributed
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
        self.send_start(&slices.distributed.drones, sealed).await
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
    runner::run_peer(slices, fleet, profiles, GCS, run).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identity::bind;

    const MISSION: &str = "package M\n\nvar D1 Quadcopter\nvar D2 Quadcopter\n\nfunc main() {\n\tD1.Takeoff(2)\n\tD2.Takeoff(2)\n}\n";
    const FLEET: &str = "[drones.D1]\nhome = { x = 0.0, y = 0.0, z = 0.0 }\n";

    fn slices(mission: &str, fleet: &Fleet) -> Slices {
        let source = eamos_lang::SourceFile::new("m.go".to_string(), mission.to_string());
        let profiles = eamos_profile::builtin();
        let compiled = eamos_lang::compile(&source, &profiles).unwrap();
        let net = eamos_petri::compile(&compiled.mission, &profiles);
        let mut s = eamos_slicer::slice(&net).unwrap();
        bind(&mut s, fleet);
        s
    }

    fn fleet(text: &str) -> Fleet {
        Fleet::parse(text, "fleet.toml", "M", &["D1".into(), "D2".into()]).unwrap()
    }

    fn gate(drone: &str, text: &str, trusted: Option<PublicKey>) -> Gate {
        Gate {
            drone: drone.into(),
            fleet_text: text.into(),
            fleet_name: "fleet.toml".into(),
            fleet_digest: fleet_version(&fleet(text)),
            trusted,
        }
    }

    const SESSION: &str = "0123456789abcdef0123456789abcdef";

    fn offer(s: &Slices, drone: &str, session: &str, with_slice: bool) -> SliceBundle {
        let slice = s.get(drone).unwrap();
        SliceBundle {
            identity: s.mission_id.clone(),
            fleet: fleet_version(&fleet(FLEET)),
            session: session.into(),
            digest: slice_digest(slice),
            slice: with_slice.then(|| slice.to_bytes()),
        }
    }

    fn seal_offer(bundle: &SliceBundle, key: Option<&GroundKey>) -> Vec<u8> {
        match key {
            Some(k) => k.seal(CONTEXT_SLICE, encode(bundle)),
            None => Sealed::unsigned(CONTEXT_SLICE, encode(bundle)),
        }
        .to_bytes()
    }

    fn sealed_slice(s: &Slices, drone: &str, key: Option<&GroundKey>) -> Vec<u8> {
        let bundle = offer(s, drone, SESSION, true);
        let sealed = match key {
            Some(k) => k.seal(CONTEXT_SLICE, encode(&bundle)),
            None => Sealed::unsigned(CONTEXT_SLICE, encode(&bundle)),
        };
        sealed.to_bytes()
    }

    #[test]
    fn a_signed_slice_for_this_drone_is_accepted_with_its_digest() {
        let key = GroundKey::generate().unwrap();
        let s = slices(MISSION, &fleet(FLEET));
        let g = gate("D2", FLEET, Some(key.public()));
        let offer = g.check_slice(&sealed_slice(&s, "D2", Some(&key)), None, &none());
        let Ok(Offer::New {
            slice,
            digest,
            session,
            ..
        }) = offer
        else {
            panic!("{offer:?}");
        };
        assert_eq!(slice.drone, "D2");
        assert_eq!(digest, slice_digest(s.get("D2").unwrap()));
        assert_eq!(session, SESSION);
    }

    #[test]
    fn unsigned_altered_and_foreign_slices_are_refused_by_an_agent_with_a_key() {
        let (key, other) = (
            GroundKey::generate().unwrap(),
            GroundKey::generate().unwrap(),
        );
        let s = slices(MISSION, &fleet(FLEET));
        let g = gate("D2", FLEET, Some(key.public()));
        let e = g
            .check_slice(&sealed_slice(&s, "D2", None), None, &none())
            .unwrap_err();
        assert!(e.starts_with("not signed"), "{e}");
        let e = g
            .check_slice(&sealed_slice(&s, "D2", Some(&other)), None, &none())
            .unwrap_err();
        assert!(e.starts_with("unknown key"), "{e}");
        let mut altered = sealed_slice(&s, "D2", Some(&key));
        let n = altered.len();
        altered[n / 2] ^= 0x01;
        let e = g.check_slice(&altered, None, &none()).unwrap_err();
        assert!(
            e.starts_with("bad signature") || e.starts_with("not a sealed"),
            "{e}"
        );
        // Without a key, an unsigned slice passes.
        assert!(gate("D2", FLEET, None)
            .check_slice(&sealed_slice(&s, "D2", None), None, &none())
            .is_ok());
    }

    #[test]
    fn a_slice_built_with_another_fleet_file_is_a_wrong_mission_version() {
        let s = slices(MISSION, &fleet(FLEET));
        let other = "[drones.D1]\nhome = { x = 5.0, y = 0.0, z = 0.0 }\n";
        let e = gate("D2", other, None)
            .check_slice(&sealed_slice(&s, "D2", None), None, &none())
            .unwrap_err();
        assert!(e.starts_with("wrong mission version"), "{e}");
    }

    #[test]
    fn another_drones_slice_is_refused() {
        let s = slices(MISSION, &fleet(FLEET));
        let e = gate("D1", FLEET, None)
            .check_slice(&sealed_slice(&s, "D2", None), None, &none())
            .unwrap_err();
        assert!(e.contains("D2's slice") && e.contains("flies D1"), "{e}");
    }

    #[test]
    fn a_start_for_another_version_than_the_slice_held_is_refused() {
        let key = GroundKey::generate().unwrap();
        let f = fleet(FLEET);
        let v1 = slices(MISSION, &f);
        let v2 = slices(&MISSION.replace("D2.Takeoff(2)", "D2.Takeoff(3)"), &f);
        let g = gate("D2", FLEET, Some(key.public()));
        let held = Held {
            identity: v1.mission_id.clone(),
            digest: slice_digest(v1.get("D2").unwrap()),
            session: SESSION.into(),
        };
        let start = |s: &Slices| StartCommand {
            identity: s.mission_id.clone(),
            fleet: fleet_version(&f),
            session: SESSION.into(),
            issued_at_ms: 1,
            digests: ["D1", "D2"]
                .iter()
                .map(|d| (d.to_string(), slice_digest(s.get(d).unwrap())))
                .collect(),
            speed: 20.0,
            max_duration: None,
            seed: 0,
        };
        let ok = key.seal(CONTEXT_START, encode(&start(&v1))).to_bytes();
        assert!(g.check_start(&ok, Some(&held), &none()).is_ok());
        let newer = key.seal(CONTEXT_START, encode(&start(&v2))).to_bytes();
        let e = g.check_start(&newer, Some(&held), &none()).unwrap_err();
        assert!(e.starts_with("wrong mission version"), "{e}");
        let e = g.check_start(&ok, None, &none()).unwrap_err();
        assert!(e.starts_with("no slice"), "{e}");
        let unsigned = Sealed::unsigned(CONTEXT_START, encode(&start(&v1))).to_bytes();
        let e = g.check_start(&unsigned, Some(&held), &none()).unwrap_err();
        assert!(e.starts_with("not signed"), "{e}");
        // A signed slice is no start command.
        let e = g
            .check_start(&sealed_slice(&v1, "D2", Some(&key)), Some(&held), &none())
            .unwrap_err();
        assert!(e.contains("expected a signed start command"), "{e}");
    }

    fn none() -> Sessions {
        Sessions::default()
    }

    /// D2 holding v1's slice, offered in `session`; the start of v1 in
    /// `session`, signed by `key`.
    fn held_and_start(key: &GroundKey, session: &str) -> (Slices, Held, Vec<u8>) {
        let f = fleet(FLEET);
        let v1 = slices(MISSION, &f);
        let held = Held {
            identity: v1.mission_id.clone(),
            digest: slice_digest(v1.get("D2").unwrap()),
            session: session.into(),
        };
        let start = StartCommand {
            identity: v1.mission_id.clone(),
            fleet: fleet_version(&f),
            session: session.into(),
            issued_at_ms: 1,
            digests: ["D1", "D2"]
                .iter()
                .map(|d| (d.to_string(), slice_digest(v1.get(d).unwrap())))
                .collect(),
            speed: 20.0,
            max_duration: None,
            seed: 0,
        };
        let wire = key.seal(CONTEXT_START, encode(&start)).to_bytes();
        (v1, held, wire)
    }

    #[test]
    fn a_start_replayed_after_its_session_was_started_is_refused_even_by_a_restarted_agent() {
        let key = GroundKey::generate().unwrap();
        let g = gate("D2", FLEET, Some(key.public()));
        let (_, held, start) = held_and_start(&key, SESSION);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("D2.sessions");
        let mut sessions = Sessions::load(&path).unwrap();
        let ok = g.check_start(&start, Some(&held), &sessions).unwrap();
        sessions.record(&ok.session, &ok.identity).unwrap();
        let e = g.check_start(&start, Some(&held), &sessions).unwrap_err();
        assert!(e.starts_with("replayed start command"), "{e}");
        assert!(e.contains(SESSION), "{e}");
        // The agent restarts: it remembers the session from its disk.
        let restarted = Sessions::load(&path).unwrap();
        let e = g.check_start(&start, Some(&held), &restarted).unwrap_err();
        assert!(e.starts_with("replayed start command"), "{e}");
    }

    #[test]
    fn a_session_record_that_cannot_be_read_or_written_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let e = Sessions::load(dir.path()).unwrap_err();
        assert!(
            e.starts_with("cannot read") && e.contains(&dir.path().display().to_string()),
            "{e}"
        );
        let mut gone = Sessions::load(&dir.path().join("no-such-dir").join("D2.sessions")).unwrap();
        let e = gone.record(SESSION, "M-1").unwrap_err();
        assert!(e.starts_with("cannot record the session"), "{e}");
        assert!(
            !gone.contains(SESSION),
            "a start not recorded is not obeyed"
        );
    }

    #[test]
    fn a_slice_offer_of_a_session_already_started_is_refused_as_a_replay() {
        let key = GroundKey::generate().unwrap();
        let s = slices(MISSION, &fleet(FLEET));
        let g = gate("D2", FLEET, Some(key.public()));
        let mut sessions = Sessions::default();
        sessions.record(SESSION, &s.mission_id).unwrap();
        let e = g
            .check_slice(&sealed_slice(&s, "D2", Some(&key)), None, &sessions)
            .unwrap_err();
        assert!(e.starts_with("replayed slice"), "{e}");
    }

    #[test]
    fn a_start_of_another_deploy_session_than_the_one_that_offered_the_slice_is_refused() {
        let key = GroundKey::generate().unwrap();
        let g = gate("D2", FLEET, Some(key.public()));
        let (_, held, start) = held_and_start(&key, SESSION);
        let offered_later = Held {
            session: "fedcba9876543210fedcba9876543210".into(),
            ..held
        };
        let e = g
            .check_start(&start, Some(&offered_later), &none())
            .unwrap_err();
        assert!(e.starts_with("start command of another deploy"), "{e}");
        assert!(e.contains("fedcba98"), "{e}");
    }

    #[test]
    fn a_keep_offer_rebinds_the_slice_held_to_the_new_session_and_no_other_slice() {
        let key = GroundKey::generate().unwrap();
        let s = slices(MISSION, &fleet(FLEET));
        let g = gate("D2", FLEET, Some(key.public()));
        let later = "fedcba9876543210fedcba9876543210";
        let keep = seal_offer(&offer(&s, "D2", later, false), Some(&key));
        let held = Held {
            identity: s.mission_id.clone(),
            digest: slice_digest(s.get("D2").unwrap()),
            session: SESSION.into(),
        };
        match g.check_slice(&keep, Some(&held), &none()) {
            Ok(Offer::Keep { digest, session }) => {
                assert_eq!(digest, held.digest);
                assert_eq!(session, later);
            }
            other => panic!("{other:?}"),
        }
        let e = g.check_slice(&keep, None, &none()).unwrap_err();
        assert!(e.starts_with("no slice"), "{e}");
        let other = Held {
            digest: "0".repeat(32),
            ..held
        };
        let e = g.check_slice(&keep, Some(&other), &none()).unwrap_err();
        assert!(e.starts_with("no such slice"), "{e}");
    }

    #[test]
    fn an_offer_whose_slice_does_not_match_its_digest_or_whose_session_is_malformed_is_refused() {
        let s = slices(MISSION, &fleet(FLEET));
        let g = gate("D2", FLEET, None);
        let mut wrong = offer(&s, "D2", SESSION, true);
        wrong.digest = "0".repeat(32);
        let e = g
            .check_slice(&seal_offer(&wrong, None), None, &none())
            .unwrap_err();
        assert!(e.starts_with("damaged slice"), "{e}");
        let odd = offer(&s, "D2", "x\nD9 forged", true);
        let e = g
            .check_slice(&seal_offer(&odd, None), None, &none())
            .unwrap_err();
        assert!(e.starts_with("malformed deploy session"), "{e}");
    }

    #[test]
    fn roll_out_messages_with_trailing_bytes_or_garbage_are_errors_not_panics() {
        let s = slices(MISSION, &fleet(FLEET));
        let mut b = offer(&s, "D2", SESSION, true).to_bytes();
        assert!(SliceBundle::from_bytes(&b).is_ok());
        b.push(0);
        assert!(SliceBundle::from_bytes(&b).is_err());
        for junk in [&[][..], &[0xff; 7], b"start"] {
            assert!(StartCommand::from_bytes(junk).is_err());
            assert!(AgentStatus::from_bytes(junk).is_err());
            assert!(Answer::from_bytes(junk).is_err());
        }
    }

    #[test]
    fn an_unchanged_drone_keeps_its_slice_under_the_new_identity() {
        let f = fleet(FLEET);
        let v1 = slices(MISSION, &f);
        let v2 = slices(&MISSION.replace("D2.Takeoff(2)", "D2.Takeoff(3)"), &f);
        assert_ne!(v1.mission_id, v2.mission_id);
        assert_eq!(
            slice_digest(v1.get("D1").unwrap()),
            slice_digest(v2.get("D1").unwrap())
        );
        let mut kept = v1.get("D1").unwrap().clone();
        kept.mission_id = v2.mission_id.clone();
        assert_eq!(&kept, v2.get("D1").unwrap());
    }

    #[test]
    fn roll_out_endpoints_default_to_a_loopback_port_of_the_fleet_and_agents_connect_to_them() {
        let f = fleet(FLEET);
        let (listen, connect) = rollout_endpoints(&f);
        assert_eq!(listen, connect);
        assert!(listen[0].starts_with("tcp/127.0.0.1:"));
        let g = fleet(
            "[rollout]\nlisten = [\"tcp/0.0.0.0:7400\"]\nconnect = [\"tcp/10.0.0.1:7400\"]\n",
        );
        assert_eq!(
            rollout_endpoints(&g),
            (
                vec!["tcp/0.0.0.0:7400".to_string()],
                vec!["tcp/10.0.0.1:7400".to_string()]
            )
        );
        assert!(rollout_options(&g, "D1").listen.is_empty());
        assert!(rollout_options(&g, GCS).connect.is_empty());
    }
}
