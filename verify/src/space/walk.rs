//! Following a drone's control flow through the whole net, from where one of
//! its actions ends to the actions of its own that can come next.
//!
//! A drone's next action may lie in another drone's branch's future: after
//! a join, a fork, an `Await`. A walk follows every arc from control place
//! to transition to control place, through every drone's steps, and stops
//! at the transitions it is asked to stop at (the starts of the drone's own
//! tracked actions). It ignores what a step needs besides the token it
//! follows (an event, the branches of a `PAR_` block that were already
//! under way when the walk began), so it finds every next action there can
//! be and perhaps some there cannot: the analyses built on it are
//! conservative, never blind. One exception keeps it from being blind the
//! other way: a `PAR_` block's join, when the walk itself went through the
//! block's fork, waits until the walk has reached every branch's end (a
//! branch it did not reach ends with an action of the drone, which comes
//! first). A walk for one drone does not go down a branch that holds none
//! of that drone's actions and leads only to its join: it takes the branch
//! as come to its end. Going down every drone's branch made each walk cross
//! the whole mission, the spatial check's work the square of the fleet's.
//! Which branches those are, for each drone, is worked out once per block
//! (`block.rs`). Down a row of fragments with one way in and one way out
//! holding none of its actions (`step.rs`), a walk for one drone jumps to
//! the fragment that holds its next one (`chain.rs`).
//!
//! Loop counters are followed exactly where a `RepeatFor` guard reads them
//! (so a body flown three times is flown three times, not for ever); a
//! counter that no guard reads stops counting past the largest count any
//! guard tests, which keeps every walk finite.

use std::collections::BTreeSet;
use std::sync::Mutex;

// The walks hash node indices by the million at a few hundred drones:
// Fx, not SipHash (a net is the program's own data, not an adversary's).
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use eamos_petri::net::{Colour, ColourOp, Net, NodeId, PlaceKind, TransitionKind};

use super::block::{Crossing, Out, Waits};
use super::chain::Chains;

pub(crate) struct Walker<'n> {
    net: &'n Net,
    /// Counters saturate here.
    cap: u32,
    /// The fork that opened each join's block.
    fork_of: HashMap<NodeId, NodeId>,
    /// How a walk for a drone crosses each block (`block.rs`): by fork,
    /// the branches it goes down; by join, the ends it waits for.
    crossings: HashMap<NodeId, Crossing>,
    waits: HashMap<NodeId, Waits>,
    /// Rows of steps a walk for a drone jumps (`chain.rs`, `step.rs`).
    chains: Chains,
    /// The sets of the last walk, for the next (see [`Sets`]). Behind a
    /// lock so that the positions and the flight states walk on two
    /// threads; each walk takes the sets or, while the other thread holds
    /// them, makes its own.
    sets: Mutex<Option<Box<Sets>>>,
}

/// One branch of a `PAR_` block, from its fork to its join.
#[derive(Debug)]
struct Branch {
    /// Drones that have an action in it.
    drones: BTreeSet<u16>,
    /// Where the branch meets the block's join.
    ends: Vec<NodeId>,
    /// It leads nowhere but to its join (or to the mission's end): no
    /// other block's join waits on it.
    closed: bool,
    /// The forks of the blocks inside it.
    forks: Vec<NodeId>,
}

/// A block worked out: how walks cross it and, when every branch of it is
/// closed, what a branch of a block around it takes from it.
struct Block {
    crossing: Crossing,
    waits: Waits,
    inner: Option<Inner>,
}

/// A closed block as seen from a branch around it, which goes from its
/// fork straight to its join: no place inside leads anywhere else.
struct Inner {
    /// Drones with an action in one of its branches.
    drones: BTreeSet<u16>,
    /// Its fork and the forks of the blocks inside it.
    forks: Vec<NodeId>,
}

/// A walk's token: where it is, its colour, the `Do` region whose body
/// it skips.
type Token = (NodeId, Colour, Option<u32>);

/// What a walk has seen, kept from one walk to the next and cleared
/// there: made afresh, the sets grew (and were hashed again) in every
/// walk, a fifth of the walks' instructions at 500 drones.
#[derive(Default)]
struct Sets {
    seen: HashSet<Token>,
    visited: HashSet<NodeId>,
    crossed: HashSet<NodeId>,
    queued: HashSet<Token>,
    stops: HashSet<(NodeId, Colour)>,
}

