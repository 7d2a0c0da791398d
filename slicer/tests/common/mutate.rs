//! Wrong slicings, made on purpose from right ones: each mutant is what a
//! slicer with one kind of bug would have produced.
//!
//! A mutant changes a step that fires in some run of the right slices (the
//! sites are taken from [`eamos_slicer::equivalence::explore`]), so that it
//! changes something a run does. A change can still leave the mission's
//! behaviour as it was (swapping two actions a drone runs side by side, a
//! bridge whose token nothing visible waits for). Where that can happen the
//! mutant carries the same change made to the mission net (`analog`): the
//! slicer never looks at what the change touches (labels, guards, delays,
//! the final place, which arcs exist), so the mutant is the slicing of that
//! changed mission, and it is equivalent exactly when the changed mission
//! is equivalent to the mission. A dropped bridge's analog drops the
//! mission's arcs the bridge stands for (for a fan-out every arc it fans
//! out, for a forward every arc it forwards; a pre-join's join never
//! fires). A moved action or condition has no analog: the drone that runs
//! it differs, so it must always be told apart.
//!
//! A dropped end notice is an owner whose end is never marked: it never
//! tells the others, so nobody stops.

use std::collections::{BTreeMap, BTreeSet};

use eamos_lang::hir::DroneId;
use eamos_petri::net::{
    ActionRef, ArcKind, GuardKind, Net, Node, Owner, PlaceKind, Transition, TransitionKind,
};
use eamos_slicer::{cut_along_owners, Slice, SliceTransition, Slices};
use petgraph::visit::EdgeRef;

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    DropBridge,
    SwapActions,
    MoveAction,
    /// A condition decided on another drone than the one whose state it
    /// reads first (the compiler's choice).
    MoveCondition,
    FlipGuard,
    DropDelay,
    DropEndNotice,
}

pub const KINDS: [Kind; 7] = [
    Kind::DropBridge,
    Kind::SwapActions,
    Kind::MoveAction,
    Kind::MoveCondition,
    Kind::FlipGuard,
    Kind::DropDelay,
    Kind::DropEndNotice,
];

pub struct Mutant {
    pub kind: Kind,
    /// What was changed, for a person.
    pub site: String,
    pub slices: Vec<Slice>,
    /// The same change made to the mission net (see the module docs).
    pub analog: Option<Net>,
}

/// One mutant of `kind`, its site picked by `pick` among the sites that
/// fire; `None` when the mission has no such site.
pub fn mutant(
    kind: Kind,
    net: &Net,
    s: &Slices,
    distributed: &Net,
    fired: &BTreeSet<String>,
    pick: usize,
) -> Option<Mutant> {
    let at = Sites { fired, pick };
    let (site, slices, analog) = match kind {
        Kind::DropBridge => drop_bridge(net, s, distributed, &at)?,
        Kind::SwapActions => swap_actions(net, s, &at)?,
        Kind::MoveAction => move_unit(net, s, distributed, &at, &|t| {
            matches!(t.kind, TransitionKind::ActionStart(_))
        })?,
        Kind::MoveCondition => move_unit(net, s, distributed, &at, &|t| {
            t.kind.action().is_none() && t.guard.as_ref().is_some_and(|g| !g.drones().is_empty())
        })?,
        Kind::FlipGuard => change_transition(net, s, &at, &FlipGuard)?,
        Kind::DropDelay => change_transition(net, s, &at, &DropDelay)?,
        Kind::DropEndNotice => drop_end_notice(net, s, &at)?,
    };
    Some(Mutant {
        kind,
        site,
        slices,
        analog,
    })
}

type Made = (String, Vec<Slice>, Option<Net>);

/// Which steps fire, and which of the candidate sites to take.
struct Sites<'a> {
    fired: &'a BTreeSet<String>,
    pick: usize,
}

impl Sites<'_> {
    fn fires(&self, t: &SliceTransition) -> bool {
        self.fired.contains(t.transition.id.as_str())
    }

    fn choose<T: Copy>(&self, sites: &[T]) -> Option<T> {
        (!sites.is_empty()).then(|| sites[self.pick % sites.len()])
    }
}

fn drop_bridge(net: &Net, s: &Slices, d: &Net, at: &Sites) -> Option<Made> {
    let mut slices = s.slices.clone();
    let sites: Vec<(usize, usize)> = slices
        .iter()
        .enumerate()
        .flat_map(|(i, sl)| {
            (0..sl.bridges_out.len())
                .filter(|&b| at.fires(&sl.transitions[sl.bridges_out[b].transition as usize]))
                .map(move |b| (i, b))
        })
        .collect();
    let (i, b) = at.choose(&sites)?;
    let out = slices[i].bridges_out.remove(b);
    let r = slices.iter().position(|x| x.drone == out.to)?;
    slices[r].bridges_in.retain(|x| x.id != out.id);
    // Consistent peer lists, so that only the behaviour can give it away.
    for k in [i, r] {
        let sl = &mut slices[k];
        let peers: BTreeSet<String> = sl
            .bridges_in
            .iter()
            .map(|b| b.from.clone())
            .chain(sl.bridges_out.iter().map(|b| b.to.clone()))
            .collect();
        sl.peers = peers.into_iter().collect();
    }
    let sender = &s.slices[i].transitions[out.transition as usize]
        .transition
        .id;
    let inbox = s.slices[r]
        .bridges_in
        .iter()
        .find(|b| b.id == out.id)?
        .inbox;
    let inbox = &s.slices[r].places[inbox as usize].id;
    let analog = without_bridge(net, d, sender, inbox)?;
    let site = format!("bridge {} from {} to {}", out.id, s.slices[i].drone, out.to);
    Some((site, slices, Some(analog)))
}

