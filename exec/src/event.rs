//! The one stream of mission events and the [`Sink`]s that read it.
//!
//! The executor of a slice says what happened exactly once, as an
//! [`Event`] pushed into one sink; the runner adds the telemetry samples
//! of its drones, and the roll-out agent what it was sent and what it did
//! with it. Every consumer is a sink: the per-drone JSON-lines mission log
//! ([`crate::log`]), the terminal display of `eamos run` and `eamos agent`,
//! the plot's paths, a channel for tests, the live monitor's feed. A new
//! consumer is a new sink, never a new vocabulary; the producers never
//! format a line for a person.
//!
//! A sink is called on the producer's task and must not block: one that
//! needs time (a file, a screen) hands the event to a thread or a task of
//! its own, as [`Channel`] and the log writer do.

use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;

use eamos_mid::Vec3;
use eamos_petri::net::Colour;

/// One thing that happened on one peer, stamped with mission time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Mission time, seconds (the run's [`eamos_mid::MissionClock`]). The
    /// roll-out events of an agent, which happen outside any mission,
    /// count seconds since the agent started.
    pub time: f64,
    /// The peer it happened on: a drone, or the ground station.
    pub drone: String,
    #[serde(flatten)]
    pub kind: Kind,
}

/// What happened. The JSON-lines mission log writes the variant's name in
/// snake case as `event`, beside its fields.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Kind {
    /// The executor of this slice is up.
    Started {
        mission: String,
        mission_id: String,
        places: usize,
        transitions: usize,
        bridges_in: usize,
        bridges_out: usize,
    },
    /// A transition fired with the binding colour (a `Signal` or an
    /// `Await` is a firing of kind `signal` or `await`).
    Fired {
        transition: String,
        label: String,
        kind: String,
        colour: Colour,
    },
    /// The marking of the slice changed (a firing, a token delivered over
    /// a bridge) or is first known (the start, a resumption): every place
    /// of the slice that holds a token now, by id, sorted. The last one a
    /// peer emitted is its marking.
    Marking { marked: Vec<String> },
    BridgeSent {
        bridge: u32,
        to: String,
        colour: Colour,
        seq: u64,
    },
    BridgeReceived {
        bridge: u32,
        from: String,
        colour: Colour,
        seq: u64,
    },
    /// An action was started (`action` names it, `args` are its
    /// arguments); a flight to a point has its absolute target, in metres
    /// from the drone's home (as its journal records it).
    ActionStarted {
        action: String,
        args: Vec<f64>,
        instance: u32,
        colour: Colour,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        target: Option<Vec3>,
    },
    /// The adapter reported the end of an action (`ok`, or the error kind
    /// of a failed or cancelled one); `action` is the call as written,
    /// arguments included.
    ActionFinished {
        action: String,
        instance: u32,
        colour: Colour,
        outcome: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
    /// The agent restarted from its journal: how many records it replayed,
    /// how many actions were running at the crash, how many messages it
    /// sends again.
    Resumed {
        records: usize,
        interrupted: usize,
        unacked: usize,
    },
    /// An action that was running when the agent crashed goes on (a motion
    /// towards the target journaled when it started). Its end is an
    /// `action_finished`; it is not a second start.
    ActionResumed {
        action: String,
        args: Vec<f64>,
        instance: u32,
        colour: Colour,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        target: Option<Vec3>,
    },
    /// An interrupted `Do` cancelled a running action.
    ActionCancelled {
        action: String,
        instance: u32,
        colour: Colour,
    },
    /// A transition has its tokens but its condition does not let it fire
    /// (once per transition and colour, when the wait begins).
    ConditionWaiting {
        transition: String,
        condition: String,
        reason: String,
    },
    /// The final place is marked (here, or as told by the peer holding it).
    MissionEnded { by: String },
    /// The mission time limit expired; what was still waiting.
    TimeLimit { waiting: Vec<String> },
    /// The executor stopped, and why (`completed`, `time limit`,
    /// `failed: ...`, `stopped`, `lost ...`, `aborted: ...`).
    Stopped { reason: String },
    /// A peer seen up has gone (its liveliness token was deleted).
    PeerLost { peer: String },
    /// A lost peer is up again.
    PeerBack { peer: String },
    /// This peer waits on peers lost for the grace period and follows
    /// its policy (`hold`, `land`, `home`, `abort`; the ground station
    /// flies nothing and only reports it).
    Stuck { lost: Vec<String>, policy: String },
    /// The ground station lost every peer, each for the grace period: no
    /// token or report can reach it any more, and it stops following.
    Isolated { lost: Vec<String> },
    /// A peer told this one (the ground station) that it is stuck on a
    /// lost peer, and what it does about it.
    PeerStuck {
        /// The drone that is stuck (`drone` names the event's peer).
        peer: String,
        lost: String,
        policy: String,
    },
    /// An abort was obeyed: every action is cancelled, the drone goes to
    /// its failsafe, every other peer is told.
    AbortReceived { from: String, reason: String },
    /// An abort was refused (another mission, not signed by the ground
    /// station, garbled); the flight goes on.
    AbortRefused { from: String, reason: String },
    /// The drone goes to its failsafe (once per run at most); it flies it
    /// only when airborne.
    Failsafe {
        failsafe: String,
        reason: String,
        airborne: bool,
    },
    /// The drone's adapter says something the crew must read (an
    /// autopilot that would leave the drone alone on a lost link; a
    /// failsafe waiting for a pilot to give the drone back).
    AdapterWarning { detail: String },
    /// How the failsafe ended (`ok`, or the error kind).
    FailsafeFinished {
        failsafe: String,
        outcome: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
    /// Where a drone is: sampled whenever it has moved 5 cm. `position` is
    /// in the fleet frame (shared by every drone of the mission), altitude
    /// in metres above its home, battery in percent.
    Telemetry {
        position: Vec3,
        altitude: f64,
        battery: f64,
    },
    /// A drone has waited its start-up timeout for the fleet's routers and
    /// none answers yet: it keeps trying (said once).
    RoutersWaiting { routers: Vec<String> },
    /// An agent waits for a slice on the fleet's roll-out endpoints.
    RolloutWaiting { endpoints: Vec<String> },
    /// An agent accepted and kept the slice of a mission.
    RolloutAccepted { mission: String, digest: String },
    /// An agent refused a slice or a start command, and why.
    RolloutRefused { what: String, reason: String },
    /// An agent started a mission on the ground station's command.
    RolloutStarted { identity: String },
    /// An agent restarted mid-flight flies on, from its journal, the
    /// mission it had started.
    RolloutResumed { identity: String },
    /// A mission an agent flew has ended.
    RolloutEnded { identity: String, outcome: String },
}

impl Kind {
    /// Whether it is the roll-out's (an agent's dealings with the ground
    /// station) rather than a flight's.
    pub fn is_rollout(&self) -> bool {
        matches!(
            self,
            Kind::RolloutWaiting { .. }
                | Kind::RolloutAccepted { .. }
                | Kind::RolloutRefused { .. }
                | Kind::RolloutStarted { .. }
                | Kind::RolloutResumed { .. }
                | Kind::RolloutEnded { .. }
        )
    }
}

/// Where events go. Called once per event, on the producer's task: it
/// must not block.
pub trait Sink: Send + Sync {
    fn event(&self, e: &Event);
}

impl<S: Sink + ?Sized> Sink for Arc<S> {
    fn event(&self, e: &Event) {
        (**self).event(e)
    }
}

/// Drops every event.
pub struct Discard;

impl Sink for Discard {
    fn event(&self, _: &Event) {}
}

/// Hands every event to each of its sinks in turn, one event at a time:
/// every sink sees the same events in the same order, even when several
/// peers of one process emit at once. A sink of a tee must not emit into that
/// tee (it holds the tee's lock while it is called).
#[derive(Default)]
pub struct Tee {
    sinks: Mutex<Vec<Arc<dyn Sink>>>,
}

impl Tee {
    pub fn new(sinks: Vec<Arc<dyn Sink>>) -> Tee {
        Tee {
            sinks: Mutex::new(sinks),
        }
    }
}

impl Sink for Tee {
    fn event(&self, e: &Event) {
        let sinks = self.sinks.lock().unwrap_or_else(|p| p.into_inner());
        for s in sinks.iter() {
            s.event(e);
        }
    }
}

/// Sends every event down a channel, to a task that reads them at its own
/// pace (a terminal display, a test, the monitor). A closed channel drops
/// them.
pub struct Channel(pub mpsc::UnboundedSender<Event>);

impl Channel {
    /// A channel sink and the receiving end of its channel.
    pub fn new() -> (Channel, mpsc::UnboundedReceiver<Event>) {
        let (tx, rx) = mpsc::unbounded_channel();
        (Channel(tx), rx)
    }
}

impl Sink for Channel {
    fn event(&self, e: &Event) {
        let _ = self.0.send(e.clone());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(drone: &str, time: f64) -> Event {
        Event {
            time,
            drone: drone.into(),
            kind: Kind::PeerLost { peer: "X".into() },
        }
    }

    #[test]
    fn a_tee_hands_each_event_to_every_sink_in_order() {
        let (a, mut ra) = Channel::new();
        let (b, mut rb) = Channel::new();
        let tee = Tee::new(vec![Arc::new(a), Arc::new(Discard), Arc::new(b)]);
        for i in 0..3 {
            tee.event(&ev("D1", i as f64));
        }
        for r in [&mut ra, &mut rb] {
            let times: Vec<f64> = std::iter::from_fn(|| r.try_recv().ok())
                .map(|e| e.time)
                .collect();
            assert_eq!(times, vec![0.0, 1.0, 2.0]);
        }
    }

    #[test]
    fn an_event_is_one_flat_json_object_named_by_its_event_field() {
        let e = Event {
            time: 1.5,
            drone: "D1".into(),
            kind: Kind::Marking {
                marked: vec!["p1".into(), "p2".into()],
            },
        };
        let text = serde_json::to_string(&e).unwrap();
        assert_eq!(
            text,
            r#"{"time":1.5,"drone":"D1","event":"marking","marked":["p1","p2"]}"#
        );
        assert_eq!(serde_json::from_str::<Event>(&text).unwrap(), e);
    }
}
