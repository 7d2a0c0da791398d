//! The structural reductions before a deadlock search (`eamos check
//! --only deadlock`) never change its answer: on random nets (some of
//! their transitions split into the runs of single-input single-output
//! nodes the rules fuse) and on random missions through the front end,
//! the verdict with the reductions is the verdict without and the
//! oracle's (`eamos_oracle`, a plain search of the token game), and every
//! deadlock found on a reduced net is shown as a trace that replays on the
//! net as compiled, in the token game, to a marking that is dead and not
//! final.
//!
//! About 3,000 cases, a few seconds of processor time in a debug build;
//! `PROPTEST_CASES=20000` runs more of each by hand. Each test also counts
//! the cases the rules reduced, with and without a deadlock, and fails if
//! there are too few: a generator drifted away from what the rules touch
//! would otherwise pass for ever.

mod agreement;

use std::cell::RefCell;
use std::collections::BTreeMap;

use agreement::mission::compile;
use agreement::net::{Arcs, RandomNet};
use agreement::{cases, replay_to_deadlock};
use eamos_oracle::Answer;
use eamos_petri::net::Net;
use eamos_profile::ProfileTable;
use eamos_verify::{check_net, FindingKind, Goal, Options, Property, Report};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// The report asked only about deadlocks, reductions on or off.
fn deadlock_only(net: &Net, profiles: &ProfileTable, src: &str, structural: bool) -> Report {
    let options = Options {
        spatial: false,
        goal: Goal::Deadlock { shortest: false },
        structural,
        ..Options::default()
    };
    check_net(net, profiles, Some(src), &options)
}

/// Whether the report says the net was reduced before the search.
fn reduced(r: &Report) -> bool {
    r.properties
        .iter()
        .flat_map(|p| &p.notes)
        .any(|n| n.starts_with("structural reductions left"))
}

/// One case: the same verdict both ways, and the reduced search's
/// counterexample a deadlock of `net`. Returns what the case covered.
fn agree(net: &Net, profiles: &ProfileTable, src: &str) -> Result<&'static str, String> {
    // The oracle's bound keeps every case small; a net that breaks the
    // token game (a second token) has no counterexample to replay there.
    let answer = agreement::oracle(net, profiles);
    let oracle_deadlock = match &answer {
        Answer::TooLarge { .. } => return Ok("too large for the oracle"),
        Answer::Broken { .. } => None,
        Answer::Decided(v) => Some(v.deadlock.is_some()),
    };
    let with = deadlock_only(net, profiles, src, true);
    let without = deadlock_only(net, profiles, src, false);
    let verdict = |r: &Report| r.verdict(Property::Deadlock).map(|v| v.word());
    // A deadlock found is real whatever the net, so on a net that is not
    // 1-safe one search may find it where the other stops at a second
    // token and counts tokens until its bound: "violated" against
    // "unknown" is no contradiction (the trace is replayed below).
    let found_where_unknown = matches!(
        (verdict(&with), verdict(&without)),
        (Some("violated"), Some("unknown")) | (Some("unknown"), Some("violated"))
    );
    if verdict(&with) != verdict(&without) && !found_where_unknown {
        return Err(format!(
            "with the reductions: {:?}, without: {:?}",
            with.verdict(Property::Deadlock),
            without.verdict(Property::Deadlock)
        ));
    }
    if reduced(&without) {
        return Err("reduced although asked not to".into());
    }
    // The checker falls back on the unreduced search when a reduced
    // counterexample does not replay: sound, but a rule's bug all the same.
    if with
        .properties
        .iter()
        .any(|p| p.notes.iter().any(|n| n == eamos_verify::check::UNREPLAYED))
    {
        return Err("a counterexample of the reduced net did not replay".into());
    }
    if let Some(deadlock) = oracle_deadlock {
        let want = if deadlock { "violated" } else { "holds" };
        if verdict(&with) != Some(want) {
            return Err(format!(
                "with the reductions: {:?}, the oracle: {want}",
                with.verdict(Property::Deadlock)
            ));
        }
        for f in with.findings_of(FindingKind::Deadlock) {
            let trace = f.trace.as_ref().ok_or("a deadlock without a trace")?;
            replay_to_deadlock(net, profiles, trace)?;
        }
    }
    Ok(match (reduced(&with), verdict(&with)) {
        (false, _) => "not reduced",
        (true, Some("violated")) => "reduced, deadlock",
        (true, Some("holds")) => "reduced, no deadlock",
        (true, _) => "reduced, undecided",
    })
}

