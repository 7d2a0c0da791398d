//! From a net to a report: which exploration runs, and what each property
//! reads from it.
//!
//! | property | decided by | reduction |
//! | --- | --- | --- |
//! | deadlock | dead markings of the exploration | stubborn sets (preserve every deadlock at its shortest depth) |
//! | termination | backward search from markings with `final` marked over the explored graph | stubborn sets with the terminal-component proviso |
//! | safety | structural concurrency (a proof when it finds no candidate); else monitors of the candidates | stubborn sets with the terminal-component proviso |
//! | dead actions | `ActionStart` transitions never fired | stubborn sets with the terminal-component proviso |
//! | conflicts | monitors of structurally concurrent running places | stubborn sets with the terminal-component proviso |
//! | conditions | interval reasoning over property ranges | none needed |
//!
//! The one exploration serves every property: the terminal-component
//! proviso costs little on mission nets (a full expansion here and there
//! once the reduced graph is built) and makes the reduced graph preserve
//! fireability and the reachability of the end (see [`crate::explore`]). A
//! net that turns out not to be 1-safe (PNML input, or a compiler bug) is
//! explored again in full with token counters, which also decides
//! boundedness.
//!
//! Asked only about deadlocks ([`Goal::Deadlock`]), the check runs the
//! portfolio of `deadlock_alone` instead, on the net shrunk by the
//! structural rules of `crate::reduce` (unless the shortest deadlock is
//! asked); what it shows is always a trace of the original net.

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::sync::Arc;

use crate::explore::{self, Bits, Bytes, Config, Encoding, Exploration, Stop};
use crate::ptnet::{MonitorKind, PtNet};
use crate::reduce::Unreplayable;
use crate::report::{
    Finding, FindingKind, InputKind, Label, Limit, Property, PropertyResult, Report, Stats, Step,
    Trace, Verdict,
};
use crate::space;
use crate::structural::Concurrency;
use eamos_lang::Span;

/// How to check.
#[derive(Clone)]
pub struct Options {
    /// Partial-order reduction with stubborn sets (on by default; off gives
    /// full exploration, for comparison).
    pub reduction: bool,
    /// Exploration stops cleanly, with partial verdicts, past this many MB.
    pub max_memory_mb: u64,
    /// Called after each chunk of states with (states stored, states expanded).
    pub progress: Option<Arc<dyn Fn(usize, usize) + Send + Sync>>,
    /// Decide the spatial properties (separation, airspace, flight state);
    /// on by default, off to measure what they cost.
    pub spatial: bool,
    /// Homes and airspace (a fleet file's); `None`: the default fleet.
    pub space: Option<crate::Space>,
    /// What to decide: everything, or only whether a deadlock is reachable.
    pub goal: Goal,
    /// Structural reductions, on by default; off to search the net as it
    /// is, for comparison: `RepeatFor` loops that nothing outside them can
    /// count are explored without their counters (`crate::fold`, every
    /// goal), and the net is reduced before a search for a deadlock alone
    /// ([`Goal::Deadlock`], not the shortest).
    pub structural: bool,
}

/// States of the first, short deadlock search of [`Goal::Deadlock`], per
/// node of the net: enough to walk into a deadlock a few times the net's
/// size deep, little beside proving there is none.
const QUICK_SEARCH_PER_NODE: usize = 2;

/// What a check is asked to decide.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Goal {
    /// Every property (one breadth-first exploration serves them all).
    #[default]
    All,
    /// Only whether a deadlock is reachable, as model checkers are asked
    /// (`ReachabilityDeadlock` of the Model Checking Contest): a
    /// depth-first search that stops at the first one, or with `shortest`
    /// a breadth-first one that stops at a shortest one.
    Deadlock { shortest: bool },
}

impl Default for Options {
    fn default() -> Self {
        Options {
            reduction: true,
            max_memory_mb: 4096,
            progress: None,
            spatial: true,
            space: None,
            goal: Goal::All,
            structural: true,
        }
    }
}

impl std::fmt::Debug for Options {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Options")
            .field("reduction", &self.reduction)
            .field("max_memory_mb", &self.max_memory_mb)
            .field("goal", &self.goal)
            .field("structural", &self.structural)
            .finish()
    }
}

/// An action as people name it.
#[derive(Debug, Clone)]
pub(crate) struct ActionInfo {
    pub drone: String,
    pub text: String,
    pub span: Span,
}

/// What the checker needs to know about its input beyond the bare net.
pub(crate) struct Subject {
    pub pt: PtNet,
    pub input: InputKind,
    pub name: String,
    /// Running places per action (mission input).
    pub running: HashMap<u32, ActionInfo>,
    /// Pairs of running places of one drone whose actions exclude each other.
    pub exclusive: Vec<(u32, u32)>,
    /// `ActionStart` transitions with their action.
    pub starts: Vec<(u32, ActionInfo)>,
    /// Findings and verdict of the condition analysis (mission input).
    pub conditions: Option<(Vec<Finding>, usize)>,
    /// Loop-back transitions (for the termination note).
    pub loops: Vec<u32>,
    /// Waits on a condition (for the termination note).
    pub waits: Vec<u32>,
    /// Why the net is not worth exploring (empty if it is): the exploration
    /// is then skipped rather than run for minutes to its memory bound.
    pub limits: Vec<Limit>,
    /// The spatial properties' part of the mission (mission input).
    pub space: Option<space::Prepared>,
    /// How many `RepeatFor` loops are folded ([`crate::fold`]).
    pub folded: usize,
    /// The concurrency relation of `pt` when it was worked out beside the
    /// spatial model; `None`: worked out here if the check needs it.
    pub relation: Option<Concurrency>,
}

pub(crate) fn check(subject: Subject, opts: &Options) -> Report {
    let mut report = check_asked(subject, opts);
    if opts.goal != Goal::All {
        report
            .properties
            .retain(|r| r.property == Property::Deadlock);
        report.findings.retain(|f| f.kind == FindingKind::Deadlock);
    }
    report
}

