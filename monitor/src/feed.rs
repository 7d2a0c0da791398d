//! The run's events as the page reads them: each one serialised once,
//! numbered, kept in a bounded history and broadcast to every open page.

use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex};

use eamos_exec::event::{Event, Kind, Sink};
use tokio::sync::broadcast;

/// How many events (telemetry aside) a page that connects late is handed
/// first: enough for a mission's recent history, bounded for a long one.
const HISTORY: usize = 512;
/// How many events wait for the slowest page before it starts losing them
/// (and is handed the latest state instead).
const BUFFER: usize = 4096;

/// One event as the page receives it: its number in the run and its JSON
/// (the mission log's own form of the event).
#[derive(Debug)]
pub struct Frame {
    pub seq: u64,
    pub json: String,
}

/// The sink that feeds the monitor's pages. Cheap to clone.
#[derive(Clone)]
pub struct Feed {
    inner: Arc<Inner>,
}

struct Inner {
    tx: broadcast::Sender<Arc<Frame>>,
    state: Mutex<State>,
}

/// What a page needs to catch up: the recent events, and for each drone
/// its latest sample and marking, however old (they are the drone's state,
/// not its history).
#[derive(Default)]
struct State {
    seq: u64,
    recent: VecDeque<Arc<Frame>>,
    telemetry: BTreeMap<String, Arc<Frame>>,
    marking: BTreeMap<String, Arc<Frame>>,
}

impl Default for Feed {
    fn default() -> Self {
        Feed::new()
    }
}

impl Feed {
    pub fn new() -> Feed {
        let (tx, _) = broadcast::channel(BUFFER);
        Feed {
            inner: Arc::new(Inner {
                tx,
                state: Mutex::new(State::default()),
            }),
        }
    }

    /// Every event from now on; see [`Feed::catch_up`] for those before.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<Frame>> {
        self.inner.tx.subscribe()
    }

    /// The state so far, oldest first: each drone's latest sample and
    /// marking and the recent events, each once.
    pub fn catch_up(&self) -> Vec<Arc<Frame>> {
        let s = self.inner.state.lock().unwrap_or_else(|p| p.into_inner());
        let mut all: Vec<Arc<Frame>> = s
            .recent
            .iter()
            .chain(s.telemetry.values())
            .chain(s.marking.values())
            .cloned()
            .collect();
        all.sort_by_key(|f| f.seq);
        all.dedup_by_key(|f| f.seq);
        all
    }
}

/// The event's JSON (the mission log's form) with `sent`, the wall clock
/// (milliseconds since the Unix epoch) at which the monitor got it: the
/// page tells from it how long an event took to reach its screen (the
/// monitor's latency benchmark reads that).
fn stamped(e: &Event) -> Option<String> {
    let mut json = serde_json::to_string(e).ok()?;
    let sent = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .ok()?
        .as_secs_f64()
        * 1000.0;
    // An event is a JSON object: its closing brace makes room for one more.
    json.pop().filter(|&c| c == '}')?;
    json.push_str(&format!(",\"sent\":{sent:.3}}}"));
    Some(json)
}

impl Sink for Feed {
    fn event(&self, e: &Event) {
        if e.kind.is_rollout() {
            return;
        }
        let Some(json) = stamped(e) else {
            return;
        };
        let frame = {
            let mut s = self.inner.state.lock().unwrap_or_else(|p| p.into_inner());
            s.seq += 1;
            let frame = Arc::new(Frame { seq: s.seq, json });
            match &e.kind {
                Kind::Telemetry { .. } => {
                    s.telemetry.insert(e.drone.clone(), frame.clone());
                }
                Kind::Marking { .. } => {
                    s.marking.insert(e.drone.clone(), frame.clone());
                }
                _ => {
                    if s.recent.len() == HISTORY {
                        s.recent.pop_front();
                    }
                    s.recent.push_back(frame.clone());
                }
            }
            frame
        };
        // Never waits: with no page open the frame is dropped, and a page
        // that lags behind loses the oldest frames.
        let _ = self.inner.tx.send(frame);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eamos_exec::event::Kind;
    use eamos_mid::Vec3;

    fn telemetry(drone: &str, x: f64) -> Event {
        Event {
            time: x,
            drone: drone.into(),
            kind: Kind::Telemetry {
                position: Vec3::new(x, 0.0, 1.0),
                altitude: 1.0,
                battery: 90.0,
            },
        }
    }

    #[test]
    fn a_late_page_gets_each_drones_latest_sample_and_the_recent_events() {
        let feed = Feed::new();
        for i in 0..1000 {
            feed.event(&telemetry("D1", i as f64));
        }
        feed.event(&Event {
            time: 5.0,
            drone: "D2".into(),
            kind: Kind::PeerLost { peer: "D1".into() },
        });
        let frames = feed.catch_up();
        assert_eq!(frames.len(), 2, "{frames:?}");
        assert!(frames[0].json.contains("\"time\":999.0"));
        let page: serde_json::Value = serde_json::from_str(&frames[1].json).unwrap();
        assert_eq!(page["peer"], "D1", "the event as the log writes it");
        assert!(page["sent"].as_f64().unwrap() > 1.7e12, "stamped: {page}");
        assert!(frames[1].json.contains("peer_lost"));
        assert!(frames[0].seq < frames[1].seq);
    }

    #[test]
    fn a_feed_with_no_page_and_a_page_that_never_reads_never_block_the_sink() {
        let feed = Feed::new();
        let _never_read = feed.subscribe();
        for i in 0..(4 * BUFFER) {
            feed.event(&telemetry("D1", i as f64));
        }
        assert_eq!(feed.catch_up().len(), 1);
    }
}
