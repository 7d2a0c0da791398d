//! The executor of one slice: the token game of one drone (or of the ground
//! station), played for real.
//!
//! It keeps the marking of the slice's places and fires what is enabled,
//! eagerly, until nothing more can fire; then it waits, without polling, for
//! whatever can change that: an action reporting its end, a token arriving
//! over a bridge, telemetry of a drone its guards read, the timer of a
//! `PauseFor`, the mission time limit. The binding colour of a firing is
//! the longest colour among its input tokens, as in the reference token game
//! (`eamos_petri::game`).
//!
//! Actions run concurrently through the drone's adapter: an `ActionStart`
//! starts one and moves on, its `ActionEnd` becomes enabled when the adapter
//! reports success, and an `ActionCancel` (fired when an interrupted `Do`
//! skips the action) cancels it. An action instance is started at most once
//! per colour, whatever the net or the network does.
//!
//! Control messages travel besides the slice's bridges: `end`, sent by
//! each slice that marks its end of the mission to the ground station (the
//! mission has ended once every slice listed in `Slice::ends` has), which
//! then sends `ended` to every other peer; and `abort`, sent by a drone
//! whose action failed. Each is delivered exactly once like any token.
//! Without a ground station among the peers, `end` goes to every peer.
//!
//! What happens is said once, as an [`Event`] into the agent's sink (see
//! [`crate::event`]): the logs, the terminal and any monitor read that one
//! stream. The executor formats no line for a person.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;
use std::time::Duration;

use tokio::sync::{mpsc, watch};
use tokio_util::sync::CancellationToken;

use eamos_lang::SourceFile;
use eamos_mid::{ActionCall, ActionError, Adapter, MissionClock, Telemetry};
use eamos_petri::net::{Colour, Guard, TransitionKind};
use eamos_slicer::Slice;

use crate::abort::{CommandOpener, CommandSealer};
use crate::event::{Event, Kind, Sink};
use crate::guard::World;
use crate::journal::{self, AgentJournal, Record};
use crate::liveness::Liveness;
use crate::transport::reliable::{BridgeStats, Bridges, Delivered};
use crate::transport::{Link, PeerId, TelemetryFrame, GCS};

/// How long the end of a run waits for cancelled actions to report back
/// before it flies the failsafe anyway (wall time: a cancellation is the
/// adapter's, not the mission's, business).
const CANCEL_SETTLE: Duration = Duration::from_secs(10);

pub use crate::names::{ABORT, END, ENDED};

mod failsafe;

/// How one executor behaves around the token game.
#[derive(Clone)]
pub struct ExecutorOptions {
    /// Mission seconds after the executor starts at which every branch
    /// stops and the drone lands.
    pub max_duration: Option<f64>,
    /// How long the ground station waits for its peers before it fires the
    /// start (wall time).
    pub startup_timeout: Duration,
    /// How long to wait for the acknowledgement of the last tokens before
    /// giving up on a peer that has gone (wall time).
    pub flush_timeout: Duration,
    /// Every peer of the mission: the `end` and `abort` notices go to all.
    pub peers: Vec<PeerId>,
    /// The mission text, to name lines in what the executor reports.
    pub source: Option<Arc<SourceFile>>,
    /// Stops the executor from outside (Ctrl-C): the drone lands.
    pub stop: CancellationToken,
    /// What this drone does when a peer it waits on is lost, and when the
    /// mission is aborted (see [`crate::liveness`]).
    pub liveness: Liveness,
    /// Checks the ground station's seal on abort commands; without it an
    /// unsigned command of this mission is obeyed (see [`crate::abort`]).
    pub abort_opener: Option<CommandOpener>,
    /// Seals the abort this peer sends when it is stopped, as a command of
    /// the ground station: given to the ground station when it holds the
    /// fleet's key, so that what it says is signed like `eamos abort`.
    pub abort_sealer: Option<CommandSealer>,
    /// Where this agent journals what it does, and what the journal held
    /// when it started (see [`crate::journal`]).
    pub journal: Option<AgentJournal>,
    /// Whether an abort that arrives is passed on to every other peer. In
    /// a mesh it reaches a drone cut off from its sender through another
    /// drone. A client of a router has no path the sender lacks, and 100
    /// clients passing it on were 10,000 copies through one router, which
    /// none of them saw acknowledged within its flush.
    pub pass_on_aborts: bool,
}

impl Default for ExecutorOptions {
    fn default() -> Self {
        ExecutorOptions {
            max_duration: None,
            startup_timeout: Duration::from_secs(30),
            flush_timeout: Duration::from_secs(10),
            peers: Vec::new(),
            source: None,
            stop: CancellationToken::new(),
            liveness: Liveness::default(),
            abort_opener: None,
            abort_sealer: None,
            journal: None,
            pass_on_aborts: true,
        }
    }
}

/// How a run of one slice ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The final place was marked (here or at a peer).
    Completed,
    /// The mission time limit expired; what was still waiting, and on what.
    TimeLimit { waiting: Vec<String> },
    /// An action failed here, or a peer reported one.
    Failed { reason: String },
    /// Stopped from outside.
    Stopped,
    /// A peer this drone waited on was lost for the grace period; the
    /// drone went to its failsafe.
    PeerLost {
        lost: Vec<String>,
        failsafe: eamos_mid::Failsafe,
    },
    /// The mission was aborted (a command, or a peer).
    Aborted { reason: String },
}

