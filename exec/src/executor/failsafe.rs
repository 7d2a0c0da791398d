//! The executor's side of liveness and abort (see [`crate::liveness`] and
//! [`crate::abort`]): watching who is up, deciding when this drone is
//! stuck on a lost peer, obeying and passing on aborts, and flying the
//! failsafe exactly once per run.

use std::collections::BTreeSet;
use std::time::Duration;

use tokio::sync::watch;

use eamos_mid::{ActionError, Failsafe};
use eamos_petri::net::Colour;

use super::{Executor, Outcome, ABORT};
use crate::abort;
use crate::event::Kind;
use crate::guard::EvalError;
use crate::liveness::{self, Change, OnLost, Watch};
use crate::transport::{PeerId, GCS};

/// How long a failsafe may take before the executor gives up waiting on it
/// (wall time; a landing from altitude takes a while).
const FAILSAFE_TIMEOUT: Duration = Duration::from_secs(300);

#[derive(Debug, Default)]
pub(super) struct State {
    watch: Watch,
    /// Lost peers this drone already acted on (a holding drone does not
    /// hold again); forgotten when the peer comes back.
    stuck_on: BTreeSet<PeerId>,
    /// The failsafe ran: it never runs twice in one run, whatever ends it.
    failsafe_done: bool,
    /// Bridges into this slice that have delivered a token in this run (or
    /// before a crash, by the journal).
    pub(super) delivered: BTreeSet<u32>,
}

/// The next presence set, or `None` once the link stops telling.
pub(super) async fn presence_changed(
    rx: &mut Option<watch::Receiver<BTreeSet<PeerId>>>,
) -> Option<BTreeSet<PeerId>> {
    match rx {
        Some(rx) => match rx.changed().await {
            Ok(()) => Some(rx.borrow_and_update().clone()),
            Err(_) => None,
        },
        None => std::future::pending().await,
    }
}

impl Executor {
    /// Takes the peers up now (only the mission's peers count: a passing
    /// `eamos abort` is nobody's peer).
    pub(super) fn on_presence(&mut self, up: BTreeSet<PeerId>) {
        let up: BTreeSet<PeerId> = up
            .into_iter()
            .filter(|p| self.options.peers.contains(p))
            .collect();
        let now = self.now();
        let me = self.me().to_string();
        tracing::debug!("{me}: peers up at {now:.2} s: {up:?}");
        for change in self.alive.watch.update(&me, &up, now) {
            match change {
                Change::Lost(peer) => {
                    if let Some(i) = self.world.index(&peer) {
                        self.world.set_lost(i, true);
                    }
                    self.emit(Kind::PeerLost { peer: peer.clone() });
                }
                Change::Back(peer) => {
                    if let Some(i) = self.world.index(&peer) {
                        self.world.set_lost(i, false);
                    }
                    self.alive.stuck_on.remove(&peer);
                    self.emit(Kind::PeerBack { peer: peer.clone() });
                }
            }
        }
    }

    /// When the grace period of the next lost peer ends.
    pub(super) fn grace_ends(&self) -> Option<f64> {
        self.alive
            .watch
            .next_deadline(self.options.liveness.grace, self.now())
    }

    /// Applies the fleet's policy if this drone, with nothing left to do on
    /// its own, waits on a peer lost for the grace period (or has lost every
    /// neighbour, the ground station included, and must decide alone).
    pub(super) fn check_lost(&mut self) {
        if self.ended.is_some() {
            return;
        }
        let lost = self
            .alive
            .watch
            .lost_for(self.options.liveness.grace, self.now());
        if lost.is_empty() {
            return;
        }
        let idle = self.running.is_empty() && self.next_timer().is_none();
        if !idle {
            return;
        }
        let me = self.me().to_string();
        let mut on: BTreeSet<PeerId> = liveness::waits_on(&self.slice, &self.marking)
            .intersection(&lost)
            .cloned()
            .collect();
        on.extend(self.conditions_wait_on(&lost));
        on.extend(liveness::waits_for_handover(
            &self.slice,
            &self.marking,
            &self.alive.delivered,
            &lost,
        ));
        // A drone follows its neighbours only (a link may tell it of
        // nobody else): it is cut off once it has lost them all.
        let followed = match self.drone {
            Some(_) => liveness::neighbours(&self.slice),
            None => self.options.peers.clone(),
        };
        let mut others = followed.iter().filter(|p| **p != me).peekable();
        let isolated = others.peek().is_some() && others.all(|p| lost.contains(p));
        if isolated && self.drone.is_none() {
            // The ground station with every peer gone, each for the grace
            // period: no token, end notice or report can reach it any more,
            // and the drones decide alone. It says so and stops following.
            let lost: Vec<String> = lost.into_iter().collect();
            self.emit(Kind::Isolated { lost: lost.clone() });
            self.ended = Some(Outcome::PeerLost {
                lost,
                failsafe: Failsafe::Hold,
            });
            return;
        }
        if isolated && self.drone.is_some() {
            on.extend(lost.iter().cloned());
        }
        on.retain(|p| !self.alive.stuck_on.contains(p));
        if on.is_empty() {
            return;
        }
        self.alive.stuck_on.extend(on.iter().cloned());
        let policy = self.options.liveness.on_lost;
        let lost: Vec<String> = on.into_iter().collect();
        self.emit(Kind::Stuck {
            lost: lost.clone(),
            policy: policy.to_string(),
        });
        if self.drone.is_none() {
            // The ground station flies nothing: it reports and follows on.
            return;
        }
        if me != GCS {
            for l in &lost {
                self.bridges
                    .send(GCS, &liveness::stuck_notice(l, policy), Vec::new());
            }
        }
        match policy {
            OnLost::Hold => {}
            OnLost::Land | OnLost::Home => {
                let failsafe = if policy == OnLost::Land {
                    Failsafe::Land
                } else {
                    Failsafe::Home
                };
                self.ended = Some(Outcome::PeerLost { lost, failsafe });
            }
            OnLost::Abort => {
                self.abort_peers(None, Vec::new());
                self.ended = Some(Outcome::Aborted {
                    reason: format!("{me} aborted the mission: lost {}", lost.join(", ")),
                });
            }
        }
    }

