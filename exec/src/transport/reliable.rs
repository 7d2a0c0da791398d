//! Exactly-once delivery of bridge tokens over a link that may lose,
//! duplicate and reorder frames.
//!
//! A token is identified by its bridge and colour: in a 1-safe net a place
//! holds at most one token of a colour, so one bridge carries a colour at
//! most once in a mission. The sender keeps a token until the receiver has
//! acknowledged that (bridge, colour), retransmitting with exponential
//! backoff; the receiver acknowledges every copy it gets (the first ack may
//! be the one that was lost) and hands each (bridge, colour) to its executor
//! once.
//!
//! The latency of a token is what a mission waits on; its ack only has to
//! come before the sender's first retransmission. So a token leaves from
//! the sender's own call (no hop through the bridges' task), the receiver
//! hands it to its executor before anything else, and acknowledgements wait
//! up to [`RetransmitPolicy::ack_delay`] to leave together, in one frame
//! per peer, off the path of the next token.
//!
//! With a [`Journal`], the bridges survive a crash of their peer: a token is
//! journaled (and flushed to the disk) before it is handed on or
//! acknowledged, every token sent is journaled with its sequence number
//! before it leaves, and acknowledgements are journaled as they come.
//! Restarted from the journal ([`Bridges::start_journaled`]), the bridges
//! still drop copies of tokens consumed before the crash and send again,
//! with their original sequence numbers, the tokens that were never
//! acknowledged.

use std::collections::{HashMap, HashSet};
use std::future::Future;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Waker};
use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch, Notify};
use tokio::time::Instant;

use eamos_petri::net::Colour;

use super::{Ack, BridgeMessage, Frame, Link, PeerId};
use crate::journal::{Journal, Record, Recovered, Sent};

/// When to send a token again that has not been acknowledged, and how long
/// a receiver may hold an acknowledgement back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RetransmitPolicy {
    /// The first retransmission comes this long after the first send.
    pub initial: Duration,
    /// The wait doubles (times `factor`) after every try, up to this.
    pub max: Duration,
    pub factor: f64,
    /// A receiver sends the acknowledgements of the tokens it got within
    /// this long together, at most this late. Well under `initial`, or the
    /// sender retransmits tokens that did arrive.
    pub ack_delay: Duration,
}

impl Default for RetransmitPolicy {
    fn default() -> Self {
        RetransmitPolicy {
            initial: Duration::from_millis(40),
            max: Duration::from_millis(800),
            factor: 2.0,
            ack_delay: Duration::from_millis(1),
        }
    }
}

/// A token handed to the executor: the first copy of its (bridge, colour).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Delivered {
    pub from: PeerId,
    pub bridge: String,
    pub colour: Colour,
    pub seq: u64,
}

/// What the bridges of one peer did, for the run summary and for tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BridgeStats {
    /// Tokens the executor asked to send (each counted once).
    pub sent: u64,
    /// Tokens handed to the executor (each counted once).
    pub received: u64,
    pub retransmissions: u64,
    /// Copies of tokens already delivered, acknowledged and dropped.
    pub duplicates: u64,
    /// Frames of another mission, dropped.
    pub foreign: u64,
    pub acks_sent: u64,
}

/// The tokens sent and not yet acknowledged, shared by [`Bridges::send`]
/// (which adds them) and the bridges' task (which retransmits and retires
/// them).
struct Outbox {
    /// By (receiver, bridge, colour).
    pending: HashMap<(PeerId, String, Colour), Pending>,
    /// When the task wakes next to retransmit (`None`: it does not): a
    /// token due sooner must wake it.
    timer: Option<Instant>,
}

struct Pending {
    /// The token as it goes on the wire.
    frame: Frame,
    due: Instant,
    wait: Duration,
}

/// The sending and receiving side of every bridge of one peer.
///
/// Dropping it stops its task (once it has sent the acknowledgements it
/// holds): keep it alive while peers may still retransmit to this one
/// (their acks may have been lost).
pub struct Bridges {
    mission: String,
    link: Arc<dyn Link>,
    policy: RetransmitPolicy,
    outbox: Arc<Mutex<Outbox>>,
    /// Wakes the task when a token is due before its timer.
    wake: Arc<Notify>,
    next_seq: Mutex<u64>,
    journal: Option<Arc<Journal>>,
    /// Tokens sent and not yet acknowledged; counted up by `send` itself so
    /// that a `flush` right after a `send` cannot miss it.
    unacked: Arc<watch::Sender<usize>>,
    stats: Arc<Mutex<BridgeStats>>,
    /// Dropped with the bridges: stops the task.
    _stop: oneshot::Sender<()>,
}

