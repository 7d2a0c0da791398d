//! Runs of plain steps, which a walk for one drone crosses in one jump up
//! to its drone's next action (see `walk.rs`).
//!
//! Between two of its actions a drone's next one is often many steps away
//! down a `SEQ_` block of other drones' actions, pauses and blocks, and a
//! walk went through them one by one: its steps grew with the fleet (19 a
//! walk at 50 drones, 52 at 500, 118 at 1,000), and the walks, as many as
//! the actions, with its square. A *plain* step takes its one input, the
//! only place it is offered to, and puts the token, its colour kept, into
//! one place, with no guard and no read arc: a walk that comes to its
//! input can only go on to its output, and nothing it is asked about (a
//! stop, a guard it cannot pass, a `Do` body after a cancel, a join's
//! inputs) happens in between. A closed block (every branch leads only to
//! its join, `walk.rs`) whose fork and join are plain in that sense is one
//! plain step for a walk for a drone with no action in it: the walk goes
//! down none of its branches and its join waits for none. Plain steps in
//! a row form a chain, broken where two of them meet; a walk in a chain
//! jumps to the place before the next step that holds one of its drone's
//! actions (its start, or a block with one inside), or to the chain's last
//! place.

use rustc_hash::FxHashMap as HashMap;

use eamos_petri::net::{ArcKind, ColourOp, Net, NodeId, PlaceKind, TransitionKind};

#[derive(Default)]
pub(crate) struct Chains {
    /// Each place in a chain: the chain and its place in it.
    at: HashMap<NodeId, (u32, u32)>,
    chains: Vec<Chain>,
}

struct Chain {
    places: Vec<NodeId>,
    /// By drone then by position `i`: the step from place `i - 1` to `i`
    /// holds an action of the drone (it starts one, or is a block with one
    /// inside).
    own: Vec<(u16, u32)>,
}

/// A closed block, as `walk.rs` works it out: its join and the drones
/// with an action in it.
pub(crate) struct Closed {
    pub join: NodeId,
    pub drones: Vec<u16>,
}

impl Chains {
    /// `followed`: the places a walk follows (see `Walker::followed`);
    /// `closed`: the closed blocks, by fork.
    pub(crate) fn new(
        net: &Net,
        followed: impl Fn(NodeId) -> bool,
        closed: &HashMap<NodeId, Closed>,
    ) -> Self {
        let mut next: HashMap<NodeId, (NodeId, Vec<u16>)> = HashMap::default();
        let mut before: HashMap<NodeId, u32> = HashMap::default();
        for (p, _) in net.places().filter(|&(p, _)| followed(p)) {
            if let Some(step) = plain_step_from(net, p, &followed, closed) {
                *before.entry(step.0).or_default() += 1;
                next.insert(p, step);
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
            let id = chains.chains.len() as u32;
            let mut chain = Chain {
                places: vec![head],
                own: Vec::new(),
            };
            chains.at.insert(head, (id, 0));
            let mut p = head;
            while let Some((q, drones)) = next.get(&p) {
                if before.get(q) != Some(&1) {
                    break;
                }
                let i = chain.places.len() as u32;
                chain.own.extend(drones.iter().map(|&d| (d, i)));
                chain.places.push(*q);
                chains.at.insert(*q, (id, i));
                p = *q;
            }
            chain.own.sort_unstable();
            chains.chains.push(chain);
        }
        chains
    }

    /// Where a walk for `drone` at `p` can jump to, further down `p`'s
    /// chain: the place before the next step with one of its drone's
    /// actions, or the chain's last.
    pub(crate) fn jump(&self, p: NodeId, drone: u16) -> Option<NodeId> {
        let &(c, i) = self.at.get(&p)?;
        let chain = &self.chains[c as usize];
        let k = chain.own.partition_point(|&r| r <= (drone, i));
        let to = match chain.own.get(k) {
            Some(&(d, at)) if d == drone => at - 1,
            _ => chain.places.len() as u32 - 1,
        };
        (to > i).then(|| chain.places[to as usize])
    }
}

/// The plain step `p` is offered to, if it is one: the place it leads to
/// and the drones with an action in it.
fn plain_step_from(
    net: &Net,
    p: NodeId,
    followed: &impl Fn(NodeId) -> bool,
    closed: &HashMap<NodeId, Closed>,
) -> Option<(NodeId, Vec<u16>)> {
    let mut consumers = net.consumers(p);
    let (t, ArcKind::Consume) = consumers.next()? else {
        return None;
    };
    if consumers.next().is_some() || net.preset(t).count() != 1 {
        return None;
    }
    let step = net.transition(t)?;
    let (last, drones) = match step.kind {
        TransitionKind::Fork => {
            let block = closed.get(&t)?;
            let outs_kept = net.postset(t).all(|(_, op)| op == ColourOp::Keep);
            (outs_kept && plain(net, block.join)).then_some(())?;
            (block.join, block.drones.clone())
        }
        TransitionKind::Join => return None,
        _ => (t, Vec::new()),
    };
    if !plain(net, t) {
        return None;
    }
    let mut outputs = net.postset(last);
    let (q, ColourOp::Keep) = outputs.next()? else {
        return None;
    };
    if outputs.next().is_some() || q == p || !followed(q) {
        return None;
    }
    let mut drones = drones;
    if let Some(PlaceKind::Running(a)) = net.place(q).map(|q| &q.kind) {
        drones.push(a.drone.0);
    }
    Some((q, drones))
}

/// A transition with no guard and no read arc.
fn plain(net: &Net, t: NodeId) -> bool {
    net.transition(t).is_some_and(|s| s.guard.is_none()) && net.read_set(t).next().is_none()
}
