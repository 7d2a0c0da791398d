//! A read-only observer of a mission's zenoh network (`eamos monitor`):
//! it hears every drone's telemetry, every peer's own events (markings,
//! actions, tokens, what it saw lost: [`super::publish`]) and every peer's
//! liveliness token, and says what it heard as the executor's own events
//! into a sink.
//!
//! Architecture Invariant: the peers never depend on an observer. It
//! declares no liveliness token (nobody waits for it, no drone counts it
//! among the peers it must see before it is ready), listens on no endpoint,
//! publishes nothing and only connects to the peers' endpoints.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

use eamos_mid::Telemetry;
use zenoh::sample::SampleKind;
use zenoh::Session;

use super::zenoh::{alive_peer, config, ZenohOptions};
use super::{TelemetryFrame, TransportError};
use crate::event::{Event, Kind, Sink};

/// The name the observer's own events bear (`drone`): it is no peer.
pub const OBSERVER: &str = "monitor";

/// An open observer; it hears until dropped or closed.
pub struct Observer {
    session: Session,
    _subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    _liveliness: zenoh::pubsub::Subscriber<()>,
}

impl Observer {
    pub async fn close(self) {
        let _ = self.session.close().await;
    }
}

/// Joins `mission`'s network with `options` (its listen endpoints are
/// ignored: an observer only connects) and hands what it hears to `sink`.
pub async fn observe(
    mission: &str,
    options: &ZenohOptions,
    sink: Arc<dyn Sink>,
) -> Result<Observer, TransportError> {
    let mut options = options.clone();
    options.listen.clear();
    let session = zenoh::open(config(&options)?)
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    let last_time = Arc::new(Mutex::new(0.0f64));
    let mission_owned = mission.to_string();
    let telemetry = {
        let (sink, last_time) = (sink.clone(), last_time.clone());
        session
            .declare_subscriber(format!("eamos/{mission}/*/telemetry"))
            .callback(move |sample| {
                let Ok(frame) = TelemetryFrame::decode(&sample.payload().to_bytes()) else {
                    return;
                };
                let Ok(t) = postcard::from_bytes::<Telemetry>(&frame.body) else {
                    return;
                };
                *last_time.lock().unwrap_or_else(|p| p.into_inner()) = t.time;
                sink.event(&Event {
                    time: t.time,
                    drone: frame.drone,
                    kind: Kind::Telemetry {
                        position: t.fleet_position(),
                        altitude: t.position.z,
                        battery: t.battery,
                    },
                });
            })
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?
    };
    // The latest mission time heard of each peer's state slot: a peer's
    // state, asked for when it is first seen, is not shown where its
    // events went further.
    let heard: Arc<Mutex<Heard>> = Arc::default();
    let events = {
        let (sink, last_time, heard) = (sink.clone(), last_time.clone(), heard.clone());
        session
            .declare_subscriber(format!("eamos/{mission}/*/events"))
            .callback(move |sample| {
                let Some(e) = event_in(&sample) else {
                    return;
                };
                {
                    let mut last = last_time.lock().unwrap_or_else(|p| p.into_inner());
                    *last = last.max(e.time);
                }
                if let Some(slot) = super::publish::slot(&e.kind) {
                    let mut heard = heard.lock().unwrap_or_else(|p| p.into_inner());
                    let t = heard.entry((e.drone.clone(), slot)).or_insert(e.time);
                    *t = t.max(e.time);
                }
                sink.event(&e);
            })
            .await
            .map_err(|e| TransportError::Open(e.to_string()))?
    };
    // Whether each peer seen so far is up.
    let seen: Arc<Mutex<BTreeMap<String, bool>>> = Arc::default();
    let ask = StateAsker {
        session: session.clone(),
        mission: mission.to_string(),
        runtime: tokio::runtime::Handle::current(),
        sink: sink.clone(),
        heard,
    };
    let liveliness = session
        .liveliness()
        .declare_subscriber(format!("eamos/{mission}/*/alive"))
        .history(true)
        .callback(move |sample| {
            let Some(peer) = alive_peer(&mission_owned, sample.key_expr().as_str()) else {
                return;
            };
            let mut seen = seen.lock().unwrap_or_else(|p| p.into_inner());
            // Lost only once seen up; back only once lost.
            let peer = peer.to_string();
            let up = sample.kind() == SampleKind::Put;
            let before = seen.insert(peer.clone(), up);
            if up && before != Some(true) {
                ask.state_of(&peer);
            }
            let kind = match (before, up) {
                (Some(false), true) => Kind::PeerBack { peer },
                (Some(true), false) => Kind::PeerLost { peer },
                _ => return,
            };
            let time = *last_time.lock().unwrap_or_else(|p| p.into_inner());
            sink.event(&Event {
                time,
                drone: OBSERVER.to_string(),
                kind,
            });
        })
        .await
        .map_err(|e| TransportError::Open(e.to_string()))?;
    Ok(Observer {
        session,
        _subscribers: vec![telemetry, events],
        _liveliness: liveliness,
    })
}

/// The event a peer published (a mission log line, [`super::publish`]);
/// a line of a later version, or garbage, is none.
fn event_in(sample: &zenoh::sample::Sample) -> Option<Event> {
    let bytes = sample.payload().to_bytes();
    crate::log::event_of(std::str::from_utf8(&bytes).ok()?).ok()
}

/// Asks a peer, when it is seen up, for its latest state (marking, action,
/// end: [`super::publish`]), so that a monitor started during a flight, or
/// that joined a peer after its first events, shows where it is.
struct StateAsker {
    session: Session,
    mission: String,
    runtime: tokio::runtime::Handle,
    sink: Arc<dyn Sink>,
    heard: Arc<Mutex<Heard>>,
}

/// The latest mission time heard, by peer and state slot.
type Heard = BTreeMap<(String, &'static str), f64>;

impl StateAsker {
    fn state_of(&self, peer: &str) {
        let at = super::zenoh::key(&self.mission, peer, "state");
        let (session, sink, heard) = (self.session.clone(), self.sink.clone(), self.heard.clone());
        self.runtime.spawn(async move {
            // Every slot is a reply on the same key: none may be
            // consolidated away.
            let asked = session
                .get(at)
                .consolidation(zenoh::query::ConsolidationMode::None);
            let Ok(replies) = asked.await else {
                return;
            };
            let mut kept = Vec::new();
            while let Ok(reply) = replies.recv_async().await {
                let Ok(sample) = reply.result() else {
                    continue;
                };
                kept.extend(event_in(sample));
            }
            kept.sort_by(|a, b| a.time.total_cmp(&b.time));
            for e in kept {
                let newer = super::publish::slot(&e.kind).is_some_and(|slot| {
                    heard
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .get(&(e.drone.clone(), slot))
                        .is_some_and(|&t| t > e.time)
                });
                if !newer {
                    sink.event(&e);
                }
            }
        });
    }
}
