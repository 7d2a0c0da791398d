//! Plain P/T nets from PNML files: the verdicts other Petri net tools give
//! on the same nets.

use std::path::PathBuf;

use eamos_verify::pnml::{parse, PnmlArcKind};
use eamos_verify::{check_pnml, FindingKind, Options, Property, Report, Verdict};

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/pnml")
        .join(name)
}

fn check_with(name: &str, reduction: bool) -> Report {
    let text = std::fs::read_to_string(path(name)).unwrap();
    let net = parse(name, &text).unwrap_or_else(|e| panic!("{e}"));
    let opts = Options {
        reduction,
        ..Options::default()
    };
    check_pnml(&net, &opts)
}

fn check(name: &str) -> Report {
    let r = check_with(name, true);
    let full = check_with(name, false);
    // The reduction never changes a verdict.
    let verdicts = |r: &Report| {
        r.properties
            .iter()
            .map(|p| (p.property, p.verdict.clone()))
            .collect::<Vec<_>>()
    };
    assert_eq!(verdicts(&r), verdicts(&full), "{name}");
    r
}

fn deadlock_trace(r: &Report) -> Vec<String> {
    r.findings_of(FindingKind::Deadlock)
        .next()
        .expect("a deadlock")
        .trace
        .as_ref()
        .unwrap()
        .steps
        .iter()
        .map(|s| s.transition.clone())
        .collect()
}

#[test]
fn mutual_exclusion_has_no_deadlock_and_no_end_to_reach() {
    let r = check("mutex_no_deadlock.pnml");
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert!(matches!(
        r.verdict(Property::Termination),
        Some(Verdict::NotApplicable(_))
    ));
    assert_eq!(r.verdict(Property::Safety), Some(&Verdict::Holds));
    // Deadlock is all a plain net asks of the exploration, and the place
    // invariants answer it without exploring.
    let deadlock = r
        .properties
        .iter()
        .find(|p| p.property == Property::Deadlock);
    assert!(
        deadlock.unwrap().method.contains("place invariants"),
        "{r:?}"
    );
    assert_eq!(r.stats.states, 0);
    assert!(!r.found_something());
}

#[test]
fn two_philosophers_each_holding_a_left_fork_deadlock() {
    let r = check("philosophers_deadlock.pnml");
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Violated));
    let mut t = deadlock_trace(&r);
    t.sort();
    assert_eq!(t, vec!["takeleft1", "takeleft2"]);
    let d = r.findings_of(FindingKind::Deadlock).next().unwrap();
    let mut marked: Vec<&str> = d
        .trace
        .as_ref()
        .unwrap()
        .marking
        .iter()
        .map(|(p, _)| p.as_str())
        .collect();
    marked.sort();
    assert_eq!(marked, vec!["hasleft1", "hasleft2"]);
}

#[test]
fn a_fork_and_join_reaching_final_ends_properly() {
    let r = check("forkjoin_ends.pnml");
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Safety), Some(&Verdict::Holds));
}

#[test]
fn a_branch_into_a_dead_end_is_a_one_step_deadlock() {
    let r = check("choice_dead_end.pnml");
    assert_eq!(deadlock_trace(&r), vec!["goright"]);
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Violated));
    // The finding points at the place in the file.
    let d = r.findings_of(FindingKind::Deadlock).next().unwrap();
    assert!(d.message.contains("final"));
}

#[test]
fn a_transition_that_only_adds_tokens_makes_the_net_unbounded() {
    let r = check("unbounded_pump.pnml");
    assert_eq!(r.verdict(Property::Safety), Some(&Verdict::Violated));
    let f = r
        .findings_of(FindingKind::Unbounded)
        .next()
        .expect("unbounded");
    assert!(f.message.contains("`heap`"), "{}", f.message);
    assert!(f.trace.as_ref().unwrap().cycle_from.is_some());
    assert!(matches!(
        r.verdict(Property::Deadlock),
        Some(Verdict::Unknown(_))
    ));
}

