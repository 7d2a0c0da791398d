//! A mission net as the checker sees it: the P/T skeleton of the coloured
//! net, with steps named in mission terms.
//!
//! Abstractions, each an over-approximation of what can happen (so a proof
//! holds however the sensors behave and however long actions take):
//! * a transition guarded by a condition may fire whenever its inputs are
//!   marked, whatever the sensors say;
//! * colours are dropped, and so are the iteration counters of the
//!   `RepeatFor` loops whose bodies nothing outside them can observe
//!   ([`crate::fold`]: their rounds and exits become a free choice, and a
//!   check that finds anything is done again with every loop counted);
//! * the other `RepeatFor` loops keep their counters, which the colour
//!   guards test: each such loop gets counter places
//!   `c0..cn` (one marked), its entry resets the counter, its loop-back moves
//!   it up and its two guarded branches read it, so the checker counts
//!   rounds exactly as the token game does and its counterexamples replay
//!   (a loop of more than [`MAX_COUNTED_ROUNDS`] is not explored at all:
//!   the check says so, at its count, and leaves the properties unknown);
//! * timed transitions (`PauseFor`) are untimed;
//! * except: a transition whose guard can never hold (by interval reasoning
//!   over the profile's property ranges, see [`crate::conditions`]) is left
//!   out, since no sensor value can let it fire.

use std::collections::{HashMap, HashSet};

use eamos_lang::hir::DroneId;
use eamos_lang::Span;
use eamos_petri::net::{
    ActionRef, ArcKind, ColourOp, GuardKind, Net, NodeId, PlaceKind, TransitionKind,
};
use eamos_profile::{ProfileTable, ValueType};
use petgraph::visit::EdgeRef;

use crate::check::{ActionInfo, Subject};
use crate::conditions::{self, Domain, Possibility};
use crate::names::{self, fmt_num, Names};
use crate::ptnet::{PlaceInfo, PtNet, RawTransition, Seeds, StepInfo, MAX_COUNTED_ROUNDS};
use crate::report::{Finding, FindingKind, InputKind, Label, Limit};
use crate::space::walk::Walker;
use crate::space::{airspace, flight, model, Prepared, Space};
use crate::structural::Concurrency;

pub(crate) fn action_text(net: &Net, a: &ActionRef) -> String {
    names::action_text(&net.drones, a)
}

/// The text of a span, if it lies in the source.
fn snippet(src: Option<&str>, span: Span) -> Option<&str> {
    src?.get(span.start as usize..span.end as usize)
}