/// What one executor did: the numbers of the paper's Table 7 and more.
#[derive(Debug, Clone)]
pub struct Report {
    pub drone: String,
    pub outcome: Outcome,
    /// Actions that ended successfully.
    pub actions: u32,
    pub actions_cancelled: u32,
    /// Bridge tokens sent and received (the `end`/`abort` notices excluded).
    pub sent: u64,
    pub received: u64,
    pub bridges: BridgeStats,
    /// Mission time of this slice's first firing (or of the executor's
    /// start if nothing fired) and of its stop.
    pub started: f64,
    pub ended: f64,
    /// Every action run, with its colour, in start order.
    pub started_actions: Vec<(u32, Colour)>,
    /// Tokens not acknowledged when the executor gave up waiting.
    pub unacked: usize,
}

impl Report {
    pub fn duration(&self) -> f64 {
        (self.ended - self.started).max(0.0)
    }
}

/// What one slice needs to run.
pub struct Agent {
    pub slice: Slice,
    /// The drone's adapter (wrapped in the uniform layer); `None` for the
    /// ground station.
    pub drone: Option<Arc<dyn Adapter>>,
    pub clock: MissionClock,
    pub bridges: Arc<Bridges>,
    pub delivered: mpsc::UnboundedReceiver<Delivered>,
    /// The link, to publish this drone's telemetry on.
    pub link: Arc<dyn Link>,
    /// Telemetry of the drones this slice's guards read.
    pub telemetry: mpsc::UnboundedReceiver<TelemetryFrame>,
    /// Where this executor says what happened, once per event (see
    /// [`crate::event`]).
    pub events: Arc<dyn Sink>,
}

struct Finished {
    instance: u32,
    colour: Colour,
    action: String,
    result: Result<(), ActionError>,
}

pub struct Executor {
    slice: Slice,
    drone: Option<Arc<dyn Adapter>>,
    clock: MissionClock,
    bridges: Arc<Bridges>,
    delivered: mpsc::UnboundedReceiver<Delivered>,
    link: Arc<dyn Link>,
    telemetry: mpsc::UnboundedReceiver<TelemetryFrame>,
    events: Arc<dyn Sink>,
    options: ExecutorOptions,

    /// Tokens per local place (1-safe: at most one, kept as a list so that
    /// a compiler bug shows up in the log instead of losing a token).
    marking: Vec<Vec<Colour>>,
    /// Transitions consuming or reading each place.
    consumers: Vec<Vec<u32>>,
    /// Bridge id to inbox place.
    inboxes: HashMap<u32, u32>,
    world: World,
    /// Latest telemetry sequence seen per remote drone.
    telemetry_seq: HashMap<String, u64>,
    /// Whether a guard here reads this drone's own state.
    reads_own: bool,
    own_index: Option<u16>,
    running: HashMap<(u32, Colour), CancellationToken>,
    succeeded: HashSet<(u32, Colour)>,
    started_actions: HashSet<(u32, Colour)>,
    started_order: Vec<(u32, Colour)>,
    finished_tx: mpsc::UnboundedSender<Finished>,
    finished_rx: mpsc::UnboundedReceiver<Finished>,
    /// When each timed transition became enabled (mission time).
    enabled_since: HashMap<(u32, Colour), f64>,
    /// Guards already logged as waiting.
    waiting_logged: HashSet<(u32, Colour)>,
    actions: u32,
    actions_cancelled: u32,
    sent: u64,
    received: u64,
    ended: Option<Outcome>,
    /// Owners of the slice's `ends` that have reached their end (this one
    /// when its final place is marked, the others by their `end` notice).
    ends_reached: HashSet<String>,
    first_firing: Option<f64>,
    /// Who is lost, who this drone is stuck on, whether its failsafe ran.
    alive: failsafe::State,
}

impl Executor {
    pub fn new(agent: Agent, options: ExecutorOptions) -> Self {
        let slice = agent.slice;
        let mut consumers = vec![Vec::new(); slice.places.len()];
        for (i, t) in slice.transitions.iter().enumerate() {
            for &p in t.consume.iter().chain(&t.read) {
                consumers[p as usize].push(i as u32);
            }
        }
        for c in &mut consumers {
            c.sort();
            c.dedup();
        }
        let inboxes = slice.bridges_in.iter().map(|b| (b.id, b.inbox)).collect();
        let own_index = slice
            .drones
            .iter()
            .position(|d| *d == slice.drone)
            .map(|i| i as u16);
        let reads_own = own_index.is_some_and(|me| {
            slice.transitions.iter().any(|t| {
                t.transition
                    .guard
                    .as_ref()
                    .is_some_and(|g| g.drones().iter().any(|d| d.0 == me))
            })
        });
        let mut marking = vec![Vec::new(); slice.places.len()];
        for &p in &slice.initial_marking {
            if marking[p as usize].is_empty() {
                marking[p as usize].push(Vec::new());
            }
        }
        let (finished_tx, finished_rx) = mpsc::unbounded_channel();
        let mut executor = Executor {
            world: World::new(slice.drones.clone()),
            slice,
            drone: agent.drone,
            clock: agent.clock,
            bridges: agent.bridges,
            delivered: agent.delivered,
            link: agent.link,
            telemetry: agent.telemetry,
            events: agent.events,
            options,
            marking,
            consumers,
            inboxes,
            telemetry_seq: HashMap::new(),
            reads_own,
            own_index,
            running: HashMap::new(),
            succeeded: HashSet::new(),
            started_actions: HashSet::new(),
            started_order: Vec::new(),
            finished_tx,
            finished_rx,
            enabled_since: HashMap::new(),
            waiting_logged: HashSet::new(),
            actions: 0,
            actions_cancelled: 0,
            sent: 0,
            received: 0,
            ended: None,
            ends_reached: HashSet::new(),
            first_firing: None,
            alive: failsafe::State::default(),
        };
        executor.recover();
        executor
    }

