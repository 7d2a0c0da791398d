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
    /// The block's join, which every closed branch meets.
    join: NodeId,
    /// The outputs a walk goes down whoever it is for.
    always: Vec<u32>,
    /// The outputs that start a branch closed on the join, by each drone
    /// with an action in the branch, in order.
    own: HashMap<u16, Vec<u32>>,
    /// The closed branches by the colour function of their arc, in the
    /// order of the first: (function, outputs in order).
    groups: Vec<(ColourOp, Vec<u32>)>,
}

/// One output of a fork: where it puts the token, with which colour
/// function, and if it starts a branch closed on the block's join, the
/// branch's drones.
pub(crate) struct Out {
    pub place: NodeId,
    pub op: ColourOp,
    pub closed: Option<BTreeSet<u16>>,
}

impl Crossing {
    pub(crate) fn new(join: NodeId, outs: Vec<Out>) -> Self {
        let mut c = Crossing {
            outs: Vec::with_capacity(outs.len()),
            join,
            always: Vec::new(),
            own: HashMap::default(),
            groups: Vec::new(),
        };
        for (i, out) in outs.into_iter().enumerate() {
            let i = i as u32;
            c.outs.push((out.place, out.op));
            let Some(drones) = out.closed else {
                c.always.push(i);
                continue;
            };
            for d in drones {
                c.own.entry(d).or_default().push(i);
            }
            match c.groups.iter_mut().find(|g| g.0 == out.op) {
                Some(g) => g.1.push(i),
                None => c.groups.push((out.op, vec![i])),
            }
        }
        c
    }

    fn own(&self, drone: u16) -> &[u32] {
        self.own.get(&drone).map_or(&[], |v| v.as_slice())
    }

    /// The outputs a walk for `drone` goes down, in the fork's order.
    pub(crate) fn down(&self, drone: u16) -> impl Iterator<Item = (NodeId, ColourOp)> + '_ {
        let (always, own) = (&self.always, self.own(drone));
        let (mut i, mut j) = (0, 0);
        std::iter::from_fn(move || {
            let next = match (always.get(i), own.get(j)) {
                (Some(&a), Some(&o)) if a < o => {
                    i += 1;
                    a
                }
                (_, Some(&o)) => {
                    j += 1;
                    o
                }
                (Some(&a), None) => {
                    i += 1;
                    a
                }
                (None, None) => return None,
            };
            Some(self.outs[next as usize])
        })
    }

    /// The join, with the colour function of the arcs into their
    /// branches, that the branches a walk for `drone` does not go down
    /// meet: once per function, in the order of the first such branch.
    pub(crate) fn skipped(&self, drone: u16) -> Vec<(NodeId, ColourOp)> {
        let own = self.own(drone);
        let mut firsts: Vec<(u32, ColourOp)> = self
            .groups
            .iter()
            .filter_map(|(op, members)| {
                let first = members
                    .iter()
                    .copied()
                    .find(|i| own.binary_search(i).is_err())?;
                Some((first, *op))
            })
            .collect();
        firsts.sort_unstable_by_key(|f| f.0);
        firsts.into_iter().map(|(_, op)| (self.join, op)).collect()
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
