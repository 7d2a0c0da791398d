//! What a walk for one drone may take as one step: a fragment of control
//! flow with one way in and one way out, holding none of the drone's
//! actions (see `chain.rs`, which strings such steps into rows).
//!
//! A row of plain steps was not enough: between two of a drone's actions a
//! generated mission holds other drones' loops, choices, `Do` regions and
//! waits, each a handful of places a walk went through one by one (and a
//! loop once per count), and their number grew with the fleet: a walk for
//! one drone took 11 steps at 50 drones and 24 at 500, 306 at most.
//!
//! The fragment that starts at a place `p` ends at `p`'s nearest
//! post-dominator that is a place, `q`: every way on from `p` to the
//! mission's end passes `q`. Its body is what can be reached from `p`
//! without passing `q`. A walk that comes to `p` leaves the body at `q`
//! alone, with the token's colour it came with, and meets nothing it is
//! asked about in between, if the body
//! - holds no action of the drone (no stop: a walk for one drone stops
//!   only at starts of its own actions) and no guard on its state (which
//!   the walk may find cannot hold), which is what [`Step::drones`] lists;
//! - has no guard on a condition over no drone (a constant, which may
//!   never hold), and neither reads nor changes a loop counter it did not
//!   push itself (every place inside is at least as deep in loops as `p`,
//!   the inputs of every colour guard, loop-back and loop exit deeper, and
//!   `q` as deep as `p`: a loop inside is left with its counter dropped);
//! - opens and closes its blocks inside: each fork's joins and each join's
//!   fork are in the body (a join waits for the branches of the walk's
//!   own fork);
//! - holds neither the mission's end nor its start.
//!
//! A body that touches a `Do` region's state is [`Step::regional`]: after a
//! cancel the walk skips that region's steps, so it walks such a body
//! itself.
//!
//! Everything here is arrays indexed by node: petgraph's dominators keep
//! a hash set of predecessors per node, 8 ms of a 500-drone check, more
//! than the jumps saved.

use std::mem::take;

use rustc_hash::FxHashMap as HashMap;

use eamos_petri::net::{ColourOp, GuardKind, Net, NodeId, PlaceKind};

use crate::ptnet::Csr;

/// A fragment a walk for a drone not among `drones` crosses in one step.
pub(crate) struct Step {
    /// Where the walk comes out: the place after the fragment.
    pub to: NodeId,
    /// Drones with an action inside, or whose state a guard inside reads.
    pub drones: Vec<u16>,
    /// Some step inside reads, takes or sets a `Do` region's state.
    pub regional: bool,
}

/// The step starting at each place of the control flow (`followed`) that
/// starts one; `fork_of`: the fork that opened each join's block.
pub(crate) fn steps(
    net: &Net,
    followed: impl Fn(NodeId) -> bool,
    fork_of: &HashMap<NodeId, NodeId>,
) -> HashMap<NodeId, Step> {
    let flow = Flow::new(net, &followed);
    let exit = post_dominators(&flow, net.final_place.index());
    let mut partners: HashMap<usize, Vec<usize>> = HashMap::default();
    for (&join, &fork) in fork_of {
        partners.entry(join.index()).or_default().push(fork.index());
        partners.entry(fork.index()).or_default().push(join.index());
    }
    let mut body = Body {
        net,
        flow: &flow,
        nodes: nodes(net, &flow, &partners),
        partners: &partners,
        mark: vec![0; flow.len()],
        epoch: 0,
        stack: Vec::new(),
        blocks: Vec::new(),
    };
    let mut steps = HashMap::default();
    for (p, place) in net.places().filter(|&(p, _)| followed(p)) {
        let exit = exit_of(&exit, &body.nodes, p.index(), place.depth);
        if let Some(step) = exit.and_then(|q| body.step(p, q, place.depth)) {
            steps.insert(p, step);
        }
    }
    steps
}

/// The nearest place post-dominating place `p` that is `depth` loops deep
/// as `p` is: past the head of a loop `p` enters, to where it is left;
/// none once a post-dominator is shallower (`p`'s own loop is left there,
/// and a body holding it would be no step).
fn exit_of(exit: &[u32], nodes: &[Node], p: usize, depth: u8) -> Option<NodeId> {
    let floor = depth.saturating_add(1);
    let mut q = exit[p];
    while q != NONE {
        let node = nodes[q as usize];
        if node.flags & PLACE != 0 && node.floor <= floor {
            return (node.floor == floor).then(|| NodeId::new(q as usize));
        }
        q = exit[q as usize];
    }
    None
}