impl Bridges {
    /// Starts the bridges of `link.me()` for `mission`. Returns the handle to
    /// send with and the stream of delivered tokens.
    pub fn start(
        mission: impl Into<String>,
        link: Arc<dyn Link>,
        frames: mpsc::UnboundedReceiver<Frame>,
        policy: RetransmitPolicy,
    ) -> (Bridges, mpsc::UnboundedReceiver<Delivered>) {
        Self::start_with(mission.into(), link, frames, policy, None, None)
    }

    /// Starts the bridges of a peer that keeps a journal, from what the
    /// journal held (`recovered`; empty for a first run): tokens consumed
    /// before are recognised, tokens not acknowledged are sent again at
    /// once with their original sequence numbers, and new tokens are
    /// numbered after the last one journaled.
    pub fn start_journaled(
        mission: impl Into<String>,
        link: Arc<dyn Link>,
        frames: mpsc::UnboundedReceiver<Frame>,
        policy: RetransmitPolicy,
        journal: Arc<Journal>,
        recovered: &Recovered,
    ) -> (Bridges, mpsc::UnboundedReceiver<Delivered>) {
        Self::start_with(
            mission.into(),
            link,
            frames,
            policy,
            Some(journal),
            Some(recovered),
        )
    }

    fn start_with(
        mission: String,
        link: Arc<dyn Link>,
        frames: mpsc::UnboundedReceiver<Frame>,
        policy: RetransmitPolicy,
        journal: Option<Arc<Journal>>,
        recovered: Option<&Recovered>,
    ) -> (Bridges, mpsc::UnboundedReceiver<Delivered>) {
        let (stop, stopped) = oneshot::channel();
        let (delivered_tx, delivered_rx) = mpsc::unbounded_channel();
        let me = link.me().to_string();
        let mut pending = HashMap::new();
        let now = Instant::now();
        for s in recovered.map(|r| r.unacked.as_slice()).unwrap_or_default() {
            pending.insert(
                (s.to.clone(), s.bridge.clone(), s.colour.clone()),
                Pending {
                    frame: Frame::Token(BridgeMessage {
                        mission: mission.clone(),
                        from: me.clone(),
                        bridge: s.bridge.clone(),
                        colour: s.colour.clone(),
                        seq: s.seq,
                    }),
                    due: now,
                    wait: policy.initial,
                },
            );
        }
        let unacked = Arc::new(watch::channel(pending.len()).0);
        let stats = Arc::new(Mutex::new(BridgeStats::default()));
        let outbox = Arc::new(Mutex::new(Outbox {
            pending,
            timer: None,
        }));
        let wake = Arc::new(Notify::new());
        let inbound = Arc::new(Inbound {
            mission: mission.clone(),
            me: me.clone(),
            policy,
            outbox: outbox.clone(),
            wake: wake.clone(),
            state: Mutex::new(Received {
                delivered: recovered.map(|r| r.delivered.clone()).unwrap_or_default(),
                acks: HashMap::new(),
                acks_due: None,
            }),
            delivered_tx,
            unacked: unacked.clone(),
            stats: stats.clone(),
            journal: journal.clone(),
        });
        let task = BridgeTask {
            link: link.clone(),
            policy,
            outbox: outbox.clone(),
            wake: wake.clone(),
            inbound,
            stats: stats.clone(),
        };
        tokio::spawn(task.run(frames, stopped));
        (
            Bridges {
                mission,
                link,
                policy,
                outbox,
                wake,
                next_seq: Mutex::new(recovered.map_or(0, |r| r.last_seq)),
                journal,
                unacked,
                stats,
                _stop: stop,
            },
            delivered_rx,
        )
    }