    /// Takes over the state a journal recorded before a crash (nothing for
    /// a first run).
    fn recover(&mut self) {
        let Some(r) = self.options.journal.as_ref().map(|j| j.recovered.clone()) else {
            return;
        };
        if !r.is_resume() {
            return;
        }
        self.marking = r.marking.clone();
        self.started_actions = r.started.iter().cloned().collect();
        self.started_order = r.started.clone();
        self.succeeded = r.succeeded.clone();
        self.actions = r.actions;
        self.actions_cancelled = r.actions_cancelled;
        self.sent = r.sent;
        self.received = r.received;
        let (simulated, now, wall) = (
            self.clock.is_simulated(),
            self.now(),
            journal::Paused::wall_now_ms(),
        );
        for p in &r.paused {
            if let Some(t) = self.slice.transition_by_id(&p.transition) {
                let began = journal::pause_began(p, simulated, now, wall);
                self.enabled_since.insert((t, p.colour.clone()), began);
            }
        }
        self.alive.delivered = r
            .delivered
            .iter()
            .filter_map(|(_, bridge, _)| bridge.parse().ok())
            .collect();
    }

    /// After a restart from a journal: ends at once if the mission had
    /// ended, sends what a journaled firing did not get to send, starts
    /// what it did not get to start, and resumes the actions that were
    /// running at the crash.
    fn resume(&mut self) {
        let Some(j) = self.options.journal.clone() else {
            return;
        };
        let r = j.recovered;
        if !r.is_resume() {
            return;
        }
        let now = self.now();
        if let Err(e) = j.journal.append(&Record::Resumed { time: now }, true) {
            self.ended = Some(Outcome::Failed {
                reason: format!("{}: {e}", self.me()),
            });
            return;
        }
        self.emit(Kind::Resumed {
            records: r.records,
            interrupted: r.interrupted.len(),
            unacked: r.unacked.len(),
        });
        if let Some(reason) = &r.failed {
            self.ended = Some(Outcome::Failed {
                reason: reason.clone(),
            });
            return;
        }
        // The notices consumed before the crash count as they did then.
        let notices = r
            .ends
            .iter()
            .map(|p| (p, END))
            .chain(r.ended.iter().map(|p| (p, ENDED)))
            .chain(r.aborts.iter().map(|p| (p, ABORT)));
        for (from, bridge) in notices {
            self.on_delivered(Delivered {
                from: from.clone(),
                bridge: bridge.to_string(),
                colour: Vec::new(),
                seq: 0,
            });
        }
        if self.ended.is_some() {
            return;
        }
        for (to, bridge, colour) in &r.unsent {
            let seq = self.bridges.send(to, bridge, colour.clone());
            self.sent += 1;
            if let Ok(id) = bridge.parse() {
                self.emit(Kind::BridgeSent {
                    bridge: id,
                    to: to.clone(),
                    colour: colour.clone(),
                    seq,
                });
            }
        }
        for (instance, colour) in &r.not_started {
            if let Some(a) = self.action_ref(*instance) {
                self.start_action(&a, colour.clone());
            }
        }
        for i in &r.interrupted {
            self.resume_action(i);
        }
    }

    fn action_ref(&self, instance: u32) -> Option<eamos_petri::net::SharedAction> {
        self.slice
            .transitions
            .iter()
            .find_map(|t| match &t.transition.kind {
                TransitionKind::ActionStart(a) if a.instance == instance => Some(a.clone()),
                _ => None,
            })
    }

    /// Runs on an action that was running when the agent crashed, towards
    /// the target journaled when it started (see [`journal::resume_action`]).
    fn resume_action(&mut self, i: &journal::Interrupted) {
        let key = (i.instance, i.colour.clone());
        self.emit(Kind::ActionResumed {
            action: i.call.name.clone(),
            args: i.call.args.clone(),
            instance: i.instance,
            colour: i.colour.clone(),
            target: i.target,
        });
        let token = CancellationToken::new();
        self.running.insert(key, token.clone());
        let done = self.finished_tx.clone();
        let (instance, colour, call, target, started) = (
            i.instance,
            i.colour.clone(),
            i.call.clone(),
            i.target,
            i.time,
        );
        let action = call.to_string();
        let drone = self.drone.clone();
        tokio::spawn(async move {
            let result = match drone {
                Some(drone) => {
                    journal::resume_action(drone.as_ref(), &call, target, started, token).await
                }
                None => Err(ActionError::Unsupported {
                    action: action.clone(),
                }),
            };
            let _ = done.send(Finished {
                instance,
                colour,
                action,
                result,
            });
        });
    }

    /// Journals `record`; a journal that cannot be written ends the run
    /// (the agent could no longer promise to run each action once).
    fn journal(&mut self, record: Record, durable: bool) -> bool {
        let Some(j) = &self.options.journal else {
            return true;
        };
        match j.journal.append(&record, durable) {
            Ok(()) => true,
            Err(e) => {
                tracing::error!("{}: {e}", self.me());
                if self.ended.is_none() {
                    self.ended = Some(Outcome::Failed {
                        reason: format!("{}: {e}", self.me()),
                    });
                }
                false
            }
        }
    }

