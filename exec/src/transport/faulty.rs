//! A link that misbehaves on purpose: it loses, duplicates and delays
//! (hence reorders) a share of the frames it is asked to send, drawn from a
//! seeded random generator so that a failing run can be replayed.
//!
//! Telemetry passes unharmed: it is a latest-value stream that the next
//! sample repairs, while losing a bridge token would lose the mission.
//!
//! A [`Partition`] shared by the links of a fleet cuts peers off the
//! network on demand, as a radio out of range would: nothing the cut peer
//! sends or is sent gets through, its telemetry is lost, and the presence
//! each side sees loses the other (the cut peer sees itself alone). It can
//! also cut the link between two peers only, as when a drone flies out of
//! range of some of the fleet but not of the rest: the two lose each
//! other's frames and presence, and both still hear everyone else.

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_trait::async_trait;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tokio::sync::watch;

use super::{Frame, Link, PeerId, TelemetryFrame, TransportError};

/// How badly the link behaves; each a probability per frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Faults {
    pub drop: f64,
    pub duplicate: f64,
    /// Delay the frame by up to `max_delay`, letting later ones overtake it.
    pub reorder: f64,
    pub max_delay: Duration,
    pub seed: u64,
}

impl Default for Faults {
    fn default() -> Self {
        Faults {
            drop: 0.0,
            duplicate: 0.0,
            reorder: 0.0,
            max_delay: Duration::from_millis(30),
            seed: 0,
        }
    }
}

/// What the faulty link did, for tests to check that faults really happened.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultCounts {
    pub sent: u64,
    pub dropped: u64,
    pub duplicated: u64,
    pub delayed: u64,
}

pub struct FaultyLink {
    inner: Arc<dyn Link>,
    faults: Faults,
    rng: Mutex<ChaCha8Rng>,
    counts: Arc<Mutex<FaultCounts>>,
    partition: Option<Partition>,
}

/// Which peers are cut off the network, and which pairs of peers from
/// each other; shared by every link of a fleet.
#[derive(Clone)]
pub struct Partition {
    cut: Arc<watch::Sender<Cuts>>,
}

#[derive(Default)]
struct Cuts {
    /// Peers that reach nobody.
    peers: BTreeSet<PeerId>,
    /// Pairs that do not reach each other, the smaller name first.
    pairs: BTreeSet<(PeerId, PeerId)>,
}

fn pair(a: &str, b: &str) -> (PeerId, PeerId) {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    (a.to_string(), b.to_string())
}

impl Default for Partition {
    fn default() -> Self {
        Partition {
            cut: Arc::new(watch::channel(Cuts::default()).0),
        }
    }
}

impl Partition {
    pub fn new() -> Self {
        Self::default()
    }

    /// Cuts `peer` off: from now on it reaches nobody and nobody reaches it.
    pub fn cut(&self, peer: &str) {
        self.cut.send_modify(|c| {
            c.peers.insert(peer.to_string());
        });
    }

    /// Puts `peer` back on the network (a cut between it and another
    /// peer stays).
    pub fn heal(&self, peer: &str) {
        self.cut.send_modify(|c| {
            c.peers.remove(peer);
        });
    }

    /// Cuts `a` and `b` off from each other only: each still reaches, and
    /// is reached by, every other peer. Telemetry and events, which a peer
    /// publishes to all at once, still pass between them; frames and
    /// presence do not.
    pub fn cut_between(&self, a: &str, b: &str) {
        self.cut.send_modify(|c| {
            c.pairs.insert(pair(a, b));
        });
    }

    /// Whether `a` and `b` cannot hear each other.
    pub fn separates(&self, a: &str, b: &str) -> bool {
        let cut = self.cut.borrow();
        a != b
            && (cut.peers.contains(a) || cut.peers.contains(b) || cut.pairs.contains(&pair(a, b)))
    }

    /// Whether `peer` reaches nobody.
    fn isolates(&self, peer: &str) -> bool {
        self.cut.borrow().peers.contains(peer)
    }

    /// What `me` sees of `up` through the partition.
    fn visible(&self, me: &str, up: &BTreeSet<PeerId>) -> BTreeSet<PeerId> {
        up.iter()
            .filter(|p| !self.separates(me, p))
            .cloned()
            .collect()
    }
}

impl FaultyLink {
    pub fn new(inner: Arc<dyn Link>, faults: Faults) -> Self {
        FaultyLink {
            inner,
            faults,
            rng: Mutex::new(ChaCha8Rng::seed_from_u64(faults.seed)),
            counts: Arc::default(),
            partition: None,
        }
    }

    /// The same link, subject to `partition` as well.
    pub fn with_partition(mut self, partition: Partition) -> Self {
        self.partition = Some(partition);
        self
    }

    fn cut_from(&self, to: &str) -> bool {
        self.partition
            .as_ref()
            .is_some_and(|p| p.separates(self.inner.me(), to))
    }