    /// Sends a token over `bridge` to `to`, until it is acknowledged.
    /// Returns the token's sequence number.
    ///
    /// The first copy leaves from this call when the link can take it
    /// without waiting (every link here can, unless another send holds it
    /// at that instant); otherwise the task sends it at once.
    pub fn send(&self, to: &str, bridge: &str, colour: Colour) -> u64 {
        let seq = {
            let mut s = self.next_seq.lock().expect("seq lock");
            *s += 1;
            *s
        };
        if let Some(journal) = &self.journal {
            // Journaled before it leaves: after a crash it is sent again
            // with this number until acknowledged.
            let record = Record::Sent(Sent {
                to: to.to_string(),
                bridge: bridge.to_string(),
                colour: colour.clone(),
                seq,
            });
            if let Err(e) = journal.append(&record, true) {
                tracing::error!("{bridge} to {to} is sent but not journaled: {e}");
            }
        }
        let frame = Frame::Token(BridgeMessage {
            mission: self.mission.clone(),
            from: self.link.me().to_string(),
            bridge: bridge.to_string(),
            colour: colour.clone(),
            seq,
        });
        let key = (to.to_string(), bridge.to_string(), colour);
        // Pending once sent: an ack quicker than this call (receivers hold
        // theirs back for `ack_delay`) would only cost a retransmission,
        // which the receiver acknowledges again.
        let now = Instant::now();
        match poll_once(self.link.send(to, &frame)) {
            Some(sent) => {
                if let Err(e) = sent {
                    tracing::debug!("first send of {bridge} to {to} failed, will retry: {e}");
                }
                self.pend(key, frame, now + self.policy.initial);
            }
            None => self.pend(key, frame, now),
        }
        self.stats.lock().expect("stats lock").sent += 1;
        seq
    }

    /// Keeps `frame` until it is acknowledged, sending it again from `due`.
    fn pend(&self, key: (PeerId, String, Colour), frame: Frame, due: Instant) {
        let mut outbox = self.outbox.lock().expect("outbox lock");
        let pending = Pending {
            frame,
            due,
            wait: self.policy.initial,
        };
        if outbox.pending.insert(key, pending).is_none() {
            // The same token sent again before its ack is still one to
            // wait for.
            self.unacked.send_modify(|n| *n += 1);
        }
        if outbox.timer.is_none_or(|t| due < t) {
            outbox.timer = Some(due);
            self.wake.notify_one();
        }
    }

    /// Waits until every token sent so far has been acknowledged, or the
    /// timeout expires. Returns how many are still unacknowledged.
    pub async fn flush(&self, timeout: Duration) -> usize {
        let mut unacked = self.unacked.subscribe();
        let _ = tokio::time::timeout(timeout, unacked.wait_for(|n| *n == 0)).await;
        let n = *unacked.borrow();
        n
    }

    pub fn stats(&self) -> BridgeStats {
        *self.stats.lock().expect("stats lock")
    }
}

/// Polls `f` once: its output if it is ready at once, `None` if it would
/// wait (the future is then dropped; links' sends are cancel safe).
fn poll_once<F: Future>(f: F) -> Option<F::Output> {
    let mut f = std::pin::pin!(f);
    match f.as_mut().poll(&mut Context::from_waker(Waker::noop())) {
        Poll::Ready(out) => Some(out),
        Poll::Pending => None,
    }
}

/// The receiving side, shared by the bridges' task and, on a link that
/// routes frames (see [`Link::route_frames`]), the link's receiving
/// thread: a token reaches the executor straight from there.
struct Inbound {
    mission: String,
    me: PeerId,
    policy: RetransmitPolicy,
    outbox: Arc<Mutex<Outbox>>,
    /// Wakes the task when acknowledgements start to wait.
    wake: Arc<Notify>,
    /// Held across the journal and the hand-over of a token: two copies
    /// arriving at once on two threads are still handed on once.
    state: Mutex<Received>,
    delivered_tx: mpsc::UnboundedSender<Delivered>,
    unacked: Arc<watch::Sender<usize>>,
    stats: Arc<Mutex<BridgeStats>>,
    journal: Option<Arc<Journal>>,
}

struct Received {
    /// Already handed to the executor, by (sender, bridge, colour).
    delivered: HashSet<(PeerId, String, Colour)>,
    /// Acknowledgements not sent yet, by the peer they go to.
    acks: HashMap<PeerId, Vec<Ack>>,
    /// When the acknowledgements held in `acks` leave.
    acks_due: Option<Instant>,
}

impl Inbound {
    fn stat(&self, f: impl FnOnce(&mut BridgeStats)) {
        f(&mut self.stats.lock().expect("stats lock"));
    }

    fn on_frame(&self, frame: Frame) {
        match frame {
            Frame::Token(m) => self.on_token(m),
            Frame::Ack(a) => self.on_ack(a),
            Frame::Acks(acks) => {
                for a in acks {
                    self.on_ack(a);
                }
            }
        }
    }