fn check_asked(subject: Subject, opts: &Options) -> Report {
    let Subject {
        pt,
        input,
        name,
        running,
        exclusive,
        starts,
        conditions,
        loops,
        waits,
        limits,
        space,
        folded: _,
        relation,
    } = subject;
    if !limits.is_empty() {
        let reason = format!("not explored, see `eamos::{}`", limits[0].code);
        let (props, found) = spatial_results(space.as_ref(), Err(reason));
        let mut report = unexplored(name, input, &pt, conditions, limits);
        report
            .properties
            .retain(|r| !props.iter().any(|q| q.property == r.property));
        report.properties.extend(props);
        report.properties.sort_by_key(|r| r.property);
        report.findings.extend(found);
        report.findings.sort_by_key(|f| f.kind);
        return report;
    }
    let final_consumed = pt
        .final_place
        .is_some_and(|f| !pt.consumers.get(f as usize).is_empty());
    let reduction = opts.reduction && !final_consumed;
    let max_bytes = (opts.max_memory_mb as usize).saturating_mul(1 << 20);
    let progress = opts.progress.clone();
    let progress_fn = progress
        .as_deref()
        .map(|f| f as &(dyn Fn(usize, usize) + Sync));
    let mut cfg = Config {
        reduction,
        max_bytes,
        keep_edges: pt.final_place.is_some(),
        progress: progress_fn,
        first_deadlock: false,
    };

    let mut ctx = Ctx {
        input,
        running,
        starts,
        loops,
        waits,
        findings: Vec::new(),
        properties: Vec::new(),
    };

    if let Goal::Deadlock { shortest } = opts.goal {
        if let Some(report) =
            deadlock_alone(&mut ctx, &name, &pt, &mut cfg, shortest, opts.structural)
        {
            return report;
        }
    }
    if pt.fits_bits() {
        let conc = relation.unwrap_or_else(|| Concurrency::compute(&pt));
        let mut monitors: Vec<MonitorKind> = exclusive
            .iter()
            .filter(|&&(a, b)| conc.get(a, b))
            .map(|&(a, b)| MonitorKind::Conflict { a, b })
            .collect();
        let structurally_safe = conc.unsafe_candidates().is_empty();
        monitors.extend(
            conc.unsafe_candidates()
                .iter()
                .map(|&(t, place)| MonitorKind::Unsafe { t, place }),
        );
        let mut ext = space.as_ref().map(|prep| space::extend(&pt, &conc, prep));
        let mut recorded = None;
        if let Some(e) = &mut ext {
            monitors.extend(e.monitors.iter().cloned());
            recorded = e.net.take();
        }
        // The relation has chosen what to watch: freed before the
        // exploration, whose peak it would otherwise be part of (a bit
        // matrix up to 8,192 classes of places, 8 MB; beyond, its rows'
        // runs).
        let explored = recorded.as_ref().unwrap_or(&pt);
        let mutex = structurally_safe.then(|| conc.mutex_inputs(explored, pt.n_places()));
        drop(conc);
        let base = recorded.unwrap_or_else(|| pt.clone());
        let mut net = base.with_monitors(monitors);
        // The monitors come after the transitions the pairs are of.
        net.mutex_inputs = mutex.unwrap_or_default();
        // A plain 1-safe net without `final` asks the exploration one
        // thing only, whether it deadlocks: where the place invariants
        // prove it cannot, nothing is explored.
        let plain = ctx.input == InputKind::Pnml && pt.final_place.is_none();
        let proof = (plain && structurally_safe && net.monitors.is_empty())
            .then(|| crate::invariants::deadlock_free(&pt))
            .flatten();
        let ex = match proof {
            Some(_) => Exploration::new::<Bits>(&net, 0),
            None => explore::explore::<Bits>(&net, &cfg),
        };
        let unsafe_hit = matches!(ex.stop, Some(Stop::Unsafe { .. }))
            || net
                .monitors
                .iter()
                .zip(&ex.monitor_hits)
                .any(|(m, h)| matches!(m, MonitorKind::Unsafe { .. }) && h.is_some());
        if !unsafe_hit {
            let method = if reduction {
                "breadth-first exploration, stubborn sets with the terminal-component proviso"
            } else {
                "breadth-first exploration, full"
            };
            ctx.evaluate::<Bits>(&net, &ex, method, Some(structurally_safe));
            if let Some(why) = proof {
                let r = ctx
                    .properties
                    .iter_mut()
                    .find(|r| r.property == Property::Deadlock)
                    .expect("evaluate answers deadlock");
                *r = result(
                    Property::Deadlock,
                    Verdict::Holds,
                    "place invariants and SAT",
                );
                r.notes.push(why);
            }
            let near = match (&space, &ext) {
                (Some(prep), Some(e)) => {
                    let hits: Vec<(u32, usize)> = net
                        .monitors
                        .iter()
                        .zip(&ex.monitor_hits)
                        .filter_map(|(m, h)| match (m, h) {
                            (MonitorKind::Near { pair, .. }, Some(s)) => Some((*s, *pair as usize)),
                            _ => None,
                        })
                        .collect();
                    let found =
                        space::near_findings(prep, e, &hits, &|s| ctx.trace::<Bits>(&net, &ex, s));
                    let undecided = if let Some(n) = e.too_many {
                        Some(format!(
                            "{n} pairs of legs or rests of two drones come within the separation: too many to watch at once (at most {}); space the drones apart or order them",
                            space::MAX_WATCHED
                        ))
                    } else if !ex.complete() {
                        Some(Ctx::stopped_reason(&ex))
                    } else if !e.unordered.is_empty() {
                        Some(format!(
                            "{} can fly two legs at once (see the conflicts), so where it rests is not known",
                            e.unordered
                                .iter()
                                .map(|&d| prep.names.drone(d))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ))
                    } else {
                        None
                    };
                    Ok((found, undecided))
                }
                _ => Err("no spatial model".to_string()),
            };
            let (props, found) = spatial_results(space.as_ref(), near);
            ctx.properties.extend(props);
            ctx.findings.extend(found);
            return ctx.finish(name, &net, &ex, method, conditions);
        }
    }
    // Not 1-safe: count tokens, explore in full.
    let monitors = exclusive
        .iter()
        .map(|&(a, b)| MonitorKind::Conflict { a, b })
        .collect();
    let net = pt.with_monitors(monitors);
    cfg.reduction = false;
    cfg.keep_edges = net.final_place.is_some();
    cfg.first_deadlock = opts.goal != Goal::All;
    let ex = explore::explore::<Bytes>(&net, &cfg);
    let method = "breadth-first exploration, full, with token counts";
    ctx.evaluate::<Bytes>(&net, &ex, method, None);
    let (props, found) = spatial_results(
        space.as_ref(),
        Err("the net is not 1-safe: see that finding".into()),
    );
    ctx.properties.extend(props);
    ctx.findings.extend(found);
    ctx.finish(name, &net, &ex, method, conditions)
}