    /// The lost peers whose telemetry a condition of this slice waits for
    /// and only they could send: a transition that has all its tokens and
    /// whose condition has no answer because it reads a lost drone (its
    /// frozen last telemetry is no answer, see [`crate::guard`]), and that
    /// reads no drone but this one and drones lost for the grace period. A
    /// condition that also reads a drone still up is not stuck: that drone
    /// may yet answer it.
    fn conditions_wait_on(&self, lost: &BTreeSet<PeerId>) -> BTreeSet<PeerId> {
        let mut out = BTreeSet::new();
        for (t, st) in self.slice.transitions.iter().enumerate() {
            let Some(g) = &st.transition.guard else {
                continue;
            };
            let Some((cond, _)) = g.condition() else {
                continue;
            };
            let Some(colour) = self.token_enabled(t as u32) else {
                continue;
            };
            if g.holds_on_colour(&colour).is_some()
                || !matches!(self.world.holds(cond), Err(EvalError::Lost(_)))
            {
                continue;
            }
            let read: BTreeSet<PeerId> = cond
                .drones()
                .iter()
                .filter(|d| Some(d.0) != self.own_index)
                .filter_map(|d| self.slice.drones.get(d.0 as usize).cloned())
                .collect();
            if !read.is_empty() && read.is_subset(lost) {
                out.extend(read);
            }
        }
        out
    }

    /// Tells every other peer (but `except`) to abort, with `colour` (empty
    /// for a peer abort, the command for a command passed on).
    pub(super) fn abort_peers(&mut self, except: Option<&str>, colour: Colour) {
        let me = self.me().to_string();
        let to: Vec<PeerId> = self
            .options
            .peers
            .iter()
            .filter(|p| **p != me && Some(p.as_str()) != except)
            .cloned()
            .collect();
        for p in to {
            self.bridges.send(&p, ABORT, colour.clone());
        }
    }

    /// An abort arrived: obeyed and passed on if it is valid, logged and
    /// ignored otherwise.
    pub(super) fn on_abort(&mut self, from: &str, colour: &[u32]) {
        let verdict = abort::accept(
            from,
            colour,
            &self.slice.mission_id,
            &self.options.peers,
            self.options.abort_opener.as_ref(),
        );
        match verdict {
            Ok(origin) => {
                let reason = origin.describe();
                self.emit(Kind::AbortReceived {
                    from: from.to_string(),
                    reason: reason.clone(),
                });
                if self.options.pass_on_aborts {
                    self.abort_peers(Some(from), colour.to_vec());
                }
                self.ended = Some(Outcome::Aborted { reason });
            }
            Err(reason) => {
                tracing::warn!("{}: {reason}", self.me());
                self.emit(Kind::AbortRefused {
                    from: from.to_string(),
                    reason: reason.clone(),
                });
            }
        }
    }

    /// A drone says it is stuck on a lost peer (the ground station reports
    /// it).
    pub(super) fn on_stuck_notice(&mut self, from: &str, bridge: &str) {
        let Some((lost, policy)) = liveness::read_stuck_notice(bridge) else {
            return;
        };
        self.emit(Kind::PeerStuck {
            peer: from.to_string(),
            lost: lost.clone(),
            policy: policy.to_string(),
        });
    }

    /// The failsafe that ends a run that did not complete: the policy's for
    /// a lost peer, the fleet's abort failsafe for anything else.
    pub(super) async fn failsafe_at_end(&mut self, outcome: &Outcome) {
        let (kind, reason) = match outcome {
            Outcome::Completed => return,
            Outcome::PeerLost { lost, failsafe } => {
                (*failsafe, format!("lost {}", lost.join(", ")))
            }
            Outcome::Aborted { reason } => (self.options.liveness.on_abort, reason.clone()),
            Outcome::Failed { reason } => (self.options.liveness.on_abort, reason.clone()),
            Outcome::TimeLimit { .. } => (self.options.liveness.on_abort, "time limit".into()),
            Outcome::Stopped => (self.options.liveness.on_abort, "stopped".into()),
        };
        self.failsafe(kind, reason).await;
    }

    /// Flies `kind`, at most once per run.
    async fn failsafe(&mut self, kind: Failsafe, reason: String) {
        let Some(drone) = self.drone.clone() else {
            return;
        };
        if std::mem::replace(&mut self.alive.failsafe_done, true) {
            return;
        }
        let airborne = !drone.telemetry().borrow().landed;
        self.emit(Kind::Failsafe {
            failsafe: kind.to_string(),
            reason,
            airborne,
        });
        if !airborne {
            return;
        }
        let result = tokio::time::timeout(FAILSAFE_TIMEOUT, drone.failsafe(kind))
            .await
            .unwrap_or_else(|_| {
                Err(ActionError::Timeout {
                    action: format!("failsafe {kind}"),
                    what: "the end of the failsafe".into(),
                })
            });
        let (outcome, error) = match &result {
            Ok(()) => ("ok".to_string(), None),
            Err(e) => (e.kind().to_string(), Some(e.to_string())),
        };
        self.emit(Kind::FailsafeFinished {
            failsafe: kind.to_string(),
            outcome,
            error,
        });
    }
}
