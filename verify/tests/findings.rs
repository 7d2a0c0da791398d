//! Each finding of `eamos check`, on a hand-built mission net made to
//! contain it, with its counterexample replayed on the net.

mod common;

use common::{claimed, is_dead, replay, Builder};
use eamos_lang::hir::BinaryOp;
use eamos_lang::span::SourceFile;
use eamos_petri::net::TransitionKind;
use eamos_verify::{check_net, FindingKind, Options, Property, Report, Verdict};

fn check(b: &Builder) -> Report {
    let profiles = eamos_profile::builtin();
    check_net(&b.net, &profiles, Some(&b.src), &Options::default())
}

fn check_without_reduction(b: &Builder) -> Report {
    let profiles = eamos_profile::builtin();
    let opts = Options {
        reduction: false,
        ..Options::default()
    };
    check_net(&b.net, &profiles, Some(&b.src), &opts)
}

/// Every counterexample of the report replays on the net to the marking it
/// claims.
fn assert_traces_replay(b: &Builder, r: &Report) {
    for f in &r.findings {
        if let Some(t) = &f.trace {
            match t.cycle_from {
                None => {
                    let reached = replay(&b.net, &t.steps);
                    assert_eq!(reached, claimed(t), "finding: {}", f.message);
                    if f.kind == FindingKind::Deadlock {
                        let final_id = b.net.id(b.net.final_place);
                        assert!(
                            reached.iter().all(|(p, _)| p != final_id),
                            "deadlock `{}` ends in the final marking",
                            f.message
                        );
                        assert!(
                            is_dead(&b.net, &reached),
                            "deadlock `{}` ends in a live marking",
                            f.message
                        );
                    }
                }
                Some(c) => {
                    // A lasso: the steps replay, and the cycle comes back to
                    // where it started.
                    let at_entry = replay(&b.net, &t.steps[..c]);
                    let round = replay(&b.net, &t.steps);
                    assert_eq!(at_entry, round, "the cycle of `{}` closes", f.message);
                }
            }
        }
    }
}

const SQUARE: &str = r#"package Square
var D1 Quadcopter
func SEQ_Square() {
	D1.Arm()
	D1.Takeoff(1.5)
	D1.FlyByX(1)
	D1.Land()
}
"#;

#[test]
fn a_sequential_mission_has_no_finding_and_every_property_holds() {
    let mut b = Builder::new("Square", &["D1"], SQUARE);
    let p = b.init();
    let p = b.action(p, 0, "Arm", &[], "D1.Arm()", 0);
    let p = b.action(p, 0, "Takeoff", &[1.5], "D1.Takeoff(1.5)", 0);
    let p = b.action(p, 0, "FlyByX", &[1.0], "D1.FlyByX(1)", 0);
    let p = b.action(p, 0, "Land", &[], "D1.Land()", 0);
    b.finish(p);
    let r = check(&b);
    assert!(r.findings.is_empty(), "{:#?}", r.findings);
    for p in Property::ALL {
        assert_eq!(r.verdict(p), Some(&Verdict::Holds), "{}", p.name());
    }
    assert!(r.stats.complete);
}

const SIGNAL_IN_BRANCH: &str = r#"package Lost
var D1 Quadcopter
var D2 Quadcopter
func PAR_Main() {
	SEQ_A()
	SEQ_B()
}
func SEQ_A() {
	If(D1.Battery() > 50, SEQ_Go)
	D1.Land()
}
func SEQ_Go() {
	Signal("go")
}
func SEQ_B() {
	Await("go")
	D2.Takeoff(1)
}
"#;

