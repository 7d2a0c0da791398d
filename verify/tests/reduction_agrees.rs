//! Partial-order reduction must never change an answer: on random small nets
//! (with read arcs, choices, loops, drone actions and events), every verdict,
//! every finding and the length of the shortest deadlock are the same with
//! stubborn sets as with full exploration.

use eamos_lang::hir::DroneId;
use eamos_lang::Span;
use eamos_petri::net::{
    ActionRef, ColourOp, Name, Net, NodeId, Owner, Place, PlaceKind, Transition, TransitionKind,
};
use eamos_verify::{check_net, FindingKind, Options, Report};
use proptest::prelude::*;

const ACTIONS: [&str; 3] = ["FlyByX", "Land", "TakePhoto"];

#[derive(Debug, Clone)]
struct RandomNet {
    /// Extra places beyond `initial` (0) and `final` (1); the first three
    /// are running places of drone D1.
    places: usize,
    marked: Vec<bool>,
    transitions: Vec<(Vec<usize>, Vec<usize>, Vec<usize>)>,
}

fn random_net() -> impl Strategy<Value = RandomNet> {
    (3usize..8).prop_flat_map(|extra| {
        let n = extra + 2;
        let arcs = || proptest::collection::vec(0..n, 1..3);
        (
            Just(extra),
            proptest::collection::vec(proptest::bool::weighted(0.25), extra),
            proptest::collection::vec(
                (
                    proptest::collection::vec(0..n, 1..3),
                    proptest::collection::vec(0..n, 0..2),
                    arcs(),
                ),
                1..9,
            ),
        )
            .prop_map(|(places, marked, transitions)| RandomNet {
                places,
                marked,
                transitions,
            })
    })
}

fn build(r: &RandomNet) -> (Net, String) {
    // One line of source per node, so every span is distinct.
    let mut src = String::new();
    let mut line = |s: &str| {
        let start = src.len();
        src.push_str(s);
        src.push('\n');
        Span::new(start, start + s.len())
    };
    let mut spans_p = Vec::new();
    let mut spans_t = Vec::new();
    for i in 0..r.places + 2 {
        spans_p.push(line(&format!("place {i}")));
    }
    for i in 0..r.transitions.len() {
        spans_t.push(line(&format!("transition {i}")));
    }
    let mut net = Net::new("Random", vec!["D1".into()], vec!["Quadcopter".into()]);
    let mut ids: Vec<NodeId> = vec![net.initial_place, net.final_place];
    for i in 0..r.places {
        let kind = if i < ACTIONS.len() {
            PlaceKind::Running(
                ActionRef {
                    drone: DroneId(0),
                    name: ACTIONS[i].into(),
                    args: vec![],
                    instance: i as u32,
                }
                .into(),
            )
        } else {
            PlaceKind::Control
        };
        let p = net.add_place(Place {
            id: Name::default(),
            label: format!("p{i}").into(),
            kind,
            owner: Owner::Unassigned,
            span: Some(spans_p[i + 2]),
            depth: 0,
        });
        if r.marked[i] {
            net.initial_marking.push(p);
        }
        ids.push(p);
    }
    for (k, (pre, read, post)) in r.transitions.iter().enumerate() {
        let mut pre = pre.clone();
        pre.sort();
        pre.dedup();
        let mut read = read.clone();
        read.sort();
        read.dedup();
        read.retain(|p| !pre.contains(p));
        let mut post = post.clone();
        post.sort();
        post.dedup();
        // A transition producing into a running place starts its action.
        let kind = match post.iter().find(|&&p| (2..2 + ACTIONS.len()).contains(&p)) {
            Some(&p) => TransitionKind::ActionStart(
                ActionRef {
                    drone: DroneId(0),
                    name: ACTIONS[p - 2].into(),
                    args: vec![],
                    instance: (p - 2) as u32,
                }
                .into(),
            ),
            None => TransitionKind::Silent,
        };
        let t = net.add_transition(Transition {
            id: Name::default(),
            label: format!("t{k}").into(),
            kind,
            owner: Owner::Unassigned,
            span: spans_t[k],
            guard: None,
            delay: None,
        });
        for &p in &pre {
            net.arc(ids[p], t, ColourOp::Keep);
        }
        for &p in &read {
            net.read_arc(ids[p], t);
        }
        for &p in &post {
            net.arc(t, ids[p], ColourOp::Keep);
        }
    }
    (net, src)
}

/// What must not depend on the reduction.
fn answers(r: &Report) -> Vec<String> {
    let mut out: Vec<String> = r
        .properties
        .iter()
        .map(|p| format!("{}: {}", p.property.name(), p.verdict.word()))
        .collect();
    for f in &r.findings {
        let spans: Vec<(u32, u32)> = f
            .labels
            .iter()
            .map(|l| (l.span.start, l.span.end))
            .collect();
        match f.kind {
            // Which deadlock is found first may differ; its distance may not.
            FindingKind::Deadlock => out.push(format!(
                "deadlock at depth {}",
                f.trace.as_ref().map_or(0, |t| t.steps.len())
            )),
            // Which marking shows a livelock may differ.
            FindingKind::NonTermination => out.push("non-termination".into()),
            k => out.push(format!("{} {:?}", k.name(), spans)),
        }
    }
    out.sort();
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn stubborn_sets_give_the_same_answers_as_full_exploration(r in random_net()) {
        let (net, src) = build(&r);
        let profiles = eamos_profile::builtin();
        let reduced = check_net(&net, &profiles, Some(&src), &Options::default());
        let full = check_net(
            &net,
            &profiles,
            Some(&src),
            &Options { reduction: false, ..Options::default() },
        );
        prop_assert_eq!(answers(&reduced), answers(&full));
        prop_assert!(reduced.stats.states <= full.stats.states);
    }
}
