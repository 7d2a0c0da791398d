//! The zenoh link: every drone's agent (and the ground station) is a zenoh
//! peer; frames travel as postcard bytes on key expressions scoped by the
//! mission's identity:
//!
//! | key | what |
//! | --- | --- |
//! | `eamos/<mission>/<peer>/bridge` | tokens addressed to `peer` |
//! | `eamos/<mission>/<peer>/ack` | acknowledgements addressed to `peer` |
//! | `eamos/<mission>/<drone>/telemetry` | the state of `drone`, for remote conditions |
//! | `eamos/<mission>/<peer>/alive` | liveliness token: `peer` is up |
//!
//! Peers find each other through explicit endpoints (each listens on its own
//! and connects to the others'); multicast scouting is off unless asked for,
//! so that two fleets on one network never meet by accident. zenoh does not
//! retransmit across a reconnect: exactly-once delivery is the job of
//! [`super::reliable::Bridges`] above this link.

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_trait::async_trait;
use tokio::sync::{mpsc, Notify};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::sample::SampleKind;
use zenoh::Session;

use super::{Endpoint, Frame, Link, PeerId, TelemetryFrame, TransportError};

/// How one peer joins the zenoh network.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ZenohOptions {
    /// Endpoints to listen on, as zenoh writes them (`tcp/127.0.0.1:7447`).
    pub listen: Vec<String>,
    /// Endpoints of the other peers.
    pub connect: Vec<String>,
    /// Find peers by multicast scouting as well (off by default).
    pub scouting: bool,
}

/// The key expression of `what` (`bridge`, `ack`, `telemetry`, `alive`) for
/// `peer` in `mission`.
pub fn key(mission: &str, peer: &str, what: &str) -> String {
    format!("eamos/{mission}/{peer}/{what}")
}

/// A key chunk may not contain zenoh's wildcards or separators.
fn check_chunk(what: &str, s: &str) -> Result<(), TransportError> {
    let bad = |c: char| matches!(c, '/' | '*' | '$' | '?' | '#' | '@') || c.is_whitespace();
    if s.is_empty() || s.chars().any(bad) {
        return Err(TransportError::Config(format!(
            "{what} `{s}` cannot be part of a zenoh key expression"
        )));
    }
    Ok(())
}

fn json(s: &str) -> String {
    serde_json::to_string(s).expect("strings serialise")
}

/// The zenoh configuration of one peer (see the dependency notes: peer mode,
/// explicit endpoints, no multicast and no gossip unless scouting is on).
pub fn config(options: &ZenohOptions) -> Result<zenoh::Config, TransportError> {
    let mut c = zenoh::Config::default();
    let list = |v: &[String]| {
        format!(
            "[{}]",
            v.iter().map(|e| json(e)).collect::<Vec<_>>().join(",")
        )
    };
    let scouting = if options.scouting { "true" } else { "false" };
    for (k, v) in [
        ("mode", json("peer")),
        ("listen/endpoints", list(&options.listen)),
        ("connect/endpoints", list(&options.connect)),
        ("scouting/multicast/enabled", scouting.to_string()),
        ("scouting/gossip/enabled", scouting.to_string()),
        ("transport/unicast/lowlatency", "true".to_string()),
        ("transport/unicast/qos/enabled", "false".to_string()),
    ] {
        c.insert_json5(k, &v)
            .map_err(|e| TransportError::Config(format!("{k} = {v}: {e}")))?;
    }
    Ok(c)
}