impl Sets {
    fn clear(&mut self) {
        self.seen.clear();
        self.visited.clear();
        self.crossed.clear();
        self.queued.clear();
        self.stops.clear();
    }
}

/// Where a walk stopped, and the places it passed.
#[derive(Debug, Default)]
pub(crate) struct Reach {
    /// A stop transition, and the colour of the token that reached it.
    pub stops: Vec<(NodeId, Colour)>,
}

/// The walk ran past its budget: the net is too large to follow this way.
#[derive(Debug)]
pub(crate) struct OutOfBudget;

impl<'n> Walker<'n> {
    pub(crate) fn new(net: &'n Net) -> Self {
        use eamos_petri::net::GuardKind;
        let cap = net
            .transitions()
            .filter_map(|(_, t)| match t.guard.as_ref().map(|g| &g.kind) {
                Some(GuardKind::IterationBelow(n)) | Some(GuardKind::IterationAtLeast(n)) => {
                    Some(*n)
                }
                _ => None,
            })
            .max()
            .unwrap_or(0)
            .min(crate::ptnet::MAX_COUNTED_ROUNDS)
            + 1;
        let forks: HashMap<(u32, u32), NodeId> = net
            .transitions()
            .filter(|(_, t)| t.kind == TransitionKind::Fork)
            .map(|(n, t)| ((t.span.start, t.span.end), n))
            .collect();
        let fork_of = net
            .transitions()
            .filter(|(_, t)| t.kind == TransitionKind::Join)
            .filter_map(|(n, t)| Some((n, *forks.get(&(t.span.start, t.span.end))?)))
            .collect();
        let mut walker = Walker {
            net,
            cap,
            fork_of,
            crossings: HashMap::default(),
            waits: HashMap::default(),
            chains: Chains::default(),
            sets: Mutex::new(None),
        };
        walker.blocks();
        let steps = super::step::steps(net, |p| followed(net, p), &walker.fork_of);
        walker.chains = Chains::new(&steps, net.graph.node_count());
        walker
    }

    /// Every branch of every block, followed structurally from its fork
    /// to its join, and what a walk for each drone does with them. Inner
    /// blocks first: a branch that comes to a closed inner block jumps from
    /// its fork to its join with what the block holds, so that each place
    /// is followed once, not once per block around it.
    fn blocks(&mut self) {
        // A `Do` region's fork has up to three joins (its two ends and its
        // exit), all after its one followed branch, the body: its block
        // closes at the first in the net's order, and a walk waits at the
        // others for every input.
        let mut join_of: HashMap<NodeId, NodeId> = HashMap::default();
        for (join, _) in self.net.transitions() {
            if let Some(&fork) = self.fork_of.get(&join) {
                join_of.entry(fork).or_insert(join);
            }
        }
        let mut done: HashMap<NodeId, Option<Block>> = HashMap::default();
        for &fork in join_of.keys() {
            self.block(fork, &join_of, &mut done);
        }
        for (fork, block) in done {
            let block = block.expect("every block is finished");
            self.waits.insert(join_of[&fork], block.waits);
            self.crossings.insert(fork, block.crossing);
        }
    }

    /// The block `fork` opens, worked out into `done` (`None` there while
    /// it is under way: a block met again inside itself is followed place
    /// by place).
    fn block(
        &self,
        fork: NodeId,
        join_of: &HashMap<NodeId, NodeId>,
        done: &mut HashMap<NodeId, Option<Block>>,
    ) {
        if done.contains_key(&fork) {
            return;
        }
        done.insert(fork, None);
        let join = join_of[&fork];
        let mut outs = Vec::new();
        let mut ended: HashMap<NodeId, BTreeSet<u16>> = HashMap::default();
        let mut inner = Some(Inner {
            drones: BTreeSet::new(),
            forks: vec![fork],
        });
        for (start, op) in self.flow_out(fork) {
            let b = self.branch(fork, join, start, join_of, done);
            let closed = b.closed.then(|| b.drones.clone());
            if b.closed {
                for &q in &b.ends {
                    let drones = ended.entry(q).or_insert_with(|| b.drones.clone());
                    drones.retain(|d| b.drones.contains(d));
                }
            }
            inner = inner.filter(|_| b.closed).map(|mut i| {
                i.drones.extend(b.drones);
                i.forks.extend(b.forks);
                i
            });
            outs.push(Out {
                place: start,
                op,
                closed,
            });
        }
        let inputs = self
            .net
            .preset(join)
            .filter(|&q| self.followed(q))
            .map(|q| (q, ended.remove(&q)));
        let block = Block {
            crossing: Crossing::new(join, outs),
            waits: Waits::new(inputs),
            inner,
        };
        done.insert(fork, Some(block));
    }

