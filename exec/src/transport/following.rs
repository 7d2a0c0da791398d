//! Whose liveliness tokens a zenoh peer follows, and through which key
//! expressions it hears them.
//!
//! A drone follows its neighbours (every peer it may ever wait on), the
//! ground station every peer. Most drones have a handful of neighbours and
//! declare one liveliness subscriber each, so they never hear the rest of
//! a fleet of hundreds come and go. A drone holding a block's fork or join
//! over the whole fleet has hundreds: one subscriber per neighbour (twice,
//! for the alive and the version tokens) held some 2 kB of zenoh's state
//! each, a megabyte at 250 drones. Past [`ONE_BY_ONE`] neighbours it
//! subscribes once to every peer's token and keeps the ones it follows:
//! what it hears of the few others costs less than what it saved.

use std::collections::HashSet;

use super::PeerId;

/// The most peers followed by one subscriber each.
pub const ONE_BY_ONE: usize = 32;

/// The peers one peer follows.
#[derive(Debug, Clone)]
pub enum Following {
    /// Every peer of the mission.
    All,
    /// These peers and itself.
    Some(HashSet<PeerId>),
}

impl Following {
    /// `follow`'s peers and `me`, or every peer.
    pub fn new(me: &str, follow: Option<&[PeerId]>) -> Self {
        match follow {
            None => Self::All,
            Some(peers) => Self::Some(
                peers
                    .iter()
                    .cloned()
                    .chain(std::iter::once(me.to_string()))
                    .collect(),
            ),
        }
    }

    /// The peer-name chunks to subscribe to: one per followed peer, or `*`
    /// for every peer.
    pub fn chunks(&self) -> Vec<&str> {
        match self {
            Self::Some(peers) if peers.len() <= ONE_BY_ONE => {
                let mut chunks: Vec<&str> = peers.iter().map(String::as_str).collect();
                chunks.sort_unstable();
                chunks
            }
            _ => vec!["*"],
        }
    }

    /// Whether a token of `peer`, heard through [`Self::chunks`], is one
    /// this peer follows.
    pub fn admits(&self, peer: &str) -> bool {
        match self {
            Self::All => true,
            Self::Some(peers) => peers.contains(peer),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drones(n: usize) -> Vec<PeerId> {
        (1..=n).map(|k| format!("D{k}")).collect()
    }

    #[test]
    fn a_drone_with_few_neighbours_subscribes_to_each_and_itself() {
        let following = Following::new("D1", Some(&["GCS".to_string(), "D2".to_string()]));
        assert_eq!(following.chunks(), ["D1", "D2", "GCS"]);
        assert!(following.admits("D2"));
        assert!(!following.admits("D3"));
    }

    #[test]
    fn a_drone_following_most_of_a_large_fleet_hears_everyone_and_keeps_its_own() {
        let neighbours = drones(200);
        let following = Following::new("D0", Some(&neighbours));
        assert_eq!(following.chunks(), ["*"]);
        assert!(following.admits("D0"), "itself");
        assert!(following.admits("D200"));
        assert!(!following.admits("D201"), "a drone it does not follow");
    }

    #[test]
    fn the_ground_station_follows_every_peer() {
        let following = Following::new("GCS", None);
        assert_eq!(following.chunks(), ["*"]);
        assert!(following.admits("D999"));
    }
}