    fn me(&self) -> &str {
        &self.slice.drone
    }

    /// What this peer's abort says when it is stopped: a sealed command
    /// when it has the ground station's key, a plain peer abort otherwise.
    fn stop_colour(&self) -> eamos_petri::net::Colour {
        match &self.options.abort_sealer {
            Some(seal) => {
                let command = crate::abort::AbortCommand::new(
                    &self.slice.mission_id,
                    &format!("{} (stopped)", self.me()),
                );
                crate::abort::pack(&seal(command.payload()))
            }
            None => Vec::new(),
        }
    }

    fn now(&self) -> f64 {
        self.clock.now()
    }

    /// Says what happened, once, into the executor's sink.
    fn emit(&self, kind: Kind) {
        self.events.event(&Event {
            time: self.now(),
            drone: self.me().to_string(),
            kind,
        });
    }

    /// Says which places hold a token now (after every change).
    fn emit_marking(&self) {
        let mut marked: Vec<String> = self
            .marking
            .iter()
            .zip(&self.slice.places)
            .filter(|(tokens, _)| !tokens.is_empty())
            .map(|(_, p)| p.id.to_string())
            .collect();
        marked.sort();
        self.emit(Kind::Marking { marked });
    }

    /// Plays the slice until the mission ends, the time limit expires, an
    /// action fails or the executor is stopped.
    pub async fn run(mut self) -> Report {
        let started = self.now();
        self.emit(Kind::Started {
            mission: self.slice.mission.clone(),
            mission_id: self.slice.mission_id.clone(),
            places: self.slice.places.len(),
            transitions: self.slice.transitions.len(),
            bridges_in: self.slice.bridges_in.len(),
            bridges_out: self.slice.bridges_out.len(),
        });
        self.emit_marking();
        self.resume();
        let publisher = CancellationToken::new();
        let mut own: Option<watch::Receiver<Telemetry>> = None;
        if let Some(drone) = &self.drone {
            let rx = drone.telemetry();
            tokio::spawn(publish_telemetry(
                self.link.clone(),
                self.slice.mission_id.clone(),
                self.me().to_string(),
                rx.clone(),
                publisher.clone(),
            ));
            if let Some(i) = self.own_index {
                self.world.set(i, *rx.borrow());
            }
            if self.reads_own {
                own = Some(rx);
            }
        }

        if self.me() == GCS {
            let others: Vec<PeerId> = self
                .options
                .peers
                .iter()
                .filter(|p| p.as_str() != GCS)
                .cloned()
                .collect();
            // Every drone ready: up, and seeing the few peers it exchanges
            // tokens or telemetry with (not the whole fleet).
            let wait = self
                .link
                .wait_for_ready(&others, self.options.startup_timeout);
            tokio::select! {
                r = wait => if let Err(e) = r {
                    self.ended = Some(Outcome::Failed { reason: format!("cannot start: {e}") });
                },
                _ = self.options.stop.cancelled() => self.ended = Some(Outcome::Stopped),
            }
        }

        if self.me() != GCS {
            // Says this drone is ready once it sees its neighbours, in the
            // background: a drone resumed mid-mission plays on meanwhile,
            // and a fresh one holds no token before the ground station,
            // which waits for that, starts the mission.
            let link = self.link.clone();
            let neighbours = crate::liveness::neighbours(&self.slice);
            let done = publisher.clone();
            tokio::spawn(async move {
                tokio::select! {
                    r = link.announce_ready(&neighbours) => if let Err(e) = r {
                        tracing::warn!("{}: cannot say it is ready: {e}", link.me());
                    },
                    _ = done.cancelled() => {}
                }
            });
        }
        let deadline = self.options.max_duration.map(|d| started + d);
        let mut presence = self.link.presence();
        if let Some(p) = presence.as_mut() {
            let now = p.borrow_and_update().clone();
            self.on_presence(now);
        }
        while self.ended.is_none() {
            self.fire_until_quiescent();
            self.check_lost();
            if self.ended.is_some() {
                break;
            }
            let next_timer = self.next_timer();
            let grace_ends = self.grace_ends();
            let clock = self.clock.clone();
            let stop = self.options.stop.clone();
            tokio::select! {
                Some(f) = self.finished_rx.recv() => self.on_finished(f),
                d = self.delivered.recv() => match d {
                    Some(d) => self.on_delivered(d),
                    None => self.ended = Some(Outcome::Failed { reason: "the transport closed".into() }),
                },
                Some(t) = self.telemetry.recv() => self.on_telemetry(t),
                changed = changed(&mut own) => {
                    if changed {
                        if let (Some(i), Some(rx)) = (self.own_index, own.as_mut()) {
                            let t = *rx.borrow_and_update();
                            self.world.set(i, t);
                        }
                    } else {
                        own = None;
                    }
                }
                _ = sleep_until(&clock, next_timer) => {}
                p = failsafe::presence_changed(&mut presence) => match p {
                    Some(now) => self.on_presence(now),
                    None => presence = None,
                },
                _ = sleep_until(&clock, grace_ends) => {}
                _ = sleep_until(&clock, deadline) => {
                    let waiting = self.waiting();
                    self.emit(Kind::TimeLimit { waiting: waiting.clone() });
                    self.ended = Some(Outcome::TimeLimit { waiting });
                }
                _ = stop.cancelled() => self.ended = Some(Outcome::Stopped),
            }
        }
        let outcome = self.ended.clone().unwrap_or(Outcome::Stopped);

        if !matches!(outcome, Outcome::Completed) {
            let cancelled = self.cancel_all();
            // An adapter refuses a failsafe while a cancelled motion still
            // holds the drone: let every cancelled action report back first.
            self.settle_cancelled(cancelled).await;
            if outcome == Outcome::Stopped {
                // Stopped here (Ctrl-C): the mission cannot go on, so
                // every peer is told, as for a failed action.
                let colour = self.stop_colour();
                self.abort_peers(None, colour);
            }
            self.failsafe_at_end(&outcome).await;
        }
        publisher.cancel();
        let unacked = self.bridges.flush(self.options.flush_timeout).await;
        let reason = match &outcome {
            Outcome::Completed => "completed".to_string(),
            Outcome::TimeLimit { .. } => "time limit".to_string(),
            Outcome::Failed { reason } => format!("failed: {reason}"),
            Outcome::Stopped => "stopped".to_string(),
            Outcome::PeerLost { lost, failsafe } => {
                format!("lost {}: {failsafe}", lost.join(", "))
            }
            Outcome::Aborted { reason } => format!("aborted: {reason}"),
        };
        self.emit(Kind::Stopped {
            reason: reason.clone(),
        });
        Report {
            drone: self.me().to_string(),
            outcome,
            actions: self.actions,
            actions_cancelled: self.actions_cancelled,
            sent: self.sent,
            received: self.received,
            bridges: self.bridges.stats(),
            started: self.first_firing.unwrap_or(started),
            ended: self.now(),
            started_actions: self.started_order.clone(),
            unacked,
        }
    }

