//! Rows of steps, which a walk for one drone crosses in one jump up to its
//! drone's next action (see `walk.rs`).
//!
//! Between two of its actions a drone's next one is often many steps away
//! down a `SEQ_` block of other drones' actions, pauses, blocks, loops and
//! choices, and a walk went through them one by one: its steps grew with
//! the fleet (19 a walk at 50 drones, 52 at 500, 118 at 1,000), and the
//! walks, as many as the actions, with its square. A step (`step.rs`) is a
//! fragment of control flow with one way in and one way out; a walk for a
//! drone with no action in it comes out at its end with the colour it
//! came with, and meets nothing it is asked about in between (a stop, a
//! guard it cannot pass, a join's inputs). Steps in a row form a chain; a
//! walk in a chain jumps to the place before the next step that holds one
//! of its drone's actions (or, after a cancel, touches a `Do` region's
//! state, which it must walk itself), or to the chain's last place.

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use eamos_petri::net::NodeId;

use super::step::Step;

#[derive(Default)]
pub(crate) struct Chains {
    /// By node index, each place a chain jumps from: the chain and its
    /// place in it (`NONE` elsewhere). An array: a walk asks at every
    /// place it comes to, a hash map's probe was a fifth of its time.
    at: Vec<(u32, u32)>,
    chains: Vec<Chain>,
}

const NONE: (u32, u32) = (u32::MAX, u32::MAX);

struct Chain {
    /// Its places in order; the last may start a chain of its own.
    places: Vec<NodeId>,
    /// By drone then by position `i`: the step from place `i - 1` to `i`
    /// holds an action of the drone (or a guard on its state).
    own: Vec<(u16, u32)>,
    /// The positions `i` whose step from place `i - 1` touches a `Do`
    /// region's state, in order.
    regional: Vec<u32>,
}

impl Chains {
    /// `steps`: the step starting at each place that starts one, of a
    /// net of `nodes` nodes.
    pub(crate) fn new(steps: &HashMap<NodeId, Step>, nodes: usize) -> Self {
        let mut chains = Chains {
            at: vec![NONE; nodes],
            chains: Vec::new(),
        };
        let led_into: HashSet<NodeId> = steps.values().map(|s| s.to).collect();
        // Chains start where no step leads in, then (places on a cycle of
        // steps) anywhere not yet in one; a place belongs to the first
        // chain that reaches it, and ends any other that does.
        let mut heads: Vec<NodeId> = steps.keys().copied().collect();
        heads.sort_unstable_by_key(|p| (led_into.contains(p), *p));
        for head in heads {
            if chains.at[head.index()] != NONE {
                continue;
            }
            let id = chains.chains.len() as u32;
            let mut chain = Chain {
                places: vec![head],
                own: Vec::new(),
                regional: Vec::new(),
            };
            chains.at[head.index()] = (id, 0);
            let mut p = head;
            while let Some(step) = steps.get(&p) {
                let i = chain.places.len() as u32;
                chain.own.extend(step.drones.iter().map(|&d| (d, i)));
                if step.regional {
                    chain.regional.push(i);
                }
                chain.places.push(step.to);
                p = step.to;
                if chains.at[p.index()] != NONE || !steps.contains_key(&p) {
                    break;
                }
                chains.at[p.index()] = (id, i);
            }
            chain.own.sort_unstable();
            chains.chains.push(chain);
        }
        chains
    }

    /// Where a walk for `drone` at `p` can jump to, further down `p`'s
    /// chain: the place before the next step with one of its drone's
    /// actions (or, where the walk skips a cancelled `Do` region's steps,
    /// `cut`, the next step touching a region), or the chain's last.
    pub(crate) fn jump(&self, p: NodeId, drone: u16, cut: bool) -> Option<NodeId> {
        let &(c, i) = self.at.get(p.index()).filter(|&&at| at != NONE)?;
        let chain = &self.chains[c as usize];
        let k = chain.own.partition_point(|&r| r <= (drone, i));
        let mut to = match chain.own.get(k) {
            Some(&(d, at)) if d == drone => at - 1,
            _ => chain.places.len() as u32 - 1,
        };
        if cut {
            let k = chain.regional.partition_point(|&r| r <= i);
            if let Some(&at) = chain.regional.get(k) {
                to = to.min(at - 1);
            }
        }
        (to > i).then(|| chain.places[to as usize])
    }
}
