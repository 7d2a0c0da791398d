//! Missions compiled by the real front end and net compiler: each file
//! under `tests/missions/` is made to contain one finding (or none), and the
//! paper's missions are checked for what is really in them. Every
//! counterexample is replayed in the reference token game, its guards
//! answered as the counterexample says, and must reach the marking reported.

mod common;

use std::path::PathBuf;

use eamos_lang::SourceFile;
use eamos_petri::game::{self, Marking};
use eamos_petri::net::Net;
use eamos_verify::{check_net, Finding, FindingKind, Options, Property, Report, Verdict};

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn compile(path: PathBuf) -> (Net, SourceFile) {
    common::compile_file(&path)
}

fn check_file(path: PathBuf) -> (Report, Net, SourceFile) {
    let (net, file) = compile(path);
    let profiles = eamos_profile::builtin();
    let report = check_net(&net, &profiles, Some(&file.text), &Options::default());
    replay_all(&net, &report);
    // The reduction never changes an answer.
    let full = check_net(
        &net,
        &profiles,
        Some(&file.text),
        &Options {
            reduction: false,
            ..Options::default()
        },
    );
    let verdicts = |r: &Report| {
        r.properties
            .iter()
            .map(|p| (p.property, p.verdict.clone()))
            .collect::<Vec<_>>()
    };
    assert_eq!(verdicts(&report), verdicts(&full));
    (report, net, file)
}

fn mission(name: &str) -> (Report, Net, SourceFile) {
    check_file(dir().join("tests/missions").join(name))
}

fn paper(name: &str) -> (Report, Net, SourceFile) {
    check_file(dir().join("../../shared/missions/paper").join(name))
}

/// Replays a counterexample in the token game: each step must be enabled
/// (tokens and colour guards; condition guards are answered by the step
/// chosen), and the end marking must be the one reported.
fn replay(net: &Net, f: &Finding) {
    let Some(trace) = &f.trace else { return };
    let mut m = Marking::initial(net);
    let mut at_cycle = None;
    for (i, s) in trace.steps.iter().enumerate() {
        if trace.cycle_from == Some(i) {
            at_cycle = Some(m.clone());
        }
        let t = net.find(&s.transition).expect("a transition of the net");
        if let (Some(held), Some(g)) = (
            s.condition_held,
            net.transition(t).and_then(|t| t.guard.as_ref()),
        ) {
            // The step says which way the world answered; the guard agrees.
            assert!(
                g.holds_when(held),
                "step {i} ({}) answers its guard",
                s.text
            );
        }
        m = game::fire(net, &m, t)
            .unwrap_or_else(|e| panic!("`{}`, step {i} ({}): {e}", f.message, s.text));
    }
    let ids = |m: &Marking| {
        let mut v: Vec<String> = m.places().map(|p| net.id(p).to_string()).collect();
        v.sort();
        v
    };
    let got = ids(&m);
    match at_cycle {
        // Colours (loop counters) go up round the cycle; places come back.
        Some(start) => assert_eq!(ids(&start), got, "the cycle of `{}` closes", f.message),
        None => {
            let mut want: Vec<String> = trace.marking.iter().map(|(p, _)| p.clone()).collect();
            want.sort();
            assert_eq!(got, want, "`{}` reaches the marking it reports", f.message);
            if f.kind == FindingKind::Deadlock {
                assert_dead_and_not_final(net, &m, &f.message);
            }
        }
    }
}

/// A deadlock's marking is not the mission's end, and nothing can fire in
/// it even if every condition guard held (the checker lets a condition go
/// either way, so a transition waiting only on one is not dead).
fn assert_dead_and_not_final(net: &Net, m: &Marking, message: &str) {
    assert!(
        !m.is_marked(net.final_place),
        "`{message}` ends in the final marking, which is no deadlock"
    );
    let enabled = game::enabled(net, m, &mut |_, _, _| true);
    assert!(
        enabled.is_empty(),
        "`{message}` ends in a live marking: {:?} can fire",
        enabled
            .iter()
            .map(|e| net.id(e.transition).to_string())
            .collect::<Vec<_>>()
    );
}

/// Nothing found, and every property decided: an exploration that stopped
/// at its limit finds nothing too, and is no proof.
fn assert_proved_clean(r: &Report, what: &str) {
    assert!(!r.found_something(), "{what}: {:#?}", r.findings);
    let undecided: Vec<_> = r.undecided().map(|p| p.name()).collect();
    assert!(undecided.is_empty(), "{what}: undecided {undecided:?}");
}

fn replay_all(net: &Net, r: &Report) {
    for f in &r.findings {
        replay(net, f);
    }
}

fn line_of(file: &SourceFile, f: &Finding) -> u32 {
    file.line_col(f.labels[0].span.start).line
}