    fn branch(
        &self,
        fork: NodeId,
        join: NodeId,
        start: NodeId,
        join_of: &HashMap<NodeId, NodeId>,
        done: &mut HashMap<NodeId, Option<Block>>,
    ) -> Branch {
        let mut branch = Branch {
            drones: BTreeSet::new(),
            ends: Vec::new(),
            closed: true,
            forks: Vec::new(),
        };
        let mut seen: HashSet<NodeId> = HashSet::from_iter([start]);
        let mut forks: HashSet<NodeId> = HashSet::from_iter([fork]);
        let mut joins: Vec<NodeId> = Vec::new();
        let mut stack = vec![start];
        while let Some(p) = stack.pop() {
            if let Some(PlaceKind::Running(a)) = self.net.place(p).map(|p| &p.kind) {
                branch.drones.insert(a.drone.0);
            }
            for (t, _) in self.net.consumers(p) {
                if t == join {
                    branch.ends.push(p);
                    continue;
                }
                let mut next = t;
                match self.net.transition(t).map(|t| &t.kind) {
                    Some(TransitionKind::Fork) => {
                        if let Some(&inner_join) = join_of.get(&t) {
                            self.block(t, join_of, done);
                            if let Some(Some(Block {
                                inner: Some(inner), ..
                            })) = done.get(&t)
                            {
                                branch.drones.extend(&inner.drones);
                                forks.extend(&inner.forks);
                                next = inner_join;
                            }
                        }
                        forks.insert(t);
                    }
                    Some(TransitionKind::Join) => joins.push(t),
                    _ => {}
                }
                for (q, _) in self.flow_out(next) {
                    if seen.insert(q) {
                        stack.push(q);
                    }
                }
            }
        }
        // A join of another block the branch did not open: the branch
        // leaves its block some other way than by its join.
        branch.closed = joins
            .iter()
            .all(|j| self.fork_of.get(j).is_some_and(|f| forks.contains(f)));
        forks.remove(&fork);
        branch.forks = forks.into_iter().collect();
        branch
    }

    /// The same walker, walking every step itself: what the jumps must
    /// agree with.
    #[cfg(test)]
    fn without_jumps(mut self) -> Self {
        self.chains = Chains::default();
        self
    }

    /// Loop counters below this are exact; at it, any count from it up.
    pub(crate) fn cap(&self) -> u32 {
        self.cap
    }

    /// The places a drone's control flow can be in at the start.
    pub(crate) fn initial(&self) -> Vec<(NodeId, Colour)> {
        self.net
            .initial_marking
            .iter()
            .filter(|&&p| self.followed(p))
            .map(|&p| (p, Vec::new()))
            .collect()
    }

    /// Where the token goes when transition `t` fires on colour `c`.
    pub(crate) fn after(&self, t: NodeId, c: &[u32], colours: bool) -> Vec<(NodeId, Colour)> {
        self.flow_out(t)
            .map(|(q, op)| (q, self.colour(op.apply(c), colours)))
            .collect()
    }