/// The Await of D2 waits for a Signal that only happens when D1's battery is
/// above half: with the battery low, D2 waits forever.
fn signal_in_branch() -> Builder {
    let mut b = Builder::new("Lost", &["D1", "D2"], SIGNAL_IN_BRANCH);
    let ev = b.event("go");
    let p = b.init();
    let par = b.span("SEQ_A()\n\tSEQ_B()", 0);
    let br = b.fork(p, 2, par);
    let cond = b.cond(0, "Battery", BinaryOp::Gt, 50.0, "D1.Battery() > 50");
    let (then, other) = b.branch(br[0], cond, "If(D1.Battery() > 50, SEQ_Go)");
    let signalled = b.signal(then, ev, "Signal(\"go\")", 0);
    let merged = b.merge(&[signalled, other], b.span("If(", 0));
    let a_end = b.action(merged, 0, "Land", &[], "D1.Land()", 0);
    let waited = b.await_(br[1], ev, "Await(\"go\")", 0);
    let b_end = b.action(waited, 1, "Takeoff", &[1.0], "D2.Takeoff(1)", 0);
    let end = b.join(&[a_end, b_end], par);
    b.finish(end);
    b
}

#[test]
fn an_await_whose_signal_sits_in_a_branch_not_taken_is_a_deadlock() {
    let b = signal_in_branch();
    let r = check(&b);
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Violated));
    let d = r
        .findings_of(FindingKind::Deadlock)
        .next()
        .expect("a deadlock");
    // It points at the Await.
    assert_eq!(d.labels[0].span, b.span("Await(\"go\")", 0));
    assert!(d.labels[0].text.contains("\"go\""), "{}", d.labels[0].text);
    // The run took the else branch of the If.
    let trace = d.trace.as_ref().unwrap();
    let choice = trace
        .steps
        .iter()
        .find(|s| s.condition_held.is_some())
        .expect("a guard choice");
    assert_eq!(choice.condition_held, Some(false));
    assert!(
        choice.text.contains("`D1.Battery() > 50` does not hold"),
        "{}",
        choice.text
    );
    assert!(choice.text.starts_with("If"), "{}", choice.text);
    assert_traces_replay(&b, &r);
    // The end is not reachable from the deadlock: termination fails too, and
    // its note says the deadlock is why.
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Violated));
    assert_eq!(r.findings_of(FindingKind::NonTermination).count(), 0);
}

#[test]
fn the_deadlock_counterexample_is_as_short_as_with_full_exploration() {
    let b = signal_in_branch();
    let reduced = check(&b);
    let full = check_without_reduction(&b);
    let len = |r: &Report| {
        r.findings_of(FindingKind::Deadlock)
            .next()
            .unwrap()
            .trace
            .as_ref()
            .unwrap()
            .steps
            .len()
    };
    assert_eq!(len(&reduced), len(&full));
    assert!(reduced.stats.states <= full.stats.states);
}

const CROSSED: &str = r#"package Crossed
var D1 Quadcopter
var D2 Quadcopter
func PAR_Main() {
	SEQ_One()
	SEQ_Two()
}
func SEQ_One() {
	Await("b")
	D1.Arm()
	Signal("a")
}
func SEQ_Two() {
	Await("a")
	D2.Arm()
	Signal("b")
}
"#;

#[test]
fn two_drones_awaiting_each_other_are_a_deadlock_naming_both_awaits() {
    let mut b = Builder::new("Crossed", &["D1", "D2"], CROSSED);
    let ea = b.event("a");
    let eb = b.event("b");
    let p = b.init();
    let par = b.span("SEQ_One()\n\tSEQ_Two()", 0);
    let br = b.fork(p, 2, par);
    let x = b.await_(br[0], eb, "Await(\"b\")", 0);
    let x = b.action(x, 0, "Arm", &[], "D1.Arm()", 0);
    let x = b.signal(x, ea, "Signal(\"a\")", 0);
    let y = b.await_(br[1], ea, "Await(\"a\")", 0);
    let y = b.action(y, 1, "Arm", &[], "D2.Arm()", 0);
    let y = b.signal(y, eb, "Signal(\"b\")", 0);
    let end = b.join(&[x, y], par);
    b.finish(end);
    let r = check(&b);
    let d = r
        .findings_of(FindingKind::Deadlock)
        .next()
        .expect("a deadlock");
    let spans: Vec<_> = d.labels.iter().map(|l| l.span).collect();
    assert!(spans.contains(&b.span("Await(\"a\")", 0)));
    assert!(spans.contains(&b.span("Await(\"b\")", 0)));
    // Init and the fork: the shortest way there.
    assert_eq!(d.trace.as_ref().unwrap().steps.len(), 2);
    // Both arms are dead code.
    assert_eq!(r.findings_of(FindingKind::DeadAction).count(), 2);
    assert_traces_replay(&b, &r);
}