/// The identifier a span starts with (`If`, `RepeatWhile`, ...).
fn structure(src: Option<&str>, span: Span) -> Option<&str> {
    let s = src?.get(span.start as usize..)?;
    let end = s
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    (end > 0).then(|| &s[..end])
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn step_info(net: &Net, t: &eamos_petri::net::Transition, src: Option<&str>) -> StepInfo {
    let span = Some(t.span).filter(|s| !(s.is_empty() && s.start == 0));
    let what = structure(src, t.span).unwrap_or("");
    let here = snippet(src, t.span).map(one_line);
    let condition = t.guard.as_ref().and_then(|g| g.condition());
    let guard = condition.map(|(c, negated)| (c.span(), !negated));
    let cond_text = condition.and_then(|(c, _)| snippet(src, c.span()).map(one_line));
    // The compiler's labels repeat the condition after a first word that
    // says which way the step goes (`iterate`, `leave`): keep that word.
    let label_suffix = match t.label.split_whitespace().next() {
        Some(w) if cond_text.is_some() => format!(" ({w})"),
        Some(_) => format!(" ({})", t.label),
        None => String::new(),
    };
    let (kind, text, internal) = match &t.kind {
        TransitionKind::Init => ("Init", "the mission starts".to_string(), false),
        TransitionKind::Finish => ("Finish", "the mission ends".to_string(), false),
        TransitionKind::ActionStart(a) => (
            "ActionStart",
            format!("{} starts", action_text(net, a)),
            false,
        ),
        TransitionKind::ActionEnd(a) => {
            ("ActionEnd", format!("{} ends", action_text(net, a)), false)
        }
        TransitionKind::ActionCancel(a) => (
            "ActionCancel",
            format!("{} is cancelled", action_text(net, a)),
            false,
        ),
        TransitionKind::Branch => {
            let text = match (&cond_text, guard) {
                (Some(c), Some((_, held))) => format!(
                    "{}: `{c}` {}{label_suffix}",
                    if what.is_empty() { "condition" } else { what },
                    if held { "holds" } else { "does not hold" }
                ),
                _ if !t.label.is_empty() => t.label.to_string(),
                _ => format!(
                    "{}: takes a branch",
                    if what.is_empty() { "branch" } else { what }
                ),
            };
            ("Branch", text, false)
        }
        TransitionKind::LoopBack => (
            "LoopBack",
            format!(
                "{}: goes round again",
                if what.is_empty() { "loop" } else { what }
            ),
            false,
        ),
        TransitionKind::Pause => {
            let text = match (&cond_text, guard) {
                (Some(c), Some((_, held))) => format!(
                    "{}: `{c}` {}: the wait is over",
                    if what.is_empty() { "wait" } else { what },
                    if held { "holds" } else { "does not hold" }
                ),
                _ => format!(
                    "{} is over",
                    here.clone().unwrap_or_else(|| "the pause".into())
                ),
            };
            ("Pause", text, false)
        }
        TransitionKind::Signal => (
            "Signal",
            here.clone().unwrap_or_else(|| t.label.to_string()),
            false,
        ),
        TransitionKind::Await => (
            "Await",
            format!(
                "{} passes",
                here.clone().unwrap_or_else(|| t.label.to_string())
            ),
            false,
        ),
        TransitionKind::Interrupt => {
            let text = match (&cond_text, guard) {
                (Some(c), Some((_, held))) => format!(
                    "{}: `{c}` {}: the body is interrupted",
                    if what.is_empty() { "Do" } else { what },
                    if held { "holds" } else { "does not hold" }
                ),
                _ => format!(
                    "{}: the body is interrupted",
                    if what.is_empty() { "Do" } else { what }
                ),
            };
            ("Interrupt", text, false)
        }
        TransitionKind::Fork => ("Fork", format!("fork{label_suffix}"), true),
        TransitionKind::Join => ("Join", format!("join{label_suffix}"), true),
        TransitionKind::Merge => ("Merge", format!("merge{label_suffix}"), true),
        TransitionKind::Skip => ("Skip", format!("skip{label_suffix}"), true),
        TransitionKind::Silent => ("Silent", format!("step{label_suffix}"), true),
    };
    // A guarded plumbing step is a choice a person must see.
    let internal = internal && guard.is_none();
    StepInfo {
        id: t.id.clone(),
        label: t.label.clone(),
        kind: kind.into(),
        text: text.into(),
        internal,
        span,
        guard,
    }
}

/// Builds what the checker needs from a mission net; with `relation`, the
/// concurrency relation too, beside the spatial model (see
/// [`Subject::relation`]).
pub(crate) fn subject(
    net: &Net,
    profiles: &ProfileTable,
    src: Option<&str>,
    space: Option<&Space>,
    fold: bool,
    relation: bool,
) -> Subject {
    let domain = |d: DroneId, name: &str| -> Option<Domain> {
        let profile = profiles.get(net.profiles.get(d.0 as usize)?)?;
        let sig = profile.properties.get(name)?;
        match sig.ty {
            ValueType::Bool => Some(Domain { lo: 0.0, hi: 1.0 }),
            ValueType::Number => sig.range.map(|(lo, hi)| Domain { lo, hi }),
        }
    };

    // Conditions first: transitions whose guard can never hold are left out.
    let mut cond_findings: Vec<Finding> = Vec::new();
    let mut verdicts: HashMap<(u32, u32), Possibility> = HashMap::new();
    let mut removed = vec![false; net.graph.node_count()];
    for (n, t) in net.transitions() {
        let Some((cond, negated)) = t.guard.as_ref().and_then(|g| g.condition()) else {
            continue;
        };
        let sp = cond.span();
        let key = (sp.start, sp.end);
        let p = *verdicts.entry(key).or_insert_with(|| {
            let p = conditions::possibility(cond, &domain);
            if p != Possibility::Either {
                cond_findings.push(condition_finding(net, cond, p, src, &domain));
            }
            p
        });
        let never = matches!(
            (p, negated),
            (Possibility::NeverHolds, false) | (Possibility::AlwaysHolds, true)
        );
        removed[n.index()] = never;
    }
    let checked = verdicts.len();

    let mut place_index = vec![u32::MAX; net.graph.node_count()];
    // Sized before they are filled (a loop's counter places come on top):
    // grown by doubling, their copies missed the cache at every step.
    let (n_places, n_transitions) = (net.places().count(), net.transitions().count());
    let mut places = Vec::with_capacity(n_places);
    let mut initial = Vec::with_capacity(n_places);
    let mut running = HashMap::new();
    let mut running_by_drone: HashMap<u16, Vec<(u32, String)>> = HashMap::new();
    for (n, p) in net.places() {
        let i = places.len() as u32;
        place_index[n.index()] = i;
        let event = match &p.kind {
            PlaceKind::Event(e) => Some(e.as_str().into()),
            _ => None,
        };
        places.push(PlaceInfo {
            id: p.id.clone(),
            label: p.label.clone(),
            span: p.span,
            event,
            is_final: n == net.final_place,
            auxiliary: matches!(
                p.kind,
                PlaceKind::Event(_) | PlaceKind::EventPending(_) | PlaceKind::Region { .. }
            ),
            synthetic: false,
        });
        initial.push(net.initial_marking.iter().filter(|&&m| m == n).count() as u32);
        if let PlaceKind::Running(a) = &p.kind {
            let span = p.span.unwrap_or_default();
            running.insert(
                i,
                ActionInfo {
                    drone: net
                        .drones
                        .get(a.drone.0 as usize)
                        .cloned()
                        .unwrap_or_default(),
                    text: action_text(net, a),
                    span,
                },
            );
            running_by_drone
                .entry(a.drone.0)
                .or_default()
                .push((i, a.name.to_string()));
        }
    }
    // RepeatFor loops: the head place of each, with its count, except the
    // folded ones, whose rounds nothing outside them can count.
    let mut counted: HashMap<NodeId, (u32, Vec<u32>)> = HashMap::new();
    let mut folded: HashSet<NodeId> = HashSet::new();
    let mut limits: Vec<Limit> = Vec::new();
    let mut too_large: Vec<Span> = Vec::new();
    for (n, t) in net.transitions() {
        let (count, round) = match t.guard.as_ref().map(|g| &g.kind) {
            Some(GuardKind::IterationBelow(c)) => (*c, true),
            Some(GuardKind::IterationAtLeast(c)) => (*c, false),
            _ => continue,
        };
        if fold && round && count > 0 && net.preset(n).all(|h| crate::fold::closed_body(net, h, n))
        {
            folded.extend(net.preset(n));
        }
    }
    for (n, t) in net.transitions() {
        let count = match t.guard.as_ref().map(|g| &g.kind) {
            Some(GuardKind::IterationBelow(c)) | Some(GuardKind::IterationAtLeast(c)) => *c,
            _ => continue,
        };
        if net.preset(n).any(|h| folded.contains(&h)) {
            continue;
        }
        if count > MAX_COUNTED_ROUNDS {
            // Both guarded branches of the loop come here: report it once.
            if !too_large.contains(&t.span) {
                too_large.push(t.span);
                limits.push(too_many_rounds(count, t.span, src));
            }
            continue;
        }
        for head in net.preset(n) {
            counted.entry(head).or_insert_with(|| {
                let first = places.len() as u32;
                let label = net
                    .place(head)
                    .map_or("loop", |p| p.label.as_str())
                    .to_string();
                for k in 0..=count {
                    places.push(PlaceInfo {
                        id: format!("{}#{k}", net.id(head)).into(),
                        label: format!("{label}: {k} round(s) done").into(),
                        span: None,
                        event: None,
                        is_final: false,
                        auxiliary: true,
                        synthetic: true,
                    });
                    initial.push(u32::from(k == 0));
                }
                (count, (first..=first + count).collect())
            });
        }
    }
    let mut steps = Vec::with_capacity(n_transitions);
    let mut raw = Vec::with_capacity(n_transitions);
    // The transition of the net each compact transition copies.
    let mut origins: Vec<NodeId> = Vec::with_capacity(n_transitions);
    let mut starts = Vec::new();
    let mut loops = Vec::new();
    let mut waits = Vec::new();
    for (n, t) in net.transitions() {
        if removed[n.index()] {
            continue;
        }
        let info = step_info(net, t, src);
        let mut r = RawTransition::default();
        // Each way a transition touches a loop counter multiplies it into
        // one copy per counter value.
        let mut variants: Vec<Vec<RawTransition>> = Vec::new();
        for e in net.graph.edges_directed(n, petgraph::Direction::Incoming) {
            let p = place_index[e.source().index()];
            match e.weight().kind {
                ArcKind::Read => r.read.push((p, e.weight().weight)),
                _ => r.pre.push((p, e.weight().weight)),
            }
            if let (Some((count, c)), Some(g)) = (counted.get(&e.source()), &t.guard) {
                let ks: Vec<u32> = match g.kind {
                    GuardKind::IterationBelow(_) => (0..*count).collect(),
                    GuardKind::IterationAtLeast(_) => vec![*count],
                    GuardKind::Cond { .. } => Vec::new(),
                };
                if !matches!(g.kind, GuardKind::Cond { .. }) {
                    variants.push(
                        ks.into_iter()
                            .map(|k| RawTransition {
                                read: vec![(c[k as usize], 1)],
                                ..RawTransition::default()
                            })
                            .collect(),
                    );
                }
            }
        }
        for e in net.graph.edges_directed(n, petgraph::Direction::Outgoing) {
            r.post
                .push((place_index[e.target().index()], e.weight().weight));
            if let Some((count, c)) = counted.get(&e.target()) {
                match e.weight().colour {
                    ColourOp::Enter => variants.push(
                        (0..=*count)
                            .map(|k| RawTransition {
                                pre: vec![(c[k as usize], 1)],
                                post: vec![(c[0], 1)],
                                ..RawTransition::default()
                            })
                            .collect(),
                    ),
                    ColourOp::Next => variants.push(
                        (0..*count)
                            .map(|k| RawTransition {
                                pre: vec![(c[k as usize], 1)],
                                post: vec![(c[k as usize + 1], 1)],
                                ..RawTransition::default()
                            })
                            .collect(),
                    ),
                    _ => {}
                }
            }
        }
        let mut copies = vec![r];
        for v in variants {
            copies = copies
                .iter()
                .flat_map(|base| {
                    v.iter().map(move |x| {
                        let mut y = base.clone();
                        y.pre.extend(x.pre.iter().copied());
                        y.read.extend(x.read.iter().copied());
                        y.post.extend(x.post.iter().copied());
                        y
                    })
                })
                .collect();
        }
        for r in copies {
            let ti = steps.len() as u32;
            match &t.kind {
                TransitionKind::ActionStart(a) => starts.push((
                    ti,
                    ActionInfo {
                        drone: net
                            .drones
                            .get(a.drone.0 as usize)
                            .cloned()
                            .unwrap_or_default(),
                        text: action_text(net, a),
                        span: t.span,
                    },
                )),
                // Counted loops end by themselves: only the others may
                // repeat for ever.
                TransitionKind::LoopBack
                    if !net
                        .postset(n)
                        .any(|(p, _)| counted.contains_key(&p) || folded.contains(&p)) =>
                {
                    loops.push(ti)
                }
                TransitionKind::Pause if info.guard.is_some() => waits.push(ti),
                _ => {}
            }
            steps.push(info.clone());
            raw.push(r);
            origins.push(n);
        }
    }
    // Running places of an action take the action's span when they have none.
    for (t, a) in &starts {
        for &(p, _) in &raw[*t as usize].post {
            if let Some(info) = running.get_mut(&p) {
                if info.span == Span::default() {
                    info.span = a.span;
                }
            }
        }
    }
    let mut exclusive = Vec::new();
    for (d, list) in &running_by_drone {
        let Some(profile) = net
            .profiles
            .get(*d as usize)
            .and_then(|name| profiles.get(name))
        else {
            continue;
        };
        // A drone flies the same few actions many times: whether two
        // exclude each other is asked of the profile once per two names.
        let mut names: Vec<&str> = list.iter().map(|(_, a)| a.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        let excludes: Vec<Vec<bool>> = names
            .iter()
            .map(|a| names.iter().map(|b| profile.excludes(a, b)).collect())
            .collect();
        let name = |a: &str| names.binary_search(&a).expect("a name of the list");
        let named: Vec<(u32, usize)> = list.iter().map(|(p, a)| (*p, name(a))).collect();
        for (i, &(p, a)) in named.iter().enumerate() {
            for &(q, b) in &named[i + 1..] {
                if excludes[a][b] {
                    exclusive.push((p.min(q), p.max(q)));
                }
            }
        }
    }
    exclusive.sort_unstable();
    let final_place = Some(place_index[net.final_place.index()]);
    // The spatial model and the concurrency relation need nothing of each
    // other: two threads, one each (at 500 drones the model was three
    // tenths of the check's time, the relation one).
    let (space, (pt, relation)) = rayon::join(
        || space.map(|space| prepare(net, profiles, src, space, &place_index, &origins)),
        || {
            let mut pt = PtNet::new(places, steps, raw, initial, final_place);
            pt.seeds = Seeds::First;
            let relation = (relation && limits.is_empty() && pt.fits_bits())
                .then(|| Concurrency::compute(&pt));
            (pt, relation)
        },
    );
    Subject {
        pt,
        input: InputKind::Mission,
        name: net.name.clone(),
        running,
        exclusive,
        starts,
        conditions: Some((cond_findings, checked)),
        loops,
        waits,
        limits,
        space,
        folded: folded.len(),
        relation,
    }
}

/// The spatial model of the mission, tied to the compact net's indices.
fn prepare(
    net: &Net,
    profiles: &ProfileTable,
    src: Option<&str>,
    space: &Space,
    place_index: &[u32],
    origins: &[NodeId],
) -> Prepared {
    let names = Names::new(net, src);
    let too_large = |_| "the mission is too large to follow every drone's legs".to_string();
    // One walker serves both analyses (it indexes the net's blocks once),
    // each on a thread of its own: neither needs the other.
    let walker = Walker::new(net);
    let (positions, flight) = rayon::join(
        || model::positions(net, profiles, &walker).map_err(too_large),
        || flight::findings(net, profiles, &walker, &space.airspace, &names).map_err(too_large),
    );
    let airspace = match &positions {
        Ok(p) => Ok(airspace::findings(p, space, &names)),
        Err(e) => Err(e.clone()),
    };
    let mut by_origin: HashMap<NodeId, Vec<u32>> = HashMap::new();
    for (i, &o) in origins.iter().enumerate() {
        by_origin.entry(o).or_default().push(i as u32);
    }
    let compact = |ts: &[NodeId]| -> Vec<u32> {
        ts.iter()
            .flat_map(|t| by_origin.get(t).cloned().unwrap_or_default())
            .collect()
    };
    let (running, ends, cancels) = match &positions {
        Ok(p) => (
            p.motions
                .iter()
                .map(|t| place_index[t.running.index()])
                .collect(),
            p.motions.iter().map(|t| compact(&t.ends)).collect(),
            p.motions.iter().map(|t| compact(&t.cancels)).collect(),
        ),
        Err(_) => Default::default(),
    };
    Prepared {
        space: space.clone(),
        positions,
        airspace,
        flight,
        running,
        ends,
        cancels,
        names,
    }
}

/// The limit for a `RepeatFor` of `count` rounds whose statement is at
/// `stmt`; it points at the count when the source is at hand.
fn too_many_rounds(count: u32, stmt: Span, src: Option<&str>) -> Limit {
    let at = src.and_then(|s| first_argument(s, stmt)).unwrap_or(stmt);
    Limit {
        code: "too-large-to-explore",
        message: format!("`RepeatFor` counts {count} rounds: too many to explore one by one"),
        labels: vec![Label {
            span: at,
            text: format!("{count} rounds, one state each"),
        }],
        notes: vec![format!(
            "the checker counts the rounds of a `RepeatFor` exactly when something outside the \
             loop can tell them apart (here, a step of its body waits on or feeds something \
             outside it); above {MAX_COUNTED_ROUNDS} it does not explore, and leaves deadlock, \
             termination, safety, dead actions and conflicts undecided (a smaller count can be \
             checked)"
        )],
    }
}

/// The span of the first argument of the call at `call` (`n` in
/// `RepeatFor(n, B)`), found with the language's own lexer so that
/// comments and nested brackets are no trouble.
fn first_argument(src: &str, call: Span) -> Option<Span> {
    use eamos_lang::lexer::{lex, Tok};
    let start = call.start as usize;
    let text = src.get(start..call.end as usize)?;
    let mut depth = 0usize;
    let mut first: Option<(usize, usize)> = None;
    for (a, tok, b) in lex(text).tokens {
        match tok {
            Tok::LParen => {
                depth += 1;
                if depth == 1 {
                    continue;
                }
            }
            Tok::RParen => depth = depth.saturating_sub(1),
            Tok::Comma if depth == 1 => break,
            _ => {}
        }
        if depth >= 1 {
            first = Some(first.map_or((a, b), |(s, _)| (s, b)));
        }
    }
    first.map(|(a, b)| Span::new(start + a, start + b))
}

fn condition_finding(
    net: &Net,
    cond: &eamos_lang::hir::Expr,
    p: Possibility,
    src: Option<&str>,
    domain: &dyn Fn(DroneId, &str) -> Option<Domain>,
) -> Finding {
    let text = snippet(src, cond.span())
        .map(one_line)
        .unwrap_or_else(|| "the condition".into());
    let ranges: Vec<String> = conditions::properties_read(cond)
        .into_iter()
        .map(|(d, name)| {
            let drone = net.drones.get(d.0 as usize).map_or("?", String::as_str);
            match domain(d, &name) {
                Some(r) => format!(
                    "{drone}.{name}() is between {} and {}",
                    fmt_num(r.lo),
                    fmt_num(r.hi)
                ),
                None => format!("{drone}.{name}() can take any value"),
            }
        })
        .collect();
    let (kind, message, label) = match p {
        Possibility::NeverHolds => (
            FindingKind::ConditionNeverHolds,
            format!("`{text}` can never hold"),
            "never holds",
        ),
        _ => (
            FindingKind::ConditionAlwaysHolds,
            format!("`{text}` always holds"),
            "always holds",
        ),
    };
    let mut notes = Vec::new();
    if !ranges.is_empty() {
        notes.push(ranges.join("; "));
    }
    Finding {
        kind,
        message,
        labels: vec![Label {
            span: cond.span(),
            text: label.into(),
        }],
        notes,
        trace: None,
        geometry: None,
    }
}
