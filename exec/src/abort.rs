//! Aborting a mission: every running action is cancelled and every drone
//! goes to its abort failsafe, each exactly once.
//!
//! An abort travels on the `abort` control bridge ([`crate::executor::ABORT`]),
//! delivered exactly once per sender like any token, and every drone that
//! accepts one passes it on to every other peer: a drone that cannot hear
//! the ground station still hears the abort from any peer that can. Two
//! kinds travel on it:
//!
//! - a *peer abort*, with an empty colour, from a peer of the mission
//!   whose action failed or that was stopped (Ctrl-C on its agent);
//! - an *abort command*, from `eamos abort` or the ground station: an
//!   [`AbortCommand`] naming the mission identity, carried in the token's
//!   colour (see [`pack`]), sealed by the ground station when the fleet
//!   has a key. A drone refuses a command of another mission, and, when it
//!   is given a [`CommandOpener`], a command that is unsigned or altered;
//!   a refused command is logged and the flight goes on.

use std::sync::Arc;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use eamos_petri::net::Colour;

use crate::executor::ABORT;
use crate::transport::reliable::{Bridges, RetransmitPolicy};
use crate::transport::zenoh::{self, ZenohOptions};
use crate::transport::{PeerId, TransportError};

/// What `eamos abort` (or the ground station) says.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AbortCommand {
    /// The mission identity the command is meant for.
    pub mission: String,
    /// Who issued it (a person's or a tool's name, for the logs).
    pub issued_by: String,
    /// Makes two commands of one mission distinct (the bridges deliver a
    /// colour once per sender).
    pub nonce: u64,
}

impl AbortCommand {
    pub fn new(mission: &str, issued_by: &str) -> AbortCommand {
        let nonce = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        AbortCommand {
            mission: mission.to_string(),
            issued_by: issued_by.to_string(),
            nonce,
        }
    }

    /// The bytes a ground station signs.
    pub fn payload(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("commands serialise")
    }

    pub fn from_payload(bytes: &[u8]) -> Result<AbortCommand, String> {
        postcard::from_bytes(bytes).map_err(|e| format!("not an abort command: {e}"))
    }
}

/// Wraps a command's payload for the wire (the ground station signs it).
pub type CommandSealer = Arc<dyn Fn(Vec<u8>) -> Vec<u8> + Send + Sync>;
/// Checks what came over the wire and returns the payload inside, or says
/// why it is refused (unsigned, another key, altered).
pub type CommandOpener = Arc<dyn Fn(&[u8]) -> Result<Vec<u8>, String> + Send + Sync>;

/// Packs bytes into a colour: the length, then four bytes per number.
pub fn pack(bytes: &[u8]) -> Colour {
    let mut c = Vec::with_capacity(1 + bytes.len().div_ceil(4));
    c.push(bytes.len() as u32);
    c.extend(bytes.chunks(4).map(|w| {
        let mut b = [0u8; 4];
        b[..w.len()].copy_from_slice(w);
        u32::from_le_bytes(b)
    }));
    c
}

/// The bytes [`pack`] put in a colour; `None` if the colour is not one.
pub fn unpack(colour: &[u32]) -> Option<Vec<u8>> {
    let (&len, words) = colour.split_first()?;
    let len = len as usize;
    if words.len() != len.div_ceil(4) {
        return None;
    }
    let mut bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    bytes.truncate(len);
    Some(bytes)
}

/// Seals commands with the ground station's key (`eamos abort --key`).
pub fn sealer(key: eamos_seal::GroundKey) -> CommandSealer {
    Arc::new(move |payload| key.seal(eamos_seal::CONTEXT_ABORT, payload).to_bytes())
}

/// Obeys only commands sealed by `trusted` (the fleet's `[keys] gcs`).
pub fn opener(trusted: eamos_seal::PublicKey) -> CommandOpener {
    Arc::new(move |wire| {
        let sealed = eamos_seal::Sealed::from_bytes(wire).map_err(|e| e.to_string())?;
        sealed
            .open(&trusted, eamos_seal::CONTEXT_ABORT)
            .map(<[u8]>::to_vec)
            .map_err(|e| e.to_string())
    })
}

/// Who aborted, once an abort is accepted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AbortOrigin {
    /// A peer of the mission (its action failed, or it was stopped).
    Peer(PeerId),
    /// A command of the ground station or of `eamos abort`.
    Command(AbortCommand),
}

impl AbortOrigin {
    pub fn describe(&self) -> String {
        match self {
            AbortOrigin::Peer(p) => format!("{p} aborted the mission"),
            AbortOrigin::Command(c) => format!("the mission was aborted by {}", c.issued_by),
        }
    }
}

/// Decides whether an abort that came from `from` with `colour` is to be
/// obeyed by a peer of mission `mission_id` whose peers are `peers`.
pub fn accept(
    from: &str,
    colour: &[u32],
    mission_id: &str,
    peers: &[PeerId],
    opener: Option<&CommandOpener>,
) -> Result<AbortOrigin, String> {
    if colour.is_empty() {
        return if peers.iter().any(|p| p == from) {
            Ok(AbortOrigin::Peer(from.to_string()))
        } else {
            Err(format!(
                "{from} is not a peer of this mission and sent an abort without a command"
            ))
        };
    }
    let wire = unpack(colour).ok_or_else(|| format!("the abort from {from} is garbled"))?;
    let payload = match opener {
        Some(open) => open(&wire).map_err(|e| format!("abort from {from} refused: {e}"))?,
        None => wire,
    };
    let command = AbortCommand::from_payload(&payload)?;
    if command.mission != mission_id {
        return Err(format!(
            "abort from {from} refused: it is for mission {}, this is {mission_id}",
            command.mission
        ));
    }
    Ok(AbortOrigin::Command(command))
}