    /// The places of the control flow transition `t` produces into, with
    /// the colour function of each arc.
    fn flow_out(&self, t: NodeId) -> impl Iterator<Item = (NodeId, ColourOp)> + '_ {
        self.net.postset(t).filter(|(q, _)| self.followed(*q))
    }

    /// Walks from `seeds` until `stop` says a transition is a stop: for a
    /// walk for one `drone`, only starts of that drone's actions may be
    /// stops (the walk jumps rows of other steps, `chain.rs`). With
    /// `colours` off every token is colourless and colour guards may go
    /// either way (for analyses whose values are few, like flight states).
    /// A transition `blocked` says cannot fire (its guard cannot hold where
    /// the drone is) is not passed. `cut`: the seeds follow a cancel in
    /// this `Do` region, whose body is then skipped (its steps that need
    /// the region live cannot fire) until the region starts again.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn walk(
        &self,
        seeds: Vec<(NodeId, Colour)>,
        drone: Option<u16>,
        stop: &dyn Fn(NodeId) -> bool,
        colours: bool,
        blocked: &dyn Fn(NodeId) -> bool,
        cut: Option<u32>,
        budget: &mut usize,
    ) -> Result<Reach, OutOfBudget> {
        // Handed back at the end; a walk past its budget lets them go
        // (the next starts afresh).
        let mut sets = self
            .sets
            .lock()
            .ok()
            .and_then(|mut kept| kept.take())
            .unwrap_or_default();
        sets.clear();
        let Sets {
            seen,
            visited,
            crossed,
            queued,
            stops,
        } = &mut *sets;
        // Joins waiting for their block's branches, each once: a block of
        // 200 drones' branches, all skipped, would queue its join 200
        // times, and each wave below looks at every one.
        let mut waiting: Vec<Token> = Vec::new();
        let mut reach = Reach::default();
        let mut stack: Vec<Token> = seeds
            .into_iter()
            .map(|(p, c)| (p, self.colour(c, colours), cut))
            .collect();
        loop {
            while let Some((p, c, cut)) = stack.pop() {
                if !seen.insert((p, c.clone(), cut)) {
                    continue;
                }
                visited.insert(p);
                *budget = budget.checked_sub(1).ok_or(OutOfBudget)?;
                if let Some(to) = drone.and_then(|d| self.chains.jump(p, d, cut.is_some())) {
                    stack.push((to, c, cut));
                    continue;
                }
                for (t, _) in self.net.consumers(p) {
                    if stop(t) {
                        if stops.insert((t, c.clone())) {
                            reach.stops.push((t, c.clone()));
                        }
                        continue;
                    }
                    let tr = self.net.transition(t);
                    let colour_says_no = colours
                        && tr
                            .and_then(|t| t.guard.as_ref())
                            .and_then(|g| g.holds_on_colour(&c))
                            == Some(false);
                    if colour_says_no || blocked(t) || cut.is_some_and(|r| self.needs_live(t, r)) {
                        continue;
                    }
                    match tr.map(|t| &t.kind) {
                        Some(TransitionKind::Fork) => {
                            crossed.insert(t);
                        }
                        Some(TransitionKind::Join)
                            if self.fork_of.get(&t).is_some_and(|f| crossed.contains(f)) =>
                        {
                            if queued.insert((t, c.clone(), cut)) {
                                waiting.push((t, c.clone(), cut));
                            }
                            continue;
                        }
                        _ => {}
                    }
                    let cut = cut.filter(|&r| !self.starts_region(t, r));
                    // A walk for one drone across a block goes down its
                    // drone's branches and the open ones; the others all
                    // meet the join, with the token's colour after their
                    // arc's colour function: the join is queued once per
                    // colour function, not once per branch (`block.rs`).
                    let crossing = drone.zip(self.crossings.get(&t));
                    let Some((d, crossing)) = crossing else {
                        for (q, op) in self.flow_out(t) {
                            stack.push((q, self.colour(op.apply(&c), colours), cut));
                        }
                        continue;
                    };
                    for (q, op) in crossing.down(d) {
                        stack.push((q, self.colour(op.apply(&c), colours), cut));
                    }
                    // As if the walk had come down each other branch to
                    // the join with the token it set out with.
                    for (join, op) in crossing.skipped(d) {
                        let c = self.colour(op.apply(&c), colours);
                        if queued.insert((join, c.clone(), cut)) {
                            waiting.push((join, c, cut));
                        }
                    }
                }
            }
            // Joins whose block the walk opened go on once every branch
            // of it has come to its end (sorted out in place: a walk
            // across a fleet waits at a join a block).
            let mut ready = false;
            waiting.retain(|(t, c, cut)| {
                let reached = match drone.zip(self.waits.get(t)) {
                    Some((d, waits)) => waits.of(d).all(|q| visited.contains(&q)),
                    None => self
                        .net
                        .preset(*t)
                        .filter(|&q| self.followed(q))
                        .all(|q| visited.contains(&q)),
                };
                if reached {
                    ready = true;
                    for (q, c) in self.after(*t, c, colours) {
                        stack.push((q, c, *cut));
                    }
                }
                !reached
            });
            if !ready {
                break;
            }
        }
        if let Ok(mut kept) = self.sets.lock() {
            *kept = Some(sets);
        }
        Ok(reach)
    }

    /// Walks on from where the transitions `via` (the ends of one action,
    /// or its cancels) put the token of colour `c`; after a cancel, the
    /// rest of its `Do` body is skipped.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn walk_after(
        &self,
        via: &[NodeId],
        c: &[u32],
        cancel: bool,
        drone: Option<u16>,
        stop: &dyn Fn(NodeId) -> bool,
        colours: bool,
        blocked: &dyn Fn(NodeId) -> bool,
        budget: &mut usize,
    ) -> Result<Reach, OutOfBudget> {
        let mut reach = Reach::default();
        for &e in via {
            let cut = if cancel { self.region_of(e) } else { None };
            let seeds = self.after(e, c, colours);
            let found = self.walk(seeds, drone, stop, colours, blocked, cut, budget)?;
            for stop in found.stops {
                if !reach.stops.contains(&stop) {
                    reach.stops.push(stop);
                }
            }
        }
        Ok(reach)
    }

    /// The `Do` region a cancel transition cancels in.
    pub(crate) fn region_of(&self, cancel: NodeId) -> Option<u32> {
        self.net
            .read_set(cancel)
            .chain(self.net.preset(cancel))
            .find_map(|p| match self.net.place(p).map(|p| &p.kind) {
                Some(PlaceKind::Region {
                    region,
                    interrupted: true,
                }) => Some(*region),
                _ => None,
            })
    }

    /// Whether `t` needs region `r` live (an observable step of its body).
    fn needs_live(&self, t: NodeId, r: u32) -> bool {
        self.net.read_set(t).chain(self.net.preset(t)).any(|p| {
            matches!(
                self.net.place(p).map(|p| &p.kind),
                Some(PlaceKind::Region { region, interrupted: false }) if *region == r
            )
        })
    }

    /// Whether `t` starts region `r` afresh (its `do_start`).
    fn starts_region(&self, t: NodeId, r: u32) -> bool {
        self.net.postset(t).any(|(p, _)| {
            matches!(
                self.net.place(p).map(|p| &p.kind),
                Some(PlaceKind::Region { region, interrupted: false }) if *region == r
            )
        })
    }

    /// Places a drone's control flow passes through: not the records of
    /// events and `Do` regions, which are state beside the flow.
    fn followed(&self, p: NodeId) -> bool {
        followed(self.net, p)
    }

    fn colour(&self, mut c: Colour, colours: bool) -> Colour {
        if !colours {
            return Vec::new();
        }
        for v in &mut c {
            *v = (*v).min(self.cap);
        }
        c
    }
}