#[test]
fn a_signal_in_a_branch_not_taken_leaves_its_await_stuck() {
    let (r, _, file) = mission("lost_signal.go");
    let d: Vec<_> = r.findings_of(FindingKind::Deadlock).collect();
    assert_eq!(d.len(), 1);
    assert_eq!(line_of(&file, d[0]), 22, "{:#?}", d[0].labels);
    let steps = &d[0].trace.as_ref().unwrap().steps;
    assert!(steps.iter().any(|s| s.condition_held == Some(false)
        && s.text.starts_with("If")
        && s.text.contains("D1.Battery() > 50")));
}

#[test]
fn two_drones_awaiting_each_other_are_stuck_from_the_start() {
    let (r, _, file) = mission("crossed_awaits.go");
    let d = r
        .findings_of(FindingKind::Deadlock)
        .next()
        .expect("deadlock");
    let lines: Vec<u32> = d
        .labels
        .iter()
        .map(|l| file.line_col(l.span.start).line)
        .collect();
    assert!(lines.contains(&13) && lines.contains(&19), "{lines:?}");
    assert_eq!(r.findings_of(FindingKind::DeadAction).count(), 2);
}

#[test]
fn two_moves_of_one_drone_at_once_are_a_conflict() {
    let (r, _, file) = mission("parallel_moves.go");
    let c: Vec<_> = r.findings_of(FindingKind::DroneConflict).collect();
    assert_eq!(c.len(), 1, "{c:#?}");
    let lines: Vec<u32> = c[0]
        .labels
        .iter()
        .map(|l| file.line_col(l.span.start).line)
        .collect();
    assert_eq!(lines, vec![7, 8]);
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
}

#[test]
fn a_condition_that_cannot_hold_is_named_and_its_branch_is_dead() {
    let (r, _, file) = mission("low_battery.go");
    let c = r
        .findings_of(FindingKind::ConditionNeverHolds)
        .next()
        .expect("condition");
    assert_eq!(line_of(&file, c), 8);
    let d: Vec<_> = r.findings_of(FindingKind::DeadAction).collect();
    assert_eq!(d.len(), 1);
    assert_eq!(line_of(&file, d[0]), 13);
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Holds));
}

#[test]
fn a_loop_whose_condition_always_holds_never_ends() {
    let (r, _, file) = mission("endless_patrol.go");
    assert!(r
        .findings_of(FindingKind::ConditionAlwaysHolds)
        .next()
        .is_some());
    let n = r
        .findings_of(FindingKind::NonTermination)
        .next()
        .expect("non-termination");
    assert!(n.trace.as_ref().unwrap().cycle_from.is_some());
    assert_eq!(line_of(&file, n), 8);
    // Land is never reached.
    let d: Vec<_> = r.findings_of(FindingKind::DeadAction).collect();
    assert_eq!(d.len(), 1);
    assert_eq!(line_of(&file, d[0]), 9);
}

#[test]
fn counted_loops_end_by_themselves_and_nothing_is_found() {
    let (r, _, _) = mission("counted_square.go");
    assert_proved_clean(&r, "counted_square.go");
    let term = r
        .properties
        .iter()
        .find(|p| p.property == Property::Termination)
        .unwrap();
    assert_eq!(term.verdict, Verdict::Holds);
    // A RepeatFor loop is not one that may repeat for ever.
    assert!(term.notes.is_empty(), "{:?}", term.notes);
}

/// The note a check leaves when it explored loops without their counters.
fn folded_note(r: &Report) -> Option<&String> {
    r.properties
        .iter()
        .flat_map(|p| &p.notes)
        .find(|n| n.contains("without counting their rounds"))
}

#[test]
fn loops_that_only_their_own_body_can_count_are_proved_without_counting_rounds() {
    let (r, net, file) = mission("folded_rounds.go");
    assert_proved_clean(&r, "folded_rounds.go");
    // D1's photos and D2's square; not D3's loop, which reads an event.
    assert!(
        folded_note(&r).is_some_and(|n| n.starts_with("2 `RepeatFor` loop(s)")),
        "{:?}",
        folded_note(&r)
    );
    let counted = check_net(
        &net,
        &eamos_profile::builtin(),
        Some(&file.text),
        &Options {
            structural: false,
            ..Options::default()
        },
    );
    assert_proved_clean(&counted, "folded_rounds.go, counted");
    assert_eq!(folded_note(&counted), None);
    assert!(
        r.stats.states < counted.stats.states,
        "{} states folded, {} counted",
        r.stats.states,
        counted.stats.states
    );
}

#[test]
fn a_finding_beside_a_folded_loop_is_a_run_with_its_rounds_counted() {
    // check_file replays every counterexample in the token game, whose
    // colour guards count the rounds.
    let (r, _, _) = mission("folded_rounds_stuck.go");
    assert_eq!(
        r.findings_of(FindingKind::Deadlock).count(),
        1,
        "{:#?}",
        r.findings
    );
    assert_eq!(folded_note(&r), None);
}