    /// The binding colour of `t` if all its input places are marked.
    fn token_enabled(&self, t: u32) -> Option<Colour> {
        let st = &self.slice.transitions[t as usize];
        let mut colour: &Colour = &EMPTY;
        for &p in st.consume.iter().chain(&st.read) {
            let c = self.marking[p as usize].first()?;
            if c.len() > colour.len() {
                colour = c;
            }
        }
        Some(colour.clone())
    }

    /// Whether `t` may fire now with `colour`, all things considered.
    fn may_fire(&mut self, t: u32, colour: &Colour) -> bool {
        let now = self.now();
        let st = &self.slice.transitions[t as usize];
        match &st.transition.kind {
            TransitionKind::ActionEnd(a)
                if !self.succeeded.contains(&(a.instance, colour.clone())) =>
            {
                return false;
            }
            TransitionKind::ActionStart(a)
                if self.started_actions.contains(&(a.instance, colour.clone())) =>
            {
                // Never the same action twice for one colour: a net that
                // asks for it is broken, and flying it twice is worse.
                return false;
            }
            _ => {}
        }
        let delay = st.transition.delay;
        if let Some(g) = st.transition.guard.clone() {
            if !self.guard_holds(t, &g, colour) {
                return false;
            }
        }
        if let Some(delay) = delay {
            let key = (t, colour.clone());
            let since = match self.enabled_since.get(&key) {
                Some(since) => *since,
                None => {
                    self.enabled_since.insert(key, now);
                    // Journaled as it begins, so that a restart waits only
                    // for what is left of it.
                    let paused = Record::Paused(journal::Paused {
                        transition: self.slice.transitions[t as usize].transition.id.to_string(),
                        colour: colour.clone(),
                        time: now,
                        wall_ms: journal::Paused::wall_now_ms(),
                    });
                    if !self.journal(paused, false) {
                        return false;
                    }
                    now
                }
            };
            if now < since + delay {
                return false;
            }
        }
        true
    }

    fn guard_holds(&mut self, t: u32, g: &Guard, colour: &Colour) -> bool {
        if let Some(v) = g.holds_on_colour(colour) {
            return v;
        }
        let Some((cond, _)) = g.condition() else {
            return false;
        };
        let (value, reason) = match self.world.holds(cond) {
            Ok(v) => (g.holds_when(v), "false now".to_string()),
            Err(e) => (false, e.to_string()),
        };
        if !value && self.waiting_logged.insert((t, colour.clone())) {
            let st = &self.slice.transitions[t as usize];
            let condition = self.guard_text(g);
            self.emit(Kind::ConditionWaiting {
                transition: st.transition.id.to_string(),
                condition: condition.clone(),
                reason,
            });
        }
        value
    }

    fn guard_text(&self, g: &Guard) -> String {
        match g.condition() {
            Some((cond, negated)) => {
                let text = eamos_petri::pretty::expr(cond, &self.slice.drones);
                if negated {
                    format!("!({text})")
                } else {
                    text
                }
            }
            None => format!("{:?}", g.kind),
        }
    }

    /// Fires enabled transitions until none is left.
    fn fire_until_quiescent(&mut self) {
        loop {
            if self.ended.is_some() {
                return;
            }
            let mut candidates: Vec<u32> = self
                .marking
                .iter()
                .enumerate()
                .filter(|(_, tokens)| !tokens.is_empty())
                .flat_map(|(p, _)| self.consumers[p].iter().copied())
                .collect();
            candidates.sort();
            candidates.dedup();
            let mut fired = false;
            for t in candidates {
                let Some(colour) = self.token_enabled(t) else {
                    continue;
                };
                if self.may_fire(t, &colour) {
                    self.fire(t, colour);
                    fired = true;
                    break;
                }
            }
            if !fired {
                return;
            }
        }
    }

