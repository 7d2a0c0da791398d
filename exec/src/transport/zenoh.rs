//! The zenoh link: every drone's agent (and the ground station) is a zenoh
//! peer; frames travel as postcard bytes on key expressions scoped by the
//! mission's identity:
//!
//! | key | what |
//! | --- | --- |
//! | `eamos/<mission>/<peer>/bridge` | tokens addressed to `peer` |
//! | `eamos/<mission>/<peer>/ack` | acknowledgements addressed to `peer` |
//! | `eamos/<mission>/<drone>/telemetry` | the state of `drone`, for remote conditions |
//! | `eamos/<mission>/<peer>/events` | `peer`'s events as mission log lines, for observers (no peer subscribes) |
//! | `eamos/<mission>/<peer>/state` | queryable: `peer`'s latest marking, action and end, for an observer that joins late |
//! | `eamos/<mission>/<peer>/alive` | liveliness token: `peer` is up |
//! | `eamos/<mission>/<peer>/ready` | liveliness token: `peer` sees every peer it exchanges tokens or telemetry with |
//!
//! Peers find each other through explicit endpoints (each listens on its own
//! and connects to the others'); multicast scouting is off unless asked for,
//! so that two fleets on one network never meet by accident. zenoh does not
//! retransmit across a reconnect: exactly-once delivery is the job of
//! [`super::reliable::Bridges`] above this link.
//!
//! With [`TlsFiles`] every link is TLS with mutual authentication: each peer
//! presents its certificate both when it listens and when it connects, and
//! accepts only peers whose certificate the fleet's CA signed. Plain `tcp/`
//! links are then refused at both ends (zenoh's protocol whitelist holds
//! only `tls`), so a misconfigured peer cannot fall back to clear text.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

use async_trait::async_trait;
use tokio::sync::{mpsc, watch, Notify};
use zenoh::liveliness::LivelinessToken;
use zenoh::matching::{MatchingListener, MatchingStatus};
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

use super::following::Following;
use super::{Endpoint, Frame, FrameHandler, Link, PeerId, TelemetryFrame, TransportError};

pub use eamos_fleet::zenoh::{TlsFiles, ZenohOptions};

/// Reads every TLS file once before zenoh does, so that a missing file or
/// a key in the wrong place is reported with its path and what it was
/// meant to be, rather than as a handshake that never succeeds.
fn check_tls(files: &TlsFiles) -> Result<(), TransportError> {
    for (what, path, marker) in [
        ("CA certificate", &files.ca, "-----BEGIN CERTIFICATE-----"),
        (
            "certificate",
            &files.certificate,
            "-----BEGIN CERTIFICATE-----",
        ),
        ("private key", &files.key, "PRIVATE KEY-----"),
    ] {
        let text = std::fs::read(path).map_err(|e| {
            TransportError::Config(format!(
                "cannot read the TLS {what} {}: {e}",
                path.display()
            ))
        })?;
        if !String::from_utf8_lossy(&text).contains(marker) {
            return Err(TransportError::Config(format!(
                "the TLS {what} {} is not a PEM {what} (no `{marker}` line)",
                path.display()
            )));
        }
    }
    Ok(())
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
    let mut settings = vec![
        ("mode", json(options.mode.as_str())),
        ("listen/endpoints", list(&options.listen)),
        ("connect/endpoints", list(&options.connect)),
        ("scouting/multicast/enabled", scouting.to_string()),
        ("scouting/gossip/enabled", scouting.to_string()),
    ];
    // Low-latency links shave the mesh's latency. Through a router they
    // are not used: a router whose hundred clients close their links at
    // once (a fleet's mission ending, its drones landing on a lost peer)
    // blocked on them, inside the runtime, for good, and heard no more.
    // Both ends of a link must agree, and every peer of a routed fleet is
    // a client or a router.
    if options.mode == eamos_fleet::Mode::Peer {
        settings.extend([
            ("transport/unicast/lowlatency", "true".to_string()),
            ("transport/unicast/qos/enabled", "false".to_string()),
        ]);
    }
    if options.mode == eamos_fleet::Mode::Client {
        // A drone may start before its routers do: it keeps trying them
        // instead of giving up (zenoh's clients give up at once by
        // default). The ground station and `eamos abort` bound the wait
        // (see `within`) and say which routers never answered.
        settings.push(("connect/timeout_ms", "-1".to_string()));
    }
    if let Some(tls) = &options.tls {
        if let Some(plain) = options
            .listen
            .iter()
            .chain(&options.connect)
            .find(|e| !e.starts_with("tls/"))
        {
            return Err(TransportError::Config(format!(
                "endpoint `{plain}` is not a TLS endpoint: with certificates every endpoint is `tls/HOST:PORT`"
            )));
        }
        check_tls(tls)?;
        let path = |p: &PathBuf| json(&p.to_string_lossy());
        settings.extend([
            ("transport/link/protocols", "[\"tls\"]".to_string()),
            ("transport/link/tls/root_ca_certificate", path(&tls.ca)),
            (
                "transport/link/tls/listen_certificate",
                path(&tls.certificate),
            ),
            ("transport/link/tls/listen_private_key", path(&tls.key)),
            (
                "transport/link/tls/connect_certificate",
                path(&tls.certificate),
            ),
            ("transport/link/tls/connect_private_key", path(&tls.key)),
            ("transport/link/tls/enable_mtls", "true".to_string()),
            (
                "transport/link/tls/verify_name_on_connect",
                tls.verify_name.to_string(),
            ),
        ]);
    }
    for (k, v) in settings {
        c.insert_json5(k, &v)
            .map_err(|e| TransportError::Config(format!("{k} = {v}: {e}")))?;
    }
    Ok(c)
}