/// [`Goal::Deadlock`] on a net that fits one bit per place: a portfolio,
/// as model checkers run one. A short depth-first search finds the
/// deadlocks that are near (most are); the place invariants may prove that
/// there is none; then the search goes on to its bound. `None`: the net is
/// not proved 1-safe, and the general exploration (with token counts)
/// answers.
///
/// A deadlock found is real whatever the net: every step of its path was
/// fired with its outputs checked for a second token. "No deadlock" needs
/// the net 1-safe, as the invariants' clauses do.
///
/// With `structural`, the searches and the invariants work on the net
/// reduced by [`crate::reduce`] (not for a shortest deadlock, whose length
/// fused steps would hide), and a deadlock found there is shown as the
/// original net's trace, replayed on it first. Should that replay fail (a
/// rule's bug), the net as it is answers.
fn deadlock_alone(
    ctx: &mut Ctx,
    name: &str,
    pt: &PtNet,
    cfg: &mut Config,
    shortest: bool,
    structural: bool,
) -> Option<Report> {
    if !pt.fits_bits() {
        return None;
    }
    let reduced = (structural && !shortest)
        .then(|| crate::reduce::reduce(pt))
        .flatten()
        .filter(|r| r.net.fits_bits());
    let mut unreplayed = false;
    if let Some(r) = &reduced {
        let searched = portfolio(ctx, name, pt, Some(r), cfg, shortest);
        unreplayed = searched.is_err();
        if let Ok(mut report) = searched {
            if let Some(deadlock) = report.as_mut().and_then(|rep| rep.properties.first_mut()) {
                let a = r.applied;
                deadlock.notes.push(format!(
                    "structural reductions left {} places and {} transitions of {} and {} before the search ({} fusions, {} places never marked, {} sink places, {} duplicate transitions)",
                    r.net.n_places(),
                    r.net.n_real,
                    pt.n_places(),
                    pt.n_real,
                    a.agglomerations,
                    a.never_marked,
                    a.sinks,
                    a.duplicates
                ));
            }
            return report;
        }
    }
    let mut report = portfolio(ctx, name, pt, None, cfg, shortest).unwrap_or(None);
    if let Some(deadlock) = report
        .as_mut()
        .and_then(|rep| rep.properties.first_mut())
        .filter(|_| unreplayed)
    {
        deadlock.notes.push(UNREPLAYED.into());
    }
    report
}

/// Said when a deadlock of the reduced net did not replay on the
/// original, which the rules' soundness excludes: the answer is then the
/// unreduced search's, and the note asks for the net that showed it.
pub const UNREPLAYED: &str = "a counterexample of the structurally reduced net did not replay on the net (a bug of the reductions, please report it with this net): the net was searched as it is";

/// A deadlock of the reduced net whose trace does not replay on the
/// original net.
struct Unreplayed;

/// The portfolio of [`deadlock_alone`] on `pt`, or on its reduced net.
fn portfolio(
    ctx: &mut Ctx,
    name: &str,
    pt: &PtNet,
    reduced: Option<&crate::reduce::Reduced>,
    cfg: &mut Config,
    shortest: bool,
) -> Result<Option<Report>, Unreplayed> {
    let net = reduced.map_or(pt, |r| &r.net);
    let dfs = "depth-first search for a deadlock, stubborn sets";
    let report =
        |ctx: &mut Ctx, ex: &Exploration, method: &str| -> Result<Option<Report>, Unreplayed> {
            let at_end = |d: u32| net.final_place.is_some_and(|f| ex.store.tokens(d, f) > 0);
            let dead = match ex.dead.iter().find(|&&d| !at_end(d)) {
                None => None,
                Some(&d) => {
                    let path = ex.store.path(d);
                    match reduced {
                        None => Some((path, ex.store.marking(d))),
                        Some(r) => {
                            let trace = r.expand(&path);
                            match crate::reduce::replay_to_deadlock(pt, &trace) {
                                Ok(m) => Some((trace, m)),
                                Err(Unreplayable::SecondToken) => return Ok(None),
                                Err(Unreplayable::NotADeadlock) => return Err(Unreplayed),
                            }
                        }
                    }
                }
            };
            Ok(Some(ctx.deadlock_only(
                name.to_string(),
                pt,
                ex,
                dead,
                method,
            )))
        };
    let mut quick = None;
    if !shortest {
        let budget = QUICK_SEARCH_PER_NODE * (net.n_places() + net.n_real);
        let ex = explore::deadlock::search::<Bits>(net, cfg.reduction, cfg.max_bytes, budget);
        if !ex.dead.is_empty() {
            return report(ctx, &ex, dfs);
        }
        if matches!(ex.stop, Some(Stop::Unsafe { .. })) {
            return Ok(None);
        }
        quick = Some(ex);
    }
    // The original net's 1-safety: a reduced net is 1-safe when the
    // original is (see `crate::reduce`), so its searches count right.
    if !Concurrency::compute(pt).unsafe_candidates().is_empty() {
        return Ok(None);
    }
    if let Some(ex) = quick.filter(|ex| ex.complete()) {
        return report(ctx, &ex, dfs);
    }
    if let Some(why) = crate::invariants::deadlock_free(net) {
        let ex = Exploration::new::<Bits>(net, 0);
        let mut r = report(ctx, &ex, "place invariants and SAT")?;
        if let Some(deadlock) = r.as_mut().and_then(|rep| rep.properties.first_mut()) {
            deadlock.notes.push(why);
        }
        return Ok(r);
    }
    let (ex, method) = if shortest {
        cfg.keep_edges = false;
        cfg.first_deadlock = true;
        let method = "breadth-first search for a deadlock, stubborn sets";
        (explore::explore::<Bits>(net, cfg), method)
    } else {
        let ex = explore::deadlock::search::<Bits>(net, cfg.reduction, cfg.max_bytes, usize::MAX);
        (ex, dfs)
    };
    report(ctx, &ex, method)
}

