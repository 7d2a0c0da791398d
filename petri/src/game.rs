//! The reference token game: the executable meaning of a net.
//!
//! A plain sequential interpreter over coloured markings. It is the yardstick
//! the other stages are measured against: the slicer's parts, played
//! together, and the executor on real drones must only ever produce firing
//! sequences this game can produce.
//!
//! Rules:
//! * The net is 1-safe: a place holds at most one token, with a colour (the
//!   iteration counters of the loops around it). Producing into a marked
//!   place is an error ([`FireError::Unsafe`]), never a second token; a
//!   consuming arc of weight above one can therefore never be satisfied.
//! * A transition is *token-enabled* when every place it consumes or reads
//!   is marked. The colour it fires with (its binding) is the longest colour
//!   among those tokens; shorter ones are the colours of places outside the
//!   inner loops (region state) or colourless event places.
//! * Colour guards (`RepeatFor`) are decided on the binding colour by the
//!   game itself. Condition guards ask the world, which a caller supplies as
//!   a guard oracle `FnMut(&Transition, &Guard, &[u32]) -> bool`; the game
//!   asks it once per token-enabled guarded transition each time it lists
//!   the enabled ones.
//! * Time does not exist here: a timed transition (`PauseFor`) is simply a
//!   transition that may fire.

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::net::{ArcKind, Colour, Guard, Net, NodeId, Transition};

/// Which places hold a token, and its colour. Sorted by place, so two
/// markings are equal exactly when they mark the same places with the same
/// colours; cloning copies one small vector and bumps reference counts.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Marking {
    tokens: Vec<(NodeId, Arc<[u32]>)>,
}

impl Marking {
    /// The initial marking of the net: one colourless token in each place of
    /// `net.initial_marking`.
    pub fn initial(net: &Net) -> Self {
        let mut m = Marking::default();
        for &p in &net.initial_marking {
            // A duplicate in the list marks the place once.
            let _ = m.put(p, Arc::from(Vec::new()));
        }
        m
    }

    pub fn is_marked(&self, p: NodeId) -> bool {
        self.index(p).is_ok()
    }

    /// The colour of the token in `p`, if `p` is marked.
    pub fn colour(&self, p: NodeId) -> Option<&[u32]> {
        self.index(p).ok().map(|i| &*self.tokens[i].1)
    }

    /// Marked places with their colours, by place.
    pub fn iter(&self) -> impl Iterator<Item = (NodeId, &[u32])> + '_ {
        self.tokens.iter().map(|(p, c)| (*p, &**c))
    }

    /// Marked places, by place.
    pub fn places(&self) -> impl Iterator<Item = NodeId> + '_ {
        self.tokens.iter().map(|(p, _)| *p)
    }

    /// Number of marked places.
    pub fn len(&self) -> usize {
        self.tokens.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tokens.is_empty()
    }

    /// The mission has ended properly: `final` is marked and every other
    /// marked place records the state of an event (see the compiler's
    /// documentation of the final marking).
    pub fn is_final(&self, net: &Net) -> bool {
        self.is_marked(net.final_place)
            && self.places().all(|p| {
                p == net.final_place || net.place(p).is_some_and(|pl| pl.kind.is_event_state())
            })
    }

    /// The same places marked, each token's colour replaced by `f` of it.
    /// A search over markings uses it to fold colours that no guard can
    /// tell apart into one marking, so that loops whose counters grow
    /// without bound still have finitely many markings.
    pub fn map_colours(&self, mut f: impl FnMut(&[u32]) -> Colour) -> Marking {
        Marking {
            tokens: self
                .tokens
                .iter()
                .map(|(p, c)| (*p, Arc::from(f(c))))
                .collect(),
        }
    }

    fn index(&self, p: NodeId) -> Result<usize, usize> {
        self.tokens.binary_search_by_key(&p, |(q, _)| *q)
    }

    fn take(&mut self, p: NodeId) -> Option<Arc<[u32]>> {
        self.index(p).ok().map(|i| self.tokens.remove(i).1)
    }

    /// Marks `p`; `Err` if it already is.
    fn put(&mut self, p: NodeId, colour: Arc<[u32]>) -> Result<(), ()> {
        match self.index(p) {
            Ok(_) => Err(()),
            Err(i) => {
                self.tokens.insert(i, (p, colour));
                Ok(())
            }
        }
    }
}

/// A transition that may fire now, with the colour it fires with.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Enabled {
    pub transition: NodeId,
    pub colour: Colour,
}

/// One step of a run.
pub type Firing = Enabled;

