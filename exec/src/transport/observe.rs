//! A read-only observer of a mission's zenoh network (`eamos monitor`):
//! it hears every drone's telemetry and every peer's liveliness token and
//! says what it heard as the executor's own events (telemetry samples,
//! peers lost and back), into a sink.
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
    // Whether each peer seen so far is up.
    let seen: Arc<Mutex<BTreeMap<String, bool>>> = Arc::default();
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
        _subscribers: vec![telemetry],
        _liveliness: liveliness,
    })
}