    fn fire(&mut self, t: u32, colour: Colour) {
        let st = self.slice.transitions[t as usize].clone();
        for &p in &st.consume {
            let tokens = &mut self.marking[p as usize];
            if !tokens.is_empty() {
                tokens.remove(0);
            }
        }
        for pr in &st.produce {
            let c = pr.colour.apply(&colour);
            let tokens = &mut self.marking[pr.place as usize];
            if !tokens.is_empty() {
                tracing::error!(
                    "{}: firing {} puts a second token in place {}: the net is not 1-safe (a compiler bug)",
                    self.slice.drone,
                    st.transition.id,
                    self.slice.places[pr.place as usize].id
                );
            }
            tokens.push(c);
        }
        self.enabled_since.remove(&(t, colour.clone()));
        let fired = Record::Fired {
            transition: st.transition.id.to_string(),
            colour: colour.clone(),
        };
        if !self.journal(fired, false) {
            return;
        }
        if self.first_firing.is_none() {
            self.first_firing = Some(self.now());
        }
        self.emit(Kind::Fired {
            transition: st.transition.id.to_string(),
            label: st.transition.label.to_string(),
            kind: kind_name(&st.transition.kind).to_string(),
            colour: colour.clone(),
        });
        self.emit_marking();
        let outs: Vec<_> = self.slice.sends(t).cloned().collect();
        for b in outs {
            let c = b.colour.apply(&colour);
            let seq = self.bridges.send(&b.to, &b.id.to_string(), c.clone());
            self.sent += 1;
            self.emit(Kind::BridgeSent {
                bridge: b.id,
                to: b.to.clone(),
                colour: c,
                seq,
            });
        }
        match &st.transition.kind {
            TransitionKind::ActionStart(a) => self.start_action(a, colour),
            TransitionKind::ActionEnd(a) => {
                self.succeeded.remove(&(a.instance, colour.clone()));
                self.running.remove(&(a.instance, colour));
                self.actions += 1;
            }
            TransitionKind::ActionCancel(a) => {
                let key = (a.instance, colour.clone());
                let token = self.running.remove(&key);
                if self.succeeded.remove(&key) {
                    // It ended just as it was interrupted: it did run.
                    self.actions += 1;
                } else if let Some(token) = token {
                    token.cancel();
                    self.actions_cancelled += 1;
                    self.emit(Kind::ActionCancelled {
                        action: a.name.to_string(),
                        instance: a.instance,
                        colour,
                    });
                }
            }
            _ => {}
        }
        if let Some(f) = self.slice.final_place {
            let me = self.me().to_string();
            if !self.marking[f as usize].is_empty() && !self.ends_reached.contains(&me) {
                if !self.relays_end() {
                    for p in self.options.peers.iter().filter(|p| **p != me) {
                        self.bridges.send(p, END, Vec::new());
                    }
                } else if me != GCS {
                    self.bridges.send(GCS, END, Vec::new());
                }
                self.end_reached(me);
            }
        }
    }

    /// The mission has ended when every owner holding an end has reached
    /// it: the slicer spreads the mission's last join over the drones that
    /// take part in it, so no token has to travel to say "I am done". Until
    /// then the slice plays on (a drone may have ended its part and still
    /// have tokens to pass on).
    fn end_reached(&mut self, by: String) {
        self.ends_reached.insert(by.clone());
        let all = self
            .slice
            .ends
            .iter()
            .all(|o| self.ends_reached.contains(o));
        if all && self.ended.is_none() {
            if self.relays_end() && self.me() == GCS {
                let me = self.me().to_string();
                let ends = &self.slice.ends;
                // A peer that holds every end knows already, and may be
                // gone: nothing to tell it.
                let told: Vec<PeerId> = self
                    .options
                    .peers
                    .iter()
                    .filter(|p| **p != me && !ends.iter().all(|o| o == *p))
                    .cloned()
                    .collect();
                for p in &told {
                    self.bridges.send(p, ENDED, Vec::new());
                }
            }
            self.emit(Kind::MissionEnded { by });
            self.ended = Some(Outcome::Completed);
        }
    }

    /// The end goes through the ground station when there is one: each
    /// owner of an end tells it, and it tells every peer once all have
    /// (every drone watches it anyway, see [`crate::liveness::neighbours`]).
    fn relays_end(&self) -> bool {
        self.options.peers.iter().any(|p| p == GCS)
    }

    /// The ground station says every end is reached.
    fn all_ended(&mut self, by: String) {
        self.ends_reached.extend(self.slice.ends.iter().cloned());
        self.end_reached(by);
    }

    fn start_action(&mut self, a: &eamos_petri::net::ActionRef, colour: Colour) {
        let key = (a.instance, colour.clone());
        self.started_actions.insert(key.clone());
        self.started_order.push(key.clone());
        let call = ActionCall::new(a.name.clone(), a.args.clone());
        // Journaled before the drone is asked, with the absolute target of
        // a motion: a crash from here on resumes it, never repeats it.
        let target = self.drone.as_ref().and_then(|d| d.motion_target(&call));
        let started = Record::Started(journal::Started {
            instance: a.instance,
            colour: colour.clone(),
            call: call.clone(),
            target,
            time: self.now(),
        });
        if !self.journal(started, true) {
            return;
        }
        self.emit(Kind::ActionStarted {
            action: a.name.to_string(),
            args: a.args.clone(),
            instance: a.instance,
            colour: colour.clone(),
            target,
        });
        let token = CancellationToken::new();
        self.running.insert(key, token.clone());
        let done = self.finished_tx.clone();
        let instance = a.instance;
        let action = call.to_string();
        match self.drone.clone() {
            Some(drone) => {
                tokio::spawn(async move {
                    let result = drone.run(&call, token).await;
                    let _ = done.send(Finished {
                        instance,
                        colour,
                        action,
                        result,
                    });
                });
            }
            None => {
                let _ = done.send(Finished {
                    instance,
                    colour,
                    action: action.clone(),
                    result: Err(ActionError::Unsupported { action }),
                });
            }
        }
    }