struct Ctx {
    input: InputKind,
    running: HashMap<u32, ActionInfo>,
    starts: Vec<(u32, ActionInfo)>,
    loops: Vec<u32>,
    waits: Vec<u32>,
    findings: Vec<Finding>,
    properties: Vec<PropertyResult>,
}

fn result(property: Property, verdict: Verdict, method: impl Into<String>) -> PropertyResult {
    PropertyResult {
        property,
        verdict,
        method: method.into(),
        notes: Vec::new(),
    }
}

impl Ctx {
    fn mission(&self) -> bool {
        self.input == InputKind::Mission
    }

    fn stopped_reason(ex: &Exploration) -> String {
        match ex.stop {
            Some(Stop::Memory) => format!(
                "nothing found in the first {} states; exploration stopped at the memory bound",
                ex.store.len()
            ),
            Some(Stop::TooManyStates) => format!(
                "nothing found in the first {} states; exploration stopped at the state limit",
                ex.store.len()
            ),
            _ => "exploration stopped early".into(),
        }
    }

    fn trace<E: Encoding>(&self, net: &PtNet, ex: &Exploration, state: u32) -> Trace {
        let path = ex.store.path(state);
        Trace {
            steps: path.iter().map(|&t| step(net, t)).collect(),
            cycle_from: None,
            marking: marking::<E>(net, &ex.store.marking(state)),
        }
    }