/// Opens a zenoh peer for `me` in `mission`, subscribed to the tokens and
/// acks addressed to it and to the telemetry of the drones in `reads`.
pub async fn open(
    mission: &str,
    me: &str,
    reads: &[PeerId],
    options: &ZenohOptions,
) -> Result<Endpoint, TransportError> {
    check_chunk("mission id", mission)?;
    check_chunk("peer name", me)?;
    for r in reads {
        check_chunk("peer name", r)?;
    }
    let session = zenoh::open(config(options)?)
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;

    let (frames_tx, frames) = mpsc::unbounded_channel();
    let (telemetry_tx, telemetry) = mpsc::unbounded_channel();
    let mut subscribers = Vec::new();
    for what in ["bridge", "ack"] {
        let tx = frames_tx.clone();
        let sub = session
            .declare_subscriber(key(mission, me, what))
            .callback(
                move |sample| match Frame::decode(&sample.payload().to_bytes()) {
                    Ok(f) => {
                        let _ = tx.send(f);
                    }
                    Err(e) => tracing::warn!("dropped a frame on {}: {e}", sample.key_expr()),
                },
            )
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?;
        subscribers.push(sub);
    }
    for drone in reads {
        let tx = telemetry_tx.clone();
        let sub = session
            .declare_subscriber(key(mission, drone, "telemetry"))
            .callback(move |sample| {
                if let Ok(t) = TelemetryFrame::decode(&sample.payload().to_bytes()) {
                    let _ = tx.send(t);
                }
            })
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?;
        subscribers.push(sub);
    }

    // Who is up: every peer declares a liveliness token once its own
    // subscribers exist, so a peer seen alive can receive.
    let alive = Arc::new(Alive::default());
    let seen = alive.clone();
    let prefix = format!("eamos/{mission}/");
    let alive_sub = session
        .liveliness()
        .declare_subscriber(format!("eamos/{mission}/*/alive"))
        .history(true)
        .callback(move |sample| {
            let k = sample.key_expr().as_str();
            let Some(peer) = k
                .strip_prefix(&prefix)
                .and_then(|r| r.strip_suffix("/alive"))
            else {
                return;
            };
            let mut peers = seen.peers.lock().expect("alive lock");
            match sample.kind() {
                SampleKind::Put => {
                    peers.insert(peer.to_string());
                }
                SampleKind::Delete => {
                    peers.remove(peer);
                }
            }
            seen.changed.notify_waiters();
        })
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    let token = session
        .liveliness()
        .declare_token(key(mission, me, "alive"))
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    let version = announce_version(&session, mission, me, alive.clone()).await?;

    let link = ZenohLink {
        me: me.to_string(),
        mission: mission.to_string(),
        session,
        publishers: tokio::sync::Mutex::new(HashMap::new()),
        alive,
        _subscribers: subscribers,
        _alive_subscriber: alive_sub,
        _token: token,
        _version: version,
    };
    Ok(Endpoint {
        link: Arc::new(link),
        frames,
        telemetry,
    })
}

#[derive(Default)]
struct Alive {
    peers: Mutex<HashSet<PeerId>>,
    changed: Notify,
    /// Peers seen running another version of this mission, with theirs.
    foreign: Mutex<HashMap<PeerId, String>>,
}

struct ZenohLink {
    me: PeerId,
    mission: String,
    session: Session,
    /// Declared once per key and reused: declaring is a network round.
    publishers: tokio::sync::Mutex<HashMap<String, Publisher<'static>>>,
    alive: Arc<Alive>,
    _subscribers: Vec<Subscriber<()>>,
    _alive_subscriber: Subscriber<()>,
    _token: LivelinessToken,
    _version: Option<(LivelinessToken, Subscriber<()>)>,
}

impl ZenohLink {
    async fn put(&self, key: String, bytes: Vec<u8>) -> Result<(), TransportError> {
        let mut publishers = self.publishers.lock().await;
        if !publishers.contains_key(&key) {
            let p = self
                .session
                .declare_publisher(key.clone())
                .await
                .map_err(|e| TransportError::Send(e.to_string()))?;
            publishers.insert(key.clone(), p);
        }
        publishers[&key]
            .put(bytes)
            .await
            .map_err(|e| TransportError::Send(e.to_string()))
    }
}

#[async_trait]
impl Link for ZenohLink {
    fn me(&self) -> &str {
        &self.me
    }

    async fn send(&self, to: &str, frame: &Frame) -> Result<(), TransportError> {
        let what = match frame {
            Frame::Token(_) => "bridge",
            Frame::Ack(_) => "ack",
        };
        self.put(key(&self.mission, to, what), frame.encode()).await
    }

    async fn publish_telemetry(&self, sample: &TelemetryFrame) -> Result<(), TransportError> {
        self.put(
            key(&self.mission, &sample.drone, "telemetry"),
            sample.encode(),
        )
        .await
    }

    async fn wait_for_peers(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let changed = self.alive.changed.notified();
            let missing: Vec<PeerId> = {
                let alive = self.alive.peers.lock().expect("alive lock");
                peers
                    .iter()
                    .filter(|p| !alive.contains(*p))
                    .cloned()
                    .collect()
            };
            if missing.is_empty() {
                return Ok(());
            }
            if let Some(e) = self.alive.other_version(&self.mission, &missing) {
                return Err(e);
            }
            // Liveliness changes wake us; the timer only bounds the wait.
            let tick = tokio::time::sleep(Duration::from_millis(200));
            tokio::select! {
                _ = changed => {}
                _ = tick => {}
            }
            if tokio::time::Instant::now() >= deadline {
                return Err(TransportError::PeersMissing {
                    missing,
                    waited: timeout,
                });
            }
        }
    }
}

