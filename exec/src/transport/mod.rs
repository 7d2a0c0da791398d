//! Bridge transports: how tokens cross from one drone's slice to another's.
//!
//! Two layers. A [`Link`] moves [`Frame`]s between named peers with no
//! promise at all: a frame may be lost, duplicated or overtaken (zenoh's own
//! reliability does not survive a reconnect, a radio link drops packets).
//! [`reliable::Bridges`] builds exactly-once delivery of bridge tokens on top
//! of any link: the sender keeps every token until it is acknowledged and
//! retransmits it with backoff; the receiver acknowledges every copy and
//! hands a (bridge, colour) to the executor only the first time.
//!
//! Links: [`inproc`] (tokio channels, the whole fleet in one process),
//! [`zenoh`] (peer to peer over the network) and [`faulty`] (a wrapper that
//! loses, duplicates and reorders frames on purpose, for tests).

use std::collections::BTreeSet;
use std::time::Duration;

use async_trait::async_trait;
use serde::{Deserialize, Serialize};
use tokio::sync::{mpsc, watch};

use eamos_petri::net::Colour;

pub mod faulty;
pub mod following;
pub mod inproc;
pub mod observe;
pub mod publish;
pub mod reliable;
pub mod zenoh;

pub use crate::names::{PeerId, GCS};

/// One token crossing a bridge.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct BridgeMessage {
    /// The mission identity: a token of another mission (or of another
    /// version of this one) is never accepted.
    pub mission: String,
    pub from: PeerId,
    /// The bridge, as the slicer names it.
    pub bridge: String,
    /// The colour of the token (loop iteration counters, outermost first).
    pub colour: Colour,
    /// The sender's sequence number of this token, kept across
    /// retransmissions so that the logs can pair copies.
    pub seq: u64,
}

/// The receiver has the token of (bridge, colour): stop retransmitting it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ack {
    pub mission: String,
    /// Who acknowledges (the token's receiver).
    pub from: PeerId,
    pub bridge: String,
    pub colour: Colour,
    pub seq: u64,
}

/// What a link carries between two peers.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Frame {
    Token(BridgeMessage),
    Ack(Ack),
    /// Acknowledgements of one receiver held back a moment and sent
    /// together (see [`reliable::RetransmitPolicy::ack_delay`]).
    Acks(Vec<Ack>),
}

impl Frame {
    pub fn encode(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("frames always serialise")
    }

    pub fn decode(bytes: &[u8]) -> Result<Frame, TransportError> {
        postcard::from_bytes(bytes).map_err(|e| TransportError::Decode(e.to_string()))
    }
}

/// The latest state of one drone, published for the conditions of other
/// drones that read it. The body is opaque to the transport (the executor
/// encodes the middle layer's telemetry in it), so that transports never
/// depend on what a drone reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TelemetryFrame {
    pub mission: String,
    pub drone: PeerId,
    /// Increases with every sample of this drone: a late, overtaken sample
    /// must not replace a newer one.
    pub seq: u64,
    pub body: Vec<u8>,
}

impl TelemetryFrame {
    pub fn encode(&self) -> Vec<u8> {
        postcard::to_stdvec(self).expect("telemetry always serialises")
    }

    pub fn decode(bytes: &[u8]) -> Result<TelemetryFrame, TransportError> {
        postcard::from_bytes(bytes).map_err(|e| TransportError::Decode(e.to_string()))
    }
}

#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("transport configuration is not valid: {0}")]
    Config(String),
    #[error("cannot open the transport: {0}")]
    Open(String),
    #[error("{peer} cannot listen on {}: the port is taken by another program{}; give {peer} endpoints of its own in the fleet file (`[gcs] listen = [...]` for the ground station, `zenoh = {{ listen = [...] }}` in `[drones.<drone>]` for a drone)", .endpoints.join(", "), .fleet.map(|n| format!(" (this mission has {n} peers)")).unwrap_or_default())]
    PortTaken {
        peer: PeerId,
        endpoints: Vec<String>,
        /// The mission's number of peers, where known.
        fleet: Option<usize>,
    },
    #[error("{peer} reached none of the fleet's routers ({}) within {waited:?}: start them first (`eamos router --fleet FLEET --router K` for each entry of the fleet file's `[zenoh] routers`), or check that this machine reaches them", .routers.join(", "))]
    NoRouter {
        peer: PeerId,
        routers: Vec<String>,
        waited: Duration,
    },
    #[error("cannot send: {0}")]
    Send(String),
    #[error("cannot decode a frame: {0}")]
    Decode(String),
    #[error("peers {missing:?} did not show up within {waited:?}")]
    PeersMissing {
        missing: Vec<PeerId>,
        waited: Duration,
    },
    #[error("peers {} are up but not ready after {waited:?}: each waits until it sees every peer it exchanges tokens or telemetry with; check the zenoh endpoints (or routers) of the fleet file (`RUST_LOG=eamos_exec=debug` on a drone says whom it does not see)", .peers.join(", "))]
    NotReady {
        /// Up, but not seeing every peer it needs yet.
        peers: Vec<PeerId>,
        waited: Duration,
    },
    #[error("peer {peer} runs another version of mission {mission} (version {theirs}, this peer {ours}): peers of two versions refuse each other; build every peer from the same mission and fleet file")]
    OtherVersion {
        peer: PeerId,
        mission: String,
        theirs: String,
        ours: String,
    },
}

