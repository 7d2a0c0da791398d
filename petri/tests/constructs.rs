//! The net of each construct of the language, specified by the firing
//! sequences the token game allows: what must happen before happens before.

mod common;

use std::collections::BTreeSet;

use common::*;
use eamos_lang::hir::CondMode::{Until, While};
use eamos_lang::hir::DroneId;
use eamos_petri::game::{self, oracle, Marking, Outcome};
use eamos_petri::net::{GuardKind, Net, NodeId, Owner, PlaceKind, TransitionKind};

const SEEDS: u64 = 64;

fn pos(net: &Net, run: &game::Run, label: &str) -> usize {
    run.position(transition(net, label))
        .unwrap_or_else(|| panic!("{label:?} did not fire in {:?}", run.ids(net)))
}

#[test]
fn the_initial_token_belongs_to_the_ground_station_and_starts_the_mission() {
    let net = compile(&["D1"], seq(vec![fly(0, 1.0)]));
    assert_eq!(net.place(net.initial_place).unwrap().owner, Owner::Gcs);
    let (init, t) = net
        .transitions()
        .find(|(_, t)| t.kind == TransitionKind::Init)
        .unwrap();
    assert_eq!(t.owner, Owner::Gcs);
    assert_eq!(
        net.preset(init).collect::<Vec<_>>(),
        vec![net.initial_place]
    );
    let run = run_to_final(&net, 1);
    assert_eq!(run.firings[0].transition, init);
}

#[test]
fn an_empty_mission_goes_straight_from_init_to_final() {
    let net = compile(&["D1"], seq(vec![]));
    assert_eq!(net.transitions().count(), 2);
    let run = run_to_final(&net, 0);
    assert_eq!(run.firings.len(), 2);
    assert!(run.marking.is_marked(net.final_place));
    assert_eq!(net.place(net.final_place).unwrap().id, "final");
}

#[test]
fn a_running_action_is_visible_in_the_marking() {
    let net = compile(&["D1"], seq(vec![fly(0, 1.0)]));
    let start = transition(&net, "D1.FlyByX(1 m)");
    let mut m = Marking::initial(&net);
    let init = game::enabled(&net, &m, &mut oracle::constant(true))[0].transition;
    m = game::fire(&net, &m, init).unwrap();
    m = game::fire(&net, &m, start).unwrap();
    let running: Vec<_> = m
        .places()
        .filter(|p| matches!(net.place(*p).unwrap().kind, PlaceKind::Running(_)))
        .collect();
    assert_eq!(running.len(), 1);
    assert_eq!(
        net.place(running[0]).unwrap().owner,
        Owner::Drone(DroneId(0))
    );
    let end = transition(&net, "end D1.FlyByX(1 m)");
    assert!(game::enabled(&net, &m, &mut oracle::constant(true))
        .iter()
        .any(|e| e.transition == end));
}

#[test]
fn an_action_and_its_running_place_belong_to_its_drone() {
    let net = compile(&["D1", "D2"], seq(vec![fly(1, 1.0)]));
    for (_, t) in net.transitions() {
        if let Some(a) = t.kind.action() {
            assert_eq!(t.owner, Owner::Drone(a.drone));
            assert_eq!(a.drone, DroneId(1));
        }
    }
    assert_sliceable(&net);
}

#[test]
fn a_sequence_starts_each_action_after_the_previous_one_has_ended() {
    let net = compile(&["D1"], seq(vec![fly(0, 1.0), fly(0, 2.0), fly(0, 3.0)]));
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        assert_eq!(
            started(&net, &run),
            ["D1.FlyByX(1 m)", "D1.FlyByX(2 m)", "D1.FlyByX(3 m)"]
        );
        assert!(pos(&net, &run, "end D1.FlyByX(1 m)") < pos(&net, &run, "D1.FlyByX(2 m)"));
        assert!(pos(&net, &run, "end D1.FlyByX(2 m)") < pos(&net, &run, "D1.FlyByX(3 m)"));
    }
}