    fn on_token(&self, m: BridgeMessage) {
        if m.mission != self.mission {
            self.stat(|s| s.foreign += 1);
            tracing::warn!("dropped a token of mission {} from {}", m.mission, m.from);
            return;
        }
        let mut state = self.state.lock().expect("inbound lock");
        let key = (m.from, m.bridge, m.colour);
        let first = !state.delivered.contains(&key);
        if first {
            if let Some(journal) = &self.journal {
                let record = Record::Consumed {
                    from: key.0.clone(),
                    bridge: key.1.clone(),
                    colour: key.2.clone(),
                    seq: m.seq,
                };
                // Journaled before handed on and acknowledged; unjournaled,
                // it is not acknowledged and its sender tries again.
                if let Err(e) = journal.append(&record, true) {
                    tracing::error!("{} from {} not acknowledged: {e}", key.1, key.0);
                    return;
                }
            }
        }
        // Every copy is acknowledged (the ack of the first may be lost),
        // after the executor has the token: the ack is not on its path.
        let ack = Ack {
            mission: self.mission.clone(),
            from: self.me.clone(),
            bridge: key.1.clone(),
            colour: key.2.clone(),
            seq: m.seq,
        };
        if first {
            self.stat(|s| s.received += 1);
            let _ = self.delivered_tx.send(Delivered {
                from: key.0.clone(),
                bridge: key.1.clone(),
                colour: key.2.clone(),
                seq: m.seq,
            });
            state.delivered.insert(key.clone());
        } else {
            self.stat(|s| s.duplicates += 1);
        }
        state.acks.entry(key.0).or_default().push(ack);
        if state.acks_due.is_none() {
            state.acks_due = Some(Instant::now() + self.policy.ack_delay);
            self.wake.notify_one();
        }
    }

    fn on_ack(&self, a: Ack) {
        if a.mission != self.mission {
            self.stat(|s| s.foreign += 1);
            return;
        }
        let key = (a.from, a.bridge, a.colour);
        let removed = {
            let mut outbox = self.outbox.lock().expect("outbox lock");
            let removed = outbox.pending.remove(&key).is_some();
            if removed {
                self.unacked.send_modify(|n| *n -= 1);
            }
            removed
        };
        if removed {
            if let Some(journal) = &self.journal {
                // Not flushed: an ack lost in a crash only costs a copy
                // that the receiver drops.
                let (to, bridge, colour) = key;
                let record = Record::Acked { to, bridge, colour };
                if let Err(e) = journal.append(&record, false) {
                    tracing::warn!("an acknowledgement is not journaled: {e}");
                }
            }
        }
    }

    /// The acknowledgements held back, now owed, by peer.
    fn take_acks(&self) -> HashMap<PeerId, Vec<Ack>> {
        let mut state = self.state.lock().expect("inbound lock");
        state.acks_due = None;
        std::mem::take(&mut state.acks)
    }
}

struct BridgeTask {
    link: Arc<dyn Link>,
    policy: RetransmitPolicy,
    outbox: Arc<Mutex<Outbox>>,
    wake: Arc<Notify>,
    inbound: Arc<Inbound>,
    stats: Arc<Mutex<BridgeStats>>,
}