/// Takes the frames addressed to a peer as they arrive (see
/// [`Link::route_frames`]).
pub type FrameHandler = std::sync::Arc<dyn Fn(Frame) + Send + Sync>;

/// Moves frames between peers, best effort: no retransmission, no
/// deduplication, no ordering (that is [`reliable::Bridges`]' job).
#[async_trait]
pub trait Link: Send + Sync + 'static {
    /// The peer this end belongs to.
    fn me(&self) -> &str;

    /// Sends one frame to one peer. `Ok` means handed to the network, not
    /// received: a peer that is not up yet simply misses the frame.
    async fn send(&self, to: &str, frame: &Frame) -> Result<(), TransportError>;

    /// From now on hands every frame addressed to this peer to `handler`,
    /// on the link's own receiving thread, rather than to the `frames`
    /// channel of its [`Endpoint`]: one hop less for a token on its way to
    /// the executor. `false` if the link cannot (or already hands its
    /// frames to another handler); its frames then keep coming on the
    /// channel, as do frames queued there before.
    fn route_frames(&self, handler: FrameHandler) -> bool {
        let _ = handler;
        false
    }

    /// Publishes this drone's telemetry to every peer subscribed to it.
    async fn publish_telemetry(&self, sample: &TelemetryFrame) -> Result<(), TransportError>;

    /// Publishes one of this peer's events (a mission log line, see
    /// [`publish`]) to whoever observes the mission, if anyone: a monitor
    /// that is not a peer. With a `state` slot (`marking`, the current
    /// action...) the line is also kept as the latest of its slot, handed
    /// to an observer that joins later and asks (`<peer>/state`). A link
    /// whose peers share one process has no such observer; their events
    /// reach a monitor through its sink.
    async fn publish_event(
        &self,
        line: Vec<u8>,
        state: Option<&'static str>,
    ) -> Result<(), TransportError> {
        let _ = (line, state);
        Ok(())
    }

    /// Waits until every peer in `peers` is reachable, so that the first
    /// token of a mission is not sent into the void (retransmission would
    /// cover it, but only after a backoff).
    async fn wait_for_peers(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError>;

    /// Says, once this peer sees every one of `neighbours` up, that it is
    /// ready: it can tell each of them lost from late. A drone's neighbours
    /// are the peers it has bridges with, the drones whose telemetry its
    /// conditions read and the ground station ([`crate::liveness::neighbours`]),
    /// a handful whatever the fleet's size: a drone never waits for the
    /// whole fleet. Returns once it has said so; a link whose peers all
    /// meet in one place (the in-process hub) has nothing to say.
    async fn announce_ready(&self, neighbours: &[PeerId]) -> Result<(), TransportError> {
        let _ = neighbours;
        Ok(())
    }

    /// Waits until every peer in `peers` is up and ready (see
    /// [`Link::announce_ready`]). The ground station starts a mission only
    /// then: a drone that never saw a peer it waits on cannot tell, when
    /// that peer dies, that it is lost rather than late. The wait costs
    /// one liveliness token per peer, not one per pair of peers. A link
    /// whose peers all meet in one place (the in-process hub) only waits
    /// for them to be up.
    async fn wait_for_ready(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        self.wait_for_peers(peers, timeout).await
    }

    /// The peers up right now (this one included), updated as they come
    /// and go: zenoh liveliness tokens, or the in-process hub's members.
    /// `None` for a link that cannot tell; its peers are never lost.
    fn presence(&self) -> Option<watch::Receiver<BTreeSet<PeerId>>> {
        None
    }
}

/// One peer's end of a link: the sending half, the frames addressed to it
/// and the telemetry of the drones it subscribed to.
pub struct Endpoint {
    pub link: std::sync::Arc<dyn Link>,
    pub frames: mpsc::UnboundedReceiver<Frame>,
    pub telemetry: mpsc::UnboundedReceiver<TelemetryFrame>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_survive_their_wire_encoding() {
        let f = Frame::Token(BridgeMessage {
            mission: "M-1".into(),
            from: "D1".into(),
            bridge: "b3".into(),
            colour: vec![2, 0],
            seq: 7,
        });
        assert_eq!(Frame::decode(&f.encode()).unwrap(), f);
    }

    #[test]
    fn a_garbled_frame_is_an_error_not_a_panic() {
        assert!(matches!(
            Frame::decode(&[0xff, 0xff, 0xff]),
            Err(TransportError::Decode(_))
        ));
        assert!(TelemetryFrame::decode(&[]).is_err());
    }
}