/// Two action instances of one drone that both start trade places.
fn swap_actions(net: &Net, s: &Slices, at: &Sites) -> Option<Made> {
    let mut slices = s.slices.clone();
    let mut sites = Vec::new();
    for (i, sl) in slices.iter().enumerate() {
        let started: Vec<u32> = sl
            .transitions
            .iter()
            .filter(|t| at.fires(t))
            .filter_map(|t| match &t.transition.kind {
                TransitionKind::ActionStart(a) => Some(a.instance),
                _ => None,
            })
            .collect();
        for (x, &a) in started.iter().enumerate() {
            for &b in &started[x + 1..] {
                sites.push((i, a, b));
            }
        }
    }
    let (i, a, b) = at.choose(&sites)?;
    let refs = action_refs(net);
    let swap = |r: &mut ActionRef| {
        if r.instance == a {
            *r = refs[&b].clone();
        } else if r.instance == b {
            *r = refs[&a].clone();
        }
    };
    let swap_in = |n: &mut Node| match n {
        Node::Transition(t) => {
            if let Some(r) = action_of(&mut t.kind) {
                swap(r)
            }
        }
        Node::Place(p) => {
            if let PlaceKind::Running(r) = &mut p.kind {
                swap(std::sync::Arc::make_mut(r))
            }
        }
    };
    let sl = &mut slices[i];
    for t in &mut sl.transitions {
        if let Some(r) = action_of(&mut t.transition.kind) {
            swap(r)
        }
    }
    for p in &mut sl.places {
        if let PlaceKind::Running(r) = &mut p.kind {
            swap(std::sync::Arc::make_mut(r))
        }
    }
    let mut analog = net.clone();
    analog.graph.node_weights_mut().for_each(swap_in);
    let site = format!("actions #{a} and #{b} of {}", sl.drone);
    Some((site, slices, Some(analog)))
}

/// A change to one transition, the same in a slice and in the mission.
trait Change {
    fn applies(&self, t: &Transition) -> bool;
    fn apply(&self, t: &mut Transition);
}

struct FlipGuard;

impl Change for FlipGuard {
    fn applies(&self, t: &Transition) -> bool {
        t.guard
            .as_ref()
            .is_some_and(|g| matches!(g.kind, GuardKind::Cond { .. }))
    }

    fn apply(&self, t: &mut Transition) {
        if let Some(GuardKind::Cond { negated, .. }) = t.guard.as_mut().map(|g| &mut g.kind) {
            *negated = !*negated;
        }
    }
}

struct DropDelay;

impl Change for DropDelay {
    fn applies(&self, t: &Transition) -> bool {
        t.delay.is_some()
    }

    fn apply(&self, t: &mut Transition) {
        t.delay = None;
    }
}

fn change_transition(net: &Net, s: &Slices, at: &Sites, change: &dyn Change) -> Option<Made> {
    let mut slices = s.slices.clone();
    let sites: Vec<(usize, usize)> = slices
        .iter()
        .enumerate()
        .flat_map(|(i, sl)| {
            (0..sl.transitions.len())
                .filter(|&k| {
                    let t = &sl.transitions[k];
                    at.fires(t) && change.applies(&t.transition)
                })
                .map(move |k| (i, k))
        })
        .collect();
    let (i, k) = at.choose(&sites)?;
    let t = &mut slices[i].transitions[k].transition;
    change.apply(t);
    let mut analog = net.clone();
    let v = analog.find(&t.id)?;
    if let Node::Transition(t) = &mut analog.graph[v] {
        change.apply(t);
    }
    let site = format!("`{}` on {}", t.label, s.slices[i].drone);
    Some((site, slices, Some(analog)))
}

fn drop_end_notice(net: &Net, s: &Slices, at: &Sites) -> Option<Made> {
    let mut slices = s.slices.clone();
    let sites: Vec<usize> = (0..slices.len())
        .filter(|&i| {
            let sl = &slices[i];
            sl.final_place.is_some_and(|f| {
                sl.transitions
                    .iter()
                    .any(|t| at.fires(t) && t.produce.iter().any(|p| p.place == f))
            })
        })
        .collect();
    let i = at.choose(&sites)?;
    let f = slices[i].final_place?;
    for t in &mut slices[i].transitions {
        t.produce.retain(|p| p.place != f);
    }
    let mut analog = net.clone();
    let into_final: Vec<_> = analog
        .graph
        .edges_directed(analog.final_place, petgraph::Direction::Incoming)
        .map(|e| e.id())
        .collect();
    for e in into_final.into_iter().rev() {
        analog.graph.remove_edge(e);
    }
    let site = format!("the end notice of {}", slices[i].drone);
    Some((site, slices, Some(analog)))
}

