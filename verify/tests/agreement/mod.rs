//! Holding a report of `check` against the oracle's verdicts on the same
//! net (`eamos_oracle`): what must agree, under every way of checking.

#![allow(dead_code)]

pub mod conditions;
pub mod mission;
pub mod net;

use std::collections::BTreeSet;

use eamos_lang::Span;
use eamos_oracle::{Answer, Verdicts};
use eamos_petri::game::{self, Marking};
use eamos_petri::net::{Guard, Net, NodeId, Transition, TransitionKind};
use eamos_profile::ProfileTable;
use eamos_verify::{check_net, FindingKind, Goal, Options, Property, Report, Verdict};

/// Cases per property test: the count given, or `PROPTEST_CASES` to run
/// more (or fewer) by hand.
pub fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Markings past which the oracle gives up and the case is not compared.
pub const MAX_MARKINGS: usize = 2_000;

/// Every way the checker can be asked to explore, each of which must give
/// the oracle's answers: the reduction on and off, with and without the
/// spatial properties (whose rest records add places to the explored net).
pub fn ways() -> Vec<(&'static str, Options)> {
    let way = |reduction, spatial| Options {
        reduction,
        spatial,
        ..Options::default()
    };
    vec![
        (
            "stubborn sets, spatial properties (as shipped)",
            way(true, true),
        ),
        ("stubborn sets", way(true, false)),
        (
            "stubborn sets, every loop counted",
            Options {
                structural: false,
                ..way(true, false)
            },
        ),
        ("full exploration", way(false, false)),
    ]
}

/// The oracle's answer on `net`, condition guards judged by
/// [`conditions::may_hold`].
pub fn oracle(net: &Net, profiles: &ProfileTable) -> Answer {
    let mut may_hold = |_: &Transition, g: &Guard| conditions::may_hold(net, profiles, g);
    eamos_oracle::search(net, profiles, &mut may_hold, MAX_MARKINGS)
}

/// Checks `net` every way and holds each report against the oracle's
/// `answer`; the first disagreement, named, is the error.
///
/// Where a drone flies two legs at once (the oracle found a conflict), the
/// spatial properties are left out: following every drone's legs through
/// every branch and round then takes seconds in a debug build for a dozen
/// actions (up to 24 s for one random mission of eleven), and separation
/// is undecided for such a drone anyway.
pub fn agree_every_way(
    net: &Net,
    profiles: &ProfileTable,
    src: &str,
    answer: &Answer,
) -> Result<(), String> {
    let two_legs_at_once = match answer {
        Answer::Decided(v) => !v.conflicts.is_empty(),
        Answer::Broken { .. } => false,
        // Nothing to hold the checker against.
        Answer::TooLarge { .. } => return Ok(()),
    };
    for (way, options) in ways() {
        if options.spatial && two_legs_at_once {
            continue;
        }
        let report = check_net(net, profiles, Some(src), &options);
        agree(net, profiles, &report, answer).map_err(|e| format!("{way}: {e}"))?;
    }
    for shortest in [false, true] {
        let options = Options {
            spatial: false,
            goal: Goal::Deadlock { shortest },
            ..Options::default()
        };
        let report = check_net(net, profiles, Some(src), &options);
        agree_on_deadlock(net, profiles, &report, answer, shortest)
            .map_err(|e| format!("deadlock only (shortest: {shortest}): {e}"))?;
    }
    Ok(())
}

/// What a report asked only about deadlocks must say: the oracle's
/// verdict, and a counterexample that replays in the token game (a
/// shortest one when asked for).
fn agree_on_deadlock(
    net: &Net,
    profiles: &ProfileTable,
    r: &Report,
    answer: &Answer,
    shortest: bool,
) -> Result<(), String> {
    // A net that breaks the game has no deadlock verdict to compare.
    let Answer::Decided(v) = answer else {
        return Ok(());
    };
    if r.properties.len() != 1 {
        return Err(format!("{} properties answered", r.properties.len()));
    }
    expect(r, Property::Deadlock, v.deadlock.is_some())?;
    if let Some(want) = &v.deadlock {
        let f = r
            .findings_of(FindingKind::Deadlock)
            .next()
            .ok_or("a deadlock verdict without its finding")?;
        let trace = f.trace.as_ref().ok_or("a deadlock without a trace")?;
        if shortest && trace.steps.len() != want.len() {
            return Err(format!(
                "the deadlock is {} steps away, the shortest {}",
                trace.steps.len(),
                want.len()
            ));
        }
        replay_to_deadlock(net, profiles, trace)?;
    }
    Ok(())
}

/// A compiled mission never ends with a token left behind: every run that
/// marks `final` has joined all its branches. (The checker relies on it: it
/// takes a dead marking with `final` marked for the end.)
pub fn ends_clean(net: &Net, answer: &Answer) -> Result<(), String> {
    match answer.decided().and_then(|v| v.unclean_end.as_ref()) {
        Some(run) => Err(format!(
            "a run ends with `final` and another token marked: {:?}",
            run.iter().map(|f| net.id(f.transition)).collect::<Vec<_>>()
        )),
        None => Ok(()),
    }
}

/// What one report must say, given the oracle's answer.
pub fn agree(
    net: &Net,
    profiles: &ProfileTable,
    report: &Report,
    answer: &Answer,
) -> Result<(), String> {
    match answer {
        Answer::Decided(v) => agree_decided(net, profiles, report, v),
        Answer::Broken { error, .. } => {
            let safety = report.verdict(Property::Safety);
            (safety == Some(&Verdict::Violated))
                .then_some(())
                .ok_or_else(|| format!("the game breaks ({error}), safety is {safety:?}"))
        }
        Answer::TooLarge { .. } => Ok(()),
    }
}