/// What `eamos abort` achieved.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AbortSent {
    /// Peers that were up when the command went out.
    pub reached: Vec<PeerId>,
    /// Peers the command was sent to.
    pub sent_to: Vec<PeerId>,
    /// Copies not acknowledged when it stopped waiting (a drone that is
    /// down, or cut off; the others pass the abort on to it if they can).
    pub unacknowledged: usize,
}

/// Joins the mission's zenoh network as `me` (not a peer of the mission:
/// it only connects to theirs), sends `command` to every peer until
/// acknowledged or `timeout` passes.
pub async fn broadcast(
    command: &AbortCommand,
    me: &str,
    peers: &[PeerId],
    options: &ZenohOptions,
    sealer: Option<&CommandSealer>,
    timeout: Duration,
) -> Result<AbortSent, TransportError> {
    let endpoint = zenoh::open(&command.mission, me, &[], options).await?;
    // Whoever is up within a short while: the others may be down for good.
    let up_wait = timeout.min(Duration::from_secs(3));
    let deadline = tokio::time::Instant::now() + up_wait;
    let mut reached = Vec::new();
    for p in peers {
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        if endpoint
            .link
            .wait_for_peers(std::slice::from_ref(p), left)
            .await
            .is_ok()
        {
            reached.push(p.clone());
        }
    }
    let payload = command.payload();
    let wire = match sealer {
        Some(seal) => seal(payload),
        None => payload,
    };
    let colour = pack(&wire);
    let (bridges, _delivered) = Bridges::start(
        command.mission.clone(),
        endpoint.link.clone(),
        endpoint.frames,
        RetransmitPolicy::default(),
    );
    for p in peers {
        bridges.send(p, ABORT, colour.clone());
    }
    let unacknowledged = bridges.flush(timeout).await;
    Ok(AbortSent {
        reached,
        sent_to: peers.to_vec(),
        unacknowledged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peers() -> Vec<PeerId> {
        ["GCS", "D1", "D2"].map(String::from).to_vec()
    }

    #[test]
    fn bytes_survive_packing_into_a_colour() {
        for n in 0..9 {
            let bytes: Vec<u8> = (0..n).map(|i| (i * 37) as u8).collect();
            assert_eq!(unpack(&pack(&bytes)), Some(bytes));
        }
        assert_eq!(unpack(&[9, 1]), None, "a length the words do not hold");
        assert_eq!(unpack(&[]), None);
    }

    #[test]
    fn a_peer_abort_is_obeyed_only_from_a_peer_of_the_mission() {
        assert_eq!(
            accept("D1", &[], "M-1", &peers(), None),
            Ok(AbortOrigin::Peer("D1".into()))
        );
        let e = accept("stranger", &[], "M-1", &peers(), None).unwrap_err();
        assert!(e.contains("not a peer"), "{e}");
    }

    #[test]
    fn an_abort_command_is_obeyed_only_for_its_own_mission() {
        let c = AbortCommand::new("M-1", "operator");
        let colour = pack(&c.payload());
        assert_eq!(
            accept("abort-1", &colour, "M-1", &peers(), None),
            Ok(AbortOrigin::Command(c.clone()))
        );
        let e = accept("abort-1", &colour, "M-2", &peers(), None).unwrap_err();
        assert!(e.contains("for mission M-1"), "{e}");
        let e = accept("abort-1", &[3, 7], "M-1", &peers(), None).unwrap_err();
        assert!(e.contains("not an abort command"), "{e}");
    }

    #[test]
    fn an_abort_command_sealed_by_the_ground_station_is_obeyed_and_any_other_refused() {
        let key = eamos_seal::GroundKey::generate().unwrap();
        let other = eamos_seal::GroundKey::generate().unwrap();
        let open = opener(key.public());
        let c = AbortCommand::new("M-1", "operator");
        let signed = pack(&sealer(key)(c.payload()));
        assert_eq!(
            accept("abort-1", &signed, "M-1", &peers(), Some(&open)),
            Ok(AbortOrigin::Command(c.clone()))
        );
        let forged = pack(&sealer(other)(c.payload()));
        assert!(accept("abort-1", &forged, "M-1", &peers(), Some(&open)).is_err());
        let unsigned = pack(&c.payload());
        assert!(accept("abort-1", &unsigned, "M-1", &peers(), Some(&open)).is_err());
        let mut altered = unpack(&signed).unwrap();
        let last = altered.len() - 1;
        altered[last] ^= 1;
        assert!(accept("abort-1", &pack(&altered), "M-1", &peers(), Some(&open)).is_err());
    }

    #[test]
    fn with_an_opener_an_abort_command_it_refuses_is_not_obeyed() {
        let c = AbortCommand::new("M-1", "operator");
        // A stand-in for the ground station's signature: a prefix byte.
        let opener: CommandOpener = Arc::new(|wire: &[u8]| match wire.split_first() {
            Some((0xA5, rest)) => Ok(rest.to_vec()),
            _ => Err("unsigned".to_string()),
        });
        let unsigned = pack(&c.payload());
        let e = accept("abort-1", &unsigned, "M-1", &peers(), Some(&opener)).unwrap_err();
        assert!(e.contains("refused: unsigned"), "{e}");
        let mut signed = vec![0xA5];
        signed.extend(c.payload());
        assert!(accept("abort-1", &pack(&signed), "M-1", &peers(), Some(&opener)).is_ok());
    }
}