/// Splits transition `t` into `t` feeding a new place and a new silent
/// transition emptying it into `t`'s outputs.
fn split(r: &mut RandomNet, t: usize) {
    let p = r.places.len() + 2;
    r.places.push((0, false));
    let outputs = std::mem::replace(&mut r.transitions[t].post, vec![p]);
    r.transitions.push(Arcs {
        pre: vec![p],
        read: Vec::new(),
        post: outputs,
        guard: None,
    });
}

fn random_net() -> impl Strategy<Value = RandomNet> {
    (
        agreement::net::random_net(),
        proptest::collection::vec(0usize..16, 0..8),
    )
        .prop_map(|(mut r, splits)| {
            for s in splits {
                let t = s % r.transitions.len();
                split(&mut r, t);
            }
            r
        })
}

fn run<S: Strategy>(
    cases: u32,
    strategy: S,
    case: impl Fn(S::Value) -> Result<&'static str, String>,
) -> BTreeMap<&'static str, usize>
where
    S::Value: std::fmt::Debug,
{
    let covered = RefCell::new(BTreeMap::new());
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    let result = TestRunner::new(config).run(&strategy, |v| {
        let kind = case(v).map_err(TestCaseError::fail)?;
        *covered.borrow_mut().entry(kind).or_insert(0) += 1;
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let covered = covered.into_inner();
    // Shown with `--nocapture`, to size the shares.
    println!("covered: {covered:?}");
    covered
}

fn at_least(covered: &BTreeMap<&'static str, usize>, cases: u32, shares: &[(&str, f64)]) {
    for &(kind, share) in shares {
        let n = covered.get(kind).copied().unwrap_or(0);
        let min = ((f64::from(cases) * share) as usize).max(1);
        assert!(n >= min, "only {n} cases {kind}, want {min}: {covered:?}");
    }
}

#[test]
fn on_random_nets_the_reductions_keep_the_deadlock_verdict_and_its_trace() {
    let profiles = eamos_profile::builtin();
    let n = cases(4000);
    let covered = run(n, random_net(), |r| {
        let (net, src) = agreement::net::build(&r);
        agree(&net, &profiles, &src)
    });
    at_least(
        &covered,
        n,
        &[("reduced, deadlock", 0.3), ("reduced, no deadlock", 0.01)],
    );
}

#[test]
fn on_random_missions_the_reductions_keep_the_deadlock_verdict_and_its_trace() {
    let profiles = eamos_profile::builtin();
    let n = cases(600);
    let covered = run(n, any::<u64>(), |seed| {
        let text = agreement::mission::random(seed);
        let net = compile(&text, &profiles)?;
        agree(&net, &profiles, &text).map_err(|e| format!("{e}\n{text}"))
    });
    at_least(
        &covered,
        n,
        &[("reduced, deadlock", 0.02), ("reduced, no deadlock", 0.3)],
    );
}

#[test]
fn on_generated_missions_the_reductions_keep_the_deadlock_verdict_and_its_trace() {
    use eamos_gen::{generate, Constructs, Options as GenOptions, Size};
    let profiles = eamos_profile::builtin();
    let n = cases(150);
    let strategy = (1usize..5, 0usize..80, any::<u64>(), any::<bool>());
    let covered = run(n, strategy, |(drones, extra, seed, risky)| {
        let options = GenOptions {
            risky,
            constructs: Constructs::ALL,
            ..GenOptions::new(
                drones,
                Size::Nodes(eamos_gen::min_size(drones, Size::Nodes(0)) + extra),
                seed,
            )
        };
        let g = generate(&options).map_err(|e| e.to_string())?;
        let net = compile(&g.text, &profiles)?;
        agree(&net, &profiles, &g.text).map_err(|e| format!("{e}\n{}", g.text))
    });
    at_least(&covered, n, &[("reduced, no deadlock", 0.3)]);
}
