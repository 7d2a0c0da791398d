//! A peer's side of what an observer hears (`eamos monitor`): its events
//! (markings, actions, tokens, peers lost) published on the mission's
//! network as mission log lines, so that a monitor that is no peer shows
//! what each drone does, not only where it is.
//!
//! Architecture Invariant: publishing never holds up the executor. The
//! sink hands each event to a bounded queue and returns; a task publishes
//! them. When the network lags the queue fills and events are dropped, an
//! observer's view goes stale until the next marking, and the mission
//! flies on. Telemetry is not repeated here (it has its own key), nor the
//! roll-out's events (an agent's own business).

use std::sync::Arc;

use tokio::sync::mpsc;

use super::Link;
use crate::event::{Event, Kind, Sink};

/// How many events wait for the network before new ones are dropped.
const QUEUE: usize = 1024;

/// The sink half: cheap, never blocks.
pub struct Published {
    tx: mpsc::Sender<Event>,
}

/// The events waiting to be published; hand them to [`drain`] once the
/// peer's link is open.
pub struct Outbox {
    rx: mpsc::Receiver<Event>,
}

/// A sink for the peer's events and the queue it fills. The sink exists
/// before the link does (the adapters are built first, with the sink).
pub fn outbox() -> (Arc<Published>, Outbox) {
    let (tx, rx) = mpsc::channel(QUEUE);
    (Arc::new(Published { tx }), Outbox { rx })
}

impl Sink for Published {
    fn event(&self, e: &Event) {
        if matches!(e.kind, Kind::Telemetry { .. }) || e.kind.is_rollout() {
            return;
        }
        let _ = self.tx.try_send(e.clone());
    }
}

/// Which of a peer's latest events an observer that joins late is handed
/// (see [`Link::publish_event`]): what the page shows as the peer's state
/// rather than its history.
pub(crate) fn slot(kind: &Kind) -> Option<&'static str> {
    match kind {
        Kind::Marking { .. } => Some("marking"),
        Kind::ActionStarted { .. } | Kind::ActionResumed { .. } => Some("action"),
        Kind::ActionFinished { .. } | Kind::ActionCancelled { .. } => Some("action_end"),
        Kind::Stuck { .. } => Some("stuck"),
        Kind::Stopped { .. } => Some("stopped"),
        _ => None,
    }
}

/// Publishes the queued events on `link` until every sink is dropped.
pub async fn drain(mut outbox: Outbox, link: Arc<dyn Link>) {
    while let Some(e) = outbox.rx.recv().await {
        let Some(line) = crate::log::line_of(&e) else {
            continue;
        };
        if let Err(err) = link.publish_event(line.into_bytes(), slot(&e.kind)).await {
            tracing::debug!("{}: event not published: {err}", e.drone);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::inproc::InProcessHub;
    use std::sync::Mutex;

    /// A link that keeps what it is asked to publish.
    struct Kept(Mutex<Vec<String>>, Arc<dyn Link>);

    #[async_trait::async_trait]
    impl Link for Kept {
        fn me(&self) -> &str {
            self.1.me()
        }
        async fn send(
            &self,
            to: &str,
            frame: &crate::transport::Frame,
        ) -> Result<(), crate::transport::TransportError> {
            self.1.send(to, frame).await
        }
        async fn publish_telemetry(
            &self,
            sample: &crate::transport::TelemetryFrame,
        ) -> Result<(), crate::transport::TransportError> {
            self.1.publish_telemetry(sample).await
        }
        async fn wait_for_peers(
            &self,
            peers: &[crate::transport::PeerId],
            timeout: std::time::Duration,
        ) -> Result<(), crate::transport::TransportError> {
            self.1.wait_for_peers(peers, timeout).await
        }
        async fn publish_event(
            &self,
            line: Vec<u8>,
            _state: Option<&'static str>,
        ) -> Result<(), crate::transport::TransportError> {
            self.0
                .lock()
                .unwrap()
                .push(String::from_utf8(line).unwrap());
            Ok(())
        }
    }

    fn at(time: f64, kind: Kind) -> Event {
        Event {
            time,
            drone: "D1".into(),
            kind,
        }
    }

    #[tokio::test]
    async fn a_peers_events_are_published_as_log_lines_telemetry_aside() {
        let hub = InProcessHub::new();
        let inner = hub.connect("D1", &[]).link;
        let kept = Arc::new(Kept(Mutex::default(), inner));
        let (sink, queue) = outbox();
        let marking = at(
            1.0,
            Kind::Marking {
                marked: vec!["p1".into()],
            },
        );
        sink.event(&marking);
        sink.event(&at(
            1.5,
            Kind::Telemetry {
                position: eamos_mid::Vec3::new(1.0, 2.0, 3.0),
                altitude: 3.0,
                battery: 99.0,
            },
        ));
        let lost = at(2.0, Kind::PeerLost { peer: "D2".into() });
        sink.event(&lost);
        drop(sink);
        drain(queue, kept.clone()).await;
        let lines = kept.0.lock().unwrap().clone();
        let events: Vec<Event> = lines
            .iter()
            .map(|l| crate::log::event_of(l).unwrap())
            .collect();
        assert_eq!(events, vec![marking, lost]);
        assert!(lines[0].starts_with(r#"{"v":1,"#), "{}", lines[0]);
    }

    #[tokio::test]
    async fn a_full_queue_drops_events_rather_than_wait() {
        let (sink, _never_drained) = outbox();
        for i in 0..(4 * QUEUE) {
            sink.event(&at(i as f64, Kind::PeerLost { peer: "D2".into() }));
        }
    }
}