const FOREVER: &str = r#"package Forever
var D1 Quadcopter
func SEQ_Main() {
	D1.Takeoff(1)
	RepeatWhile(D1.Battery() > 20, SEQ_Patrol)
	D1.Land()
}
func SEQ_Patrol() {
	D1.FlyByX(1)
}
"#;

#[test]
fn a_loop_that_can_never_be_left_is_non_termination_with_a_lasso() {
    let mut b = Builder::new("Forever", &["D1"], FOREVER);
    let p = b.init();
    let p = b.action(p, 0, "Takeoff", &[1.0], "D1.Takeoff(1)", 0);
    // The loop head has no exit at all (as if the exit branch were lost).
    let head = p;
    let body_end = b.action(head, 0, "FlyByX", &[1.0], "D1.FlyByX(1)", 0);
    let rep = b.span("RepeatWhile", 0);
    b.trans(TransitionKind::LoopBack, rep, &[body_end], &[head]);
    let unreachable = b.place("after loop");
    let l = b.action(unreachable, 0, "Land", &[], "D1.Land()", 0);
    b.finish(l);
    let r = check(&b);
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Violated));
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    let f = r
        .findings_of(FindingKind::NonTermination)
        .next()
        .expect("non-termination");
    let t = f.trace.as_ref().unwrap();
    assert!(t.cycle_from.is_some());
    assert!(t.steps[t.cycle_from.unwrap()..]
        .iter()
        .any(|s| s.kind == "LoopBack"));
    assert_eq!(f.labels[0].span, rep);
    assert_traces_replay(&b, &r);
    // Land never starts.
    let dead: Vec<_> = r.findings_of(FindingKind::DeadAction).collect();
    assert_eq!(dead.len(), 1);
    assert_eq!(dead[0].labels[0].span, b.span("D1.Land()", 0));
}

#[test]
fn a_loop_with_an_exit_terminates_with_a_note_that_it_may_repeat() {
    let mut b = Builder::new("Forever", &["D1"], FOREVER);
    let p = b.init();
    let p = b.action(p, 0, "Takeoff", &[1.0], "D1.Takeoff(1)", 0);
    let cond = b.cond(0, "Battery", BinaryOp::Gt, 20.0, "D1.Battery() > 20");
    let (body, exit) = b.branch(p, cond, "RepeatWhile(D1.Battery() > 20, SEQ_Patrol)");
    let body_end = b.action(body, 0, "FlyByX", &[1.0], "D1.FlyByX(1)", 0);
    let rep = b.span("RepeatWhile", 0);
    b.trans(TransitionKind::LoopBack, rep, &[body_end], &[p]);
    let l = b.action(exit, 0, "Land", &[], "D1.Land()", 0);
    b.finish(l);
    let r = check(&b);
    // Nothing wrong with its logic. In space, each round takes D1 a metre
    // further for as long as the battery lasts, and it takes off (and
    // flies) without having armed.
    assert!(
        r.findings
            .iter()
            .all(|f| matches!(f.kind, FindingKind::Drift | FindingKind::FlightState)),
        "{:#?}",
        r.findings
    );
    assert_eq!(r.findings_of(FindingKind::Drift).count(), 1);
    let term = r
        .properties
        .iter()
        .find(|p| p.property == Property::Termination)
        .unwrap();
    assert_eq!(term.verdict, Verdict::Holds);
    assert!(
        term.notes.iter().any(|n| n.contains("loop")),
        "{:?}",
        term.notes
    );
}

const TWICE: &str = r#"package Twice
var D1 Quadcopter
func PAR_Main() {
	D1.Arm()
	D1.TakePhoto()
}
"#;

