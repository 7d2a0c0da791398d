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
//! first).
//!
//! Loop counters are followed exactly where a `RepeatFor` guard reads them
//! (so a body flown three times is flown three times, not for ever); a
//! counter that no guard reads stops counting past the largest count any
//! guard tests, which keeps every walk finite.

use std::collections::{HashMap, HashSet};

use eamos_petri::net::{Colour, Net, NodeId, PlaceKind, TransitionKind};

pub(crate) struct Walker<'n> {
    net: &'n Net,
    /// Counters saturate here.
    cap: u32,
    /// The fork that opened each join's block.
    fork_of: HashMap<NodeId, NodeId>,
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
        Walker { net, cap, fork_of }
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
        self.net
            .postset(t)
            .filter(|(q, _)| self.followed(*q))
            .map(|(q, op)| (q, self.colour(op.apply(c), colours)))
            .collect()
    }

    /// Walks from `seeds` until `stop` says a transition is a stop. With
    /// `colours` off every token is colourless and colour guards may go
    /// either way (for analyses whose values are few, like flight states).
    /// A transition `blocked` says cannot fire (its guard cannot hold where
    /// the drone is) is not passed. `cut`: the seeds follow a cancel in
    /// this `Do` region, whose body is then skipped (its steps that need
    /// the region live cannot fire) until the region starts again.
    pub(crate) fn walk(
        &self,
        seeds: Vec<(NodeId, Colour)>,
        stop: &dyn Fn(NodeId) -> bool,
        colours: bool,
        blocked: &dyn Fn(NodeId) -> bool,
        cut: Option<u32>,
        budget: &mut usize,
    ) -> Result<Reach, OutOfBudget> {
        type Token = (NodeId, Colour, Option<u32>);
        let mut seen: HashSet<Token> = HashSet::new();
        let mut visited: HashSet<NodeId> = HashSet::new();
        let mut crossed: HashSet<NodeId> = HashSet::new();
        let mut waiting: Vec<(NodeId, Colour, Option<u32>)> = Vec::new();
        let mut stops: HashSet<(NodeId, Colour)> = HashSet::new();
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
                            waiting.push((t, c.clone(), cut));
                            continue;
                        }
                        _ => {}
                    }
                    let cut = cut.filter(|&r| !self.starts_region(t, r));
                    stack.extend(
                        self.after(t, &c, colours)
                            .into_iter()
                            .map(|(q, c)| (q, c, cut)),
                    );
                }
            }
            // Joins whose block the walk opened go on once every branch
            // of it has come to its end.
            let (ready, still): (Vec<_>, Vec<_>) = waiting.drain(..).partition(|(t, _, _)| {
                self.net
                    .preset(*t)
                    .filter(|&q| self.followed(q))
                    .all(|q| visited.contains(&q))
            });
            waiting = still;
            if ready.is_empty() {
                break;
            }
            for (t, c, cut) in ready {
                stack.extend(
                    self.after(t, &c, colours)
                        .into_iter()
                        .map(|(q, c)| (q, c, cut)),
                );
            }
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
        stop: &dyn Fn(NodeId) -> bool,
        colours: bool,
        blocked: &dyn Fn(NodeId) -> bool,
        budget: &mut usize,
    ) -> Result<Reach, OutOfBudget> {
        let mut reach = Reach::default();
        for &e in via {
            let cut = if cancel { self.region_of(e) } else { None };
            let seeds = self.after(e, c, colours);
            for stop in self.walk(seeds, stop, colours, blocked, cut, budget)?.stops {
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
        self.net.place(p).is_some_and(|p| {
            !p.kind.is_event_state() && !matches!(p.kind, PlaceKind::Region { .. })
        })
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
