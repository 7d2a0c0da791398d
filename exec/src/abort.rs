//! Aborting a mission: every running action is cancelled and every drone
//! goes to its abort failsafe, each exactly once.
//!
//! An abort travels on the `abort` control bridge ([`crate::names::ABORT`]),
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
//!   is given a [`CommandOpener`], a command that is unsigned, signed by
//!   another key, altered, or issued before the flight began (a replay,
//!   see [`opener_since`]); a refused command is logged and the flight
//!   goes on.
//!
//! A peer abort carries no signature: drones hold no key. What vouches for
//! a peer is the transport (zenoh over mutual TLS when the fleet names
//! certificates), not the seal.

use std::sync::Arc;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use eamos_petri::net::Colour;

use crate::names::ABORT;
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
    /// When it was issued, in milliseconds since the Unix epoch on the
    /// issuer's clock: signed with the rest, so that a recorded command
    /// cannot be replayed into a later flight (see [`opener_since`]).
    pub issued_at_ms: u64,
}

/// Milliseconds since the Unix epoch on this machine's clock (0 if the
/// clock is set before 1970).
pub fn unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// How much earlier than the flight's start an abort command may be
/// issued and still be obeyed. The two times come from two clocks (the
/// issuer's, and the ground station's or the drone's), which in the field
/// are only roughly in step: refusing a genuine abort because of a slow
/// clock would be worse than the narrow replay window this leaves (a
/// command recorded in a flight that ended less than this before the next
/// one began).
pub const ABORT_CLOCK_SKEW_MS: u64 = 60_000;

impl AbortCommand {
    pub fn new(mission: &str, issued_by: &str) -> AbortCommand {
        AbortCommand {
            mission: mission.to_string(),
            issued_by: issued_by.to_string(),
            nonce: rand::random(),
            issued_at_ms: unix_ms(),
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

/// Seals a command's payload as the ground station sends it: signed
/// when it has a key, an unsigned envelope otherwise (which only agents
/// that trust no key accept).
pub fn seal_command(key: Option<&eamos_seal::GroundKey>, payload: Vec<u8>) -> Vec<u8> {
    match key {
        Some(k) => k.seal(eamos_seal::CONTEXT_ABORT, payload),
        None => eamos_seal::Sealed::unsigned(eamos_seal::CONTEXT_ABORT, payload),
    }
    .to_bytes()
}

/// Seals commands with the ground station's key (`eamos abort`, and the
/// ground station of `eamos deploy` when it is stopped).
pub fn sealer(key: Arc<eamos_seal::GroundKey>) -> CommandSealer {
    Arc::new(move |payload| seal_command(Some(&key), payload))
}

/// Obeys only commands sealed by `trusted` (the fleet's `[keys] gcs`) and
/// issued since this opener was made: `eamos run` makes it as the flight
/// begins, on the drone's own clock.
pub fn opener(trusted: eamos_seal::PublicKey) -> CommandOpener {
    opener_since(trusted, unix_ms())
}

/// Obeys only commands sealed by `trusted` and issued no earlier than
/// `flight_began_ms` (less [`ABORT_CLOCK_SKEW_MS`]).
///
/// Why a time and not a list of commands seen: an abort is passed on from
/// peer to peer by design, so a drone sees one genuine command several
/// times, and a command replayed within the flight it was issued for asks
/// for what is being done already (the failsafe runs once). The harm a
/// replay can do is to abort a *later* flight of the same mission version,
/// which has the same mission identity; the time the command was issued,
/// signed with it, tells the two apart without the drone keeping anything
/// across flights. A deployed agent takes `flight_began_ms` from the signed
/// start command, so both times come from the ground station's clock.
pub fn opener_since(trusted: eamos_seal::PublicKey, flight_began_ms: u64) -> CommandOpener {
    Arc::new(move |wire| {
        let sealed = eamos_seal::Sealed::from_bytes(wire).map_err(|e| e.to_string())?;
        let payload = sealed
            .open(&trusted, eamos_seal::CONTEXT_ABORT)
            .map_err(|e| e.to_string())?;
        let command = AbortCommand::from_payload(payload)?;
        if command.issued_at_ms.saturating_add(ABORT_CLOCK_SKEW_MS) < flight_began_ms {
            return Err(format!(
                "replayed abort command: it was issued at {} by {}, {} s before this flight began ({}); a genuine abort is issued during the flight",
                when(command.issued_at_ms),
                command.issued_by,
                (flight_began_ms - command.issued_at_ms) / 1000,
                when(flight_began_ms),
            ));
        }
        Ok(payload.to_vec())
    })
}

/// A time for a message, in UTC: `2026-11-22 03:41:07 UTC`.
pub fn when(ms: u64) -> String {
    let secs = ms / 1000;
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Days to a civil date (H. Hinnant's algorithm, for days since 1970).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
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
    let opening = zenoh::open(&command.mission, me, &[], options);
    let endpoint = zenoh::within(opening, me, options, timeout).await?;
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
        let signed = pack(&sealer(Arc::new(key))(c.payload()));
        assert_eq!(
            accept("abort-1", &signed, "M-1", &peers(), Some(&open)),
            Ok(AbortOrigin::Command(c.clone()))
        );
        let forged = pack(&sealer(Arc::new(other))(c.payload()));
        let e = accept("abort-1", &forged, "M-1", &peers(), Some(&open)).unwrap_err();
        assert!(e.contains("refused: unknown key"), "{e}");
        let unsigned = pack(&seal_command(None, c.payload()));
        let e = accept("abort-1", &unsigned, "M-1", &peers(), Some(&open)).unwrap_err();
        assert!(e.contains("refused: not signed"), "{e}");
        let bare = pack(&c.payload());
        assert!(accept("abort-1", &bare, "M-1", &peers(), Some(&open)).is_err());
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

    #[test]
    fn an_abort_command_issued_before_the_flight_began_is_refused_as_a_replay() {
        let key = eamos_seal::GroundKey::generate().unwrap();
        let began = 1_800_000_000_000;
        let open = opener_since(key.public(), began);
        let mut old = AbortCommand::new("M-1", "operator");
        old.issued_at_ms = began - ABORT_CLOCK_SKEW_MS - 1;
        let replayed = pack(&seal_command(Some(&key), old.payload()));
        let e = accept("abort-9", &replayed, "M-1", &peers(), Some(&open)).unwrap_err();
        assert!(e.contains("replayed abort command"), "{e}");
        assert!(e.contains("2027-01-15 08:00:00 UTC"), "{e}");
        // Within the clock allowance, and during the flight: obeyed.
        for at in [began - ABORT_CLOCK_SKEW_MS, began + 5_000] {
            let mut c = old.clone();
            c.issued_at_ms = at;
            let wire = pack(&seal_command(Some(&key), c.payload()));
            assert!(accept("abort-9", &wire, "M-1", &peers(), Some(&open)).is_ok());
        }
    }

    #[test]
    fn two_abort_commands_of_one_mission_differ() {
        let (a, b) = (
            AbortCommand::new("M-1", "operator"),
            AbortCommand::new("M-1", "operator"),
        );
        assert_ne!(a.payload(), b.payload());
    }

    #[test]
    fn times_in_messages_are_civil_dates_in_utc() {
        assert_eq!(when(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(when(951_782_400_000), "2000-02-29 00:00:00 UTC");
        assert_eq!(when(1_800_000_000_000), "2027-01-15 08:00:00 UTC");
    }
}
