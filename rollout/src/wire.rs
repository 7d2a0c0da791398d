//! The roll-out's messages, as they cross the network: what the ground
//! station offers and commands, what an agent answers. Each decodes from
//! untrusted bytes without panicking, and one message has one encoding.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

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
pub(crate) fn decode<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Result<T, String> {
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

pub(crate) fn encode<T: Serialize>(v: &T) -> Vec<u8> {
    postcard::to_stdvec(v).expect("roll-out messages always serialise")
}