impl BridgeTask {
    async fn run(
        self,
        mut frames: mpsc::UnboundedReceiver<Frame>,
        mut stop: oneshot::Receiver<()>,
    ) {
        // Frames the link hands over on its own thread skip this task; the
        // handler lets go once the task (and with it the bridges) ends.
        let inbound = Arc::downgrade(&self.inbound);
        self.link.route_frames(Arc::new(move |frame| {
            if let Some(inbound) = inbound.upgrade() {
                inbound.on_frame(frame);
            }
        }));
        // A peer whose link has closed its inbound side can still send.
        let mut frames_open = true;
        loop {
            let retransmit = {
                let mut outbox = self.outbox.lock().expect("outbox lock");
                outbox.timer = outbox.pending.values().map(|p| p.due).min();
                outbox.timer
            };
            let acks_due = self.inbound.state.lock().expect("inbound lock").acks_due;
            let next = match (retransmit, acks_due) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            };
            tokio::select! {
                frame = frames.recv(), if frames_open => match frame {
                    Some(frame) => self.inbound.on_frame(frame),
                    None => frames_open = false,
                },
                _ = self.wake.notified() => {}
                _ = &mut stop => {
                    // The acknowledgements held back are owed already.
                    self.send_acks().await;
                    return;
                }
                _ = sleep_until_or_forever(next) => {
                    self.retransmit_due().await;
                    if acks_due.is_some_and(|t| t <= Instant::now()) {
                        self.send_acks().await;
                    }
                }
            }
        }
    }

    fn stat(&self, f: impl FnOnce(&mut BridgeStats)) {
        f(&mut self.stats.lock().expect("stats lock"));
    }

    /// Sends the acknowledgements held back, one frame per peer.
    async fn send_acks(&self) {
        for (peer, mut acks) in self.inbound.take_acks() {
            let n = acks.len() as u64;
            let frame = if acks.len() == 1 {
                Frame::Ack(acks.pop().expect("one ack"))
            } else {
                Frame::Acks(acks)
            };
            if let Err(e) = self.link.send(&peer, &frame).await {
                tracing::debug!("acks to {peer} failed: {e}");
            }
            self.stat(|s| s.acks_sent += n);
        }
    }

    async fn retransmit_due(&self) {
        let now = Instant::now();
        let due: Vec<(PeerId, Frame)> = {
            let mut outbox = self.outbox.lock().expect("outbox lock");
            let mut due = Vec::new();
            for ((peer, _, _), p) in outbox.pending.iter_mut() {
                if p.due <= now {
                    due.push((peer.clone(), p.frame.clone()));
                    p.wait = p.wait.mul_f64(self.policy.factor).min(self.policy.max);
                    p.due = now + p.wait;
                }
            }
            due
        };
        for (peer, frame) in due {
            self.stat(|s| s.retransmissions += 1);
            if let Frame::Token(m) = &frame {
                tracing::debug!("retransmitting {} {:?} to {peer}", m.bridge, m.colour);
            }
            let _ = self.link.send(&peer, &frame).await;
        }
    }
}