#[test]
fn par_branches_interleave_both_ways_and_join_before_what_follows() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![
            block(par(vec![fly(0, 1.0), fly(1, 2.0)])),
            fly(0, 3.0),
        ]),
    );
    let mut orders = BTreeSet::new();
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        let s = started(&net, &run);
        orders.insert(s[..2].to_vec());
        let after = pos(&net, &run, "D1.FlyByX(3 m)");
        assert!(pos(&net, &run, "end D1.FlyByX(1 m)") < after);
        assert!(pos(&net, &run, "end D2.FlyByX(2 m)") < after);
    }
    assert_eq!(orders.len(), 2, "both orders should occur: {orders:?}");
}

#[test]
fn a_par_of_one_statement_needs_no_fork_and_an_empty_par_nothing() {
    let net = compile(
        &["D1"],
        seq(vec![block(par(vec![fly(0, 1.0)])), block(par(vec![]))]),
    );
    assert!(!net
        .transitions()
        .any(|(_, t)| matches!(t.kind, TransitionKind::Fork | TransitionKind::Join)));
    run_to_final(&net, 3);
}

#[test]
fn each_call_of_a_block_is_its_own_instance() {
    let body = seq(vec![fly(0, 1.0)]);
    let net = compile(&["D1"], seq(vec![block(body.clone()), block(body)]));
    let instances: BTreeSet<u32> = net
        .transitions()
        .filter_map(|(_, t)| match &t.kind {
            TransitionKind::ActionStart(a) => Some(a.instance),
            _ => None,
        })
        .collect();
    assert_eq!(instances.len(), 2);
    let run = run_to_final(&net, 0);
    assert_eq!(started(&net, &run).len(), 2);
}

fn if_mission(with_else: bool) -> Net {
    compile(
        &["D1", "D2"],
        seq(vec![
            if_(
                x_above(1, 0.0),
                seq(vec![fly(0, 1.0)]),
                with_else.then(|| seq(vec![fly(0, 2.0)])),
            ),
            fly(0, 3.0),
        ]),
    )
}

#[test]
fn if_takes_exactly_one_branch_and_both_branches_are_possible() {
    let net = if_mission(true);
    let mut seen = BTreeSet::new();
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        let s = started(&net, &run);
        assert_eq!(s.len(), 2, "one branch then the rest: {s:?}");
        assert_eq!(s[1], "D1.FlyByX(3 m)");
        seen.insert(s[0].clone());
    }
    assert_eq!(seen.len(), 2);
}

#[test]
fn if_follows_the_value_of_its_condition() {
    let net = if_mission(true);
    let yes = game::run_random(&net, 0, oracle::constant(true), 1000);
    assert_eq!(started(&net, &yes), ["D1.FlyByX(1 m)", "D1.FlyByX(3 m)"]);
    let no = game::run_random(&net, 0, oracle::constant(false), 1000);
    assert_eq!(started(&net, &no), ["D1.FlyByX(2 m)", "D1.FlyByX(3 m)"]);
    let net = if_mission(false);
    let no = game::run_random(&net, 0, oracle::constant(false), 1000);
    assert_eq!(no.outcome, Outcome::Final);
    assert_eq!(started(&net, &no), ["D1.FlyByX(3 m)"]);
}

#[test]
fn the_branches_of_an_if_are_complementary_guards_owned_by_the_condition_drone() {
    let net = if_mission(true);
    let branches: Vec<_> = net
        .transitions()
        .filter(|(_, t)| t.kind == TransitionKind::Branch)
        .collect();
    assert_eq!(branches.len(), 2);
    let choice: Vec<NodeId> = net.preset(branches[0].0).collect();
    assert_eq!(choice, net.preset(branches[1].0).collect::<Vec<_>>());
    let negations: BTreeSet<bool> = branches
        .iter()
        .map(|(_, t)| {
            assert_eq!(t.owner, Owner::Drone(DroneId(1)));
            t.guard.as_ref().unwrap().condition().unwrap().1
        })
        .collect();
    assert_eq!(negations.len(), 2);
    assert_eq!(
        net.place(choice[0]).unwrap().owner,
        Owner::Drone(DroneId(1))
    );
    assert_eq!(
        net.transitions()
            .filter(|(_, t)| t.kind == TransitionKind::Merge)
            .count(),
        2
    );
    assert_sliceable(&net);
}