    fn evaluate<E: Encoding>(
        &mut self,
        net: &PtNet,
        ex: &Exploration,
        method: &str,
        structurally_safe: Option<bool>,
    ) {
        let complete = ex.complete();
        let is_final = |id: u32| net.final_place.is_some_and(|f| ex.store.tokens(id, f) > 0);

        // Safety and boundedness first: if the net is not 1-safe, say so.
        let mut unsafe_found = false;
        match &ex.stop {
            Some(Stop::Unbounded { state, ancestor }) => {
                unsafe_found = true;
                let mut trace = self.trace::<E>(net, ex, *state);
                let prefix = ex.store.path(*ancestor).len();
                trace.cycle_from = Some(prefix);
                let a = &ex.store.marking(*ancestor);
                let m = &ex.store.marking(*state);
                let grows: Vec<String> = (0..net.n_places() as u32)
                    .filter(|&p| E::get(m, p) > E::get(a, p))
                    .map(|p| format!("`{}`", net.places[p as usize].id))
                    .collect();
                self.findings.push(Finding {
                    kind: FindingKind::Unbounded,
                    message: format!(
                        "the net is unbounded: repeating the last steps adds tokens to {} without end",
                        grows.join(", ")
                    ),
                    labels: grows_labels::<E>(net, m, a),
                    notes: self.bug_note(),
                    trace: Some(trace),
                    geometry: None,
                });
                self.properties.push(result(
                    Property::Safety,
                    Verdict::Violated,
                    format!("{method}; a marking covering an ancestor proves unboundedness"),
                ));
            }
            Some(Stop::Overflow { state, place, .. }) => {
                unsafe_found = true;
                self.findings.push(Finding {
                    kind: FindingKind::Unbounded,
                    message: format!(
                        "place `{}` exceeds {} tokens",
                        net.places[*place as usize].id,
                        E::MAX
                    ),
                    labels: place_label(net, *place, "here"),
                    notes: self.bug_note(),
                    trace: Some(self.trace::<E>(net, ex, *state)),
                    geometry: None,
                });
                self.properties.push(result(
                    Property::Safety,
                    Verdict::Violated,
                    method.to_string(),
                ));
            }
            _ => {
                if E::MAX > 1 {
                    // Counting: the first marking (BFS order) with two tokens.
                    let first = (0..ex.store.len() as u32).find(|&id| {
                        let m = &ex.store.marking(id);
                        (0..net.n_places() as u32).any(|p| E::get(m, p) > 1)
                    });
                    if let Some(id) = first {
                        unsafe_found = true;
                        let m = &ex.store.marking(id);
                        let p = (0..net.n_places() as u32)
                            .find(|&p| E::get(m, p) > 1)
                            .unwrap_or(0);
                        let message = if self.mission() {
                            format!(
                                "place `{}` ({}) can hold {} tokens: the net compiler broke its 1-safety invariant",
                                net.places[p as usize].id,
                                net.places[p as usize].label,
                                E::get(m, p)
                            )
                        } else {
                            format!(
                                "the net is not 1-safe: place `{}` can hold {} tokens",
                                net.places[p as usize].id,
                                E::get(m, p)
                            )
                        };
                        self.findings.push(Finding {
                            kind: FindingKind::Unsafe,
                            message,
                            labels: place_label(net, p, "two tokens here"),
                            notes: self.bug_note(),
                            trace: Some(self.trace::<E>(net, ex, id)),
                            geometry: None,
                        });
                        self.properties.push(result(
                            Property::Safety,
                            Verdict::Violated,
                            method.to_string(),
                        ));
                    } else if complete {
                        let mut r = result(Property::Safety, Verdict::Holds, method.to_string());
                        r.notes.push(format!(
                            "every place holds at most {} token(s)",
                            ex.max_tokens.max(1)
                        ));
                        self.properties.push(r);
                    } else {
                        self.properties.push(result(
                            Property::Safety,
                            Verdict::Unknown(Self::stopped_reason(ex)),
                            method.to_string(),
                        ));
                    }
                } else if structurally_safe == Some(true) {
                    self.properties.push(result(
                        Property::Safety,
                        Verdict::Holds,
                        "structural: no transition can put a token into a place that may already be marked",
                    ));
                } else if complete {
                    self.properties.push(result(
                        Property::Safety,
                        Verdict::Holds,
                        format!(
                            "{method}; monitors on the places the structural check could not clear"
                        ),
                    ));
                } else {
                    self.properties.push(result(
                        Property::Safety,
                        Verdict::Unknown(Self::stopped_reason(ex)),
                        method.to_string(),
                    ));
                }
            }
        }

        // Deadlock.
        let deadlocks: Vec<u32> = ex.dead.iter().copied().filter(|&d| !is_final(d)).collect();
        if let Some(&d) = deadlocks.first() {
            self.findings.push(self.deadlock_finding::<E>(net, ex, d));
            self.properties.push(result(
                Property::Deadlock,
                Verdict::Violated,
                method.to_string(),
            ));
        } else if complete {
            self.properties.push(result(
                Property::Deadlock,
                Verdict::Holds,
                method.to_string(),
            ));
        } else {
            self.properties.push(result(
                Property::Deadlock,
                Verdict::Unknown(unsafe_or(unsafe_found, Self::stopped_reason(ex))),
                method.to_string(),
            ));
        }

        // Termination.
        match net.final_place {
            None => self.properties.push(result(
                Property::Termination,
                Verdict::NotApplicable("the net has no place `final`".into()),
                "-",
            )),
            Some(_) if !complete => self.properties.push(result(
                Property::Termination,
                Verdict::Unknown(unsafe_or(unsafe_found, Self::stopped_reason(ex))),
                method.to_string(),
            )),
            Some(_) => self.termination::<E>(net, ex, method, &deadlocks),
        }

        // Dead actions.
        if !self.mission() {
            self.properties.push(result(
                Property::DeadActions,
                Verdict::NotApplicable("a plain net has no actions".into()),
                "-",
            ));
        } else if !complete {
            self.properties.push(result(
                Property::DeadActions,
                Verdict::Unknown(unsafe_or(
                    unsafe_found,
                    "exploration stopped early".to_string(),
                )),
                method.to_string(),
            ));
        } else {
            // Group instances by source span: a line is dead when none of
            // its instances can start.
            let mut by_span: BTreeMap<(u32, u32), (Vec<bool>, ActionInfo)> = BTreeMap::new();
            for (t, a) in &self.starts {
                let e = by_span
                    .entry((a.span.start, a.span.end))
                    .or_insert_with(|| (Vec::new(), a.clone()));
                e.0.push(ex.fired[*t as usize]);
            }
            let mut any = false;
            for (fired, a) in by_span.values() {
                let dead = fired.iter().filter(|f| !**f).count();
                if dead == 0 {
                    continue;
                }
                any = true;
                let message = if dead == fired.len() {
                    format!("{} can never start", a.text)
                } else {
                    format!(
                        "{} of the {} instances of {} can never start",
                        dead,
                        fired.len(),
                        a.text
                    )
                };
                self.findings.push(Finding {
                    kind: FindingKind::DeadAction,
                    message,
                    labels: vec![Label {
                        span: a.span,
                        text: "never starts".into(),
                    }],
                    notes: vec![
                        "no order of events and no sensor values lead here: the code is dead"
                            .into(),
                    ],
                    trace: None,
                    geometry: None,
                });
            }
            self.properties.push(result(
                Property::DeadActions,
                if any {
                    Verdict::Violated
                } else {
                    Verdict::Holds
                },
                method.to_string(),
            ));
        }

        // Drone conflicts.
        if !self.mission() {
            self.properties.push(result(
                Property::Conflicts,
                Verdict::NotApplicable("a plain net has no drones".into()),
                "-",
            ));
        } else {
            let mut seen: BTreeSet<((u32, u32), (u32, u32))> = BTreeSet::new();
            let mut hits: Vec<(u32, u32, u32)> = net
                .monitors
                .iter()
                .zip(&ex.monitor_hits)
                .filter_map(|(m, h)| match (m, h) {
                    (MonitorKind::Conflict { a, b }, Some(s)) => Some((*s, *a, *b)),
                    _ => None,
                })
                .collect();
            hits.sort();
            let mut any = false;
            for (state, a, b) in hits {
                let (Some(x), Some(y)) = (self.running.get(&a), self.running.get(&b)) else {
                    continue;
                };
                let (x, y) = if (x.span.start, x.span.end) <= (y.span.start, y.span.end) {
                    (x, y)
                } else {
                    (y, x)
                };
                if !seen.insert(((x.span.start, x.span.end), (y.span.start, y.span.end))) {
                    continue;
                }
                any = true;
                let message = if x.span == y.span {
                    format!(
                        "two instances of {} can run at the same time on {}",
                        x.text, x.drone
                    )
                } else {
                    format!(
                        "{} and {} can run at the same time, but {}'s profile says they exclude each other",
                        x.text, y.text, x.drone
                    )
                };
                let mut labels = vec![Label {
                    span: x.span,
                    text: "runs".into(),
                }];
                if y.span != x.span {
                    labels.push(Label {
                        span: y.span,
                        text: "while this runs".into(),
                    });
                }
                self.findings.push(Finding {
                    kind: FindingKind::DroneConflict,
                    message,
                    labels,
                    notes: vec![format!(
                        "order them (a SEQ_ block, or Signal/Await) so that {} runs one at a time",
                        x.drone
                    )],
                    trace: Some(self.trace::<E>(net, ex, state)),
                    geometry: None,
                });
            }
            let verdict = if any {
                Verdict::Violated
            } else if complete {
                Verdict::Holds
            } else {
                Verdict::Unknown(unsafe_or(unsafe_found, Self::stopped_reason(ex)))
            };
            self.properties.push(result(
                Property::Conflicts,
                verdict,
                format!("{method}; structural concurrency picks the pairs to watch"),
            ));
        }
    }

