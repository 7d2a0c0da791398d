//! Runs of plain steps, which a walk for one drone crosses in one jump up
//! to its drone's next action (see `walk.rs`).
//!
//! Between two of its actions a drone's next one is often many steps away
//! down a `SEQ_` block of other drones' actions and pauses, and a walk
//! went through them one by one: its steps grew with the fleet (19 a walk
//! at 50 drones, 52 at 500, 118 at 1,000), and the walks, as many as the
//! actions, with its square. A *plain* step takes its one input, the only
//! place it is offered to, and puts the token, its colour kept, into one
//! place, with no guard, no read arc, no fork or join: a walk that comes
//! to its input can only go on to its output, and nothing it is asked
//! about (a stop, a guard it cannot pass, a `Do` body after a cancel, a
//! join's inputs) happens in between. Plain steps in a row form a chain,
//! broken where two of them meet; a walk in a chain jumps to the place
//! before the next start of one of its drone's actions there (the start
//! may be a stop), or to the chain's last place.

use rustc_hash::FxHashMap as HashMap;

use eamos_petri::net::{ArcKind, ColourOp, Net, NodeId, PlaceKind, TransitionKind};

pub(crate) struct Chains {
    /// Each place in a chain: the chain and its place in it.
    at: HashMap<NodeId, (u32, u32)>,
    chains: Vec<Chain>,
}

struct Chain {
    places: Vec<NodeId>,
    /// The running places in it, by drone then by position: a drone's
    /// action starts with the step into the one before.
    running: Vec<(u16, u32)>,
}

impl Chains {
    /// `followed`: the places a walk follows (see `Walker::followed`).
    pub(crate) fn new(net: &Net, followed: impl Fn(NodeId) -> bool) -> Self {
        let mut next: HashMap<NodeId, NodeId> = HashMap::default();
        let mut before: HashMap<NodeId, u32> = HashMap::default();
        for (p, _) in net.places().filter(|&(p, _)| followed(p)) {
            if let Some(q) = plain_step_from(net, p, &followed) {
                next.insert(p, q);
                *before.entry(q).or_default() += 1;
            }
        }
        let mut chains = Chains {
            at: HashMap::default(),
            chains: Vec::new(),
        };
        // A chain starts where no single plain step leads in; places on a
        // cycle of plain steps have no start and are walked step by step.
        let heads = next.keys().copied().filter(|p| before.get(p) != Some(&1));
        let mut heads: Vec<NodeId> = heads.collect();
        heads.sort_unstable();
        for head in heads {
            let mut places = vec![head];
            let mut p = head;
            while let Some(&q) = next.get(&p) {
                if before.get(&q) != Some(&1) {
                    break;
                }
                places.push(q);
                p = q;
            }
            let id = chains.chains.len() as u32;
            let mut running = Vec::new();
            for (i, &p) in places.iter().enumerate() {
                chains.at.insert(p, (id, i as u32));
                if let Some(PlaceKind::Running(a)) = net.place(p).map(|p| &p.kind) {
                    running.push((a.drone.0, i as u32));
                }
            }
            running.sort_unstable();
            chains.chains.push(Chain { places, running });
        }
        chains
    }

    /// Where a walk for `drone` at `p` can jump to, further down `p`'s
    /// chain: the place before the next of its drone's running places, or
    /// the chain's last.
    pub(crate) fn jump(&self, p: NodeId, drone: u16) -> Option<NodeId> {
        let &(c, i) = self.at.get(&p)?;
        let chain = &self.chains[c as usize];
        let k = chain.running.partition_point(|&r| r <= (drone, i));
        let to = match chain.running.get(k) {
            Some(&(d, at)) if d == drone => at - 1,
            _ => chain.places.len() as u32 - 1,
        };
        (to > i).then(|| chain.places[to as usize])
    }
}

/// The output of the plain step `p` is offered to, if it is one.
fn plain_step_from(net: &Net, p: NodeId, followed: &impl Fn(NodeId) -> bool) -> Option<NodeId> {
    let mut consumers = net.consumers(p);
    let (t, ArcKind::Consume) = consumers.next()? else {
        return None;
    };
    if consumers.next().is_some() {
        return None;
    }
    let step = net.transition(t)?;
    if step.guard.is_some() || matches!(step.kind, TransitionKind::Fork | TransitionKind::Join) {
        return None;
    }
    if net.preset(t).count() != 1 || net.read_set(t).next().is_some() {
        return None;
    }
    let mut outputs = net.postset(t);
    let (q, ColourOp::Keep) = outputs.next()? else {
        return None;
    };
    (outputs.next().is_none() && q != p && followed(q)).then_some(q)
}
