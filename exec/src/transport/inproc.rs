//! The in-process link: every peer of the fleet in one process, frames over
//! tokio channels. It never loses a frame by itself; wrap it in
//! [`super::faulty::FaultyLink`] to test what the network would do.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_trait::async_trait;
use tokio::sync::{mpsc, watch, Notify};

use super::{Endpoint, Frame, Link, PeerId, TelemetryFrame, TransportError};

/// The switchboard every in-process peer connects to.
#[derive(Clone, Default)]
pub struct InProcessHub {
    inner: Arc<HubInner>,
}

struct HubInner {
    state: Mutex<HubState>,
    joined: Notify,
    /// Who is connected: the in-process stand-in for zenoh liveliness.
    presence: watch::Sender<BTreeSet<PeerId>>,
}

impl Default for HubInner {
    fn default() -> Self {
        HubInner {
            state: Mutex::default(),
            joined: Notify::new(),
            presence: watch::channel(BTreeSet::new()).0,
        }
    }
}

#[derive(Default)]
struct HubState {
    peers: HashMap<PeerId, mpsc::UnboundedSender<Frame>>,
    /// Subscribers of each drone's telemetry.
    telemetry: HashMap<PeerId, Vec<mpsc::UnboundedSender<TelemetryFrame>>>,
}

impl InProcessHub {
    pub fn new() -> Self {
        Self::default()
    }

    /// Joins the hub as `me`, subscribed to the telemetry of `reads`.
    /// Joining twice under one name replaces the first end (a restarted
    /// peer), as a network would.
    pub fn connect(&self, me: &str, reads: &[PeerId]) -> Endpoint {
        let (frames_tx, frames) = mpsc::unbounded_channel();
        let (telemetry_tx, telemetry) = mpsc::unbounded_channel();
        {
            let mut state = self.inner.state.lock().expect("hub lock");
            state.peers.insert(me.to_string(), frames_tx);
            for d in reads {
                state
                    .telemetry
                    .entry(d.clone())
                    .or_default()
                    .push(telemetry_tx.clone());
            }
        }
        self.inner.presence.send_modify(|p| {
            p.insert(me.to_string());
        });
        self.inner.joined.notify_waiters();
        Endpoint {
            link: Arc::new(InProcessLink {
                me: me.to_string(),
                hub: self.inner.clone(),
            }),
            frames,
            telemetry,
        }
    }
}

impl InProcessHub {
    /// Takes `peer` off the hub, as if its process had died: frames to it
    /// are lost and the others see it gone. It may [`connect`] again.
    ///
    /// [`connect`]: InProcessHub::connect
    pub fn leave(&self, peer: &str) {
        {
            let mut state = self.inner.state.lock().expect("hub lock");
            state.peers.remove(peer);
        }
        self.inner.presence.send_modify(|p| {
            p.remove(peer);
        });
    }
}

struct InProcessLink {
    me: PeerId,
    hub: Arc<HubInner>,
}

#[async_trait]
impl Link for InProcessLink {
    fn me(&self) -> &str {
        &self.me
    }

    async fn send(&self, to: &str, frame: &Frame) -> Result<(), TransportError> {
        let state = self.hub.state.lock().expect("hub lock");
        if let Some(tx) = state.peers.get(to) {
            // A peer that has gone away loses the frame, like on a network.
            let _ = tx.send(frame.clone());
        }
        Ok(())
    }

    async fn publish_telemetry(&self, sample: &TelemetryFrame) -> Result<(), TransportError> {
        let state = self.hub.state.lock().expect("hub lock");
        if let Some(subs) = state.telemetry.get(&sample.drone) {
            for s in subs {
                let _ = s.send(sample.clone());
            }
        }
        Ok(())
    }