/// Peers of one mission announce its version with a liveliness token
/// `eamos/<mission name>/<peer>/version/<version>` beside the identity-scoped
/// keys, so that a peer of another version of the same mission is told
/// apart from a peer that is simply not up: the two never exchange a token
/// (their keys differ), and each says why. `None` for an identity without
/// a version.
async fn announce_version(
    session: &Session,
    mission: &str,
    me: &str,
    alive: Arc<Alive>,
) -> Result<Option<(LivelinessToken, Subscriber<()>)>, TransportError> {
    let Some((name, version)) = crate::identity::split(mission) else {
        return Ok(None);
    };
    let ours = version.to_string();
    let prefix = format!("eamos/{name}/");
    let mission_name = name.to_string();
    let sub = session
        .liveliness()
        .declare_subscriber(format!("eamos/{name}/*/version/*"))
        .history(true)
        .callback(move |sample| {
            let k = sample.key_expr().as_str();
            let Some((peer, theirs)) = k
                .strip_prefix(&prefix)
                .and_then(|r| r.split_once("/version/"))
            else {
                return;
            };
            if theirs == ours {
                return;
            }
            let mut foreign = alive.foreign.lock().expect("alive lock");
            match sample.kind() {
                SampleKind::Put => {
                    if foreign.insert(peer.to_string(), theirs.to_string()).is_none() {
                        tracing::error!(
                            "peer {peer} runs version {theirs} of mission {mission_name}, this peer version {ours}: they refuse each other"
                        );
                    }
                }
                SampleKind::Delete => {
                    foreign.remove(peer);
                }
            }
            alive.changed.notify_waiters();
        })
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    let token = session
        .liveliness()
        .declare_token(format!("eamos/{name}/{me}/version/{version}"))
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    Ok(Some((token, sub)))
}

impl Alive {
    /// The first of `missing` that runs another version of `mission`.
    fn other_version(&self, mission: &str, missing: &[PeerId]) -> Option<TransportError> {
        let foreign = self.foreign.lock().expect("alive lock");
        let (name, ours) = crate::identity::split(mission)?;
        missing.iter().find_map(|p| {
            foreign.get(p).map(|theirs| TransportError::OtherVersion {
                peer: p.clone(),
                mission: name.to_string(),
                theirs: theirs.clone(),
                ours: ours.to_string(),
            })
        })
    }
}

#[cfg(test)]
mod version_tests {
    use super::*;