/// The world of a loop test: the condition holds for the first `n`
/// iterations. The loop head's colour counts finished iterations.
fn first_iterations(
    n: u32,
) -> impl FnMut(&eamos_petri::Transition, &eamos_petri::Guard, &[u32]) -> bool {
    move |_, g, colour| g.holds_when(colour.last().copied().unwrap_or(0) < n)
}

#[test]
fn repeat_while_runs_its_body_while_the_guard_holds_and_exits_when_it_is_false() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![repeat(
            While,
            x_above(1, 0.0),
            seq(vec![fly(0, 1.0)]),
            Some(seq(vec![fly(0, 9.0)])),
        )]),
    );
    for n in 0..4 {
        let run = game::run_random(&net, u64::from(n), first_iterations(n), 10_000);
        assert_eq!(run.outcome, Outcome::Final);
        let s = started(&net, &run);
        assert_eq!(s.len(), n as usize + 1);
        assert!(s[..n as usize].iter().all(|l| l == "D1.FlyByX(1 m)"));
        assert_eq!(s[n as usize], "D1.FlyByX(9 m)");
    }
    assert_sliceable(&net);
}

#[test]
fn repeat_until_is_repeat_while_of_the_negated_condition() {
    let net = compile(
        &["D1"],
        seq(vec![repeat(
            Until,
            x_above(0, 0.0),
            seq(vec![fly(0, 1.0)]),
            None,
        )]),
    );
    // The condition holds from the start: the body never runs.
    let run = game::run_random(&net, 0, oracle::constant(true), 1000);
    assert_eq!(run.outcome, Outcome::Final);
    assert!(started(&net, &run).is_empty());
    // It holds after two iterations.
    let run = game::run_random(
        &net,
        0,
        |_, g, c: &[u32]| g.holds_when(c.last().copied().unwrap_or(0) >= 2),
        1000,
    );
    assert_eq!(started(&net, &run).len(), 2);
}

#[test]
fn repeat_for_runs_its_body_exactly_n_times() {
    for n in 0..5 {
        let net = compile(
            &["D1"],
            seq(vec![repeat_for(n, seq(vec![fly(0, 1.0)])), fly(0, 2.0)]),
        );
        for seed in 0..8 {
            let run = run_to_final(&net, seed);
            let body = count(
                &net,
                &run,
                |k| matches!(k, TransitionKind::ActionStart(a) if a.args == [1.0]),
            );
            assert_eq!(body, n as usize);
        }
    }
}

#[test]
fn nested_repeat_for_counts_with_the_token_colour() {
    let net = compile(
        &["D1"],
        seq(vec![repeat_for(
            2,
            seq(vec![repeat_for(3, seq(vec![fly(0, 1.0)]))]),
        )]),
    );
    let run = run_to_final(&net, 0);
    let colours: Vec<Vec<u32>> = run
        .firings
        .iter()
        .filter(|f| {
            matches!(
                net.transition(f.transition).unwrap().kind,
                TransitionKind::ActionStart(_)
            )
        })
        .map(|f| f.colour.clone())
        .collect();
    assert_eq!(
        colours,
        vec![
            vec![0, 0],
            vec![0, 1],
            vec![0, 2],
            vec![1, 0],
            vec![1, 1],
            vec![1, 2]
        ]
    );
    let guards: Vec<_> = net
        .transitions()
        .filter_map(|(_, t)| t.guard.as_ref().map(|g| g.kind.clone()))
        .collect();
    assert!(guards.contains(&GuardKind::IterationBelow(3)));
    assert!(guards.contains(&GuardKind::IterationAtLeast(2)));
}

