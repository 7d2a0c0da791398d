//! Liveness: who is up, who is lost, and what a drone that waits on a lost
//! peer does about it.
//!
//! Every peer announces itself (a zenoh liveliness token, or the in-process
//! hub's presence set) and watches the others through
//! [`crate::transport::Link::presence`]. A peer seen once and then gone is
//! *lost*; a lost peer seen again within the grace period was never lost
//! as far as the mission is concerned.
//!
//! A drone is *stuck* on a lost peer when it has nothing left to do on its
//! own (no action running, no pause counting) and waits for something only
//! that peer would send: a token (a transition whose missing inputs are all
//! inboxes of bridges from it, or, when the drone holds no token at all,
//! bridges from it being the only ones still to deliver, see
//! [`waits_for_handover`]) or telemetry (a condition with all its tokens
//! that has no answer because it reads the lost peer and no drone up but
//! this one: the peer's last telemetry, frozen, is no answer). A drone that
//! has lost every one of its [`neighbours`], the ground station included,
//! is stuck on all of them as soon as it is idle: nobody can tell it the
//! mission ended or was aborted, so it decides alone (a drone follows
//! whether its neighbours are up, not the whole fleet). Drones that do not
//! wait on the lost peer carry on untouched.
//!
//! Once the grace period has passed, a stuck drone follows the policy its
//! fleet file declares ([`OnLost`]) and tells the ground station, which
//! reports who is lost and who is stuck because of it.

use std::collections::{BTreeMap, BTreeSet};

use eamos_petri::net::Colour;
use eamos_slicer::Slice;

use crate::names::PeerId;

pub use eamos_fleet::policy::{parse_duration, Grace, Liveness, OnLost, DEFAULT_GRACE};

/// The peers a drone must see before the mission starts: those it has
/// bridges with (either way), the drones whose telemetry its conditions
/// read, and the ground station. They are every peer it may ever wait on
/// ([`waits_on`], [`waits_for_handover`], a condition's frozen telemetry),
/// so once it has seen them all it can tell each of them lost from late;
/// the rest of the fleet it need not wait for. The slicer knows them: a
/// handful per drone, whatever the fleet's size.
pub fn neighbours(slice: &Slice) -> Vec<PeerId> {
    let mut out: BTreeSet<PeerId> = slice
        .peers
        .iter()
        .chain(&slice.telemetry)
        .chain(slice.bridges_in.iter().map(|b| &b.from))
        .chain(slice.bridges_out.iter().map(|b| &b.to))
        .cloned()
        .collect();
    out.insert(crate::names::GCS.to_string());
    out.remove(&slice.drone);
    out.into_iter().collect()
}

/// The peers whose tokens the marking waits for: every transition that has
/// some input tokens and lacks only tokens from bridges names the senders
/// of those bridges.
pub fn waits_on(slice: &Slice, marking: &[Vec<Colour>]) -> BTreeSet<PeerId> {
    let inbox_from: BTreeMap<u32, &str> = slice
        .bridges_in
        .iter()
        .map(|b| (b.inbox, b.from.as_str()))
        .collect();
    let marked = |p: u32| marking.get(p as usize).is_some_and(|t| !t.is_empty());
    let mut out = BTreeSet::new();
    for t in &slice.transitions {
        let inputs: Vec<u32> = t.consume.iter().chain(&t.read).copied().collect();
        if !inputs.iter().any(|&p| marked(p)) {
            continue;
        }
        let missing: Vec<u32> = inputs.iter().copied().filter(|&p| !marked(p)).collect();
        if missing.is_empty() || !missing.iter().all(|p| inbox_from.contains_key(p)) {
            continue;
        }
        out.extend(missing.iter().map(|p| inbox_from[p].to_string()));
    }
    out
}

/// The peers a drone that holds no token waits on. With nothing marked
/// (and its end of the mission not reached), its next token can only come
/// over a bridge; when every bridge into it that has not delivered yet in
/// this run comes from lost peers, only they can send it: the thread of
/// the mission is with them (a condition that only they answer is decided
/// on their side, for instance). `delivered` holds the bridges that have
/// delivered. A bridge of a loop that delivered once may deliver again, so
/// a live sender of one keeps the drone from counting as stuck only until
/// it has delivered: the rule errs towards waiting, never towards a guess.
pub fn waits_for_handover(
    slice: &Slice,
    marking: &[Vec<Colour>],
    delivered: &BTreeSet<u32>,
    lost: &BTreeSet<PeerId>,
) -> BTreeSet<PeerId> {
    if marking.iter().any(|tokens| !tokens.is_empty()) {
        return BTreeSet::new();
    }
    let pending: BTreeSet<&str> = slice
        .bridges_in
        .iter()
        .filter(|b| !delivered.contains(&b.id))
        .map(|b| b.from.as_str())
        .collect();
    if pending.is_empty() || !pending.iter().all(|p| lost.contains(*p)) {
        return BTreeSet::new();
    }
    pending.into_iter().map(str::to_string).collect()
}