#[test]
fn a_place_that_can_get_two_tokens_is_reported_as_a_compiler_bug() {
    let mut b = Builder::new("Twice", &["D1"], TWICE);
    let p = b.init();
    let par = b.span("D1.Arm()\n\tD1.TakePhoto()", 0);
    let br = b.fork(p, 2, par);
    // Both branches end in the same place: a broken join.
    let x = b.action(br[0], 0, "Arm", &[], "D1.Arm()", 0);
    let y = b.action(br[1], 0, "TakePhoto", &[], "D1.TakePhoto()", 0);
    let shared = b.place("shared");
    b.trans(TransitionKind::Silent, par, &[x], &[shared]);
    b.trans(TransitionKind::Silent, par, &[y], &[shared]);
    b.finish(shared);
    let r = check(&b);
    assert_eq!(r.verdict(Property::Safety), Some(&Verdict::Violated));
    let f = r.findings_of(FindingKind::Unsafe).next().expect("unsafe");
    assert!(f.message.contains("compiler"), "{}", f.message);
    assert!(f.notes.iter().any(|n| n.contains("report")));
    let t = f.trace.as_ref().unwrap();
    assert!(t.marking.iter().any(|(_, n)| *n == 2));
    assert_traces_replay(&b, &r);
}

const LOW: &str = r#"package Low
var D1 Quadcopter
func SEQ_Main() {
	If(D1.Battery() > 120, SEQ_Photo)
	D1.Land()
}
func SEQ_Photo() {
	D1.TakePhoto()
}
"#;

#[test]
fn an_action_behind_a_condition_that_never_holds_is_dead_and_the_condition_is_named() {
    let mut b = Builder::new("Low", &["D1"], LOW);
    let p = b.init();
    let cond = b.cond(0, "Battery", BinaryOp::Gt, 120.0, "D1.Battery() > 120");
    let (then, other) = b.branch(p, cond, "If(D1.Battery() > 120, SEQ_Photo)");
    let x = b.action(then, 0, "TakePhoto", &[], "D1.TakePhoto()", 0);
    let m = b.merge(&[x, other], b.span("If(", 0));
    let l = b.action(m, 0, "Land", &[], "D1.Land()", 0);
    b.finish(l);
    let r = check(&b);
    let c = r
        .findings_of(FindingKind::ConditionNeverHolds)
        .next()
        .expect("condition finding");
    assert_eq!(c.labels[0].span, b.span("D1.Battery() > 120", 0));
    assert!(c.notes[0].contains("between 0 and 100"), "{:?}", c.notes);
    let d: Vec<_> = r.findings_of(FindingKind::DeadAction).collect();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].labels[0].span, b.span("D1.TakePhoto()", 0));
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Conditions), Some(&Verdict::Violated));
}

const ALWAYS: &str = r#"package Always
var D1 Quadcopter
func SEQ_Main() {
	If(D1.Battery() >= 0 || D1.X() < 3, SEQ_Photo, SEQ_Land)
}
func SEQ_Photo() {
	D1.TakePhoto()
}
func SEQ_Land() {
	D1.Land()
}
"#;

#[test]
fn a_condition_that_always_holds_makes_its_else_branch_dead() {
    use eamos_lang::hir::{DroneId, Expr};
    let mut b = Builder::new("Always", &["D1"], ALWAYS);
    let p = b.init();
    let whole = b.span("D1.Battery() >= 0 || D1.X() < 3", 0);
    let left = b.cond(0, "Battery", BinaryOp::Ge, 0.0, "D1.Battery() >= 0");
    let right = b.cond(0, "X", BinaryOp::Lt, 3.0, "D1.X() < 3");
    let cond = Expr::Binary {
        op: BinaryOp::Or,
        lhs: Box::new(left),
        rhs: Box::new(right),
        span: whole,
    };
    let _ = DroneId(0);
    let (then, other) = b.branch(p, cond, "If(D1.Battery() >= 0");
    let x = b.action(then, 0, "TakePhoto", &[], "D1.TakePhoto()", 0);
    let y = b.action(other, 0, "Land", &[], "D1.Land()", 0);
    let m = b.merge(&[x, y], b.span("If(", 0));
    b.finish(m);
    let r = check(&b);
    let c = r
        .findings_of(FindingKind::ConditionAlwaysHolds)
        .next()
        .expect("always holds");
    assert_eq!(c.labels[0].span, whole);
    let d: Vec<_> = r.findings_of(FindingKind::DeadAction).collect();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].labels[0].span, b.span("D1.Land()", 0));
}

