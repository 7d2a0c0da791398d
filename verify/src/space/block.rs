//! How a walk for one drone crosses a `PAR_` block (see `walk.rs`), worked
//! out once per block instead of once per walk.
//!
//! A walk for a drone goes down the branches of a block that hold one of
//! its actions, or that leave the block some other way than by its join,
//! and takes every other branch as come to its end. Looking at each branch
//! in each walk made a walk across a fleet-wide block cost as much as the
//! fleet (2.65 million branches looked at, and as many ends marked reached,
//! in a check of 500 drones); here a walk looks only at its drone's
//! branches, and a join waits only for the ends of the branches walks for
//! that drone go down.

use std::collections::BTreeSet;

use rustc_hash::FxHashMap as HashMap;

use eamos_petri::net::{ColourOp, NodeId};

/// What a walk for each drone does at one fork.
pub(crate) struct Crossing {
    /// Where the fork puts its tokens, with each arc's colour function.
    outs: Vec<(NodeId, ColourOp)>,
    /// The outputs a walk goes down whoever it is for.
    always: Vec<u32>,
    /// The outputs that start a branch closed on its join, by each drone
    /// with an action in the branch.
    own: HashMap<u16, Vec<u32>>,
    /// The closed branches, by the join they meet and the colour function
    /// of their arc: (join, function, outputs in order).
    groups: Vec<(NodeId, ColourOp, Vec<u32>)>,
    /// The drones of each output's branch, if it is closed.
    drones: Vec<Option<BTreeSet<u16>>>,
}

/// One output of a fork: where it puts the token, with which colour
/// function, and if it starts a branch closed on the block's join, the
/// branch's drones and join.
pub(crate) struct Out {
    pub place: NodeId,
    pub op: ColourOp,
    pub closed: Option<(BTreeSet<u16>, NodeId)>,
}

impl Crossing {
    pub(crate) fn new(outs: Vec<Out>) -> Self {
        let mut c = Crossing {
            outs: Vec::with_capacity(outs.len()),
            always: Vec::new(),
            own: HashMap::default(),
            groups: Vec::new(),
            drones: Vec::with_capacity(outs.len()),
        };
        for (i, out) in outs.into_iter().enumerate() {
            let i = i as u32;
            c.outs.push((out.place, out.op));
            match out.closed {
                None => {
                    c.always.push(i);
                    c.drones.push(None);
                }
                Some((drones, join)) => {
                    for &d in &drones {
                        c.own.entry(d).or_default().push(i);
                    }
                    match c.groups.iter_mut().find(|g| g.0 == join && g.1 == out.op) {
                        Some(g) => g.2.push(i),
                        None => c.groups.push((join, out.op, vec![i])),
                    }
                    c.drones.push(Some(drones));
                }
            }
        }
        c
    }

    /// The outputs a walk for `drone` goes down, in the fork's order.
    pub(crate) fn down(&self, drone: u16) -> Vec<(NodeId, ColourOp)> {
        let own = self.own.get(&drone).map_or(&[][..], |v| v.as_slice());
        let mut picked = Vec::with_capacity(self.always.len() + own.len());
        let (mut i, mut j) = (0, 0);
        while i < self.always.len() || j < own.len() {
            let next = if j == own.len() || (i < self.always.len() && self.always[i] < own[j]) {
                i += 1;
                self.always[i - 1]
            } else {
                j += 1;
                own[j - 1]
            };
            picked.push(self.outs[next as usize]);
        }
        picked
    }

    /// The joins, with the colour function of the arcs into their
    /// branches, that the branches a walk for `drone` does not go down
    /// meet: in the order of the first such branch of each.
    pub(crate) fn skipped(&self, drone: u16) -> Vec<(NodeId, ColourOp)> {
        let mut firsts: Vec<(u32, NodeId, ColourOp)> = self
            .groups
            .iter()
            .filter_map(|(join, op, members)| {
                let first = members.iter().copied().find(|&i| {
                    self.drones[i as usize]
                        .as_ref()
                        .is_some_and(|d| !d.contains(&drone))
                })?;
                Some((first, *join, *op))
            })
            .collect();
        firsts.sort_unstable_by_key(|f| f.0);
        firsts.into_iter().map(|(_, j, op)| (j, op)).collect()
    }
}

/// What a join waits for in a walk for each drone that went through its
/// fork: the ends of the branches the walk goes down.
#[derive(Default)]
pub(crate) struct Waits {
    /// Inputs every walk waits for.
    always: Vec<NodeId>,
    /// Inputs only walks for these drones wait for: each ends a closed
    /// branch (or several) that has an action of the drone.
    own: HashMap<u16, Vec<NodeId>>,
}

impl Waits {
    /// `inputs`: the join's inputs in the control flow, each with the
    /// drones that every closed branch it ends has an action of (`None`
    /// where it ends no closed branch): a walk for another drone takes it
    /// as reached.
    pub(crate) fn new(inputs: impl Iterator<Item = (NodeId, Option<BTreeSet<u16>>)>) -> Self {
        let mut w = Waits::default();
        for (q, drones) in inputs {
            match drones {
                None => w.always.push(q),
                Some(drones) => {
                    for d in drones {
                        w.own.entry(d).or_default().push(q);
                    }
                }
            }
        }
        w
    }

    /// The inputs a walk for `drone` must have reached.
    pub(crate) fn of(&self, drone: u16) -> impl Iterator<Item = NodeId> + '_ {
        let own = self.own.get(&drone).map_or(&[][..], |v| v.as_slice());
        self.always.iter().chain(own).copied()
    }
}