    /// A handle on the counts that stays valid after the link moves.
    pub fn counts(&self) -> Arc<Mutex<FaultCounts>> {
        self.counts.clone()
    }
}

enum Fate {
    Drop,
    Send { copies: u8, delay: Option<Duration> },
}

impl FaultyLink {
    fn fate(&self) -> Fate {
        let mut rng = self.rng.lock().expect("rng lock");
        let mut counts = self.counts.lock().expect("counts lock");
        counts.sent += 1;
        if rng.random_bool(self.faults.drop.clamp(0.0, 1.0)) {
            counts.dropped += 1;
            return Fate::Drop;
        }
        let copies = if rng.random_bool(self.faults.duplicate.clamp(0.0, 1.0)) {
            counts.duplicated += 1;
            2
        } else {
            1
        };
        let delay = if rng.random_bool(self.faults.reorder.clamp(0.0, 1.0)) {
            counts.delayed += 1;
            let max = self.faults.max_delay.as_micros().max(1) as u64;
            Some(Duration::from_micros(rng.random_range(0..max)))
        } else {
            None
        };
        Fate::Send { copies, delay }
    }
}

#[async_trait]
impl Link for FaultyLink {
    fn me(&self) -> &str {
        self.inner.me()
    }

    async fn send(&self, to: &str, frame: &Frame) -> Result<(), TransportError> {
        if self.cut_from(to) {
            self.counts.lock().expect("counts lock").dropped += 1;
            return Ok(());
        }
        match self.fate() {
            Fate::Drop => Ok(()),
            Fate::Send {
                copies,
                delay: None,
            } => {
                for _ in 0..copies {
                    self.inner.send(to, frame).await?;
                }
                Ok(())
            }
            Fate::Send {
                copies,
                delay: Some(d),
            } => {
                let inner = self.inner.clone();
                let to = to.to_string();
                let frame = frame.clone();
                tokio::spawn(async move {
                    tokio::time::sleep(d).await;
                    for _ in 0..copies {
                        let _ = inner.send(&to, &frame).await;
                    }
                });
                Ok(())
            }
        }
    }

    async fn publish_telemetry(&self, sample: &TelemetryFrame) -> Result<(), TransportError> {
        let me = self.inner.me();
        if self.partition.as_ref().is_some_and(|p| p.isolates(me)) {
            return Ok(());
        }
        self.inner.publish_telemetry(sample).await
    }

    async fn publish_event(
        &self,
        line: Vec<u8>,
        state: Option<&'static str>,
    ) -> Result<(), TransportError> {
        let me = self.inner.me();
        if self.partition.as_ref().is_some_and(|p| p.isolates(me)) {
            return Ok(());
        }
        self.inner.publish_event(line, state).await
    }

    async fn wait_for_peers(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        self.inner.wait_for_peers(peers, timeout).await
    }

    async fn announce_ready(&self, neighbours: &[PeerId]) -> Result<(), TransportError> {
        self.inner.announce_ready(neighbours).await
    }

    async fn wait_for_ready(
        &self,
        peers: &[PeerId],
        timeout: Duration,
    ) -> Result<(), TransportError> {
        self.inner.wait_for_ready(peers, timeout).await
    }