#[test]
fn a_net_with_two_tokens_is_bounded_but_not_safe_and_has_no_deadlock() {
    let r = check("weighted_two_tokens.pnml");
    assert_eq!(r.verdict(Property::Safety), Some(&Verdict::Violated));
    assert_eq!(r.findings_of(FindingKind::Unsafe).count(), 1);
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Holds));
    assert_eq!(r.stats.max_tokens, 2);
}

#[test]
fn a_cycle_that_never_reaches_final_is_non_termination() {
    let r = check("livelock.pnml");
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Violated));
    let f = r
        .findings_of(FindingKind::NonTermination)
        .next()
        .expect("non-termination");
    let t = f.trace.as_ref().unwrap();
    let ids: Vec<&str> = t.steps.iter().map(|s| s.transition.as_str()).collect();
    assert_eq!(ids[0], "go");
    let cycle: Vec<&str> = ids[t.cycle_from.unwrap()..].to_vec();
    assert_eq!(cycle.len(), 2);
    assert!(cycle.contains(&"ab") && cycle.contains(&"ba"));
}

#[test]
fn read_arcs_and_the_eamos_final_mark_are_understood() {
    let text = std::fs::read_to_string(path("read_arc_tapaal.pnml")).unwrap();
    let net = parse("gate.pnml", &text).unwrap();
    let read = net.arcs.iter().find(|a| a.id == "r1").unwrap();
    assert_eq!(read.kind, PnmlArcKind::Read);
    assert!(net.places.iter().any(|p| p.id == "end" && p.is_final));
    let r = check("read_arc_tapaal.pnml");
    assert_eq!(r.verdict(Property::Deadlock), Some(&Verdict::Holds));
    assert_eq!(r.verdict(Property::Termination), Some(&Verdict::Holds));
}

#[test]
fn an_unclosed_element_is_an_error_with_line_and_column() {
    let text = std::fs::read_to_string(path("malformed_unclosed.pnml")).unwrap();
    let e = parse("broken.pnml", &text).unwrap_err();
    assert_eq!(e.file, "broken.pnml");
    assert!(e.line >= 4, "{e}");
    assert!(e.to_string().starts_with("broken.pnml:"), "{e}");
}

#[test]
fn an_arc_to_an_unknown_node_is_an_error_at_the_arc() {
    let text = std::fs::read_to_string(path("malformed_arc.pnml")).unwrap();
    let e = parse("arc.pnml", &text).unwrap_err();
    assert_eq!((e.line, e.col), (6, 5), "{e}");
    assert!(e.message.contains("nowhere"), "{e}");
}

#[test]
fn inhibitor_arcs_and_bad_numbers_are_refused_not_misread() {
    let inhibitor = r#"<pnml><net id="n"><place id="p"/><transition id="t"/>
<arc id="a" source="p" target="t"><type value="inhibitor"/></arc></net></pnml>"#;
    let e = parse("i.pnml", inhibitor).unwrap_err();
    assert!(e.message.contains("inhibitor"), "{e}");
    assert_eq!(e.line, 2);
    let bad = r#"<pnml><net id="n"><place id="p"><initialMarking><text>lots</text></initialMarking></place></net></pnml>"#;
    let e = parse("b.pnml", bad).unwrap_err();
    assert!(e.message.contains("lots"), "{e}");
    let none = "<pnml></pnml>";
    assert!(parse("e.pnml", none)
        .unwrap_err()
        .message
        .contains("no <net>"));
    let garbage = "<pnml><net id='n'><place id='p'></net></pnml>";
    assert!(parse("g.pnml", garbage).is_err());
    let twice = r#"<pnml><net id="n"><place id="p"/><place id="p"/></net></pnml>"#;
    assert!(parse("d.pnml", twice)
        .unwrap_err()
        .message
        .contains("twice"));
}