/// Opens the zenoh session of `who` (a peer, or a router): a port already
/// taken is said as such, since zenoh's own words name its source files
/// and the crew needs the port.
async fn open_session(options: &ZenohOptions, who: &str) -> Result<zenoh::Session, TransportError> {
    // zenoh opens a session by blocking the thread that awaits it (a
    // client keeps trying its routers as long as none answers): on a task
    // of its own, so that whoever waits for it can give up (Ctrl-C).
    let config = config(options)?;
    let opening = tokio::spawn(async move { zenoh::open(config).await });
    let opened = opening
        .await
        .map_err(|e| TransportError::Open(format!("the session's opening failed: {e}")))?;
    opened.map_err(|e| {
        let e = e.to_string();
        if e.contains("Address already in use") {
            TransportError::PortTaken {
                peer: who.to_string(),
                endpoints: options.listen.clone(),
                fleet: None,
            }
        } else {
            TransportError::Open(e)
        }
    })
}

/// Waits for `opening` (a session of `who`, opened with `options`) at most
/// `patience` where it joins through routers: a client whose routers never
/// answer keeps trying them for good (see [`config`]), which is right for a
/// drone powered up before the ground network, but a ground station or a
/// command the crew waits on must say so instead of hanging.
pub async fn within<T>(
    opening: impl std::future::Future<Output = Result<T, TransportError>>,
    who: &str,
    options: &ZenohOptions,
    patience: Duration,
) -> Result<T, TransportError> {
    if options.mode != eamos_fleet::Mode::Client {
        return opening.await;
    }
    tokio::time::timeout(patience, opening)
        .await
        .unwrap_or_else(|_| {
            Err(TransportError::NoRouter {
                peer: who.to_string(),
                routers: options.connect.clone(),
                waited: patience,
            })
        })
}

/// The peer whose liveliness token `key` is, in `mission`
/// (`eamos/<mission>/<peer>/alive`).
pub(crate) fn alive_peer<'k>(mission: &str, key: &'k str) -> Option<&'k str> {
    key.strip_prefix("eamos/")?
        .strip_prefix(mission)?
        .strip_prefix('/')?
        .strip_suffix("/alive")
}

/// Runs a zenoh router of the fleet (`eamos router`) until `stop`: it
/// carries the traffic of the peers that join through it as clients, and
/// passes on what the other routers carry, so that losing one router loses
/// only the links through it, which its clients open again to the next.
pub async fn route(
    options: &ZenohOptions,
    stop: tokio_util::sync::CancellationToken,
) -> Result<(), TransportError> {
    let session = open_session(options, "the router").await?;
    stop.cancelled().await;
    session
        .close()
        .await
        .map_err(|e| TransportError::Open(e.to_string()))
}

/// Opens a zenoh peer for `me` in `mission`, subscribed to the tokens and
/// acks addressed to it and to the telemetry of the drones in `reads`,
/// following whether every other peer is up: the ground station, an
/// observer, `eamos abort`.
pub async fn open(
    mission: &str,
    me: &str,
    reads: &[PeerId],
    options: &ZenohOptions,
) -> Result<Endpoint, TransportError> {
    open_following(mission, me, reads, None, options).await
}