    fn bug_note(&self) -> Vec<String> {
        if self.mission() {
            vec!["the net of a mission is 1-safe by construction: this is a bug of the eamos net compiler, please report it with this mission".into()]
        } else {
            Vec::new()
        }
    }

    fn deadlock_finding<E: Encoding>(&self, net: &PtNet, ex: &Exploration, d: u32) -> Finding {
        self.deadlock_finding_at::<E>(net, &ex.store.path(d), &ex.store.marking(d))
    }

    /// The finding for the dead marking `m` that `path` reaches on `net`.
    fn deadlock_finding_at<E: Encoding>(&self, net: &PtNet, path: &[u32], m: &[u64]) -> Finding {
        let mut labels: Vec<Label> = Vec::new();
        let mut blocked: BTreeSet<u32> = BTreeSet::new();
        E::for_each_marked(m, |p| {
            if net.places[p as usize].auxiliary || net.places[p as usize].is_final {
                return;
            }
            for &t in net
                .consumers
                .get(p as usize)
                .iter()
                .chain(net.readers.get(p as usize))
            {
                if !net.is_monitor(t) {
                    blocked.insert(t);
                }
            }
        });
        let mut seen_spans = BTreeSet::new();
        for &t in &blocked {
            let info = &net.steps[t as usize];
            let missing: Vec<u32> = net
                .pre
                .get(t as usize)
                .iter()
                .chain(net.read.get(t as usize))
                .filter(|&&(p, w)| E::get(m, p) < w)
                .map(|&(p, _)| p)
                .collect();
            let Some(span) = info.span else { continue };
            if !seen_spans.insert((span.start, span.end)) {
                continue;
            }
            let events: Vec<&str> = missing
                .iter()
                .filter_map(|&p| net.places[p as usize].event.as_deref())
                .collect();
            let text = if !events.is_empty() {
                format!(
                    "waits for event \"{}\", which was not signalled and no longer can be",
                    events.join("\", \"")
                )
            } else if info.kind == "Join" {
                "waits for its other branches, which cannot finish".to_string()
            } else {
                format!(
                    "cannot happen: it also needs {}",
                    missing
                        .iter()
                        .map(|&p| format!("`{}`", net.places[p as usize].label))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            // Awaits first: they are the usual culprits.
            let label = Label { span, text };
            if info.kind == "Await" {
                labels.insert(0, label);
            } else {
                labels.push(label);
            }
        }
        labels.truncate(8);
        let message = match (self.input, net.final_place.is_some()) {
            (InputKind::Mission, _) => {
                "the mission can get stuck: no step can happen and it has not ended".to_string()
            }
            (InputKind::Pnml, true) => {
                "a dead marking is reachable without `final` being marked".to_string()
            }
            (InputKind::Pnml, false) => "a dead marking is reachable".to_string(),
        };
        Finding {
            kind: FindingKind::Deadlock,
            message,
            labels,
            notes: Vec::new(),
            trace: Some(Trace {
                steps: path.iter().map(|&t| step(net, t)).collect(),
                cycle_from: None,
                marking: marking::<E>(net, m),
            }),
            geometry: None,
        }
    }

    fn termination<E: Encoding>(
        &mut self,
        net: &PtNet,
        ex: &Exploration,
        method: &str,
        deadlocks: &[u32],
    ) {
        let n = ex.store.len();
        let f = net.final_place.unwrap_or(0);
        // Reverse edges.
        let mut rev_off = vec![0u32; n + 1];
        for s in 0..n {
            for k in ex.edge_offsets[s]..ex.edge_offsets[s + 1] {
                rev_off[ex.edges[k as usize] as usize + 1] += 1;
            }
        }
        for i in 0..n {
            rev_off[i + 1] += rev_off[i];
        }
        let mut fill = rev_off.clone();
        let mut rev = vec![0u32; ex.edges.len()];
        for s in 0..n {
            for k in ex.edge_offsets[s]..ex.edge_offsets[s + 1] {
                let t = ex.edges[k as usize] as usize;
                rev[fill[t] as usize] = s as u32;
                fill[t] += 1;
            }
        }
        let backward = |targets: &mut dyn Iterator<Item = u32>| {
            let mut reach = vec![false; n];
            let mut q: VecDeque<u32> = VecDeque::new();
            for t in targets {
                if !reach[t as usize] {
                    reach[t as usize] = true;
                    q.push_back(t);
                }
            }
            while let Some(s) = q.pop_front() {
                for &p in &rev[rev_off[s as usize] as usize..rev_off[s as usize + 1] as usize] {
                    if !reach[p as usize] {
                        reach[p as usize] = true;
                        q.push_back(p);
                    }
                }
            }
            reach
        };
        let ends = backward(&mut (0..n as u32).filter(|&s| ex.store.tokens(s, f) > 0));
        let mut r = result(Property::Termination, Verdict::Holds, method.to_string());
        let bad: Vec<u32> = (0..n as u32).filter(|&s| !ends[s as usize]).collect();
        if !bad.is_empty() {
            r.verdict = Verdict::Violated;
            let to_dead = backward(&mut deadlocks.iter().copied());
            if let Some(&b) = bad.iter().find(|&&b| !to_dead[b as usize]) {
                self.findings
                    .push(self.livelock_finding::<E>(net, ex, b, &ends));
            } else {
                r.notes.push(
                    "every marking that cannot reach the end leads to the deadlock reported".into(),
                );
            }
        } else {
            let reached = |ts: &[u32]| {
                let mut spans: Vec<Span> = ts
                    .iter()
                    .filter(|&&t| ex.fired[t as usize])
                    .filter_map(|&t| net.steps[t as usize].span)
                    .collect();
                spans.sort_by_key(|s| (s.start, s.end));
                spans.dedup();
                spans.len()
            };
            let (loops, waits) = (reached(&self.loops), reached(&self.waits));
            if loops + waits > 0 {
                r.notes.push(format!(
                    "the end is always reachable, but only if the conditions change: {loops} loop(s) can repeat for as long as their conditions hold and {waits} wait(s) last until theirs do"
                ));
            }
        }
        self.properties.push(r);
    }

    /// A marking from which neither the end nor a deadlock is reachable: the
    /// run goes round forever. The trace is a lasso.
    fn livelock_finding<E: Encoding>(
        &self,
        net: &PtNet,
        ex: &Exploration,
        b: u32,
        ends: &[bool],
    ) -> Finding {
        // Depth-first search from b for a cycle (all of it cannot reach the end).
        let n = ex.store.len();
        let mut colour = vec![0u8; n];
        let mut stack: Vec<(u32, u64)> = vec![(b, ex.edge_offsets[b as usize])];
        let mut via: Vec<u32> = Vec::new();
        colour[b as usize] = 1;
        let mut cycle: Option<(usize, u32)> = None;
        while let Some(&(s, k)) = stack.last() {
            if k < ex.edge_offsets[s as usize + 1] {
                let e = k as usize;
                if let Some(top) = stack.last_mut() {
                    top.1 += 1;
                }
                let t = ex.edges[e];
                debug_assert!(!ends[t as usize]);
                match colour[t as usize] {
                    0 => {
                        colour[t as usize] = 1;
                        via.push(ex.edge_trans[e]);
                        stack.push((t, ex.edge_offsets[t as usize]));
                    }
                    1 => {
                        let pos = stack.iter().position(|&(x, _)| x == t).unwrap_or(0);
                        via.push(ex.edge_trans[e]);
                        cycle = Some((pos, t));
                        break;
                    }
                    _ => {}
                }
            } else {
                colour[s as usize] = 2;
                stack.pop();
                via.pop();
            }
        }
        let mut trace = self.trace::<E>(net, ex, b);
        let prefix = trace.steps.len();
        for &t in &via {
            trace.steps.push(step(net, t));
        }
        let mut labels = Vec::new();
        if let Some((pos, _)) = cycle {
            trace.cycle_from = Some(prefix + pos);
            let mut spans = BTreeSet::new();
            for &t in &via[pos..] {
                let s = &net.steps[t as usize];
                if matches!(s.kind.as_str(), "LoopBack" | "Branch") {
                    if let Some(sp) = s.span {
                        if spans.insert((sp.start, sp.end)) {
                            labels.push(Label {
                                span: sp,
                                text: "goes round here".into(),
                            });
                        }
                    }
                }
            }
            trace.marking = Vec::new();
        }
        Finding {
            kind: FindingKind::NonTermination,
            message: if self.mission() {
                "the mission can reach a state from which it can never end: it can only go round a loop"
                    .into()
            } else {
                "a marking is reachable from which `final` can never be marked".into()
            },
            labels,
            notes: Vec::new(),
            trace: Some(trace),
            geometry: None,
        }
    }

    /// The report of a search for a deadlock alone: found (with its
    /// counterexample), proved absent (the search ran to its end), or
    /// undecided.
    ///
    /// `dead` is the deadlock found, as a trace of `net` and the dead
    /// marking it reaches there (the search may have run on a reduced
    /// net, whose `ex` gives the verdict's other half and the counts).
    fn deadlock_only(
        &mut self,
        name: String,
        net: &PtNet,
        ex: &Exploration,
        dead: Option<(Vec<u32>, Vec<u64>)>,
        method: &str,
    ) -> Report {
        let verdict = if let Some((path, m)) = dead {
            self.findings
                .push(self.deadlock_finding_at::<Bits>(net, &path, &m));
            Verdict::Violated
        } else if ex.complete() {
            Verdict::Holds
        } else {
            Verdict::Unknown(Self::stopped_reason(ex))
        };
        self.properties
            .push(result(Property::Deadlock, verdict, method.to_string()));
        let mut report = self.finish(name, net, ex, method, None);
        report
            .properties
            .retain(|r| r.property == Property::Deadlock);
        report
    }

    /// The report of what this context gathered, which it hands over.
    fn finish(
        &mut self,
        name: String,
        net: &PtNet,
        ex: &Exploration,
        method: &str,
        conditions: Option<(Vec<Finding>, usize)>,
    ) -> Report {
        self.properties
            .push(conditions_result(conditions, &mut self.findings));
        self.properties.sort_by_key(|r| r.property);
        self.findings.sort_by_key(|f| f.kind);
        Report {
            name,
            input: self.input,
            properties: std::mem::take(&mut self.properties),
            findings: std::mem::take(&mut self.findings),
            limits: Vec::new(),
            stats: Stats {
                places: net.n_places(),
                transitions: net.n_real,
                states: ex.store.len(),
                edges: ex.edge_count,
                full_expansions: ex.full_expansions,
                seconds: ex.seconds,
                memory_bytes: ex.memory_bytes(),
                reduction: if method.contains("stubborn") {
                    "stubborn sets".into()
                } else {
                    "none".into()
                },
                complete: ex.complete(),
                max_tokens: ex.max_tokens,
            },
        }
    }
}

/// The near findings of an exploration and why, if so, the separation is
/// not decided although nothing was found.
type Near = Result<(Vec<Finding>, Option<String>), String>;

/// The verdicts of the spatial properties and their findings.
fn spatial_results(
    prep: Option<&space::Prepared>,
    near: Near,
) -> (Vec<PropertyResult>, Vec<Finding>) {
    let Some(prep) = prep else {
        let na = |p| {
            result(
                p,
                Verdict::NotApplicable("a plain net has no drones".into()),
                "-",
            )
        };
        return (
            vec![
                na(Property::Separation),
                na(Property::Airspace),
                na(Property::FlightState),
            ],
            Vec::new(),
        );
    };
    let mut findings = Vec::new();
    let mut props = Vec::new();
    let mut decided = |p: Property, r: &Result<Vec<Finding>, String>, method: &str| match r {
        Ok(f) => {
            findings.extend(f.iter().cloned());
            let v = if f.is_empty() {
                Verdict::Holds
            } else {
                Verdict::Violated
            };
            result(p, v, method)
        }
        Err(why) => result(p, Verdict::Unknown(why.clone()), method),
    };
    props.push(decided(
        Property::Airspace,
        &prep.airspace,
        "every leg of every drone, followed from home through every branch and counted loop round",
    ));
    props.push(decided(
        Property::FlightState,
        &prep.flight,
        "each drone's actions followed in order from home, where it stands disarmed",
    ));
    let homes = space::homes_findings(prep);
    let sep = prep.space.airspace.separation;
    let method =
        format!("legs and rests of every two drones within {sep} m, watched in the exploration");
    let mut found = homes;
    let undecided = match near {
        Ok((f, undecided)) => {
            found.extend(f);
            undecided
        }
        Err(why) => Some(why),
    };
    let undecided = undecided.or_else(|| match &prep.positions {
        Err(why) => Some(why.clone()),
        Ok(p) if !p.drifts.is_empty() => Some(
            "a drone drifts without bound (see the airspace finding), so not all of its legs are known"
                .into(),
        ),
        Ok(_) => None,
    });
    let verdict = if !found.is_empty() {
        Verdict::Violated
    } else if let Some(why) = undecided.clone() {
        Verdict::Unknown(why)
    } else {
        Verdict::Holds
    };
    let violated_partly = matches!(verdict, Verdict::Violated) && undecided.is_some();
    let mut r = result(Property::Separation, verdict, method);
    r.notes.push(format!("separation {sep} m"));
    if let (true, Some(why)) = (violated_partly, &undecided) {
        // Violated all the same, but not every way the drones can meet
        // was looked for: the findings are some of them, not the closest.
        r.notes.push(format!("not every pair was judged: {why}"));
    }
    props.push(r);
    findings.extend(found);
    (props, findings)
}

/// The verdict on conditions, which needs no exploration; its findings go
/// into `findings`.
fn conditions_result(
    conditions: Option<(Vec<Finding>, usize)>,
    findings: &mut Vec<Finding>,
) -> PropertyResult {
    match conditions {
        Some((found, checked)) => {
            let verdict = if found.is_empty() {
                Verdict::Holds
            } else {
                Verdict::Violated
            };
            findings.extend(found);
            result(
                Property::Conditions,
                verdict,
                format!("interval reasoning over property ranges ({checked} condition(s))"),
            )
        }
        None => result(
            Property::Conditions,
            Verdict::NotApplicable("a plain net has no conditions".into()),
            "-",
        ),
    }
}

/// The report when the net is not explored: the conditions are still
/// decided (they need no exploration), every other property is unknown,
/// and the limits say why.
fn unexplored(
    name: String,
    input: InputKind,
    pt: &PtNet,
    conditions: Option<(Vec<Finding>, usize)>,
    limits: Vec<Limit>,
) -> Report {
    let mut findings = Vec::new();
    let reason = format!("not explored, see `eamos::{}`", limits[0].code);
    let mut properties: Vec<PropertyResult> = Property::ALL
        .iter()
        .filter(|&&p| p != Property::Conditions)
        .map(|&p| result(p, Verdict::Unknown(reason.clone()), "none"))
        .collect();
    properties.push(conditions_result(conditions, &mut findings));
    properties.sort_by_key(|r| r.property);
    findings.sort_by_key(|f| f.kind);
    Report {
        name,
        input,
        properties,
        findings,
        limits,
        stats: Stats {
            places: pt.n_places(),
            transitions: pt.n_real,
            reduction: "none".into(),
            ..Stats::default()
        },
    }
}

fn unsafe_or(unsafe_found: bool, reason: String) -> String {
    if unsafe_found {
        "the net is not 1-safe or not bounded: see that finding".into()
    } else {
        reason
    }
}

fn step(net: &PtNet, t: u32) -> Step {
    let s = &net.steps[t as usize];
    Step {
        transition: s.id.to_string(),
        kind: s.kind.to_string(),
        text: s.text.to_string(),
        internal: s.internal,
        span: s.span,
        condition_held: s.guard.map(|(_, held)| held),
    }
}

fn marking<E: Encoding>(net: &PtNet, m: &[u64]) -> Vec<(String, u32)> {
    let mut out = Vec::new();
    E::for_each_marked(m, |p| {
        if !net.places[p as usize].synthetic {
            out.push((net.places[p as usize].id.to_string(), E::get(m, p)));
        }
    });
    out
}

fn place_label(net: &PtNet, p: u32, text: &str) -> Vec<Label> {
    net.places[p as usize]
        .span
        .map(|span| Label {
            span,
            text: text.into(),
        })
        .into_iter()
        .collect()
}

fn grows_labels<E: Encoding>(net: &PtNet, m: &[u64], a: &[u64]) -> Vec<Label> {
    (0..net.n_places() as u32)
        .filter(|&p| E::get(m, p) > E::get(a, p))
        .flat_map(|p| place_label(net, p, "grows"))
        .collect()
}