    /// The inner link's presence as seen through the partition, kept up to
    /// date as either changes.
    fn presence(&self) -> Option<watch::Receiver<BTreeSet<PeerId>>> {
        let mut inner = self.inner.presence()?;
        let Some(partition) = self.partition.clone() else {
            return Some(inner);
        };
        let me = self.inner.me().to_string();
        let mut cut = partition.cut.subscribe();
        let (tx, rx) = watch::channel(partition.visible(&me, &inner.borrow_and_update()));
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    r = inner.changed() => if r.is_err() { return },
                    r = cut.changed() => if r.is_err() { return },
                    _ = tx.closed() => return,
                }
                let now = partition.visible(&me, &inner.borrow_and_update());
                cut.borrow_and_update();
                tx.send_if_modified(|v| {
                    let changed = *v != now;
                    *v = now;
                    changed
                });
            }
        });
        Some(rx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::inproc::InProcessHub;
    use crate::transport::BridgeMessage;

    fn token(seq: u64) -> Frame {
        Frame::Token(BridgeMessage {
            mission: "M".into(),
            from: "D1".into(),
            bridge: "b".into(),
            colour: vec![],
            seq,
        })
    }

    async fn received_after(faults: Faults, n: u64) -> (Vec<u64>, FaultCounts) {
        let hub = InProcessHub::new();
        let a = hub.connect("D1", &[]);
        let mut b = hub.connect("D2", &[]);
        let link = FaultyLink::new(a.link, faults);
        for i in 0..n {
            link.send("D2", &token(i)).await.unwrap();
        }
        tokio::time::sleep(faults.max_delay * 2).await;
        let mut seqs = Vec::new();
        while let Ok(Frame::Token(m)) = b.frames.try_recv() {
            seqs.push(m.seq);
        }
        let counts = *link.counts().lock().unwrap();
        (seqs, counts)
    }

    #[tokio::test]
    async fn a_faulty_link_loses_and_duplicates_about_the_share_it_is_told() {
        let faults = Faults {
            drop: 0.3,
            duplicate: 0.2,
            seed: 7,
            ..Faults::default()
        };
        let (seqs, counts) = received_after(faults, 1000).await;
        assert!((200..400).contains(&counts.dropped), "{counts:?}");
        assert!((100..250).contains(&counts.duplicated), "{counts:?}");
        assert_eq!(seqs.len() as u64, 1000 - counts.dropped + counts.duplicated);
    }

    #[tokio::test]
    async fn the_same_seed_makes_the_same_faults() {
        let faults = Faults {
            drop: 0.5,
            seed: 42,
            ..Faults::default()
        };
        let (a, _) = received_after(faults, 200).await;
        let (b, _) = received_after(faults, 200).await;
        assert_eq!(a, b);
    }

    /// `endpoint`'s link behind `partition`, and its frames.
    fn behind(
        partition: &Partition,
        endpoint: crate::transport::Endpoint,
    ) -> (Arc<dyn Link>, tokio::sync::mpsc::UnboundedReceiver<Frame>) {
        let link = FaultyLink::new(endpoint.link, Faults::default());
        (
            Arc::new(link.with_partition(partition.clone())),
            endpoint.frames,
        )
    }

    #[tokio::test]
    async fn a_cut_peer_reaches_nobody_is_reached_by_nobody_and_sees_itself_alone() {
        let hub = InProcessHub::new();
        let partition = Partition::new();
        let wrap = |e| behind(&partition, e);
        let (a, mut a_frames) = wrap(hub.connect("D1", &[]));
        let (b, mut b_frames) = wrap(hub.connect("D2", &[]));
        let (_c, _) = wrap(hub.connect("D3", &[]));
        let mut a_sees = a.presence().unwrap();
        let mut b_sees = b.presence().unwrap();
        assert_eq!(a_sees.borrow_and_update().len(), 3);

        partition.cut("D2");
        a.send("D2", &token(1)).await.unwrap();
        b.send("D1", &token(2)).await.unwrap();
        a_sees.changed().await.unwrap();
        assert!(!a_sees.borrow().contains("D2"));
        b_sees.changed().await.unwrap();
        let alone: Vec<PeerId> = b_sees.borrow().iter().cloned().collect();
        assert_eq!(alone, vec!["D2".to_string()]);
        assert!(a_frames.try_recv().is_err() && b_frames.try_recv().is_err());

        partition.heal("D2");
        a_sees.changed().await.unwrap();
        assert!(a_sees.borrow().contains("D2"));
        a.send("D2", &token(3)).await.unwrap();
        assert_eq!(b_frames.recv().await.unwrap(), token(3));
    }

    #[tokio::test]
    async fn a_cut_between_two_peers_parts_them_and_leaves_both_with_the_rest() {
        let hub = InProcessHub::new();
        let partition = Partition::new();
        let wrap = |e| behind(&partition, e);
        let (a, _a_frames) = wrap(hub.connect("D1", &[]));
        let (b, mut b_frames) = wrap(hub.connect("D2", &[]));
        let (c, mut c_frames) = wrap(hub.connect("D3", &[]));
        let mut a_sees = a.presence().unwrap();
        let mut c_sees = c.presence().unwrap();
        assert_eq!(a_sees.borrow_and_update().len(), 3);

        partition.cut_between("D2", "D1");
        tokio::time::timeout(Duration::from_secs(5), a_sees.changed())
            .await
            .expect("D1 sees D2 go")
            .unwrap();
        let a_now: Vec<PeerId> = a_sees.borrow().iter().cloned().collect();
        assert_eq!(a_now, vec!["D1".to_string(), "D3".to_string()]);
        assert_eq!(c_sees.borrow_and_update().len(), 3, "D3 still sees both");
        a.send("D2", &token(1)).await.unwrap();
        a.send("D3", &token(2)).await.unwrap();
        b.send("D3", &token(3)).await.unwrap();
        assert_eq!(c_frames.recv().await.unwrap(), token(2));
        assert_eq!(c_frames.recv().await.unwrap(), token(3));
        assert!(b_frames.try_recv().is_err(), "D1's frame to D2 was lost");
    }

    #[tokio::test]
    async fn a_delayed_frame_can_be_overtaken() {
        let faults = Faults {
            reorder: 0.5,
            max_delay: Duration::from_millis(20),
            seed: 3,
            ..Faults::default()
        };
        let (seqs, counts) = received_after(faults, 100).await;
        assert_eq!(seqs.len(), 100);
        assert!(counts.delayed > 0);
        let mut sorted = seqs.clone();
        sorted.sort();
        assert_ne!(seqs, sorted, "some frame should arrive out of order");
    }
}
