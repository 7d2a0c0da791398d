//! The yardstick itself, on missions small enough to know the answer by
//! reading them: if these fail, no agreement with it means anything.

use eamos_lang::SourceFile;
use eamos_oracle::{search, Answer, Verdicts};
use eamos_petri::net::{Guard, Net, Transition, TransitionKind};

fn net(body: &str, blocks: &str) -> Net {
    let text = format!(
        "package M\n\nvar (\n\tD1 Quadcopter\n\tD2 Quadcopter\n)\n\nfunc SEQ_Main() {{\n{body}\n}}\n\n{blocks}\n"
    );
    let profiles = eamos_profile::builtin();
    let file = SourceFile::new("m.go", text);
    let compiled = eamos_lang::compile(&file, &profiles).unwrap_or_else(|d| {
        panic!(
            "{}",
            eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN)
        )
    });
    eamos_petri::compile(&compiled.mission, &profiles)
}

fn answer(net: &Net, may_hold: &mut dyn FnMut(&Transition, &Guard) -> bool) -> Answer {
    search(net, &eamos_profile::builtin(), may_hold, 100_000)
}

fn verdicts(net: &Net) -> Verdicts {
    match answer(net, &mut |_, _| true) {
        Answer::Decided(v) => v,
        other => panic!("undecided: {other:?}"),
    }
}

fn started<'n>(net: &'n Net, v: &Verdicts) -> Vec<&'n str> {
    let mut names: Vec<&str> = v
        .started
        .iter()
        .filter_map(|&t| match &net.transition(t)?.kind {
            TransitionKind::ActionStart(a) => Some(a.name.as_str()),
            _ => None,
        })
        .collect();
    names.sort();
    names
}

#[test]
fn two_drones_awaiting_each_other_deadlock_and_never_end() {
    let n = net(
        "\tPAR_Both()",
        "func PAR_Both() {\n\tSEQ_A()\n\tSEQ_B()\n}\n\
         func SEQ_A() {\n\tAwait(\"b\")\n\tD1.Arm()\n\tSignal(\"a\")\n}\n\
         func SEQ_B() {\n\tAwait(\"a\")\n\tD2.Arm()\n\tSignal(\"b\")\n}",
    );
    let v = verdicts(&n);
    let run = v.deadlock.expect("a deadlock");
    // The mission starts and forks: then both wait.
    assert_eq!(run.len(), 2, "{run:?}");
    assert!(!v.terminates);
    assert!(v.started.is_empty());
}

#[test]
fn a_signal_before_its_await_lets_the_mission_end() {
    let n = net(
        "\tPAR_Both()",
        "func PAR_Both() {\n\tSEQ_A()\n\tSEQ_B()\n}\n\
         func SEQ_A() {\n\tD1.Arm()\n\tSignal(\"a\")\n}\n\
         func SEQ_B() {\n\tAwait(\"a\")\n\tD2.Arm()\n}",
    );
    let v = verdicts(&n);
    assert!(v.deadlock.is_none());
    assert!(v.terminates);
    assert_eq!(started(&n, &v), ["Arm", "Arm"]);
}

#[test]
fn a_condition_loop_has_finitely_many_markings_and_can_always_end() {
    let n = net(
        "\tRepeatWhile(D1.Z() < 5, SEQ_Climb)",
        "func SEQ_Climb() {\n\tD1.FlyByZ(1)\n}",
    );
    let v = verdicts(&n);
    assert!(v.deadlock.is_none());
    assert!(v.terminates);
}

#[test]
fn counted_loops_keep_their_rounds_apart() {
    let rounds = |n: u32| {
        let m = net(
            &format!("\tRepeatFor({n}, SEQ_Lap)"),
            "func SEQ_Lap() {\n\tD1.FlyByX(1)\n}",
        );
        verdicts(&m).markings
    };
    // One more round, one more lap's markings (start, running, end, back).
    assert_eq!(rounds(3) - rounds(2), rounds(2) - rounds(1));
    assert!(rounds(2) > rounds(1));
}

#[test]
fn both_sides_of_a_choice_are_explored_unless_a_side_cannot_hold() {
    let n = net(
        "\tIf(D1.X() > 1, SEQ_Then, SEQ_Else)",
        "func SEQ_Then() {\n\tD1.Arm()\n}\nfunc SEQ_Else() {\n\tD1.Land()\n}",
    );
    assert_eq!(started(&n, &verdicts(&n)), ["Arm", "Land"]);
    let Answer::Decided(v) = answer(&n, &mut |_, g| {
        g.condition().is_some_and(|(_, negated)| negated)
    }) else {
        panic!("undecided")
    };
    assert_eq!(started(&n, &v), ["Land"]);
}

#[test]
fn a_wait_on_a_condition_that_cannot_hold_is_a_deadlock() {
    let n = net("\tPauseUntil(D1.Z() > 3)\n\tD1.Arm()", "");
    assert!(verdicts(&n).deadlock.is_none());
    let Answer::Decided(v) = answer(&n, &mut |_, _| false) else {
        panic!("undecided")
    };
    assert!(v.deadlock.is_some());
    assert!(!v.terminates);
}

#[test]
fn two_motions_of_one_drone_at_once_conflict_a_hover_and_a_photo_do_not() {
    let n = net(
        "\tPAR_Move()\n\tPAR_Shoot()",
        "func PAR_Move() {\n\tD1.FlyByX(1)\n\tD1.FlyByY(1)\n\tD2.FlyByX(1)\n}\n\
         func PAR_Shoot() {\n\tD1.Hover(2)\n\tD1.TakePhoto()\n}",
    );
    let v = verdicts(&n);
    assert_eq!(v.conflicts.len(), 1, "{:?}", v.conflicts);
    let (a, b) = *v.conflicts.iter().next().expect("one");
    let names: Vec<String> = [a, b]
        .iter()
        .map(|&p| n.place(p).expect("a place").label.to_string())
        .collect();
    assert!(names.iter().all(|l| l.contains("D1.FlyBy")), "{names:?}");
}

#[test]
fn the_search_gives_up_past_its_bound_rather_than_decide() {
    let n = net(
        "\tRepeatFor(50, SEQ_Lap)",
        "func SEQ_Lap() {\n\tD1.FlyByX(1)\n}",
    );
    let a = search(&n, &eamos_profile::builtin(), &mut |_, _| true, 20);
    assert!(matches!(a, Answer::TooLarge { markings: 20 }), "{a:?}");
}