const NONE: u32 = u32::MAX;

/// The control flow as arrays: each node's successors and predecessors,
/// over the arcs a walk follows.
struct Flow {
    succ: Csr<u32>,
    pred: Csr<u32>,
}

impl Flow {
    fn new(net: &Net, followed: &impl Fn(NodeId) -> bool) -> Self {
        let n = net.graph.node_count();
        let on_flow = |a: NodeId| !net.is_place(a) || followed(a);
        let arcs: Vec<(u32, u32)> = net
            .arcs()
            .filter(|&(from, to, _)| on_flow(from) && on_flow(to))
            .map(|(from, to, _)| (from.index() as u32, to.index() as u32))
            .collect();
        let back: Vec<(u32, u32)> = arcs.iter().map(|&(a, b)| (b, a)).collect();
        Flow {
            succ: Csr::from_pairs(n, &arcs),
            pred: Csr::from_pairs(n, &back),
        }
    }

    fn len(&self) -> usize {
        self.succ.len()
    }
}

/// Each node's immediate post-dominator (`NONE` for the root and for
/// nodes that never reach it), by Cooper, Harvey and Kennedy's iteration
/// over the reversed flow in reverse post-order.
fn post_dominators(flow: &Flow, root: usize) -> Vec<u32> {
    // Post-order of the reversed flow from the root.
    let mut order: Vec<u32> = Vec::new();
    let mut rank = vec![NONE; flow.len()];
    let mut seen = vec![false; flow.len()];
    let mut stack: Vec<(u32, u32)> = vec![(root as u32, 0)];
    seen[root] = true;
    while let Some((n, i)) = stack.last_mut() {
        let preds = flow.pred.get(*n as usize);
        if let Some(&m) = preds.get(*i as usize) {
            *i += 1;
            if !seen[m as usize] {
                seen[m as usize] = true;
                stack.push((m, 0));
            }
        } else {
            rank[*n as usize] = order.len() as u32;
            order.push(*n);
            stack.pop();
        }
    }
    let mut idom = vec![NONE; flow.len()];
    idom[root] = root as u32;
    let intersect = |idom: &[u32], mut a: u32, mut b: u32| {
        while a != b {
            while rank[a as usize] < rank[b as usize] {
                a = idom[a as usize];
            }
            while rank[b as usize] < rank[a as usize] {
                b = idom[b as usize];
            }
        }
        a
    };
    let mut changed = true;
    while changed {
        changed = false;
        for &n in order.iter().rev().skip(1) {
            let mut next = NONE;
            for &s in flow.succ.get(n as usize) {
                if idom[s as usize] == NONE {
                    continue;
                }
                next = if next == NONE {
                    s
                } else {
                    intersect(&idom, next, s)
                };
            }
            if idom[n as usize] != next {
                idom[n as usize] = next;
                changed = true;
            }
        }
    }
    idom[root] = NONE;
    idom
}

/// What a body's walk needs to know of a node, worked out once.
#[derive(Clone, Copy)]
struct Node {
    /// The body's start must be shallower in loops than this: a place's
    /// depth plus one; a transition reading or changing the innermost
    /// counter, its inputs' depth; any other, no bound.
    floor: u8,
    flags: u8,
    /// The drone whose action it starts, ends or cancels.
    drone: u16,
}

/// Never in a body: the mission's start or end, a constant guard.
const BARRED: u8 = 1;
/// Reads, takes or sets a `Do` region's state.
const REGIONAL: u8 = 2;
/// Guarded by a condition on drones' state.
const GUARDED: u8 = 4;
/// A fork or a join.
const BLOCK: u8 = 8;
const PLACE: u8 = 16;
/// A `Do` region's state.
const REGION: u8 = 32;
/// Reads or changes the token's innermost loop counter: a colour guard,
/// a loop's way back or out.
const COUNTS: u8 = 64;

