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
//! With a [`Journal`], the bridges survive a crash of their peer: a token is
//! journaled (and flushed to the disk) before it is acknowledged, every
//! token sent is journaled with its sequence number before it leaves, and
//! acknowledgements are journaled as they come. Restarted from the journal
//! ([`Bridges::start_journaled`]), the bridges still drop copies of tokens
//! consumed before the crash and send again, with their original sequence
//! numbers, the tokens that were never acknowledged.

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

use eamos_petri::net::Colour;

use super::{Ack, BridgeMessage, Frame, Link, PeerId};
use crate::journal::{Journal, Record, Recovered, Sent};

/// When to send a token again that has not been acknowledged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RetransmitPolicy {
    /// The first retransmission comes this long after the first send.
    pub initial: Duration,
    /// The wait doubles (times `factor`) after every try, up to this.
    pub max: Duration,
    pub factor: f64,
}

impl Default for RetransmitPolicy {
    fn default() -> Self {
        RetransmitPolicy {
            initial: Duration::from_millis(40),
            max: Duration::from_millis(800),
            factor: 2.0,
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

enum Command {
    Send {
        to: PeerId,
        bridge: String,
        colour: Colour,
        seq: u64,
    },
}

/// The sending and receiving side of every bridge of one peer.
///
/// Dropping it stops its task: keep it alive while peers may still
/// retransmit to this one (their acks may have been lost).
pub struct Bridges {
    commands: mpsc::UnboundedSender<Command>,
    next_seq: Mutex<u64>,
    journal: Option<Arc<Journal>>,
    /// Tokens sent and not yet acknowledged; counted up by `send` itself so
    /// that a `flush` right after a `send` cannot miss it.
    unacked: Arc<watch::Sender<usize>>,
    stats: Arc<Mutex<BridgeStats>>,
}

struct Pending {
    message: BridgeMessage,
    due: Instant,
    wait: Duration,
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
        let (commands, command_rx) = mpsc::unbounded_channel();
        let (delivered_tx, delivered_rx) = mpsc::unbounded_channel();
        let me = link.me().to_string();
        let mut pending = HashMap::new();
        let now = Instant::now();
        for s in recovered.map(|r| r.unacked.as_slice()).unwrap_or_default() {
            pending.insert(
                (s.to.clone(), s.bridge.clone(), s.colour.clone()),
                Pending {
                    message: BridgeMessage {
                        mission: mission.clone(),
                        from: me.clone(),
                        bridge: s.bridge.clone(),
                        colour: s.colour.clone(),
                        seq: s.seq,
                    },
                    due: now,
                    wait: policy.initial,
                },
            );
        }
        let unacked = Arc::new(watch::channel(pending.len()).0);
        let stats = Arc::new(Mutex::new(BridgeStats::default()));
        let task = BridgeTask {
            mission,
            link,
            policy,
            pending,
            delivered: recovered.map(|r| r.delivered.clone()).unwrap_or_default(),
            delivered_tx,
            unacked: unacked.clone(),
            stats: stats.clone(),
            journal: journal.clone(),
        };
        tokio::spawn(task.run(frames, command_rx));
        (
            Bridges {
                commands,
                next_seq: Mutex::new(recovered.map_or(0, |r| r.last_seq)),
                journal,
                unacked,
                stats,
            },
            delivered_rx,
        )
    }

    /// Sends a token over `bridge` to `to`, until it is acknowledged.
    /// Returns the token's sequence number.
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
        self.unacked.send_modify(|n| *n += 1);
        let _ = self.commands.send(Command::Send {
            to: to.to_string(),
            bridge: bridge.to_string(),
            colour,
            seq,
        });
        seq
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

struct BridgeTask {
    mission: String,
    link: Arc<dyn Link>,
    policy: RetransmitPolicy,
    /// Sent and not yet acknowledged, by (receiver, bridge, colour).
    pending: HashMap<(PeerId, String, Colour), Pending>,
    /// Already handed to the executor, by (sender, bridge, colour).
    delivered: HashSet<(PeerId, String, Colour)>,
    delivered_tx: mpsc::UnboundedSender<Delivered>,
    unacked: Arc<watch::Sender<usize>>,
    stats: Arc<Mutex<BridgeStats>>,
    journal: Option<Arc<Journal>>,
}

impl BridgeTask {
    async fn run(
        mut self,
        mut frames: mpsc::UnboundedReceiver<Frame>,
        mut commands: mpsc::UnboundedReceiver<Command>,
    ) {
        // A peer whose link has closed its inbound side can still send.
        let mut frames_open = true;
        loop {
            let next_due = self.pending.values().map(|p| p.due).min();
            tokio::select! {
                frame = frames.recv(), if frames_open => match frame {
                    Some(frame) => self.on_frame(frame).await,
                    None => frames_open = false,
                },
                command = commands.recv() => match command {
                    Some(Command::Send { to, bridge, colour, seq }) => {
                        self.on_send(to, bridge, colour, seq).await
                    }
                    None => return,
                },
                _ = sleep_until_or_forever(next_due) => self.retransmit_due().await,
            }
        }
    }

    fn stat(&self, f: impl FnOnce(&mut BridgeStats)) {
        f(&mut self.stats.lock().expect("stats lock"));
    }

    async fn on_send(&mut self, to: PeerId, bridge: String, colour: Colour, seq: u64) {
        let message = BridgeMessage {
            mission: self.mission.clone(),
            from: self.link.me().to_string(),
            bridge: bridge.clone(),
            colour: colour.clone(),
            seq,
        };
        self.stat(|s| s.sent += 1);
        if let Err(e) = self.link.send(&to, &Frame::Token(message.clone())).await {
            tracing::debug!("first send of {bridge} to {to} failed, will retry: {e}");
        }
        let replaced = self.pending.insert(
            (to, bridge, colour),
            Pending {
                message,
                due: Instant::now() + self.policy.initial,
                wait: self.policy.initial,
            },
        );
        if replaced.is_some() {
            // The same token sent again before its ack: still one to wait for.
            self.unacked.send_modify(|n| *n -= 1);
        }
    }

    async fn on_frame(&mut self, frame: Frame) {
        match frame {
            Frame::Token(m) => {
                if m.mission != self.mission {
                    self.stat(|s| s.foreign += 1);
                    tracing::warn!("dropped a token of mission {} from {}", m.mission, m.from);
                    return;
                }
                let key = (m.from.clone(), m.bridge.clone(), m.colour.clone());
                let first = !self.delivered.contains(&key);
                if first {
                    if let Some(journal) = &self.journal {
                        let record = Record::Consumed {
                            from: m.from.clone(),
                            bridge: m.bridge.clone(),
                            colour: m.colour.clone(),
                            seq: m.seq,
                        };
                        // Journaled before acknowledged; unjournaled, it is
                        // not acknowledged and its sender tries again.
                        if let Err(e) = journal.append(&record, true) {
                            tracing::error!("{} from {} not acknowledged: {e}", m.bridge, m.from);
                            return;
                        }
                    }
                }
                let ack = Frame::Ack(Ack {
                    mission: self.mission.clone(),
                    from: self.link.me().to_string(),
                    bridge: m.bridge.clone(),
                    colour: m.colour.clone(),
                    seq: m.seq,
                });
                // Every copy is acknowledged: the ack of the first may be lost.
                if let Err(e) = self.link.send(&m.from, &ack).await {
                    tracing::debug!("ack to {} failed: {e}", m.from);
                }
                self.stat(|s| s.acks_sent += 1);
                if first {
                    self.delivered.insert(key);
                    self.stat(|s| s.received += 1);
                    let _ = self.delivered_tx.send(Delivered {
                        from: m.from,
                        bridge: m.bridge,
                        colour: m.colour,
                        seq: m.seq,
                    });
                } else {
                    self.stat(|s| s.duplicates += 1);
                }
            }
            Frame::Ack(a) => {
                if a.mission != self.mission {
                    self.stat(|s| s.foreign += 1);
                    return;
                }
                let key = (a.from, a.bridge, a.colour);
                if self.pending.remove(&key).is_some() {
                    self.unacked.send_modify(|n| *n -= 1);
                    if let Some(journal) = &self.journal {
                        // Not flushed: an ack lost in a crash only costs a
                        // copy that the receiver drops.
                        let (to, bridge, colour) = key;
                        let record = Record::Acked { to, bridge, colour };
                        if let Err(e) = journal.append(&record, false) {
                            tracing::warn!("an acknowledgement is not journaled: {e}");
                        }
                    }
                }
            }
        }
    }

    async fn retransmit_due(&mut self) {
        let now = Instant::now();
        let mut due: Vec<BridgeMessage> = Vec::new();
        let mut to: Vec<PeerId> = Vec::new();
        for ((peer, _, _), p) in self.pending.iter_mut() {
            if p.due <= now {
                due.push(p.message.clone());
                to.push(peer.clone());
                p.wait = p.wait.mul_f64(self.policy.factor).min(self.policy.max);
                p.due = now + p.wait;
            }
        }
        for (peer, m) in to.into_iter().zip(due) {
            self.stat(|s| s.retransmissions += 1);
            tracing::debug!("retransmitting {} {:?} to {peer}", m.bridge, m.colour);
            let _ = self.link.send(&peer, &Frame::Token(m)).await;
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

    #[tokio::test]
    async fn flushing_with_a_peer_that_never_answers_reports_what_is_left() {
        let hub = InProcessHub::new();
        let (tx, _) = start(hub.connect("D1", &[]));
        tx.send("D9", "b", vec![]);
        assert_eq!(tx.flush(Duration::from_millis(50)).await, 1);
        assert!(tx.stats().retransmissions > 0);
    }
}