#[test]
fn wait_until_holds_its_body_back_until_the_condition_holds() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![wait(Until, x_above(1, 0.0), seq(vec![fly(0, 1.0)]))]),
    );
    let run = game::run_random(&net, 0, oracle::constant(false), 500);
    assert_eq!(run.outcome, Outcome::Waiting);
    assert!(started(&net, &run).is_empty());
    let run = game::run_random(&net, 0, oracle::constant(true), 500);
    assert_eq!(run.outcome, Outcome::Final);
    assert_eq!(started(&net, &run), ["D1.FlyByX(1 m)"]);
    let wait = transition(&net, "WaitUntil D2.X() > 0");
    assert_eq!(
        net.transition(wait).unwrap().owner,
        Owner::Drone(DroneId(1))
    );
}

#[test]
fn wait_while_proceeds_once_the_condition_no_longer_holds() {
    let net = compile(
        &["D1"],
        seq(vec![wait(While, x_above(0, 0.0), seq(vec![fly(0, 1.0)]))]),
    );
    assert_eq!(
        game::run_random(&net, 0, oracle::constant(true), 500).outcome,
        Outcome::Waiting
    );
    assert_eq!(
        game::run_random(&net, 0, oracle::constant(false), 500).outcome,
        Outcome::Final
    );
}

#[test]
fn pause_while_and_pause_until_hold_their_branch_only() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![block(par(vec![
            block(seq(vec![pause(While, x_above(0, 0.0)), fly(0, 1.0)])),
            block(seq(vec![pause(Until, x_above(0, 0.0)), fly(1, 2.0)])),
        ]))]),
    );
    let run = game::run_random(&net, 0, oracle::constant(true), 500);
    assert_eq!(run.outcome, Outcome::Waiting);
    assert_eq!(started(&net, &run), ["D2.FlyByX(2 m)"]);
    let run = game::run_random(&net, 0, oracle::constant(false), 500);
    assert_eq!(run.outcome, Outcome::Waiting);
    assert_eq!(started(&net, &run), ["D1.FlyByX(1 m)"]);
}

#[test]
fn pause_for_is_a_timed_transition_carrying_its_delay() {
    let net = compile(&["D1"], seq(vec![fly(0, 1.0), pause_for(2.5), fly(0, 2.0)]));
    let pause = transition(&net, "PauseFor 2.5 s");
    let t = net.transition(pause).unwrap();
    assert_eq!(t.kind, TransitionKind::Pause);
    assert_eq!(t.delay, Some(2.5));
    assert!(t.guard.is_none());
    let run = run_to_final(&net, 0);
    assert!(pos(&net, &run, "end D1.FlyByX(1 m)") < run.position(pause).unwrap());
    assert!(run.position(pause).unwrap() < pos(&net, &run, "D1.FlyByX(2 m)"));
}

fn signal_await_mission() -> Net {
    compile(
        &["D1", "D2"],
        seq(vec![block(par(vec![
            block(seq(vec![fly(0, 1.0), signal("ready"), fly(0, 2.0)])),
            block(seq(vec![await_("ready"), fly(1, 3.0)])),
        ]))]),
    )
}

#[test]
fn an_await_never_fires_before_its_signal() {
    let net = signal_await_mission();
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        let sig = pos(&net, &run, "Signal(\"ready\")");
        assert!(pos(&net, &run, "end D1.FlyByX(1 m)") < sig);
        assert!(sig < pos(&net, &run, "Await(\"ready\")"));
        assert!(pos(&net, &run, "Await(\"ready\")") < pos(&net, &run, "D2.FlyByX(3 m)"));
    }
    assert_sliceable(&net);
}

#[test]
fn after_the_mission_only_the_event_state_stays_marked() {
    let net = signal_await_mission();
    let run = run_to_final(&net, 7);
    let kinds: Vec<PlaceKind> = run
        .marking
        .places()
        .map(|p| net.place(p).unwrap().kind.clone())
        .collect();
    assert_eq!(
        kinds,
        vec![PlaceKind::Final, PlaceKind::Event("ready".into())]
    );
}