fn verdict(r: &Report, p: Property) -> Result<&Verdict, String> {
    r.verdict(p)
        .ok_or_else(|| format!("no verdict on {}", p.name()))
}

fn expect(r: &Report, p: Property, violated: bool) -> Result<(), String> {
    let got = verdict(r, p)?;
    let want = if violated {
        Verdict::Violated
    } else {
        Verdict::Holds
    };
    if *got == want {
        Ok(())
    } else {
        Err(format!(
            "{}: check says {got:?}, the oracle {want:?}",
            p.name()
        ))
    }
}

fn agree_decided(
    net: &Net,
    profiles: &ProfileTable,
    r: &Report,
    v: &Verdicts,
) -> Result<(), String> {
    expect(r, Property::Safety, false)?;
    expect(r, Property::Deadlock, v.deadlock.is_some())?;
    expect(r, Property::Termination, !v.terminates)?;
    if let Some(shortest) = &v.deadlock {
        let f = r
            .findings_of(FindingKind::Deadlock)
            .next()
            .ok_or("a deadlock verdict without its finding")?;
        let trace = f.trace.as_ref().ok_or("a deadlock without a trace")?;
        if trace.steps.len() != shortest.len() {
            return Err(format!(
                "the deadlock is {} steps away, the shortest {}",
                trace.steps.len(),
                shortest.len()
            ));
        }
        replay_to_deadlock(net, profiles, trace)?;
    }
    // Check names a conflict by its two actions' spans, smaller first.
    let conflicts: BTreeSet<(Pos, Pos)> = r
        .findings_of(FindingKind::DroneConflict)
        .filter_map(|f| Some((pos(f.labels.first()?.span), pos(f.labels.last()?.span))))
        .collect();
    let want: BTreeSet<(Pos, Pos)> = v
        .conflicts
        .iter()
        .map(|&(p, q)| {
            let (a, b) = (pos(running_span(net, p)), pos(running_span(net, q)));
            (a.min(b), a.max(b))
        })
        .collect();
    expect(r, Property::Conflicts, !want.is_empty())?;
    if conflicts != want {
        return Err(format!(
            "conflicts: check {conflicts:?}, the oracle {want:?}"
        ));
    }
    let dead: BTreeSet<Pos> = r
        .findings_of(FindingKind::DeadAction)
        .filter_map(|f| Some(pos(f.labels.first()?.span)))
        .collect();
    let never: BTreeSet<Pos> = net
        .transitions()
        .filter(|(t, tr)| {
            matches!(tr.kind, TransitionKind::ActionStart(_)) && !v.started.contains(t)
        })
        .map(|(_, tr)| pos(tr.span))
        .collect();
    if dead != never {
        return Err(format!(
            "dead actions: check {dead:?}, the oracle {never:?}"
        ));
    }
    Ok(())
}

/// Where a span starts and ends: spans are not ordered, these are.
type Pos = (u32, u32);

fn pos(s: Span) -> Pos {
    (s.start, s.end)
}

/// The span check names a running place by: its own, else its action's.
fn running_span(net: &Net, p: NodeId) -> Span {
    net.place(p)
        .and_then(|pl| pl.span)
        .or_else(|| {
            net.producers(p).find_map(|t| {
                let tr = net.transition(t)?;
                matches!(tr.kind, TransitionKind::ActionStart(_)).then_some(tr.span)
            })
        })
        .unwrap_or_default()
}

/// Replays a deadlock's trace in the token game on the net as compiled:
/// every step fires, a guarded step's condition could have been as the
/// trace says, and the game ends in the marking reported, in which nothing
/// may fire and which is not the final one.
pub fn replay_to_deadlock(
    net: &Net,
    profiles: &ProfileTable,
    trace: &eamos_verify::Trace,
) -> Result<(), String> {
    let mut m = Marking::initial(net);
    for (i, s) in trace.steps.iter().enumerate() {
        let t = net
            .find(&s.transition)
            .ok_or_else(|| format!("step {i}: no transition `{}`", s.transition))?;
        if let Some(g) = net.transition(t).and_then(|tr| tr.guard.as_ref()) {
            if g.condition().is_some() {
                let held = s
                    .condition_held
                    .ok_or(format!("step {i} hides its condition"))?;
                if !g.holds_when(held) || !conditions::may_hold(net, profiles, g) {
                    return Err(format!(
                        "step {i} ({}) passes a guard that is false",
                        s.text
                    ));
                }
            }
        }
        m = game::fire(net, &m, t).map_err(|e| format!("step {i} ({}): {e}", s.text))?;
    }
    let mut reached: Vec<&str> = m.places().map(|p| net.id(p)).collect();
    let mut reported: Vec<&str> = trace.marking.iter().map(|(p, _)| p.as_str()).collect();
    reached.sort_unstable();
    reported.sort_unstable();
    if reached != reported {
        return Err(format!(
            "the deadlock reaches {reached:?}, reports {reported:?}"
        ));
    }
    if m.is_final(net) {
        return Err("the deadlock is the final marking".into());
    }
    let live = game::enabled(net, &m, &mut |_, g, _| {
        conditions::may_hold(net, profiles, g)
    });
    if let Some(e) = live.first() {
        return Err(format!(
            "the deadlock is live: `{}` may fire",
            net.id(e.transition)
        ));
    }
    Ok(())
}