    fn free_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn peers_of_two_versions_of_one_mission_refuse_each_other_and_say_why() {
        let (pa, pb) = (free_port(), free_port());
        let options = |listen: u16, connect: u16| ZenohOptions {
            listen: vec![format!("tcp/127.0.0.1:{listen}")],
            connect: vec![format!("tcp/127.0.0.1:{connect}")],
            ..ZenohOptions::default()
        };
        let gcs = open("Survey-0a1b2c", "GCS", &[], &options(pa, pb))
            .await
            .unwrap();
        let mut d1 = open("Survey-9f8e7d", "D1", &[], &options(pb, pa))
            .await
            .unwrap();
        let e = gcs
            .link
            .wait_for_peers(&["D1".into()], Duration::from_secs(20))
            .await
            .unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, TransportError::OtherVersion { .. }), "{msg}");
        assert!(
            msg.contains("D1") && msg.contains("9f8e7d") && msg.contains("0a1b2c"),
            "{msg}"
        );
        let e = d1
            .link
            .wait_for_peers(&["GCS".into()], Duration::from_secs(20))
            .await
            .unwrap_err();
        assert!(e.to_string().contains("0a1b2c"), "{e}");
        // Nor does a token cross.
        let token = Frame::Token(crate::transport::BridgeMessage {
            mission: "Survey-0a1b2c".into(),
            from: "GCS".into(),
            bridge: "b0".into(),
            colour: vec![],
            seq: 1,
        });
        gcs.link.send("D1", &token).await.unwrap();
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert!(d1.frames.try_recv().is_err());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::reliable::{Bridges, RetransmitPolicy};
    use crate::transport::BridgeMessage;

    /// A free loopback port: bind port 0 and let the OS choose.
    fn free_port() -> u16 {
        std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    }

    fn tcp(port: u16) -> String {
        format!("tcp/127.0.0.1:{port}")
    }

    #[test]
    fn a_mission_id_with_a_wildcard_is_refused() {
        assert!(check_chunk("mission id", "M*").is_err());
        assert!(check_chunk("mission id", "a/b").is_err());
        assert!(check_chunk("mission id", "").is_err());
        assert!(check_chunk("mission id", "ExperimentB-3fa2").is_ok());
    }

    #[test]
    fn the_configuration_is_a_loopback_peer_without_scouting() {
        let c = config(&ZenohOptions {
            listen: vec![tcp(7447)],
            connect: vec![tcp(7448)],
            scouting: false,
        })
        .unwrap();
        let text = format!("{c}");
        assert!(text.contains("tcp/127.0.0.1:7447"), "{text}");
        assert!(text.contains("tcp/127.0.0.1:7448"), "{text}");
    }

    #[test]
    fn a_malformed_endpoint_is_a_configuration_error() {
        let e = config(&ZenohOptions {
            listen: vec!["not an endpoint".into()],
            ..ZenohOptions::default()
        });
        assert!(matches!(e, Err(TransportError::Config(_))), "{:?}", e.err());
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn two_peers_on_loopback_pass_tokens_and_telemetry_exactly_once() {
        let (pa, pb) = (free_port(), free_port());
        let mission = "ZenohTest-1";
        let a = open(
            mission,
            "D1",
            &["D2".into()],
            &ZenohOptions {
                listen: vec![tcp(pa)],
                connect: vec![tcp(pb)],
                scouting: false,
            },
        )
        .await
        .unwrap();
        let b = open(
            mission,
            "D2",
            &[],
            &ZenohOptions {
                listen: vec![tcp(pb)],
                connect: vec![tcp(pa)],
                scouting: false,
            },
        )
        .await
        .unwrap();
        a.link
            .wait_for_peers(&["D2".into()], Duration::from_secs(20))
            .await
            .unwrap();
        b.link
            .wait_for_peers(&["D1".into()], Duration::from_secs(20))
            .await
            .unwrap();

        let b_link = b.link.clone();
        let mut a_telemetry = a.telemetry;
        let (ta, _) = Bridges::start(mission, a.link, a.frames, RetransmitPolicy::default());
        let (_tb, mut rb) = Bridges::start(mission, b.link, b.frames, RetransmitPolicy::default());
        ta.send("D2", "b1", vec![0]);
        ta.send("D2", "b1", vec![1]);
        let first = rb.recv().await.unwrap();
        let second = rb.recv().await.unwrap();
        assert_eq!(first.bridge, "b1");
        assert_eq!((first.colour, second.colour), (vec![0], vec![1]));
        assert_eq!(ta.flush(Duration::from_secs(20)).await, 0);

        // Telemetry of D2, read by D1: published until seen (the first
        // sample may precede the subscription's arrival at D2).
        let sample = TelemetryFrame {
            mission: mission.into(),
            drone: "D2".into(),
            seq: 1,
            body: vec![9],
        };
        let got = loop {
            b_link.publish_telemetry(&sample).await.unwrap();
            if let Ok(Some(t)) =
                tokio::time::timeout(Duration::from_millis(200), a_telemetry.recv()).await
            {
                break t;
            }
        };
        assert_eq!(got, sample);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_peer_of_another_mission_hears_nothing() {
        let (pa, pb) = (free_port(), free_port());
        let a = open(
            "MissionA-1",
            "D1",
            &[],
            &ZenohOptions {
                listen: vec![tcp(pa)],
                connect: vec![tcp(pb)],
                scouting: false,
            },
        )
        .await
        .unwrap();
        let mut b = open(
            "MissionB-1",
            "D2",
            &[],
            &ZenohOptions {
                listen: vec![tcp(pb)],
                connect: vec![tcp(pa)],
                scouting: false,
            },
        )
        .await
        .unwrap();
        let err = a
            .link
            .wait_for_peers(&["D2".into()], Duration::from_millis(600))
            .await;
        assert!(err.is_err(), "D2 is in another mission");
        let m = Frame::Token(BridgeMessage {
            mission: "MissionA-1".into(),
            from: "D1".into(),
            bridge: "b".into(),
            colour: vec![],
            seq: 1,
        });
        a.link.send("D2", &m).await.unwrap();
        tokio::time::sleep(Duration::from_millis(200)).await;
        assert!(b.frames.try_recv().is_err());
    }
}