#[test]
fn several_signals_and_awaits_of_one_event_stay_one_safe() {
    let net = compile(
        &["D1", "D2", "D3"],
        seq(vec![block(par(vec![
            block(seq(vec![fly(0, 1.0), signal("e")])),
            block(seq(vec![fly(1, 2.0), signal("e")])),
            block(seq(vec![await_("e"), fly(2, 3.0)])),
            block(seq(vec![await_("e"), fly(2, 4.0)])),
        ]))]),
    );
    let mut first = BTreeSet::new();
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        let signals: Vec<usize> = transitions(&net, "Signal(\"e\")")
            .into_iter()
            .filter_map(|t| run.position(t))
            .collect();
        let earliest = *signals.iter().min().unwrap();
        for a in transitions(&net, "Await(\"e\")") {
            assert!(run.position(a).unwrap() > earliest);
        }
        first.insert(started(&net, &run)[0].clone());
    }
    assert!(first.len() >= 2, "the signallers race: {first:?}");
}

#[test]
fn an_await_whose_signal_is_never_sent_deadlocks() {
    let net = compile(&["D1"], seq(vec![await_("never"), fly(0, 1.0)]));
    let run = game::run_random(&net, 0, oracle::random(0, 0.5), 1000);
    assert_eq!(run.outcome, Outcome::Deadlock);
    assert!(started(&net, &run).is_empty());
}

/// `DoUntil(D2.X() > 5, SEQ(D1 x1, D1 x2, D1 x3)); D1 x4`: the condition
/// lives on D2, the body on D1, so the region needs its messages.
fn remote_do() -> Net {
    compile(
        &["D1", "D2"],
        seq(vec![
            do_(
                Until,
                x_above(1, 5.0),
                seq(vec![fly(0, 1.0), fly(0, 2.0), fly(0, 3.0)]),
            ),
            fly(0, 4.0),
        ]),
    )
}

fn fire(net: &Net, m: &Marking, label: &str) -> Marking {
    game::fire(net, m, transition(net, label))
        .unwrap_or_else(|e| panic!("{label:?} cannot fire: {e}"))
}

#[test]
fn a_do_until_body_stops_at_the_interrupt_cancelling_the_running_action() {
    let net = remote_do();
    let mut m = Marking::initial(&net);
    m = fire(&net, &m, "init Test");
    m = fire(&net, &m, "start DoUntil D2.X() > 5");
    m = fire(&net, &m, "D1.FlyByX(1 m)");
    m = fire(&net, &m, "interrupt DoUntil D2.X() > 5");
    m = fire(&net, &m, "cancel Do#0 at D1");
    // The world never lets the body go on by itself from here: whatever the
    // order, the rest of the body is skipped and the mission still ends.
    for seed in 0..SEEDS {
        let run = game::run_with(
            &net,
            m.clone(),
            &mut oracle::random(seed, 0.5),
            {
                let mut rng = seed;
                move |en: &[game::Enabled]| {
                    rng = rng
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (rng >> 33) as usize % en.len()
                }
            },
            10_000,
        );
        assert_eq!(run.outcome, Outcome::Final, "{:?}", run.ids(&net));
        assert_eq!(started(&net, &run), ["D1.FlyByX(4 m)"]);
        let ids: Vec<&str> = run
            .transitions()
            .map(|t| net.transition(t).unwrap().label.as_str())
            .collect();
        assert!(ids.contains(&"skip D1.FlyByX(2 m)"));
        assert!(ids.contains(&"skip D1.FlyByX(3 m)"));
        // The running action either ended just then or was cancelled.
        assert!(ids.contains(&"cancel D1.FlyByX(1 m)") || ids.contains(&"end D1.FlyByX(1 m)"));
        assert!(ids.contains(&"end interrupted DoUntil D2.X() > 5"));
    }
    // Cancelling is always possible right after the flip.
    let cancel = transition(&net, "cancel D1.FlyByX(1 m)");
    assert!(game::enabled(&net, &m, &mut oracle::constant(false))
        .iter()
        .any(|e| e.transition == cancel));
}

#[test]
fn no_body_action_starts_at_a_drone_once_the_interrupt_has_reached_it() {
    let net = remote_do();
    let flip = transition(&net, "cancel Do#0 at D1");
    let mut interrupted = 0;
    for seed in 0..SEEDS * 4 {
        let run = run_to_final(&net, seed);
        if let Some(at) = run.position(flip) {
            interrupted += 1;
            let late = run.firings[at..].iter().any(|f| {
                matches!(&net.transition(f.transition).unwrap().kind,
                    TransitionKind::ActionStart(a) if a.args != [4.0])
            });
            assert!(
                !late,
                "a body action started after the interrupt: {:?}",
                run.ids(&net)
            );
        }
        assert_eq!(started(&net, &run).last().unwrap(), "D1.FlyByX(4 m)");
    }
    assert!(interrupted > 0 && interrupted < SEEDS * 4);
}