    async fn wait_for_peers(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            let joined = self.hub.joined.notified();
            let missing: Vec<PeerId> = {
                let state = self.hub.state.lock().expect("hub lock");
                peers
                    .iter()
                    .filter(|p| !state.peers.contains_key(*p))
                    .cloned()
                    .collect()
            };
            if missing.is_empty() {
                return Ok(());
            }
            if tokio::time::timeout_at(deadline, joined).await.is_err() {
                return Err(TransportError::PeersMissing {
                    missing,
                    waited: timeout,
                });
            }
        }
    }

    fn presence(&self) -> Option<watch::Receiver<BTreeSet<PeerId>>> {
        Some(self.hub.presence.subscribe())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::{Ack, BridgeMessage};

    fn token(seq: u64) -> Frame {
        Frame::Token(BridgeMessage {
            mission: "M".into(),
            from: "D1".into(),
            bridge: "b0".into(),
            colour: vec![],
            seq,
        })
    }

    #[tokio::test]
    async fn a_frame_reaches_the_peer_it_is_addressed_to_and_no_other() {
        let hub = InProcessHub::new();
        let a = hub.connect("D1", &[]);
        let mut b = hub.connect("D2", &[]);
        let mut c = hub.connect("D3", &[]);
        a.link.send("D2", &token(1)).await.unwrap();
        assert_eq!(b.frames.recv().await.unwrap(), token(1));
        assert!(c.frames.try_recv().is_err());
    }

    #[tokio::test]
    async fn a_frame_to_a_peer_not_yet_joined_is_lost_quietly() {
        let hub = InProcessHub::new();
        let a = hub.connect("D1", &[]);
        a.link
            .send(
                "D9",
                &Frame::Ack(Ack {
                    mission: "M".into(),
                    from: "D1".into(),
                    bridge: "b".into(),
                    colour: vec![],
                    seq: 0,
                }),
            )
            .await
            .unwrap();
    }

    #[tokio::test]
    async fn telemetry_goes_only_to_peers_that_read_that_drone() {
        let hub = InProcessHub::new();
        let d3 = hub.connect("D3", &[]);
        let mut d1 = hub.connect("D1", &["D3".into()]);
        let mut d2 = hub.connect("D2", &[]);
        let sample = TelemetryFrame {
            mission: "M".into(),
            drone: "D3".into(),
            seq: 1,
            body: vec![1, 2],
        };
        d3.link.publish_telemetry(&sample).await.unwrap();
        assert_eq!(d1.telemetry.recv().await.unwrap(), sample);
        assert!(d2.telemetry.try_recv().is_err());
    }

    #[tokio::test]
    async fn waiting_for_peers_ends_when_the_last_one_joins() {
        let hub = InProcessHub::new();
        let gcs = hub.connect("GCS", &[]);
        let h2 = hub.clone();
        let late = tokio::spawn(async move {
            tokio::task::yield_now().await;
            h2.connect("D1", &[])
        });
        gcs.link
            .wait_for_peers(&["D1".into()], Duration::from_secs(30))
            .await
            .unwrap();
        late.await.unwrap();
    }

    #[tokio::test]
    async fn a_peer_that_leaves_the_hub_disappears_from_everyones_presence() {
        let hub = InProcessHub::new();
        let a = hub.connect("D1", &[]);
        let _b = hub.connect("D2", &[]);
        let mut presence = a.link.presence().expect("the hub tells who is up");
        assert_eq!(presence.borrow_and_update().len(), 2);
        hub.leave("D2");
        presence.changed().await.unwrap();
        let now: Vec<PeerId> = presence.borrow().iter().cloned().collect();
        assert_eq!(now, vec!["D1".to_string()]);
        let _back = hub.connect("D2", &[]);
        presence.changed().await.unwrap();
        assert!(presence.borrow().contains("D2"));
    }

    #[tokio::test]
    async fn waiting_for_a_peer_that_never_joins_names_it() {
        let hub = InProcessHub::new();
        let gcs = hub.connect("GCS", &[]);
        let err = gcs
            .link
            .wait_for_peers(&["D7".into()], Duration::from_millis(20))
            .await
            .unwrap_err();
        match err {
            TransportError::PeersMissing { missing, .. } => assert_eq!(missing, vec!["D7"]),
            e => panic!("unexpected {e}"),
        }
    }
}
