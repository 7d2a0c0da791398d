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
            .min(crate::mission::MAX_COUNTED_ROUNDS)
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
    /// the drone is) is not passed.
    pub(crate) fn walk(
        &self,
        seeds: Vec<(NodeId, Colour)>,
        stop: &dyn Fn(NodeId) -> bool,
        colours: bool,
        blocked: &dyn Fn(NodeId) -> bool,
        budget: &mut usize,
    ) -> Result<Reach, OutOfBudget> {
        let mut seen: HashSet<(NodeId, Colour)> = HashSet::new();
        let mut visited: HashSet<NodeId> = HashSet::new();
        let mut crossed: HashSet<NodeId> = HashSet::new();
        let mut waiting: Vec<(NodeId, Colour)> = Vec::new();
        let mut stops: HashSet<(NodeId, Colour)> = HashSet::new();
        let mut reach = Reach::default();
        let mut stack: Vec<(NodeId, Colour)> = seeds
            .into_iter()
            .map(|(p, c)| (p, self.colour(c, colours)))
            .collect();
        loop {
            while let Some((p, c)) = stack.pop() {
                if !seen.insert((p, c.clone())) {
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
                    let closed = blocked;
                    let blocked = colours
                        && tr
                            .and_then(|t| t.guard.as_ref())
                            .and_then(|g| g.holds_on_colour(&c))
                            == Some(false);
                    if blocked || closed(t) {
                        continue;
                    }
                    match tr.map(|t| &t.kind) {
                        Some(TransitionKind::Fork) => {
                            crossed.insert(t);
                        }
                        Some(TransitionKind::Join)
                            if self.fork_of.get(&t).is_some_and(|f| crossed.contains(f)) =>
                        {
                            waiting.push((t, c.clone()));
                            continue;
                        }
                        _ => {}
                    }
                    stack.extend(self.after(t, &c, colours));
                }
            }
            // Joins whose block the walk opened go on once every branch
            // of it has come to its end.
            let (ready, still): (Vec<_>, Vec<_>) = waiting.drain(..).partition(|(t, _)| {
                self.net
                    .preset(*t)
                    .filter(|&q| self.followed(q))
                    .all(|q| visited.contains(&q))
            });
            waiting = still;
            if ready.is_empty() {
                break;
            }
            for (t, c) in ready {
                stack.extend(self.after(t, &c, colours));
            }
        }
        Ok(reach)
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