async fn sleep_until_or_forever(t: Option<Instant>) {
    match t {
        Some(t) => tokio::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::faulty::{Faults, FaultyLink};
    use crate::transport::inproc::InProcessHub;
    use crate::transport::Endpoint;

    fn faulty(e: Endpoint, faults: Faults) -> Endpoint {
        Endpoint {
            link: Arc::new(FaultyLink::new(e.link, faults)),
            ..e
        }
    }

    fn start(e: Endpoint) -> (Bridges, mpsc::UnboundedReceiver<Delivered>) {
        Bridges::start(
            "M",
            e.link,
            e.frames,
            RetransmitPolicy {
                initial: Duration::from_millis(5),
                max: Duration::from_millis(40),
                factor: 2.0,
                ack_delay: Duration::from_millis(1),
            },
        )
    }

    #[tokio::test]
    async fn every_token_arrives_exactly_once_over_a_link_that_drops_and_duplicates() {
        let hub = InProcessHub::new();
        let faults = Faults {
            drop: 0.3,
            duplicate: 0.3,
            reorder: 0.2,
            max_delay: Duration::from_millis(10),
            seed: 11,
        };
        let a = faulty(hub.connect("D1", &[]), faults);
        let b = faulty(hub.connect("D2", &[]), Faults { seed: 12, ..faults });
        let (tx, _) = start(a);
        let (rx_bridges, mut rx) = start(b);
        for i in 0..200u32 {
            tx.send("D2", &format!("b{}", i % 5), vec![i / 5]);
        }
        assert_eq!(tx.flush(Duration::from_secs(60)).await, 0);
        let mut got = HashSet::new();
        while let Ok(d) = rx.try_recv() {
            assert!(got.insert((d.bridge, d.colour)), "delivered twice");
        }
        assert_eq!(got.len(), 200);
        let s = rx_bridges.stats();
        assert_eq!(s.received, 200);
        assert!(s.duplicates > 0, "the faults should have caused duplicates");
        assert!(tx.stats().retransmissions > 0);
    }

    #[tokio::test]
    async fn a_token_sent_before_its_receiver_is_up_arrives_once_it_is() {
        let hub = InProcessHub::new();
        let (tx, _) = start(hub.connect("GCS", &[]));
        tx.send("D1", "start", vec![]);
        tokio::time::sleep(Duration::from_millis(30)).await;
        let (_rx_b, mut rx) = start(hub.connect("D1", &[]));
        let d = rx.recv().await.unwrap();
        assert_eq!((d.from.as_str(), d.bridge.as_str()), ("GCS", "start"));
        assert_eq!(tx.flush(Duration::from_secs(10)).await, 0);
    }

    #[tokio::test]
    async fn the_same_bridge_with_another_colour_is_another_token() {
        let hub = InProcessHub::new();
        let (tx, _) = start(hub.connect("D1", &[]));
        let (_b, mut rx) = start(hub.connect("D2", &[]));
        tx.send("D2", "loop", vec![0]);
        tx.send("D2", "loop", vec![1]);
        tx.send("D2", "loop", vec![1]);
        let first = rx.recv().await.unwrap();
        let second = rx.recv().await.unwrap();
        assert_eq!((first.colour, second.colour), (vec![0], vec![1]));
        assert_eq!(tx.flush(Duration::from_secs(10)).await, 0);
        tokio::task::yield_now().await;
        assert!(rx.try_recv().is_err());
    }

    #[tokio::test]
    async fn a_token_of_another_mission_is_dropped_and_not_acknowledged() {
        let hub = InProcessHub::new();
        let (tx, _) = Bridges::start(
            "OTHER",
            hub.connect("D1", &[]).link,
            mpsc::unbounded_channel().1,
            RetransmitPolicy::default(),
        );
        let (b, mut rx) = start(hub.connect("D2", &[]));
        tx.send("D2", "b", vec![]);
        assert_eq!(tx.flush(Duration::from_millis(100)).await, 1);
        assert!(rx.try_recv().is_err());
        assert!(b.stats().foreign > 0);
    }

    fn token(bridge: &str, colour: u32) -> Frame {
        Frame::Token(BridgeMessage {
            mission: "M".into(),
            from: "D1".into(),
            bridge: bridge.into(),
            colour: vec![colour],
            seq: u64::from(colour),
        })
    }

    fn acked(frame: Frame) -> Vec<(String, Colour)> {
        match frame {
            Frame::Ack(a) => vec![(a.bridge, a.colour)],
            Frame::Acks(acks) => acks.into_iter().map(|a| (a.bridge, a.colour)).collect(),
            Frame::Token(m) => panic!("a token where an ack was expected: {m:?}"),
        }
    }

    #[tokio::test]
    async fn tokens_received_together_are_handed_on_at_once_and_acknowledged_in_one_frame() {
        let hub = InProcessHub::new();
        let mut sender = hub.connect("D1", &[]);
        let receiver = hub.connect("D2", &[]);
        let (_b, mut rx) = Bridges::start(
            "M",
            receiver.link,
            receiver.frames,
            RetransmitPolicy {
                ack_delay: Duration::from_millis(50),
                ..RetransmitPolicy::default()
            },
        );
        for c in 0..3 {
            sender.link.send("D2", &token("b", c)).await.unwrap();
        }
        for c in 0..3 {
            assert_eq!(rx.recv().await.unwrap().colour, vec![c]);
        }
        let frame = sender.frames.recv().await.unwrap();
        assert_eq!(
            acked(frame),
            (0..3)
                .map(|c| ("b".to_string(), vec![c]))
                .collect::<Vec<_>>()
        );
        assert!(sender.frames.try_recv().is_err(), "one frame for the three");
    }

    #[tokio::test]
    async fn acknowledgements_held_back_still_leave_when_the_bridges_are_dropped() {
        let hub = InProcessHub::new();
        let mut sender = hub.connect("D1", &[]);
        let receiver = hub.connect("D2", &[]);
        let (b, mut rx) = Bridges::start(
            "M",
            receiver.link,
            receiver.frames,
            RetransmitPolicy {
                ack_delay: Duration::from_secs(3600),
                ..RetransmitPolicy::default()
            },
        );
        sender.link.send("D2", &token("end", 0)).await.unwrap();
        rx.recv().await.unwrap();
        drop(b);
        let frame = tokio::time::timeout(Duration::from_secs(10), sender.frames.recv())
            .await
            .expect("the ack leaves before the hour is up")
            .unwrap();
        assert_eq!(acked(frame), vec![("end".to_string(), vec![0])]);
    }

    #[tokio::test]
    async fn flushing_with_a_peer_that_never_answers_reports_what_is_left() {
        let hub = InProcessHub::new();
        let (tx, _) = start(hub.connect("D1", &[]));
        tx.send("D9", "b", vec![]);
        assert_eq!(tx.flush(Duration::from_millis(50)).await, 1);
        assert!(tx.stats().retransmissions > 0);
    }
}
