//! The mission's end, distributed.
//!
//! The net ends in one place, `final`, behind a tree of silent joins (the
//! join of the last PAR block, the `Finish` transition). Played as it is,
//! that tree lives on one owner, which must hear of every other drone's last
//! action: one bridge per drone that does not hold it, messages that tell
//! nothing but "I am done". The paper's drones do not send them; each simply
//! stops when its part is over.
//!
//! Here the tree is not played by anyone. Each owner consumes the tree's
//! inputs that live on it into an end of its own (`end.<owner>` marking
//! `final.<owner>`), and the mission has ended when every owner that holds
//! an end has reached it. The executors learn that through the `end` control
//! notice each of them sends when it reaches its end, delivered exactly once
//! like any token but not a bridge: it carries no token of the net.
//!
//! Why this plays like the net: the tree is made of silent joins, each the
//! only consumer of its input places, which nobody reads, none marked at the
//! start, each with a single producer, all at the depth of `final`. So every
//! run that ends marks every input exactly once (no input is one of two
//! alternatives: those would meet in a place with two producers, which stops
//! the tree), and once marked an input stays marked until the tree takes it.
//! Firing the tree's joins at once, or per owner and then all together, is
//! the pre-join argument of the crate docs applied to the whole tree: the
//! composition of the slices (see [`crate::compose`]) joins the owners' ends
//! into `final` with one silent transition that nobody runs, and that
//! composition has the net's traces. Where the tree is not of this shape the
//! slicer keeps `final` on one owner, as before.

use eamos_petri::net::{ArcKind, Net, NodeId, TransitionKind};
use petgraph::visit::EdgeRef;
use petgraph::Direction;

pub(crate) struct End {
    /// Nodes of the join tree that ends the mission, `final` included.
    pub region: Vec<bool>,
    /// Places the tree consumes; every run that ends marks each once.
    pub inputs: Vec<NodeId>,
    /// The transition that marks `final`: in the distributed net it stands
    /// for the whole tree, joining the owners' ends, and belongs to no one.
    pub finish: NodeId,
}

impl End {
    /// The join tree in front of `final`, if it can be distributed.
    pub fn of(net: &Net) -> Option<End> {
        let fin = net.final_place;
        let depth = net.place(fin)?.depth;
        let mut marked = vec![false; net.graph.node_count()];
        for &p in &net.initial_marking {
            marked[p.index()] = true;
        }
        if marked[fin.index()] || net.consumers(fin).next().is_some() {
            return None;
        }
        let mut region = vec![false; net.graph.node_count()];
        region[fin.index()] = true;
        let mut inputs = Vec::new();
        let mut finish = None;
        let mut stack = vec![fin];
        while let Some(q) = stack.pop() {
            let mut producers = net.producers(q);
            let t = match (producers.next(), producers.next()) {
                (Some(t), None) if joins_silently(net, t, &marked, &region, depth) => t,
                _ if q == fin => return None,
                _ => {
                    inputs.push(q);
                    continue;
                }
            };
            if q == fin {
                finish = Some(t);
            }
            region[q.index()] = true;
            region[t.index()] = true;
            stack.extend(net.preset(t));
        }
        // A place reached twice would be consumed by two joins: not a tree.
        inputs.sort_unstable();
        inputs.dedup();
        Some(End {
            region,
            inputs,
            finish: finish?,
        })
    }
}

/// Whether `t` is a silent join of the end tree: no guard, no delay, no
/// read arc, one output, and the only consumer of each of its inputs, which
/// are unmarked places at the depth of `final` not already in the tree.
fn joins_silently(net: &Net, t: NodeId, marked: &[bool], region: &[bool], depth: u8) -> bool {
    let Some(tr) = net.transition(t) else {
        return false;
    };
    if !matches!(
        tr.kind,
        TransitionKind::Join | TransitionKind::Finish | TransitionKind::Silent
    ) || tr.guard.is_some()
        || tr.delay.is_some()
        || net.postset(t).count() != 1
    {
        return false;
    }
    net.graph
        .edges_directed(t, Direction::Incoming)
        .next()
        .is_some()
        && net.graph.edges_directed(t, Direction::Incoming).all(|e| {
            let p = e.source();
            e.weight().kind == ArcKind::Consume
                && !marked[p.index()]
                && !region[p.index()]
                && net.place(p).is_some_and(|pl| pl.depth == depth)
                && net.consumers(p).count() == 1
        })
}