/// Why a transition could not fire.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FireError {
    #[error("node {0:?} is not a transition of the net")]
    NotATransition(NodeId),
    #[error("transition `{transition}` is not enabled: place `{place}` is empty")]
    NotEnabled { transition: String, place: String },
    #[error("transition `{transition}` is not enabled: its colour guard is false")]
    ColourGuard { transition: String },
    #[error(
        "firing `{transition}` would put a second token in place `{place}`: the net is not 1-safe (a compiler bug)"
    )]
    Unsafe { transition: String, place: String },
    #[error(
        "firing `{transition}` would put a token of colour {colour:?} in place `{place}` of depth {depth} (a compiler bug)"
    )]
    ColourDepth {
        transition: String,
        place: String,
        colour: Colour,
        depth: u8,
    },
}

/// The binding colour of `t` if every place it consumes or reads is marked,
/// ignoring guards.
pub fn token_enabled(net: &Net, marking: &Marking, t: NodeId) -> Option<Colour> {
    net.transition(t)?;
    let mut colour: &[u32] = &[];
    for (p, _, arc) in inputs(net, t) {
        if arc.kind == ArcKind::Consume && arc.weight > 1 {
            return None;
        }
        let c = marking.colour(p)?;
        if c.len() > colour.len() {
            colour = c;
        }
    }
    Some(colour.to_vec())
}

fn inputs<'a>(
    net: &'a Net,
    t: NodeId,
) -> impl Iterator<Item = (NodeId, NodeId, &'a crate::net::Arc)> + 'a {
    use petgraph::visit::EdgeRef;
    net.graph
        .edges_directed(t, petgraph::Direction::Incoming)
        .map(move |e| (e.source(), t, e.weight()))
}

/// Transitions that consume or read a marked place: the only candidates.
fn candidates(net: &Net, marking: &Marking) -> Vec<NodeId> {
    let mut ts: Vec<NodeId> = marking
        .places()
        .flat_map(|p| net.consumers(p).map(|(t, _)| t))
        .collect();
    ts.sort();
    ts.dedup();
    ts
}

/// Whether a guard lets `t` fire with `colour`: colour guards are decided
/// here, condition guards by the oracle.
fn guard_holds<G>(t: &Transition, colour: &[u32], guards: &mut G) -> bool
where
    G: FnMut(&Transition, &Guard, &[u32]) -> bool,
{
    match &t.guard {
        None => true,
        Some(g) => match g.holds_on_colour(colour) {
            Some(v) => v,
            None => guards(t, g, colour),
        },
    }
}

/// Every transition that may fire in `marking`, by node index, asking
/// `guards` about condition guards.
pub fn enabled<G>(net: &Net, marking: &Marking, guards: &mut G) -> Vec<Enabled>
where
    G: FnMut(&Transition, &Guard, &[u32]) -> bool,
{
    candidates(net, marking)
        .into_iter()
        .filter_map(|t| {
            let colour = token_enabled(net, marking, t)?;
            let tr = net.transition(t)?;
            guard_holds(tr, &colour, guards).then_some(Enabled {
                transition: t,
                colour,
            })
        })
        .collect()
}

/// Transitions that have their tokens and a true colour guard (if any) but
/// wait on a condition guard: what a run waits for when nothing is enabled.
pub fn waiting_on_conditions(net: &Net, marking: &Marking) -> Vec<NodeId> {
    candidates(net, marking)
        .into_iter()
        .filter(|&t| {
            let (Some(colour), Some(tr)) = (token_enabled(net, marking, t), net.transition(t))
            else {
                return false;
            };
            tr.guard
                .as_ref()
                .is_some_and(|g| g.holds_on_colour(&colour).is_none())
        })
        .collect()
}

/// Fires `t` in `marking` and returns the next marking. Checks the tokens
/// and colour guards; condition guards are the caller's to decide (it chose
/// `t` from [`enabled`], or it plays the world itself).
pub fn fire(net: &Net, marking: &Marking, t: NodeId) -> Result<Marking, FireError> {
    let mut next = marking.clone();
    fire_in_place(net, &mut next, t)?;
    Ok(next)
}

/// [`fire`] on a marking the caller owns; returns the binding colour. On
/// error the marking is unchanged.
pub fn fire_in_place(net: &Net, marking: &mut Marking, t: NodeId) -> Result<Colour, FireError> {
    let tr = net.transition(t).ok_or(FireError::NotATransition(t))?;
    let id = |n: NodeId| match &net.graph[n] {
        crate::Node::Place(p) => p.id.to_string(),
        crate::Node::Transition(t) => t.id.to_string(),
    };
    let colour = match token_enabled(net, marking, t) {
        Some(c) => c,
        None => {
            let missing = inputs(net, t)
                .find(|(p, _, arc)| {
                    !marking.is_marked(*p) || (arc.kind == ArcKind::Consume && arc.weight > 1)
                })
                .map_or_else(String::new, |(p, _, _)| id(p));
            return Err(FireError::NotEnabled {
                transition: tr.id.to_string(),
                place: missing,
            });
        }
    };
    if let Some(false) = tr.guard.as_ref().and_then(|g| g.holds_on_colour(&colour)) {
        return Err(FireError::ColourGuard {
            transition: tr.id.to_string(),
        });
    }
    let mut next = marking.clone();
    for p in net.preset(t) {
        next.take(p);
    }
    for (p, op) in net.postset(t) {
        let c = op.apply(&colour);
        let depth = net.place(p).map_or(0, |pl| pl.depth);
        if c.len() != depth as usize {
            return Err(FireError::ColourDepth {
                transition: tr.id.to_string(),
                place: id(p),
                colour: c,
                depth,
            });
        }
        if next.put(p, Arc::from(c)).is_err() {
            return Err(FireError::Unsafe {
                transition: tr.id.to_string(),
                place: id(p),
            });
        }
    }
    *marking = next;
    Ok(colour)
}

/// How a run ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Nothing is enabled and the marking is the final one.
    Final,
    /// Nothing is token-enabled and the marking is not the final one.
    Deadlock,
    /// The step budget ran out while the only transitions with their tokens
    /// waited on conditions the oracle kept answering false.
    Waiting,
    /// The step budget ran out with transitions still enabled.
    StepLimit,
    /// A firing broke the net's invariants: a compiler bug.
    Broken(FireError),
}