/// The control bridge on which a stuck drone tells the ground station.
const STUCK_PREFIX: &str = "stuck:";

/// The name of the notice "I am stuck on `lost` and apply `policy`".
pub fn stuck_notice(lost: &str, policy: OnLost) -> String {
    format!("{STUCK_PREFIX}{lost}:{policy}")
}

/// Reads a notice made by [`stuck_notice`].
pub fn read_stuck_notice(bridge: &str) -> Option<(String, OnLost)> {
    let rest = bridge.strip_prefix(STUCK_PREFIX)?;
    let (lost, policy) = rest.rsplit_once(':')?;
    Some((lost.to_string(), OnLost::parse(policy)?))
}

/// Who is up and who has been lost since when, as one peer sees it.
#[derive(Debug, Default)]
pub struct Watch {
    /// Peers seen up at least once.
    seen: BTreeSet<PeerId>,
    present: BTreeSet<PeerId>,
    /// Lost peers, with the mission time they disappeared.
    lost: BTreeMap<PeerId, f64>,
}

/// A change worth logging.
#[derive(Debug, Clone, PartialEq)]
pub enum Change {
    Lost(PeerId),
    Back(PeerId),
}

impl Watch {
    /// Takes the latest presence set at mission time `now`; returns who was
    /// lost and who came back. A peer never seen is not lost, only late.
    pub fn update(&mut self, me: &str, present: &BTreeSet<PeerId>, now: f64) -> Vec<Change> {
        let mut changes = Vec::new();
        for p in present.iter().filter(|p| p.as_str() != me) {
            self.seen.insert(p.clone());
            if self.lost.remove(p).is_some() {
                changes.push(Change::Back(p.clone()));
            }
        }
        for p in self.present.iter().filter(|p| p.as_str() != me) {
            if !present.contains(p) && !self.lost.contains_key(p) {
                self.lost.insert(p.clone(), now);
                changes.push(Change::Lost(p.clone()));
            }
        }
        self.present = present.clone();
        changes
    }

    /// Lost peers whose grace period has passed at `now`.
    pub fn lost_for(&self, grace: f64, now: f64) -> BTreeSet<PeerId> {
        self.lost
            .iter()
            .filter(|(_, since)| now >= *since + grace)
            .map(|(p, _)| p.clone())
            .collect()
    }

    /// When the next grace period ends (mission time), if a peer is lost
    /// and still within it.
    pub fn next_deadline(&self, grace: f64, now: f64) -> Option<f64> {
        self.lost
            .values()
            .map(|since| since + grace)
            .filter(|t| *t > now)
            .min_by(f64::total_cmp)
    }

    pub fn is_lost(&self, peer: &str) -> bool {
        self.lost.contains_key(peer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(peers: &[&str]) -> BTreeSet<PeerId> {
        peers.iter().map(|p| p.to_string()).collect()
    }

    #[test]
    fn a_peer_seen_and_then_gone_is_lost_and_one_never_seen_is_only_late() {
        let mut w = Watch::default();
        assert!(w.update("D1", &set(&["D1", "GCS"]), 0.0).is_empty());
        assert_eq!(
            w.update("D1", &set(&["D1"]), 2.0),
            vec![Change::Lost("GCS".into())]
        );
        assert!(w.is_lost("GCS") && !w.is_lost("D2"));
        assert_eq!(w.lost_for(5.0, 6.0), set(&[]));
        assert_eq!(w.next_deadline(5.0, 6.0), Some(7.0));
        assert_eq!(w.lost_for(5.0, 7.0), set(&["GCS"]));
    }

    #[test]
    fn a_peer_back_within_the_grace_period_is_no_longer_lost() {
        let mut w = Watch::default();
        w.update("D1", &set(&["D1", "D2"]), 0.0);
        w.update("D1", &set(&["D1"]), 1.0);
        assert_eq!(
            w.update("D1", &set(&["D1", "D2"]), 3.0),
            vec![Change::Back("D2".into())]
        );
        assert!(w.lost_for(0.0, 100.0).is_empty());
        assert_eq!(w.next_deadline(5.0, 3.0), None);
    }

    #[test]
    fn a_stuck_notice_names_the_lost_peer_and_the_policy() {
        let n = stuck_notice("D2", OnLost::Home);
        assert_eq!(read_stuck_notice(&n), Some(("D2".into(), OnLost::Home)));
        assert_eq!(read_stuck_notice("stuck:D2:fly"), None);
        assert_eq!(read_stuck_notice("17"), None);
    }
}