fn nodes(net: &Net, flow: &Flow, partners: &HashMap<usize, Vec<usize>>) -> Vec<Node> {
    let mut nodes = vec![
        Node {
            floor: u8::MAX,
            flags: 0,
            drone: u16::MAX,
        };
        flow.len()
    ];
    for (p, place) in net.places() {
        let node = &mut nodes[p.index()];
        node.floor = place.depth.saturating_add(1);
        node.flags |= PLACE;
        match place.kind {
            PlaceKind::Final | PlaceKind::Initial => node.flags |= BARRED,
            PlaceKind::Region { .. } => node.flags |= REGION,
            _ => {}
        }
    }
    for (t, tr) in net.transitions() {
        let node = &mut nodes[t.index()];
        if let Some(a) = tr.kind.action() {
            node.drone = a.drone.0;
        }
        if partners.contains_key(&t.index()) {
            node.flags |= BLOCK;
        }
        node.flags |= match tr.guard.as_ref().map(|g| &g.kind) {
            None => 0,
            Some(GuardKind::Cond { cond, .. }) if cond.drones().is_empty() => BARRED,
            Some(GuardKind::Cond { .. }) => GUARDED,
            Some(GuardKind::IterationBelow(_) | GuardKind::IterationAtLeast(_)) => COUNTS,
        };
    }
    for (from, to, arc) in net.arcs() {
        let (from, to) = (from.index(), to.index());
        if nodes[from].flags & REGION != 0 {
            nodes[to].flags |= REGIONAL;
        }
        if nodes[to].flags & REGION != 0 {
            nodes[from].flags |= REGIONAL;
        }
        // Looping back and leaving a loop change the innermost counter.
        if matches!(arc.colour, ColourOp::Next | ColourOp::Leave) && nodes[from].flags & PLACE == 0
        {
            nodes[from].flags |= COUNTS;
        }
    }
    for t in 0..nodes.len() {
        if nodes[t].flags & COUNTS != 0 {
            let inputs = flow
                .pred
                .get(t)
                .iter()
                .map(|&i| nodes[i as usize].floor - 1);
            nodes[t].floor = inputs.min().unwrap_or(0);
        }
    }
    nodes
}

/// The walk through one fragment's body, with a mark per node reused from
/// one fragment to the next.
struct Body<'a> {
    net: &'a Net,
    flow: &'a Flow,
    nodes: Vec<Node>,
    partners: &'a HashMap<usize, Vec<usize>>,
    /// The epoch in which each node was last reached.
    mark: Vec<u32>,
    epoch: u32,
    /// Kept from one body to the next, cleared.
    stack: Vec<u32>,
    blocks: Vec<usize>,
}

impl Body<'_> {
    /// The fragment from `p` to `q`, both `depth` loops deep, if a walk
    /// may cross it in one step.
    fn step(&mut self, p: NodeId, q: NodeId, depth: u8) -> Option<Step> {
        let mut step = Step {
            to: q,
            drones: Vec::new(),
            regional: false,
        };
        let (mut stack, mut blocks) = (take(&mut self.stack), take(&mut self.blocks));
        stack.clear();
        blocks.clear();
        let crossed = self.cross(p, q, depth, &mut step, &mut stack, &mut blocks);
        let epoch = self.epoch;
        let inside = |n: &usize| self.mark[*n] == epoch;
        let closed = blocks.iter().all(|b| self.partners[b].iter().all(inside));
        (self.stack, self.blocks) = (stack, blocks);
        step.drones.sort_unstable();
        step.drones.dedup();
        (crossed.is_some() && closed).then_some(step)
    }

    /// Marks the body from `p` up to `q`, noting in `step` what it holds
    /// and in `blocks` its forks and joins; `None` if it holds what no
    /// step may.
    fn cross(
        &mut self,
        p: NodeId,
        q: NodeId,
        depth: u8,
        step: &mut Step,
        stack: &mut Vec<u32>,
        blocks: &mut Vec<usize>,
    ) -> Option<()> {
        self.epoch += 1;
        let epoch = self.epoch;
        self.mark[p.index()] = epoch;
        stack.push(p.index() as u32);
        while let Some(n) = stack.pop() {
            let node = self.nodes[n as usize];
            if node.flags & BARRED != 0 || node.floor <= depth {
                return None;
            }
            if node.drone != u16::MAX {
                step.drones.push(node.drone);
            }
            if node.flags & GUARDED != 0 {
                let t = self.net.transition(NodeId::new(n as usize))?;
                let drones = t.guard.as_ref().map(|g| g.drones()).unwrap_or_default();
                step.drones.extend(drones.iter().map(|d| d.0));
            }
            step.regional |= node.flags & REGIONAL != 0;
            if node.flags & BLOCK != 0 {
                blocks.push(n as usize);
            }
            for &m in self.flow.succ.get(n as usize) {
                if m as usize != q.index() && self.mark[m as usize] != epoch {
                    self.mark[m as usize] = epoch;
                    stack.push(m);
                }
            }
        }
        Some(())
    }
}