#[test]
fn identical_drones_running_identical_blocks_cost_markings_in_proportion_to_the_fleet() {
    // Eight drones, each choosing a leg and flying three laps, side by
    // side: all their interleavings are more than 10^11 markings. Their
    // steps commute, and the stubborn sets take one drone after another,
    // so the proof needs no symmetry reduction to stay small.
    // (Not `mission`, which explores every interleaving too.)
    let (net, file) = compile(dir().join("tests/missions/identical_drones.go"));
    let profiles = eamos_profile::builtin();
    // A small memory bound: should the reduction ever fail here, the
    // check stops undecided at once instead of exploring for minutes.
    let options = Options {
        max_memory_mb: 64,
        ..Options::default()
    };
    let r = check_net(&net, &profiles, Some(&file.text), &options);
    assert_proved_clean(&r, "identical_drones.go");
    assert!(
        r.stats.states < 30 * 8,
        "{} markings for 8 drones",
        r.stats.states
    );
}

#[test]
fn a_handshake_of_signals_and_awaits_is_proved_correct() {
    let (r, _, _) = mission("handshake.go");
    assert_proved_clean(&r, "handshake.go");
    for p in Property::ALL {
        assert_eq!(r.verdict(p), Some(&Verdict::Holds), "{}", p.name());
    }
}

#[test]
fn the_paper_missions_a_b_c_and_listing_1_are_clean() {
    for m in [
        "experiment_a.go",
        "experiment_b.go",
        "experiment_c.go",
        "listing01_demo.go",
    ] {
        let (r, _, _) = paper(m);
        assert_proved_clean(&r, m);
    }
}

/// Experiment D: four loops in parallel, two steering D1 and two D2, each
/// exiting through its own copy of `PAR_Exit` (`D3.Land()`).
#[test]
fn experiment_d_moves_drones_both_ways_at_once_and_lands_d3_four_times() {
    let (r, _, file) = paper("experiment_d.go");
    let conflicts: Vec<(u32, u32, String)> = r
        .findings_of(FindingKind::DroneConflict)
        .map(|f| {
            let l: Vec<u32> = f
                .labels
                .iter()
                .map(|l| file.line_col(l.span.start).line)
                .collect();
            (l[0], *l.last().unwrap(), f.message.clone())
        })
        .collect();
    // D1 forward and backward (lines 84 and 88), D2 likewise (92, 96), and
    // D3 landing in several exits at once (line 100).
    assert!(
        conflicts.iter().any(|c| (c.0, c.1) == (84, 88)),
        "{conflicts:#?}"
    );
    assert!(
        conflicts.iter().any(|c| (c.0, c.1) == (92, 96)),
        "{conflicts:#?}"
    );
    assert!(
        conflicts.iter().any(|c| (c.0, c.1) == (100, 100)),
        "{conflicts:#?}"
    );
    // Moves of one drone in the same direction, from two loops, cannot
    // meet: each loop runs one body at a time.
    assert_eq!(conflicts.len(), 3, "{conflicts:#?}");
    // No deadlock, and the end stays reachable, but only if the conditions
    // change: the note says the loops may repeat for ever.
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    let term = r
        .properties
        .iter()
        .find(|p| p.property == Property::Termination)
        .unwrap();
    assert_eq!(term.verdict, Verdict::Holds);
    assert!(
        term.notes.iter().any(|n| n.contains("4 loop")),
        "{:?}",
        term.notes
    );
    assert_eq!(r.findings_of(FindingKind::DeadAction).count(), 0);
}

#[test]
fn a_mission_exported_to_pnml_gets_the_same_deadlock_termination_and_safety_verdicts() {
    use eamos_petri::export::pnml::{to_pnml, PnmlOptions};
    for name in [
        "lost_signal.go",
        "crossed_awaits.go",
        "endless_patrol.go",
        "counted_square.go",
        "handshake.go",
    ] {
        let (net, file) = compile(dir().join("tests/missions").join(name));
        let profiles = eamos_profile::builtin();
        let direct = check_net(&net, &profiles, Some(&file.text), &Options::default());
        for final_loop in [false, true] {
            let text = to_pnml(
                &net,
                &PnmlOptions {
                    final_loop,
                    locate: None,
                },
            );
            let pnml = eamos_verify::pnml::parse("exported.pnml", &text)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let via_pnml = eamos_verify::check_pnml(&pnml, &Options::default());
            for p in [Property::Deadlock, Property::Safety] {
                assert_eq!(
                    via_pnml.verdict(p),
                    direct.verdict(p),
                    "{name}: {}",
                    p.name()
                );
            }
            // Guards are lost in the P/T export: a counted loop may then go
            // round for ever, and a loop whose condition always holds may
            // leave; other missions agree on termination.
            if !["counted_square.go", "endless_patrol.go"].contains(&name) {
                assert_eq!(
                    via_pnml.verdict(Property::Termination),
                    direct.verdict(Property::Termination),
                    "{name}"
                );
            }
        }
    }
}