fn followed(net: &Net, p: NodeId) -> bool {
    net.place(p)
        .is_some_and(|p| !p.kind.is_event_state() && !matches!(p.kind, PlaceKind::Region { .. }))
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    fn net(text: &str) -> Net {
        let profiles = eamos_profile::builtin();
        let source = eamos_lang::SourceFile::new("m.go", text);
        let compiled = eamos_lang::compile(&source, &profiles).expect("compiles");
        eamos_petri::compile(&compiled.mission, &profiles)
    }

    /// The starts of drone `d`'s actions (their `Running` place's producers).
    fn starts(net: &Net, d: u16) -> HashSet<NodeId> {
        net.places()
            .filter(|(_, p)| matches!(&p.kind, PlaceKind::Running(a) if a.drone.0 == d))
            .flat_map(|(r, _)| net.producers(r).collect::<Vec<_>>())
            .collect()
    }

    /// Walks for drone `drone` (every drone's branches: `None`) from where
    /// the first drone's takeoff ends to its next actions: their labels,
    /// sorted, and the steps the walk took.
    fn from_takeoff(net: &Net, drone: Option<u16>) -> (Vec<String>, usize) {
        let walker = Walker::new(net);
        let b = starts(net, 0);
        let label = |t: NodeId| net.transition(t).unwrap().label.to_string();
        let takeoff = *b
            .iter()
            .find(|&&t| label(t).contains("Takeoff"))
            .expect("the first drone's takeoff");
        let mut budget = usize::MAX;
        let stop = |t: NodeId| b.contains(&t) && t != takeoff;
        let seeds = walker.after(takeoff, &[], true);
        let reach = walker
            .walk(seeds, drone, &stop, true, &|_| false, None, &mut budget)
            .unwrap();
        let mut labels: Vec<String> = reach.stops.iter().map(|(t, _)| label(*t)).collect();
        labels.sort();
        (labels, usize::MAX - budget)
    }

    /// B takes off, C and E fly a block of their own, then B flies on: B's
    /// walk from its takeoff passes the block's join without going down
    /// C's long branch, and finds the same next actions.
    #[test]
    fn a_walk_passes_a_block_without_going_down_the_other_drones_branches() {
        let mut text = String::from(
            "package P\n\nvar (\n\tB Quadcopter\n\tC Quadcopter\n\tE Quadcopter\n)\n\nfunc SEQ_M() {\n\tB.Arm()\n\tB.Takeoff(2)\n\tPAR_Others()\n\tB.FlyTo(3, 0, 2)\n\tB.Land()\n}\n\nfunc PAR_Others() {\n\tSEQ_C()\n\tE.Arm()\n}\n\nfunc SEQ_C() {\n\tC.Arm()\n\tC.Takeoff(2)\n",
        );
        for k in 0..40 {
            text += &format!("\tC.FlyTo({k}, 1, 2)\n");
        }
        text += "\tC.Land()\n}\n";
        let net = net(&text);
        let (every_branch, long) = from_takeoff(&net, None);
        let (own_branches, short) = from_takeoff(&net, Some(0));
        assert_eq!(own_branches, every_branch);
        assert!(
            own_branches.iter().any(|l| l.contains("FlyTo")),
            "B's walk from its takeoff passes the first block's join: {own_branches:?}"
        );
        assert!(
            short * 4 < long,
            "B's walk took {short} steps, going down C's branch {long}"
        );
    }

    /// B takes off, C and E fly forty actions and twenty blocks of their
    /// own in a row, then B hovers (alone, or in a block with C: `hover`) and
    /// flies on: B's walk jumps the row (`chain.rs`) to the hover, the
    /// first of its own actions there, and stops there as a walk step by
    /// step does, in a fraction of the steps.
    fn jumps_a_row_to(hover: &str) {
        let mut text = String::from(
            "package P\n\nvar (\n\tB Quadcopter\n\tC Quadcopter\n\tE Quadcopter\n)\n\nfunc SEQ_M() {\n\tB.Arm()\n\tB.Takeoff(2)\n",
        );
        for k in 0..20 {
            text += &format!("\tC.FlyTo({k}, 1, 2)\n\tE.TakePhoto()\n");
            text += "\tPAR_CE()\n";
        }
        text += &format!("\t{hover}\n\tC.Land()\n\tB.FlyTo(3, 0, 2)\n\tB.Land()\n}}\n");
        text += "\nfunc PAR_CE() {\n\tC.Hover(1)\n\tE.TakePhoto()\n}\n";
        if hover.starts_with("PAR_BC") {
            text += "\nfunc PAR_BC() {\n\tB.Hover(2)\n\tC.Hover(1)\n}\n";
        }
        let net = net(&text);
        let (step_by_step, long) = from_takeoff(&net, None);
        let (jumping, short) = from_takeoff(&net, Some(0));
        assert_eq!(jumping, step_by_step);
        assert_eq!(jumping.len(), 1, "{jumping:?}");
        assert!(jumping[0].contains("Hover"), "{jumping:?}");
        assert!(
            short <= 4 && short * 10 < long,
            "B's walk took {short} steps, step by step {long}"
        );
    }

    #[test]
    fn a_walk_jumps_a_row_of_other_drones_actions_up_to_its_own() {
        jumps_a_row_to("B.Hover(2)");
    }

    #[test]
    fn a_walk_jumps_a_row_up_to_a_block_with_its_own_action() {
        jumps_a_row_to("PAR_BC()");
    }

    /// B's walk from its takeoff, for B alone, finds one next action, a
    /// `Hover`, and the walk down every branch finds the same.
    fn assert_next_is_only_a_hover(net: &Net) {
        let (own, _) = from_takeoff(net, Some(0));
        assert_eq!(own, from_takeoff(net, None).0);
        assert_eq!(own.len(), 1, "{own:?}");
        assert!(own[0].contains("Hover"), "{own:?}");
    }

    /// B's next action lies in a block inside a branch of a block: the
    /// outer branch holds B's action through the inner block, whose fork
    /// the branch jumps to its join, so B's walk goes down it.
    #[test]
    fn a_branch_holds_the_actions_of_the_blocks_inside_it() {
        let text = "package P\n\nvar (\n\tB Quadcopter\n\tC Quadcopter\n\tE Quadcopter\n)\n\nfunc SEQ_M() {\n\tB.Arm()\n\tB.Takeoff(2)\n\tPAR_All()\n\tB.Land()\n}\n\nfunc PAR_All() {\n\tC.Arm()\n\tSEQ_Inner()\n\tE.Arm()\n}\n\nfunc SEQ_Inner() {\n\tE.Takeoff(2)\n\tPAR_Inner()\n}\n\nfunc PAR_Inner() {\n\tB.Hover(1)\n\tC.Takeoff(2)\n}\n";
        assert_next_is_only_a_hover(&net(text));
    }

    /// B has a branch of its own in a block beside C's and E's: B's walk
    /// from its takeoff goes down it to B's next action and not past the
    /// join, which waits for B's branch although C's and E's are taken as
    /// come to their end.
    #[test]
    fn a_join_waits_for_the_branches_of_the_drone_walked() {
        let text = "package P\n\nvar (\n\tB Quadcopter\n\tC Quadcopter\n\tE Quadcopter\n)\n\nfunc SEQ_M() {\n\tB.Arm()\n\tB.Takeoff(2)\n\tPAR_All()\n\tB.Land()\n}\n\nfunc PAR_All() {\n\tC.Arm()\n\tSEQ_B()\n\tE.Arm()\n}\n\nfunc SEQ_B() {\n\tB.Hover(1)\n\tB.FlyTo(3, 0, 2)\n}\n";
        assert_next_is_only_a_hover(&net(text));
    }

    /// Where walks for drone `d` set out from: the mission's start (no
    /// transition), and the ends, then the cancels, of each of its actions.
    fn walks_of(net: &Net, d: u16) -> Vec<(Vec<NodeId>, bool)> {
        let mut by_action: BTreeMap<(u32, bool), Vec<NodeId>> = BTreeMap::new();
        for (t, tr) in net.transitions() {
            let (a, cancel) = match &tr.kind {
                TransitionKind::ActionEnd(a) => (a, false),
                TransitionKind::ActionCancel(a) => (a, true),
                _ => continue,
            };
            if a.drone.0 == d {
                by_action.entry((a.instance, cancel)).or_default().push(t);
            }
        }
        let after = by_action
            .into_iter()
            .map(|((_, cancel), via)| (via, cancel));
        std::iter::once((Vec::new(), false)).chain(after).collect()
    }

    /// On generated missions with every construct, a walk for one drone
    /// finds the same next actions with the colours they start with,
    /// jumping rows of steps (`chain.rs`, `step.rs`) or walking every
    /// step: from the start, and from every end and cancel of each of
    /// the drone's actions, with colours and without.
    #[test]
    fn a_walk_finds_the_same_next_actions_jumping_as_step_by_step() {
        use eamos_gen::{generate, Options, Size};
        for (drones, nodes, seed) in [(4, 300, 1), (12, 800, 4), (6, 600, 7), (20, 1500, 12)] {
            let mission = generate(&Options::new(drones, Size::Nodes(nodes), seed)).unwrap();
            let net = net(&mission.text);
            let jumping = Walker::new(&net);
            let stepping = Walker::new(&net).without_jumps();
            for d in 0..drones as u16 {
                let own = starts(&net, d);
                let stop = |t: NodeId| own.contains(&t);
                for (via, cancel) in walks_of(&net, d) {
                    for colours in [true, false] {
                        let walk = |w: &Walker| {
                            let mut budget = usize::MAX;
                            let never = |_| false;
                            let reach = match via.is_empty() {
                                true => w.walk(
                                    w.initial(),
                                    Some(d),
                                    &stop,
                                    colours,
                                    &never,
                                    None,
                                    &mut budget,
                                ),
                                false => w.walk_after(
                                    &via,
                                    &[],
                                    cancel,
                                    Some(d),
                                    &stop,
                                    colours,
                                    &never,
                                    &mut budget,
                                ),
                            };
                            let mut stops = reach.unwrap().stops;
                            stops.sort();
                            stops
                        };
                        assert_eq!(
                            walk(&jumping),
                            walk(&stepping),
                            "{drones} drones, seed {seed}: D{} from {via:?} (cancel {cancel}, colours {colours})",
                            d + 1
                        );
                    }
                }
            }
        }
    }
}