    fn on_finished(&mut self, f: Finished) {
        let finished = Record::Finished {
            instance: f.instance,
            colour: f.colour.clone(),
            error: f.result.as_ref().err().map(|e| e.kind().to_string()),
        };
        self.journal(finished, true);
        let key = (f.instance, f.colour.clone());
        let cancelled_by_us = !self.running.contains_key(&key);
        let (outcome, error) = match &f.result {
            Ok(()) => ("ok".to_string(), None),
            Err(e) => (e.kind().to_string(), Some(e.to_string())),
        };
        self.emit(Kind::ActionFinished {
            action: f.action.clone(),
            instance: f.instance,
            colour: f.colour.clone(),
            outcome,
            error: error.clone(),
        });
        match f.result {
            Ok(()) => {
                if !cancelled_by_us {
                    self.succeeded.insert(key);
                }
            }
            Err(_) if cancelled_by_us => {}
            Err(e) => {
                self.running.remove(&key);
                // The report is the drone's own: whoever prints it names it.
                let reason = e.to_string();
                let me = self.me().to_string();
                for p in self.options.peers.iter().filter(|p| **p != me) {
                    self.bridges.send(p, ABORT, Vec::new());
                }
                self.ended = Some(Outcome::Failed { reason });
            }
        }
    }

    fn on_delivered(&mut self, d: Delivered) {
        match d.bridge.as_str() {
            END => {
                self.end_reached(d.from);
                return;
            }
            ENDED => {
                self.all_ended(d.from);
                return;
            }
            ABORT => {
                self.on_abort(&d.from, &d.colour);
                return;
            }
            b if crate::liveness::read_stuck_notice(b).is_some() => {
                self.on_stuck_notice(&d.from, &d.bridge);
                return;
            }
            _ => {}
        }
        let Some(id) = d.bridge.parse::<u32>().ok() else {
            tracing::warn!("{}: token on unknown bridge `{}`", self.me(), d.bridge);
            return;
        };
        let Some(&inbox) = self.inboxes.get(&id) else {
            tracing::warn!("{}: token on bridge {id}, which is not ours", self.me());
            return;
        };
        self.alive.delivered.insert(id);
        self.received += 1;
        self.emit(Kind::BridgeReceived {
            bridge: id,
            from: d.from,
            colour: d.colour.clone(),
            seq: d.seq,
        });
        let tokens = &mut self.marking[inbox as usize];
        if !tokens.is_empty() {
            tracing::error!(
                "{}: bridge {id} delivers a second token into {}: the net is not 1-safe",
                self.slice.drone,
                self.slice.places[inbox as usize].id
            );
        }
        tokens.push(d.colour);
        self.emit_marking();
    }

    fn on_telemetry(&mut self, t: TelemetryFrame) {
        if t.mission != self.slice.mission_id {
            return;
        }
        let last = self.telemetry_seq.entry(t.drone.clone()).or_insert(0);
        if t.seq <= *last {
            return;
        }
        *last = t.seq;
        let Some(i) = self.world.index(&t.drone) else {
            return;
        };
        match postcard::from_bytes::<Telemetry>(&t.body) {
            Ok(tel) => self.world.set(i, tel),
            Err(e) => tracing::warn!("{}: bad telemetry from {}: {e}", self.me(), t.drone),
        }
    }

    /// The earliest mission time at which a timed transition becomes due.
    fn next_timer(&self) -> Option<f64> {
        self.enabled_since
            .iter()
            .filter_map(|((t, colour), since)| {
                let st = &self.slice.transitions[*t as usize];
                let still = self.token_enabled(*t).as_ref() == Some(colour);
                still.then(|| since + st.transition.delay.unwrap_or(0.0))
            })
            .min_by(f64::total_cmp)
    }

    /// Cancels every running action; returns how many will report back.
    fn cancel_all(&mut self) -> usize {
        let mut cancelled = 0;
        for (_, token) in self.running.drain() {
            token.cancel();
            cancelled += 1;
        }
        cancelled
    }

    /// Waits until `pending` cancelled actions have reported their end, or
    /// until [`CANCEL_SETTLE`] has passed: an adapter that does not honour a
    /// cancellation must not keep the failsafe from flying.
    async fn settle_cancelled(&mut self, mut pending: usize) {
        let deadline = tokio::time::Instant::now() + CANCEL_SETTLE;
        while pending > 0 {
            match tokio::time::timeout_at(deadline, self.finished_rx.recv()).await {
                Ok(Some(f)) => {
                    self.on_finished(f);
                    pending -= 1;
                }
                Ok(None) | Err(_) => break,
            }
        }
    }