const PARALLEL_MOVES: &str = r#"package Pull
var D1 Quadcopter
func PAR_Main() {
	D1.FlyByX(1)
	D1.FlyByX(-1)
	D1.TakePhoto()
}
"#;

#[test]
fn two_moves_of_one_drone_in_parallel_are_a_conflict_but_a_photo_is_not() {
    let mut b = Builder::new("Pull", &["D1"], PARALLEL_MOVES);
    let p = b.init();
    let par = b.span("D1.FlyByX(1)\n\tD1.FlyByX(-1)\n\tD1.TakePhoto()", 0);
    let br = b.fork(p, 3, par);
    let x = b.action(br[0], 0, "FlyByX", &[1.0], "D1.FlyByX(1)", 0);
    let y = b.action(br[1], 0, "FlyByX", &[-1.0], "D1.FlyByX(-1)", 0);
    let z = b.action(br[2], 0, "TakePhoto", &[], "D1.TakePhoto()", 0);
    let end = b.join(&[x, y, z], par);
    b.finish(end);
    let r = check(&b);
    let c: Vec<_> = r.findings_of(FindingKind::DroneConflict).collect();
    assert_eq!(c.len(), 1, "{c:#?}");
    assert!(c[0].message.contains("D1.FlyByX(1)") && c[0].message.contains("D1.FlyByX(-1)"));
    let spans: Vec<_> = c[0].labels.iter().map(|l| l.span).collect();
    assert!(spans.contains(&b.span("D1.FlyByX(1)", 0)));
    assert!(spans.contains(&b.span("D1.FlyByX(-1)", 0)));
    assert_traces_replay(&b, &r);
    // The trace ends with both running.
    let marking = &c[0].trace.as_ref().unwrap().marking;
    assert_eq!(
        marking.iter().filter(|(p, _)| p.starts_with('p')).count(),
        3
    );
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
}

#[test]
fn sequential_moves_of_one_drone_do_not_conflict() {
    let mut b = Builder::new("Pull", &["D1"], PARALLEL_MOVES);
    let p = b.init();
    let x = b.action(p, 0, "FlyByX", &[1.0], "D1.FlyByX(1)", 0);
    let y = b.action(x, 0, "FlyByX", &[-1.0], "D1.FlyByX(-1)", 0);
    b.finish(y);
    let r = check(&b);
    assert_eq!(r.verdict(Property::Conflicts), Some(&Verdict::Holds));
}

#[test]
fn the_memory_bound_stops_exploration_with_a_partial_verdict() {
    // Twenty drones photographing in parallel, explored in full: a million
    // interleavings, far more than one megabyte holds.
    let src = "package Many\n".to_string()
        + &(0..20)
            .map(|i| format!("D{i}.TakePhoto()\n"))
            .collect::<String>();
    let drones: Vec<String> = (0..20).map(|i| format!("D{i}")).collect();
    let names: Vec<&str> = drones.iter().map(String::as_str).collect();
    let mut b = Builder::new("Many", &names, &src);
    let p = b.init();
    let br = b.fork(p, 20, eamos_lang::Span::default());
    let ends: Vec<_> = br
        .iter()
        .enumerate()
        .map(|(i, &q)| {
            let needle = format!("D{i}.TakePhoto()");
            b.action(q, i as u16, "TakePhoto", &[], &needle, 0)
        })
        .collect();
    let end = b.join(&ends, eamos_lang::Span::default());
    b.finish(end);
    let profiles = eamos_profile::builtin();
    let opts = Options {
        reduction: false,
        max_memory_mb: 1,
        ..Options::default()
    };
    let r = check_net(&b.net, &profiles, Some(&b.src), &opts);
    assert!(!r.stats.complete);
    match r.verdict(Property::Deadlock) {
        Some(Verdict::Unknown(reason)) => {
            assert!(reason.contains("memory bound"), "{reason}");
            assert!(reason.contains("no deadlock") || reason.contains("nothing found"));
        }
        other => panic!("expected a partial verdict, got {other:?}"),
    }
    // With the reduction the same net is proved at once.
    let r = check_net(&b.net, &profiles, Some(&b.src), &Options::default());
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert!(r.stats.states < 200, "{} states", r.stats.states);
}