/// [`open`], following only whether the peers in `follow` are up (a
/// drone: its [`crate::liveness::neighbours`], every peer it may ever wait
/// on), when given. Following every peer, each of 250 drones heard every
/// other's liveliness tokens come and go, its presence set recomputed at
/// each: the fleet's work at start grew as the cube of its size.
pub async fn open_following(
    mission: &str,
    me: &str,
    reads: &[PeerId],
    follow: Option<&[PeerId]>,
    options: &ZenohOptions,
) -> Result<Endpoint, TransportError> {
    check_chunk("mission id", mission)?;
    check_chunk("peer name", me)?;
    for r in reads.iter().chain(follow.unwrap_or_default()) {
        check_chunk("peer name", r)?;
    }
    let session = open_session(options, me).await?;

    let (frames_tx, frames) = mpsc::unbounded_channel();
    let (telemetry_tx, telemetry) = mpsc::unbounded_channel();
    let mut subscribers = Vec::new();
    let handler: Arc<OnceLock<FrameHandler>> = Arc::default();
    for what in ["bridge", "ack"] {
        let tx = frames_tx.clone();
        let handler = handler.clone();
        let sub = session
            .declare_subscriber(key(mission, me, what))
            .callback(
                move |sample| match Frame::decode(&sample.payload().to_bytes()) {
                    Ok(f) => match handler.get() {
                        Some(h) => h(f),
                        None => {
                            let _ = tx.send(f);
                        }
                    },
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
    let presence = Arc::new(watch::channel(BTreeSet::new()).0);
    let presence_tx = presence.clone();
    let seen = alive.clone();
    let mission_owned = mission.to_string();
    let me_owned = me.to_string();
    let following = Arc::new(Following::new(me, follow));
    let admitted = following.clone();
    let on_alive = move |sample: Sample| {
        let Some(peer) =
            alive_peer(&mission_owned, sample.key_expr().as_str()).filter(|p| admitted.admits(p))
        else {
            return;
        };
        let mut peers = seen.peers.lock().expect("alive lock");
        tracing::debug!("{me_owned}: {peer} is {}", up_or_gone(sample.kind()));
        match sample.kind() {
            SampleKind::Put => {
                peers.insert(peer.to_string());
            }
            SampleKind::Delete => {
                peers.remove(peer);
            }
        }
        presence_tx.send_replace(peers.iter().cloned().collect());
        seen.changed.notify_waiters();
    };
    let keys = following
        .chunks()
        .into_iter()
        .map(|who| format!("eamos/{mission}/{who}/alive"));
    let alive_subs = follow_tokens(&session, keys, on_alive).await?;
    let token = session
        .liveliness()
        .declare_token(key(mission, me, "alive"))
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    let version = announce_version(&session, mission, me, following, alive.clone()).await?;
    let state: Arc<Mutex<BTreeMap<&'static str, Vec<u8>>>> = Arc::default();
    let state_queryable = {
        let (state, at) = (state.clone(), key(mission, me, "state"));
        session
            .declare_queryable(at.clone())
            .callback(move |query| {
                let kept: Vec<Vec<u8>> = state
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .values()
                    .cloned()
                    .collect();
                for line in kept {
                    use zenoh::Wait;
                    let _ = query.reply(at.clone(), line).wait();
                }
            })
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?
    };

    let link = ZenohLink {
        me: me.to_string(),
        mission: mission.to_string(),
        session,
        publishers: tokio::sync::Mutex::new(HashMap::new()),
        handler,
        alive,
        _subscribers: subscribers,
        _alive_subscribers: alive_subs,
        ready: tokio::sync::Mutex::new(Ready::default()),
        _token: token,
        _version: version,
        presence,
        state,
        _state_queryable: state_queryable,
    };
    Ok(Endpoint {
        link: Arc::new(link),
        frames,
        telemetry,
    })
}

/// Subscribes `on` to the liveliness tokens on each of `keys`, those up
/// already included.
async fn follow_tokens(
    session: &Session,
    keys: impl Iterator<Item = String>,
    on: impl Fn(Sample) + Clone + Send + Sync + 'static,
) -> Result<Vec<Subscriber<()>>, TransportError> {
    let mut subs = Vec::new();
    for key in keys {
        let sub = session
            .liveliness()
            .declare_subscriber(key)
            .history(true)
            .callback(on.clone())
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?;
        subs.push(sub);
    }
    Ok(subs)
}

fn up_or_gone(kind: SampleKind) -> &'static str {
    match kind {
        SampleKind::Put => "up",
        SampleKind::Delete => "gone",
    }
}

#[derive(Default)]
struct Alive {
    peers: Mutex<HashSet<PeerId>>,
    /// Peers whose `ready` token is up (followed once
    /// [`Link::wait_for_ready`] is first asked).
    ready: Mutex<HashSet<PeerId>>,
    changed: Notify,
    /// Peers seen running another version of this mission, with theirs.
    foreign: Mutex<HashMap<PeerId, String>>,
}

/// The `ready` liveliness tokens of one link (see [`Link::announce_ready`]).
#[derive(Default)]
struct Ready {
    token: Option<LivelinessToken>,
    subscriber: Option<Subscriber<()>>,
}

struct ZenohLink {
    me: PeerId,
    mission: String,
    session: Session,
    /// Its publishers, by key.
    publishers: tokio::sync::Mutex<HashMap<String, Stream>>,
    /// Where frames go once set (see [`Link::route_frames`]).
    handler: Arc<OnceLock<FrameHandler>>,
    alive: Arc<Alive>,
    /// The peers whose liveliness token is up (see [`Link::presence`]).
    presence: Arc<watch::Sender<BTreeSet<PeerId>>>,
    _subscribers: Vec<Subscriber<()>>,
    _alive_subscribers: Vec<Subscriber<()>>,
    /// This peer's `ready` token once declared, and the subscriber to the
    /// others' once someone waits for them.
    ready: tokio::sync::Mutex<Ready>,
    _token: LivelinessToken,
    _version: Option<(LivelinessToken, Vec<Subscriber<()>>)>,
    /// The latest of this peer's events by slot, for observers that ask
    /// (see [`Link::publish_event`]).
    state: Arc<Mutex<BTreeMap<&'static str, Vec<u8>>>>,
    _state_queryable: zenoh::query::Queryable<()>,
}

impl ZenohLink {
    /// Follows the peers' `ready` tokens into `alive.ready`, from the first
    /// call on: only whoever waits for them (the ground station) hears
    /// them, one token per peer.
    async fn follow_ready(&self) -> Result<(), TransportError> {
        let mut ready = self.ready.lock().await;
        if ready.subscriber.is_some() {
            return Ok(());
        }
        let prefix = format!("eamos/{}/", self.mission);
        let alive = self.alive.clone();
        let sub = self
            .session
            .liveliness()
            .declare_subscriber(format!("eamos/{}/*/ready", self.mission))
            .history(true)
            .callback(move |sample| {
                let Some(peer) = sample
                    .key_expr()
                    .as_str()
                    .strip_prefix(&prefix)
                    .and_then(|r| r.strip_suffix("/ready"))
                else {
                    return;
                };
                let mut ready = alive.ready.lock().expect("alive lock");
                match sample.kind() {
                    SampleKind::Put => ready.insert(peer.to_string()),
                    SampleKind::Delete => ready.remove(peer),
                };
                drop(ready);
                alive.changed.notify_waiters();
            })
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?;
        ready.subscriber = Some(sub);
        Ok(())
    }
}

/// A publisher of what nobody may be listening to (telemetry, events),
/// declared once per key and reused (declaring is a network round).
struct Stream {
    publisher: Publisher<'static>,
    /// Whether a subscriber matches the key, as zenoh last said.
    heard: Arc<AtomicBool>,
    _listener: MatchingListener<()>,
}

/// Who a publication is for.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Audience {
    /// A peer that must get it (a token, an acknowledgement): always sent,
    /// and without declaring a publisher. A drone that holds the join of a
    /// block of 250 drones acknowledges each of them, one that holds its
    /// fork sends each a token: a publisher kept for each peer cost such a
    /// drone 2-4 kB apiece, 0.5-0.9 MB of its 22-23 MB.
    Addressed,
    /// Whoever subscribes: a drone's telemetry is read by the few peers
    /// whose conditions name it, its events by a monitor if one watches.
    /// Published only while a subscriber matches; one that comes later
    /// misses nothing it needs (telemetry is published again every 250 ms,
    /// and a peer's latest events are kept for whoever asks, see
    /// [`Link::publish_event`]). zenoh would not send an unheard sample over
    /// the network anyway (`tests/unheard.rs`), but each put still cost the
    /// publisher zenoh's routing match: each of 250 drones did that up to a
    /// hundred times a second, most of the fleet's work once it flew.
    IfHeard,
}

impl ZenohLink {
    async fn put(&self, key: String, bytes: Vec<u8>, to: Audience) -> Result<(), TransportError> {
        let send = |e: zenoh::Error| TransportError::Send(e.to_string());
        if to == Audience::Addressed {
            return self.session.put(key, bytes).await.map_err(send);
        }
        let mut publishers = self.publishers.lock().await;
        if !publishers.contains_key(&key) {
            let publisher = self
                .session
                .declare_publisher(key.clone())
                .await
                .map_err(send)?;
            let heard = Arc::new(AtomicBool::new(false));
            let h = heard.clone();
            let listener = publisher
                .matching_listener()
                .callback(move |s: MatchingStatus| h.store(s.matching(), Ordering::Relaxed))
                .await
                .map_err(send)?;
            // Any change after this is the listener's.
            let now = publisher.matching_status().await.map_err(send)?;
            heard.store(now.matching(), Ordering::Relaxed);
            let stream = Stream {
                publisher,
                heard,
                _listener: listener,
            };
            publishers.insert(key.clone(), stream);
        }
        let stream = &publishers[&key];
        if !stream.heard.load(Ordering::Relaxed) {
            return Ok(());
        }
        stream.publisher.put(bytes).await.map_err(send)
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
            Frame::Ack(_) | Frame::Acks(_) => "ack",
        };
        self.put(
            key(&self.mission, to, what),
            frame.encode(),
            Audience::Addressed,
        )
        .await
    }

    fn route_frames(&self, handler: FrameHandler) -> bool {
        self.handler.set(handler).is_ok()
    }

    async fn publish_telemetry(&self, sample: &TelemetryFrame) -> Result<(), TransportError> {
        self.put(
            key(&self.mission, &sample.drone, "telemetry"),
            sample.encode(),
            Audience::IfHeard,
        )
        .await
    }

    async fn publish_event(
        &self,
        line: Vec<u8>,
        state: Option<&'static str>,
    ) -> Result<(), TransportError> {
        if let Some(slot) = state {
            let mut kept = self.state.lock().unwrap_or_else(|p| p.into_inner());
            kept.insert(slot, line.clone());
        }
        self.put(
            key(&self.mission, &self.me, "events"),
            line,
            Audience::IfHeard,
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
            let missing = self.alive.missing(peers);
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

    async fn announce_ready(&self, neighbours: &[PeerId]) -> Result<(), TransportError> {
        loop {
            let changed = self.alive.changed.notified();
            let unseen = self.alive.missing(neighbours);
            if unseen.is_empty() {
                break;
            }
            tracing::debug!("{}: not ready, does not see {unseen:?} yet", self.me);
            // Liveliness changes wake us; the timer only bounds the wait.
            let tick = tokio::time::sleep(Duration::from_secs(1));
            tokio::select! {
                _ = changed => {}
                _ = tick => {}
            }
        }
        let mut ready = self.ready.lock().await;
        if ready.token.is_none() {
            let token = self
                .session
                .liveliness()
                .declare_token(key(&self.mission, &self.me, "ready"))
                .await
                .map_err(|e| TransportError::Open(e.to_string()))?;
            tracing::debug!("{}: ready", self.me);
            ready.token = Some(token);
        }
        Ok(())
    }

    async fn wait_for_ready(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        let deadline = tokio::time::Instant::now() + timeout;
        self.follow_ready().await?;
        self.wait_for_peers(peers, timeout).await?;
        loop {
            let changed = self.alive.changed.notified();
            let unready: Vec<PeerId> = {
                let ready = self.alive.ready.lock().expect("alive lock");
                peers
                    .iter()
                    .filter(|p| !ready.contains(*p))
                    .cloned()
                    .collect()
            };
            if unready.is_empty() {
                return Ok(());
            }
            tracing::debug!("{}: waiting until {unready:?} are ready", self.me);
            let tick = tokio::time::sleep(Duration::from_millis(200));
            tokio::select! {
                _ = changed => {}
                _ = tick => {}
            }
            if tokio::time::Instant::now() >= deadline {
                return Err(TransportError::NotReady {
                    peers: unready,
                    waited: timeout,
                });
            }
        }
    }

    fn presence(&self) -> Option<watch::Receiver<BTreeSet<PeerId>>> {
        Some(self.presence.subscribe())
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
    following: Arc<Following>,
    alive: Arc<Alive>,
) -> Result<Option<(LivelinessToken, Vec<Subscriber<()>>)>, TransportError> {
    let Some((name, version)) = eamos_fleet::identity::split(mission) else {
        return Ok(None);
    };
    let ours = version.to_string();
    let prefix = format!("eamos/{name}/");
    let mission_name = name.to_string();
    let admitted = following.clone();
    let on_version = move |sample: Sample| {
        let k = sample.key_expr().as_str();
        let Some((peer, theirs)) = k
            .strip_prefix(&prefix)
            .and_then(|r| r.split_once("/version/"))
        else {
            return;
        };
        if theirs == ours || !admitted.admits(peer) {
            return;
        }
        let mut foreign = alive.foreign.lock().expect("alive lock");
        match sample.kind() {
            SampleKind::Put => {
                if foreign
                    .insert(peer.to_string(), theirs.to_string())
                    .is_none()
                {
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
    };
    let keys = following
        .chunks()
        .into_iter()
        .map(|who| format!("eamos/{name}/{who}/version/*"));
    let subs = follow_tokens(session, keys, on_version).await?;
    let token = session
        .liveliness()
        .declare_token(format!("eamos/{name}/{me}/version/{version}"))
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    Ok(Some((token, subs)))
}

impl Alive {
    /// Those of `peers` whose alive token this peer does not see (yet).
    fn missing(&self, peers: &[PeerId]) -> Vec<PeerId> {
        let up = self.peers.lock().expect("alive lock");
        peers.iter().filter(|p| !up.contains(*p)).cloned().collect()
    }

    /// The first of `missing` that runs another version of `mission`.
    fn other_version(&self, mission: &str, missing: &[PeerId]) -> Option<TransportError> {
        let foreign = self.foreign.lock().expect("alive lock");
        let (name, ours) = eamos_fleet::identity::split(mission)?;
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
    use super::tests::free_port;
    use super::*;

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
    use crate::transport::following::ONE_BY_ONE;
    use crate::transport::reliable::{Bridges, RetransmitPolicy};
    use crate::transport::BridgeMessage;

    #[test]
    fn a_liveliness_key_names_its_peer_only_in_its_own_mission() {
        assert_eq!(alive_peer("M-1", "eamos/M-1/Drone2/alive"), Some("Drone2"));
        assert_eq!(alive_peer("M-1", "eamos/M-12/Drone2/alive"), None);
        assert_eq!(alive_peer("M-1", "eamos/M-1/Drone2/sees"), None);
        assert_eq!(alive_peer("M-1", "other/M-1/Drone2/alive"), None);
    }

    /// A free loopback port, the system's choice, and none another test
    /// of this binary was given: the system may hand a port just closed
    /// to the next caller, and the tests ask from parallel threads before
    /// their sessions listen.
    pub(super) fn free_port() -> u16 {
        static GIVEN: std::sync::Mutex<std::collections::BTreeSet<u16>> =
            std::sync::Mutex::new(std::collections::BTreeSet::new());
        loop {
            let port = std::net::TcpListener::bind("127.0.0.1:0")
                .unwrap()
                .local_addr()
                .unwrap()
                .port();
            if GIVEN.lock().unwrap_or_else(|e| e.into_inner()).insert(port) {
                return port;
            }
        }
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
            mode: Default::default(),
            listen: vec![tcp(7447)],
            connect: vec![tcp(7448)],
            scouting: false,
            tls: None,
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

    /// Opens `me` listening on `listen` and connecting to `connect`.
    async fn peer(mission: &str, me: &str, listen: u16, connect: &[u16]) -> Endpoint {
        open(
            mission,
            me,
            &[],
            &ZenohOptions {
                listen: vec![tcp(listen)],
                connect: connect.iter().map(|p| tcp(*p)).collect(),
                ..ZenohOptions::default()
            },
        )
        .await
        .unwrap()
    }

    /// Announces `me` ready once it sees `neighbours`, in the background.
    fn announce(e: &Endpoint, neighbours: &[&str]) -> tokio::task::JoinHandle<()> {
        let link = e.link.clone();
        let neighbours: Vec<PeerId> = neighbours.iter().map(|p| p.to_string()).collect();
        tokio::spawn(async move { link.announce_ready(&neighbours).await.unwrap() })
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_drone_is_ready_once_it_sees_its_neighbours_and_the_ground_station_waits_for_every_drone(
    ) {
        let (pg, p1, p2, p3) = (free_port(), free_port(), free_port(), free_port());
        let mission = "ReadyTest-1";
        // Each drone knows only the ground station: zenoh peers do not pass
        // on each other's tokens, so no two drones ever meet.
        let gcs = peer(mission, "GCS", pg, &[p1, p2, p3]).await;
        let d1 = peer(mission, "D1", p1, &[pg]).await;
        let d2 = peer(mission, "D2", p2, &[pg]).await;
        let d3 = peer(mission, "D3", p3, &[pg]).await;
        // D1 and D2 exchange nothing with another drone: they are ready as
        // soon as they see the ground station, not waiting for D3.
        let (r1, r2) = (announce(&d1, &["GCS"]), announce(&d2, &["GCS"]));
        // D3 has a bridge with D1, which it never sees: it never says it is
        // ready, and the ground station names it.
        let r3 = announce(&d3, &["GCS", "D1"]);
        gcs.link
            .wait_for_ready(&["D1".into(), "D2".into()], Duration::from_secs(20))
            .await
            .expect("D1 and D2 need to see only the ground station");
        let e = gcs
            .link
            .wait_for_ready(
                &["D1".into(), "D2".into(), "D3".into()],
                Duration::from_secs(2),
            )
            .await
            .unwrap_err();
        match &e {
            TransportError::NotReady { peers, .. } => assert_eq!(peers, &["D3".to_string()]),
            other => panic!("{other}"),
        }
        assert!(e.to_string().contains("D3 are up but not ready"), "{e}");
        assert!(r1.is_finished() && r2.is_finished() && !r3.is_finished());
        r3.abort();
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn drones_that_see_their_neighbours_are_ready_whatever_order_they_start_in() {
        let (pg, p1, p2) = (free_port(), free_port(), free_port());
        let mission = "ReadyTest-2";
        // The drones start first and try each other at once; the ground
        // station comes last.
        let (c1, c2) = ([pg, p2], [pg, p1]);
        let (d1, d2) = tokio::join!(peer(mission, "D1", p1, &c1), peer(mission, "D2", p2, &c2));
        let _ready = (announce(&d1, &["GCS", "D2"]), announce(&d2, &["GCS", "D1"]));
        let gcs = peer(mission, "GCS", pg, &[p1, p2]).await;
        gcs.link
            .wait_for_ready(&["D1".into(), "D2".into()], Duration::from_secs(30))
            .await
            .expect("every drone sees its neighbours");
        drop((d1, d2));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn frames_routed_to_a_handler_reach_it_and_not_the_channel_and_only_one_handler_is_taken()
    {
        let (pa, pb) = (free_port(), free_port());
        let mission = "RouteTest-1";
        let a = peer(mission, "D1", pa, &[pb]).await;
        let mut b = peer(mission, "D2", pb, &[pa]).await;
        a.link
            .wait_for_peers(&["D2".into()], Duration::from_secs(20))
            .await
            .unwrap();
        let (tx, mut routed) = mpsc::unbounded_channel();
        assert!(b.link.route_frames(Arc::new(move |f| {
            let _ = tx.send(f);
        })));
        assert!(!b.link.route_frames(Arc::new(|_| {})), "a second handler");
        let token = Frame::Token(crate::transport::BridgeMessage {
            mission: mission.into(),
            from: "D1".into(),
            bridge: "b1".into(),
            colour: vec![],
            seq: 1,
        });
        // Sent until it arrives: D2's subscription may reach D1 late.
        let got = loop {
            a.link.send("D2", &token).await.unwrap();
            if let Ok(Some(f)) =
                tokio::time::timeout(Duration::from_millis(200), routed.recv()).await
            {
                break f;
            }
        };
        assert_eq!(got, token);
        assert!(b.frames.try_recv().is_err(), "nothing on the channel");
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
                mode: Default::default(),
                listen: vec![tcp(pa)],
                connect: vec![tcp(pb)],
                scouting: false,
                tls: None,
            },
        )
        .await
        .unwrap();
        let b = open(
            mission,
            "D2",
            &[],
            &ZenohOptions {
                mode: Default::default(),
                listen: vec![tcp(pb)],
                connect: vec![tcp(pa)],
                scouting: false,
                tls: None,
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

    /// A drone follows whether its neighbours are up, and hears nothing
    /// of the rest of the fleet, however many they are.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_peer_that_follows_its_neighbours_sees_them_come_and_go_and_no_one_else() {
        follows_d1_among(0, "ZenohTest-follow").await;
    }

    /// Past [`ONE_BY_ONE`] neighbours a drone hears every peer's token
    /// through one subscriber: it still keeps only its neighbours'.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_peer_that_follows_many_neighbours_still_sees_no_one_else() {
        follows_d1_among(ONE_BY_ONE, "ZenohTest-follow-many").await;
    }

    /// D3 follows D1 and `absent` neighbours never up; D2 is up and is not
    /// one of them.
    async fn follows_d1_among(absent: usize, mission: &str) {
        let ports = [free_port(), free_port(), free_port()];
        let mesh = |k: usize| ZenohOptions {
            mode: Default::default(),
            listen: vec![tcp(ports[k])],
            connect: (0..3).filter(|j| *j != k).map(|j| tcp(ports[j])).collect(),
            scouting: false,
            tls: None,
        };
        let d1 = open(mission, "D1", &[], &mesh(0)).await.unwrap();
        let _d2 = open(mission, "D2", &[], &mesh(1)).await.unwrap();
        let neighbours: Vec<PeerId> = std::iter::once("D1".to_string())
            .chain((1..=absent).map(|k| format!("F{k}")))
            .collect();
        let d3 = open_following(mission, "D3", &[], Some(&neighbours), &mesh(2))
            .await
            .unwrap();
        let all = ["D2".to_string(), "D3".to_string()];
        d1.link
            .wait_for_peers(&all, Duration::from_secs(20))
            .await
            .expect("D1 follows everyone");
        d3.link
            .wait_for_peers(&["D1".into()], Duration::from_secs(20))
            .await
            .unwrap();
        let mut presence = d3.link.presence().unwrap();
        // D2 has been up long enough for D1 to see it; D3 never does.
        tokio::time::sleep(Duration::from_millis(300)).await;
        let up: Vec<PeerId> = presence.borrow_and_update().iter().cloned().collect();
        assert_eq!(up, ["D1", "D3"]);
        drop(d1);
        let gone = tokio::time::timeout(
            Duration::from_secs(20),
            presence.wait_for(|up| !up.contains("D1")),
        )
        .await;
        assert!(gone.is_ok(), "D3 never saw D1 go");
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_peer_of_another_mission_hears_nothing() {
        let (pa, pb) = (free_port(), free_port());
        let a = open(
            "MissionA-1",
            "D1",
            &[],
            &ZenohOptions {
                mode: Default::default(),
                listen: vec![tcp(pa)],
                connect: vec![tcp(pb)],
                scouting: false,
                tls: None,
            },
        )
        .await
        .unwrap();
        let mut b = open(
            "MissionB-1",
            "D2",
            &[],
            &ZenohOptions {
                mode: Default::default(),
                listen: vec![tcp(pb)],
                connect: vec![tcp(pa)],
                scouting: false,
                tls: None,
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

    /// A throwaway certificate authority and the certificates it signs, in
    /// a temporary directory, as a drone team would make them with openssl.
    struct Pki {
        dir: tempfile::TempDir,
        ca_key: rcgen::KeyPair,
        ca_params: rcgen::CertificateParams,
    }

    impl Pki {
        fn new(name: &str) -> Pki {
            let dir = tempfile::tempdir().unwrap();
            let ca_key = rcgen::KeyPair::generate().unwrap();
            let mut ca_params = rcgen::CertificateParams::new(Vec::<String>::new()).unwrap();
            ca_params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
            ca_params
                .distinguished_name
                .push(rcgen::DnType::CommonName, name);
            let ca = ca_params.self_signed(&ca_key).unwrap();
            std::fs::write(dir.path().join("ca.pem"), ca.pem()).unwrap();
            Pki {
                dir,
                ca_key,
                ca_params,
            }
        }

        fn ca(&self) -> PathBuf {
            self.dir.path().join("ca.pem")
        }

        /// A certificate and key for `peer`, valid for loopback, trusting
        /// `trusted`'s CA.
        fn peer(&self, peer: &str, trusted: &Pki) -> TlsFiles {
            let key = rcgen::KeyPair::generate().unwrap();
            let mut params =
                rcgen::CertificateParams::new(vec!["127.0.0.1".to_string(), "localhost".into()])
                    .unwrap();
            params
                .distinguished_name
                .push(rcgen::DnType::CommonName, peer);
            params.extended_key_usages = vec![
                rcgen::ExtendedKeyUsagePurpose::ServerAuth,
                rcgen::ExtendedKeyUsagePurpose::ClientAuth,
            ];
            let issuer = rcgen::Issuer::from_params(&self.ca_params, &self.ca_key);
            let cert = params.signed_by(&key, &issuer).unwrap();
            let certificate = self.dir.path().join(format!("{peer}.pem"));
            let key_path = self.dir.path().join(format!("{peer}.key"));
            std::fs::write(&certificate, cert.pem()).unwrap();
            std::fs::write(&key_path, key.serialize_pem()).unwrap();
            TlsFiles {
                ca: trusted.ca(),
                certificate,
                key: key_path,
                verify_name: true,
            }
        }
    }

    fn tls(port: u16) -> String {
        format!("tls/127.0.0.1:{port}")
    }

    fn token(mission: &str, from: &str) -> Frame {
        Frame::Token(BridgeMessage {
            mission: mission.into(),
            from: from.into(),
            bridge: "b".into(),
            colour: vec![],
            seq: 1,
        })
    }

    #[test]
    fn certificates_make_every_link_mutual_tls_and_nothing_else() {
        let pki = Pki::new("fleet CA");
        let files = pki.peer("D1", &pki);
        let c = config(&ZenohOptions {
            mode: Default::default(),
            listen: vec![tls(7447)],
            connect: vec![tls(7448)],
            scouting: false,
            tls: Some(files.clone()),
        })
        .unwrap();
        let get = |k: &str| c.get_json(k).unwrap();
        assert_eq!(get("transport/link/tls/enable_mtls"), "true");
        assert_eq!(get("transport/link/tls/verify_name_on_connect"), "true");
        assert_eq!(
            get("transport/link/tls/root_ca_certificate"),
            json(&pki.ca().to_string_lossy())
        );
        for side in ["listen", "connect"] {
            assert_eq!(
                get(&format!("transport/link/tls/{side}_certificate")),
                json(&files.certificate.to_string_lossy())
            );
            assert_eq!(
                get(&format!("transport/link/tls/{side}_private_key")),
                json(&files.key.to_string_lossy())
            );
        }
        assert_eq!(get("transport/link/protocols"), r#"["tls"]"#);
    }

    #[test]
    fn a_plain_tcp_endpoint_beside_certificates_is_refused() {
        let pki = Pki::new("fleet CA");
        let e = config(&ZenohOptions {
            mode: Default::default(),
            listen: vec![tls(7447)],
            connect: vec![tcp(7448)],
            scouting: false,
            tls: Some(pki.peer("D1", &pki)),
        })
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("tcp/127.0.0.1:7448") && e.contains("tls/"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_key_file_is_named_in_the_error() {
        let pki = Pki::new("fleet CA");
        let mut files = pki.peer("D1", &pki);
        files.key = pki.dir.path().join("nowhere/D1.key");
        let e = config(&ZenohOptions {
            listen: vec![tls(7447)],
            tls: Some(files),
            ..ZenohOptions::default()
        })
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("private key") && e.contains("nowhere/D1.key"),
            "{e}"
        );
    }

    #[test]
    fn a_key_given_as_the_certificate_is_named_in_the_error() {
        let pki = Pki::new("fleet CA");
        let mut files = pki.peer("D1", &pki);
        files.certificate = files.key.clone();
        let e = config(&ZenohOptions {
            listen: vec![tls(7447)],
            tls: Some(files.clone()),
            ..ZenohOptions::default()
        })
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("certificate") && e.contains(files.key.to_str().unwrap()),
            "{e}"
        );
    }

    async fn tls_peer(
        mission: &str,
        me: &str,
        listen: u16,
        connect: &[u16],
        files: TlsFiles,
    ) -> Endpoint {
        open(
            mission,
            me,
            &[],
            &ZenohOptions {
                mode: Default::default(),
                listen: vec![tls(listen)],
                connect: connect.iter().map(|p| tls(*p)).collect(),
                scouting: false,
                tls: Some(files),
            },
        )
        .await
        .unwrap()
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn peers_of_one_ca_meet_over_mutual_tls_and_a_peer_of_another_ca_never_joins() {
        let fleet = Pki::new("fleet CA");
        let intruder = Pki::new("another CA");
        let (pa, pb, pc) = (free_port(), free_port(), free_port());
        let mission = "TlsTest-1";
        // C trusts the fleet's CA (its certificate is public) but holds a
        // certificate of its own CA.
        let a = tls_peer(mission, "D1", pa, &[pb, pc], fleet.peer("D1", &fleet)).await;
        let b = tls_peer(mission, "D2", pb, &[pa, pc], fleet.peer("D2", &fleet)).await;
        let mut c = tls_peer(mission, "D3", pc, &[pa, pb], intruder.peer("D3", &fleet)).await;

        a.link
            .wait_for_peers(&["D2".into()], Duration::from_secs(20))
            .await
            .expect("two peers of the fleet's CA meet");
        let b_link = b.link.clone();
        let (ta, _) = Bridges::start(
            mission,
            a.link.clone(),
            a.frames,
            RetransmitPolicy::default(),
        );
        let (_tb, mut rb) = Bridges::start(mission, b.link, b.frames, RetransmitPolicy::default());
        ta.send("D2", "b1", vec![4]);
        let got = rb.recv().await.unwrap();
        assert_eq!((got.bridge.as_str(), got.colour), ("b1", vec![4]));

        let missing = a
            .link
            .wait_for_peers(&["D3".into()], Duration::from_secs(3))
            .await;
        assert!(
            matches!(&missing, Err(TransportError::PeersMissing { missing, .. }) if missing == &["D3".to_string()]),
            "{missing:?}"
        );
        assert!(b_link
            .wait_for_peers(&["D3".into()], Duration::from_secs(1))
            .await
            .is_err());
        assert!(c
            .link
            .wait_for_peers(&["D1".into()], Duration::from_secs(1))
            .await
            .is_err());
        // Nothing crosses either way.
        c.link.send("D1", &token(mission, "D3")).await.unwrap();
        a.link.send("D3", &token(mission, "D1")).await.unwrap();
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert!(c.frames.try_recv().is_err());
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_peer_without_a_certificate_cannot_join() {
        let fleet = Pki::new("fleet CA");
        let (pa, pb) = (free_port(), free_port());
        let mission = "TlsTest-2";
        let a = tls_peer(mission, "D1", pa, &[pb], fleet.peer("D1", &fleet)).await;
        // A zenoh peer that trusts the fleet's CA and connects over TLS,
        // but has no certificate to show (so it cannot listen on TLS
        // either: D1's attempts to reach it find nobody).
        let mut c = config(&ZenohOptions {
            connect: vec![tls(pa)],
            ..ZenohOptions::default()
        })
        .unwrap();
        let ca = json(&fleet.ca().to_string_lossy());
        c.insert_json5("transport/link/tls/root_ca_certificate", &ca)
            .unwrap();
        let stranger = zenoh::open(c).await.unwrap();
        let _alive = stranger
            .liveliness()
            .declare_token(key(mission, "D2", "alive"))
            .await
            .unwrap();
        let missing = a
            .link
            .wait_for_peers(&["D2".into()], Duration::from_secs(3))
            .await;
        assert!(missing.is_err(), "a peer without a certificate joined");
        stranger
            .put(key(mission, "D1", "bridge"), token(mission, "D2").encode())
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(300)).await;
        let mut frames = a.frames;
        assert!(frames.try_recv().is_err());
    }
}