    /// What the slice is waiting for: transitions that have their tokens
    /// but whose condition is false (or undecided), transitions that lack
    /// only a token from a peer, actions still running, pauses still
    /// counting.
    pub fn waiting(&self) -> Vec<String> {
        let mut out = Vec::new();
        let at = |t: &eamos_slicer::SliceTransition| match &self.options.source {
            Some(src) => format!(" at {}", src.location(t.transition.span)),
            None => String::new(),
        };
        let mut seen = HashSet::new();
        for (p, tokens) in self.marking.iter().enumerate() {
            if tokens.is_empty() {
                continue;
            }
            for &t in &self.consumers[p] {
                if !seen.insert(t) {
                    continue;
                }
                let st = &self.slice.transitions[t as usize];
                let inputs: Vec<u32> = st.consume.iter().chain(&st.read).copied().collect();
                let missing: Vec<u32> = inputs
                    .iter()
                    .copied()
                    .filter(|q| self.marking[*q as usize].is_empty())
                    .collect();
                if missing.is_empty() {
                    let colour = self.token_enabled(t).unwrap_or_default();
                    if let TransitionKind::ActionEnd(a) = &st.transition.kind {
                        out.push(format!(
                            "{}: action {}.{} still running{}",
                            self.me(),
                            self.slice.drones[a.drone.0 as usize],
                            ActionCall::new(a.name.clone(), a.args.clone()),
                            at(st)
                        ));
                        continue;
                    }
                    if let Some(g) = &st.transition.guard {
                        if g.condition().is_some() {
                            let state = match g.condition().map(|(c, _)| self.world.holds(c)) {
                                Some(Ok(v)) if !g.holds_when(v) => "false".to_string(),
                                Some(Ok(_)) => "true".to_string(),
                                Some(Err(e)) => format!("undecided: {e}"),
                                None => String::new(),
                            };
                            if state != "true" {
                                let cond = self.guard_text(g);
                                let what = if st.transition.label.contains(&cond) {
                                    "its condition".to_string()
                                } else {
                                    format!("`{cond}`")
                                };
                                out.push(format!(
                                    "{}: `{}` ({}){} has its tokens and waits for {what} ({state} now)",
                                    self.me(),
                                    st.transition.label,
                                    st.transition.id,
                                    at(st),
                                ));
                            }
                            continue;
                        }
                    }
                    if let Some(delay) = st.transition.delay {
                        let since = self
                            .enabled_since
                            .get(&(t, colour))
                            .copied()
                            .unwrap_or(self.now());
                        out.push(format!(
                            "{}: `{}` ({}){} pauses, {:.1} s left",
                            self.me(),
                            st.transition.label,
                            st.transition.id,
                            at(st),
                            (since + delay - self.now()).max(0.0)
                        ));
                    }
                } else {
                    let from_peers: Vec<String> = missing
                        .iter()
                        .filter_map(|q| {
                            self.slice
                                .bridges_in
                                .iter()
                                .find(|b| b.inbox == *q)
                                .map(|b| format!("{} (bridge {})", b.from, b.id))
                        })
                        .collect();
                    if !from_peers.is_empty() && from_peers.len() == missing.len() {
                        out.push(format!(
                            "{}: `{}` ({}){} waits for a bridge message from {}",
                            self.me(),
                            st.transition.label,
                            st.transition.id,
                            at(st),
                            from_peers.join(", ")
                        ));
                    }
                }
            }
        }
        out
    }
}

static EMPTY: Colour = Vec::new();

/// A stable short name of a transition kind for the log.
pub fn kind_name(k: &TransitionKind) -> &'static str {
    match k {
        TransitionKind::Init => "init",
        TransitionKind::ActionStart(_) => "action_start",
        TransitionKind::ActionEnd(_) => "action_end",
        TransitionKind::ActionCancel(_) => "action_cancel",
        TransitionKind::Skip => "skip",
        TransitionKind::Fork => "fork",
        TransitionKind::Join => "join",
        TransitionKind::Branch => "branch",
        TransitionKind::Merge => "merge",
        TransitionKind::LoopBack => "loop_back",
        TransitionKind::Pause => "pause",
        TransitionKind::Signal => "signal",
        TransitionKind::Await => "await",
        TransitionKind::Interrupt => "interrupt",
        TransitionKind::Finish => "finish",
        TransitionKind::Silent => "silent",
    }
}

async fn changed(rx: &mut Option<watch::Receiver<Telemetry>>) -> bool {
    match rx {
        Some(rx) => rx.changed().await.is_ok(),
        None => std::future::pending().await,
    }
}

async fn sleep_until(clock: &MissionClock, t: Option<f64>) {
    match t {
        Some(t) => clock.sleep_until(t).await,
        None => std::future::pending().await,
    }
}

/// Publishes this drone's telemetry for the remote conditions that read
/// it: on every change, at most every few milliseconds of wall time, and
/// again now and then so that a peer that joins late learns the state of a
/// drone that does not move.
async fn publish_telemetry(
    link: Arc<dyn Link>,
    mission: String,
    drone: String,
    mut rx: watch::Receiver<Telemetry>,
    stop: CancellationToken,
) {
    // Numbered from the wall clock, so that the samples of an agent
    // restarted after a crash are not taken by its peers for old ones.
    let mut seq = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64);
    let mut heartbeat = tokio::time::interval(Duration::from_millis(250));
    heartbeat.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        tokio::select! {
            _ = stop.cancelled() => return,
            r = rx.changed() => if r.is_err() { return },
            _ = heartbeat.tick() => {}
        }
        let t = *rx.borrow_and_update();
        seq += 1;
        let frame = TelemetryFrame {
            mission: mission.clone(),
            drone: drone.clone(),
            seq,
            body: postcard::to_stdvec(&t).expect("telemetry serialises"),
        };
        if let Err(e) = link.publish_telemetry(&frame).await {
            tracing::debug!("{drone}: telemetry not published: {e}");
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}