#[test]
fn a_do_while_whose_condition_keeps_holding_runs_its_body_to_the_end() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![do_(
            While,
            x_above(1, 5.0),
            seq(vec![fly(0, 1.0), fly(0, 2.0)]),
        )]),
    );
    let run = game::run_random(&net, 0, oracle::constant(true), 1000);
    assert_eq!(run.outcome, Outcome::Final);
    assert_eq!(started(&net, &run), ["D1.FlyByX(1 m)", "D1.FlyByX(2 m)"]);
    assert!(run
        .position(transition(&net, "end DoWhile D2.X() > 5"))
        .is_some());
    // And one whose condition never held skips everything (D1 may still
    // start an action before the kill message arrives, and cancels it).
    let run = game::run_random(&net, 0, oracle::constant(false), 1000);
    assert_eq!(run.outcome, Outcome::Final);
    assert!(run
        .position(transition(&net, "end interrupted DoWhile D2.X() > 5"))
        .is_some());
}

#[test]
fn a_remote_region_reads_live_and_cancelled_state_only_where_it_lives() {
    let net = remote_do();
    assert_sliceable(&net);
    let d1 = Owner::Drone(DroneId(0));
    let d2 = Owner::Drone(DroneId(1));
    let interrupt = transition(&net, "interrupt DoUntil D2.X() > 5");
    let t = net.transition(interrupt).unwrap();
    assert_eq!((t.owner, t.kind.clone()), (d2, TransitionKind::Interrupt));
    assert!(t
        .guard
        .as_ref()
        .unwrap()
        .condition()
        .is_some_and(|(_, neg)| !neg));
    for (p, place) in net.places() {
        if let PlaceKind::Region { interrupted, .. } = place.kind {
            let readers: BTreeSet<Owner> = net.consumers(p).map(|(t, _)| net.owner(t)).collect();
            assert_eq!(readers.len(), 1, "{}", place.label);
            let _ = interrupted;
        }
    }
    let start = transition(&net, "D1.FlyByX(2 m)");
    let reads: Vec<_> = net.read_set(start).collect();
    assert_eq!(reads.len(), 1);
    assert_eq!(net.place(reads[0]).unwrap().owner, d1);
}

#[test]
fn a_region_guarding_its_own_drone_needs_no_messages() {
    let net = compile(
        &["D1"],
        seq(vec![
            do_(Until, x_above(0, 5.0), seq(vec![fly(0, 1.0), fly(0, 2.0)])),
            fly(0, 3.0),
        ]),
    );
    assert!(net
        .transitions()
        .all(|(_, t)| !t.label.starts_with("cancel Do#")));
    assert!(net
        .transitions()
        .all(|(_, t)| !t.label.starts_with("exit ")));
    let regions = net
        .places()
        .filter(|(_, p)| matches!(p.kind, PlaceKind::Region { .. }))
        .count();
    assert_eq!(regions, 2, "watch and interrupted only");
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        let interrupt = run.position(transition(&net, "interrupt DoUntil D1.X() > 5"));
        if let Some(at) = interrupt {
            let late = run.firings[at..].iter().any(|f| {
                matches!(&net.transition(f.transition).unwrap().kind,
                    TransitionKind::ActionStart(a) if a.args != [3.0])
            });
            assert!(!late);
        }
    }
    assert_sliceable(&net);
}