fn action_of(kind: &mut TransitionKind) -> Option<&mut ActionRef> {
    match kind {
        TransitionKind::ActionStart(a)
        | TransitionKind::ActionEnd(a)
        | TransitionKind::ActionCancel(a) => Some(std::sync::Arc::make_mut(a)),
        _ => None,
    }
}

fn action_refs(net: &Net) -> BTreeMap<u32, ActionRef> {
    net.transitions()
        .filter_map(|(_, t)| t.kind.action())
        .map(|a| (a.instance, ActionRef::clone(a)))
        .collect()
}

/// The slicer's partition put one step that `what` picks (with every node
/// that must live beside it) on another owner: the next drone, or the
/// ground station in a mission of one drone.
fn move_unit(
    net: &Net,
    s: &Slices,
    d: &Net,
    at: &Sites,
    what: &dyn Fn(&Transition) -> bool,
) -> Option<Made> {
    let sites: Vec<_> = d
        .transitions()
        .filter(|(_, t)| what(t) && at.fired.contains(t.id.as_str()))
        .map(|(v, _)| v)
        .collect();
    let start = at.choose(&sites)?;
    // The unit: places and the owned transitions that consume or read them,
    // closed under both (the join that ends the mission belongs to nobody).
    let mut unit = BTreeSet::from([start]);
    let mut stack = vec![start];
    while let Some(v) = stack.pop() {
        let mut next = Vec::new();
        if d.is_place(v) {
            next.extend(
                d.consumers(v)
                    .map(|(t, _)| t)
                    .filter(|&t| d.owner(t) != Owner::Unassigned),
            );
        } else {
            next.extend(
                d.graph
                    .edges_directed(v, petgraph::Direction::Incoming)
                    .filter(|e| e.weight().kind != ArcKind::Produce)
                    .map(|e| e.source()),
            );
        }
        for u in next {
            if unit.insert(u) {
                stack.push(u);
            }
        }
    }
    let from = d.owner(start);
    let to = match from {
        Owner::Drone(DroneId(i)) if d.drones.len() > 1 => {
            Owner::Drone(DroneId((i + 1) % d.drones.len() as u16))
        }
        _ => Owner::Gcs,
    };
    let mut moved = d.clone();
    for &v in &unit {
        match &mut moved.graph[v] {
            Node::Place(p) => p.owner = to,
            Node::Transition(t) => t.owner = to,
        }
    }
    let slices = cut_along_owners(&moved, &s.mission_id);
    let label = d.transition(start).map_or("?", |t| &t.label).to_string();
    let site = format!(
        "`{label}` ({} nodes) from {} to {}",
        unit.len(),
        net.owner_name(from),
        net.owner_name(to)
    );
    Some((site, slices, None))
}

/// The mission net without what a bridge stands for: the arc from `sender`
/// to `inbox` of the distributed net `d`, traced back through the bundle
/// that made it (the ids of bundle nodes are not the mission's).
fn without_bridge(net: &Net, d: &Net, sender: &str, inbox: &str) -> Option<Net> {
    let mut a = net.clone();
    let drop_arcs = |a: &mut Net, from: &str, to: &str| {
        if let (Some(x), Some(y)) = (a.find(from), a.find(to)) {
            while let Some(e) = a.graph.find_edge(x, y) {
                a.graph.remove_edge(e);
            }
        }
    };
    let (t, p) = (d.find(sender)?, d.find(inbox)?);
    match (net.find(sender).is_some(), net.find(inbox).is_some()) {
        (true, true) => drop_arcs(&mut a, sender, inbox),
        // A fan-out: its proxy puts the tokens where the arcs went.
        (true, false) => {
            let (proxy, _) = d.consumers(p).next()?;
            for (q, _) in d.postset(proxy) {
                drop_arcs(&mut a, sender, d.id(q));
            }
        }
        // A pre-join: the join it feeds never gets its inputs.
        (false, false) => {
            let (join, _) = d.consumers(p).next()?;
            let join = a.find(d.id(join))?;
            let never = a.add_place(eamos_petri::Place {
                id: "never".into(),
                label: "never marked".into(),
                kind: PlaceKind::Control,
                owner: Owner::Unassigned,
                span: None,
                depth: 0,
            });
            a.arc(never, join, eamos_petri::net::ColourOp::Keep);
        }
        // A forward: every producer it forwards for.
        (false, true) => {
            let local = d.preset(t).next()?;
            for s in d.producers(local) {
                drop_arcs(&mut a, d.id(s), inbox);
            }
        }
    }
    Some(a)
}