#[test]
fn the_json_form_names_verdicts_findings_spans_and_steps() {
    let b = signal_in_branch();
    let r = check(&b);
    let src = SourceFile::new("lost.go", b.src.clone());
    let j = r.to_json(&src);
    assert_eq!(j["schema"], "eamos-check/1");
    assert_eq!(j["input"], "mission");
    assert_eq!(j["found"], true);
    let props = j["properties"].as_array().unwrap();
    assert!(props
        .iter()
        .any(|p| p["property"] == "deadlock" && p["verdict"] == "violated"));
    let d = j["findings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["kind"] == "deadlock")
        .unwrap();
    assert_eq!(d["severity"], "error");
    assert_eq!(d["spans"][0]["file"], "lost.go");
    assert_eq!(d["spans"][0]["line"], 16);
    assert_eq!(d["spans"][0]["col"], 2);
    let steps = d["counterexample"]["steps"].as_array().unwrap();
    assert!(steps.iter().any(|s| s["condition_held"] == false));
    assert!(steps
        .iter()
        .all(|s| s["transition"].as_str().unwrap().starts_with('t')));
}

#[test]
fn the_text_form_shows_the_line_the_verdicts_and_the_steps() {
    let b = signal_in_branch();
    let r = check(&b);
    let src = SourceFile::new("lost.go", b.src.clone());
    let text = r.render(&src, false);
    assert!(text.contains("lost.go:16:2"), "{text}");
    assert!(text.contains("Await(\"go\")"), "{text}");
    assert!(text.contains("does not hold"), "{text}");
    assert!(text.contains("deadlock"), "{text}");
    assert!(text.contains("violated"), "{text}");
    assert!(text.contains("states"), "{text}");
}

const BESIDE_A_LOOP: &str = r#"package Beside
var D1 Quadcopter
var D2 Quadcopter
func PAR_Main() {
	SEQ_Patrol()
	D2.Arm()
}
func SEQ_Patrol() {
	D1.FlyByX(1)
}
"#;

#[test]
fn an_action_beside_an_endless_loop_is_not_taken_for_dead() {
    // The loop's transitions come first, so a stubborn set without the cycle
    // proviso would go round the loop for ever and never start D2.Arm().
    let mut b = Builder::new("Beside", &["D1", "D2"], BESIDE_A_LOOP);
    let p = b.init();
    let par = b.span("SEQ_Patrol()\n\tD2.Arm()", 0);
    let fork_place = b.place("fork");
    let t_fork = b.span("PAR_Main", 0);
    let head = b.place("head");
    let other = b.place("other");
    b.trans(TransitionKind::Silent, t_fork, &[p], &[fork_place]);
    let body_end = b.place("body end");
    b.trans(
        TransitionKind::LoopBack,
        b.span("SEQ_Patrol()", 0),
        &[body_end],
        &[head],
    );
    let back = b.span("D1.FlyByX(1)", 0);
    b.trans(TransitionKind::Silent, back, &[head], &[body_end]);
    b.trans(TransitionKind::Fork, par, &[fork_place], &[head, other]);
    let end = b.action(other, 1, "Arm", &[], "D2.Arm()", 0);
    let _ = end;
    let r = check(&b);
    assert_eq!(
        r.findings_of(FindingKind::DeadAction).count(),
        0,
        "{:#?}",
        r.findings
    );
    assert_eq!(r.verdict(Property::DeadActions), Some(&Verdict::Holds));
    assert!(r.stats.full_expansions > 0);
}