#[test]
fn an_interrupted_region_leaves_its_loops_and_skips_their_exit_blocks() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![
            do_(
                Until,
                x_above(1, 5.0),
                seq(vec![repeat(
                    While,
                    x_above(0, 0.0),
                    seq(vec![fly(0, 1.0)]),
                    Some(seq(vec![fly(0, 9.0)])),
                )]),
            ),
            fly(0, 4.0),
        ]),
    );
    // The loop would run for ever; only the interrupt ends it.
    let mut world = |t: &eamos_petri::Transition, g: &eamos_petri::Guard, _: &[u32]| {
        if t.kind == TransitionKind::Interrupt {
            true
        } else {
            g.holds_when(true)
        }
    };
    for seed in 0..SEEDS {
        let run = game::run_random(&net, seed, &mut world, 10_000);
        assert_eq!(run.outcome, Outcome::Final, "{:?}", run.ids(&net));
        let s = started(&net, &run);
        assert!(!s.contains(&"D1.FlyByX(9 m)".to_string()), "{s:?}");
        assert_eq!(s.last().unwrap(), "D1.FlyByX(4 m)");
    }
    assert_sliceable(&net);
}

#[test]
fn nested_regions_skip_their_steps_when_either_is_interrupted() {
    let net = compile(
        &["D1", "D2", "D3"],
        seq(vec![
            do_(
                Until,
                x_above(1, 5.0),
                seq(vec![
                    fly(0, 1.0),
                    do_(
                        While,
                        x_above(2, 0.0),
                        seq(vec![fly(0, 2.0), pause_for(1.0), fly(0, 3.0)]),
                    ),
                    fly(0, 4.0),
                ]),
            ),
            fly(0, 5.0),
        ]),
    );
    assert_sliceable(&net);
    assert_consumers_agree(&net);
    let inner_start = transition(&net, "D1.FlyByX(2 m)");
    assert_eq!(
        net.read_set(inner_start).count(),
        2,
        "live state of both regions"
    );
    assert_eq!(transitions(&net, "skip D1.FlyByX(2 m)").len(), 2);
    assert_eq!(transitions(&net, "cancel D1.FlyByX(2 m)").len(), 2);
    let mut endings = BTreeSet::new();
    for seed in 0..SEEDS * 2 {
        let run = run_to_final(&net, seed);
        assert_eq!(started(&net, &run).last().unwrap(), "D1.FlyByX(5 m)");
        endings.insert(started(&net, &run).len());
    }
    assert!(
        endings.len() > 2,
        "interrupts at different moments: {endings:?}"
    );
}

#[test]
fn a_region_inside_a_loop_starts_clean_every_iteration() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![repeat_for(
            3,
            seq(vec![do_(
                Until,
                x_above(1, 5.0),
                seq(vec![fly(0, 1.0), signal_free_pause()]),
            )]),
        )]),
    );
    for seed in 0..SEEDS {
        let run = run_to_final(&net, seed);
        let dos = count(&net, &run, |k| *k == TransitionKind::Fork);
        assert_eq!(dos, 3);
    }
}

fn signal_free_pause() -> eamos_lang::hir::Stmt {
    pause_for(0.5)
}

#[test]
fn steps_without_a_drone_inside_a_region_take_the_owner_of_its_condition() {
    let net = compile(
        &["D1", "D2"],
        seq(vec![block(par(vec![
            do_(
                Until,
                x_above(1, 5.0),
                seq(vec![pause_for(1.0), signal("s"), await_("t")]),
            ),
            block(seq(vec![await_("s"), signal("t")])),
        ]))]),
    );
    let d2 = Owner::Drone(DroneId(1));
    for label in ["PauseFor 1 s", "skip PauseFor 1 s"] {
        assert_eq!(net.transition(transition(&net, label)).unwrap().owner, d2);
    }
    let outside = net
        .transitions()
        .filter(|(_, t)| t.label == "Await(\"s\")")
        .map(|(_, t)| t.owner)
        .collect::<Vec<_>>();
    assert_eq!(outside, vec![Owner::Unassigned]);
    assert_sliceable(&net);
    for seed in 0..SEEDS {
        let run = game::run_random(&net, seed, oracle::random(seed, 0.3), 10_000);
        // If the interrupt skips the signal, the other branch waits for ever.
        assert!(
            matches!(run.outcome, Outcome::Final | Outcome::Deadlock),
            "{:?}",
            run.outcome
        );
    }
}