/// A finished run of the token game.
#[derive(Debug, Clone)]
pub struct Run {
    pub firings: Vec<Firing>,
    pub marking: Marking,
    pub outcome: Outcome,
}

impl Run {
    /// The fired transitions, in order.
    pub fn transitions(&self) -> impl Iterator<Item = NodeId> + '_ {
        self.firings.iter().map(|f| f.transition)
    }

    /// The position of the first firing of `t`, if it fired.
    pub fn position(&self, t: NodeId) -> Option<usize> {
        self.transitions().position(|x| x == t)
    }

    /// The ids of the fired transitions, in order.
    pub fn ids<'n>(&self, net: &'n Net) -> Vec<&'n str> {
        self.transitions()
            .filter_map(|t| net.transition(t).map(|tr| tr.id.as_str()))
            .collect()
    }
}

/// Plays the game from the initial marking, choosing uniformly at random
/// (ChaCha8 seeded with `seed`) among the enabled transitions, until nothing
/// is enabled or `max_steps` steps are spent.
///
/// When nothing is enabled but some transition waits on a condition guard,
/// the run asks the oracle again (the world may have changed); each such
/// poll costs a step, like a firing. An oracle that answers at random thus
/// lets every wait end; one that answers `false` for ever ends the run with
/// [`Outcome::Waiting`].
pub fn run_random<G>(net: &Net, seed: u64, mut guards: G, max_steps: usize) -> Run
where
    G: FnMut(&Transition, &Guard, &[u32]) -> bool,
{
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    run_with(
        net,
        Marking::initial(net),
        &mut guards,
        |en| rng.random_range(0..en.len()),
        max_steps,
    )
}

/// Plays the game from `marking`, letting `choose` pick the index of the
/// transition to fire among the enabled ones (never called with an empty
/// list). See [`run_random`] for the rules of a run.
pub fn run_with<G, C>(
    net: &Net,
    marking: Marking,
    guards: &mut G,
    mut choose: C,
    max_steps: usize,
) -> Run
where
    G: FnMut(&Transition, &Guard, &[u32]) -> bool,
    C: FnMut(&[Enabled]) -> usize,
{
    let mut run = Run {
        firings: Vec::new(),
        marking,
        outcome: Outcome::StepLimit,
    };
    let mut polled = false;
    for _ in 0..max_steps {
        let en = enabled(net, &run.marking, guards);
        if en.is_empty() {
            if waiting_on_conditions(net, &run.marking).is_empty() {
                run.outcome = if run.marking.is_final(net) {
                    Outcome::Final
                } else {
                    Outcome::Deadlock
                };
                return run;
            }
            polled = true;
            continue;
        }
        polled = false;
        let pick = en[choose(&en).min(en.len() - 1)].clone();
        if let Err(e) = fire_in_place(net, &mut run.marking, pick.transition) {
            run.outcome = Outcome::Broken(e);
            return run;
        }
        run.firings.push(pick);
    }
    if polled {
        run.outcome = Outcome::Waiting;
    }
    run
}

/// Ready-made guard oracles.
pub mod oracle {
    use super::*;

    /// Answers every condition guard at random, independently each time it
    /// is asked: the world changes all the time. A guard is true with
    /// probability `p_true` (clamped to 0..=1).
    pub fn random(seed: u64, p_true: f64) -> impl FnMut(&Transition, &Guard, &[u32]) -> bool {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let p = if p_true.is_nan() {
            0.5
        } else {
            p_true.clamp(0.0, 1.0)
        };
        move |_, _, _| rng.random_bool(p)
    }

    /// Every condition has the value `value`: a guard holds when it asks for
    /// that value (its negation holds otherwise).
    pub fn constant(value: bool) -> impl FnMut(&Transition, &Guard, &[u32]) -> bool {
        move |_, g, _| g.holds_when(value)
    }
}
