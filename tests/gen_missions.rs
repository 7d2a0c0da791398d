//! Generated stress missions are what they claim: the size the front end
//! sees is the size asked for, their mix follows the paper's experiments,
//! and the checker proves them free of deadlocks and conflicts (and finds
//! the deadlocks that `risky` missions may have).

use std::path::PathBuf;

use eamos_gen::{generate, meg, Constructs, Generated, Options, Size, Stats};
use eamos_lang::{compile, hir, SourceFile};
use eamos_verify::{check_net, FindingKind, Options as CheckOptions, Property, Verdict};

fn mission(options: &Options) -> (Generated, SourceFile, hir::Mission) {
    let g = generate(options).expect("generates");
    let file = SourceFile::new("gen.go", g.text.clone());
    let profiles = eamos_profile::builtin();
    let compiled = compile(&file, &profiles).unwrap_or_else(|d| {
        panic!(
            "{options:?} does not compile:\n{}",
            eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN)
        )
    });
    (g, file, compiled.mission)
}

fn controls_without_pauses(s: &Stats) -> usize {
    s.controls
        .iter()
        .filter(|(k, _)| k.as_str() != "PauseFor")
        .map(|(_, v)| v)
        .sum()
}

#[test]
fn the_front_end_sees_exactly_the_size_and_mix_the_generator_reports() {
    for seed in 0..12 {
        for (drones, size) in [
            (1, Size::Nodes(34)),
            (3, Size::Nodes(250)),
            (20, Size::Nodes(5000)),
            (4, Size::Actions(300)),
        ] {
            let (g, _, m) = mission(&Options::new(drones, size, seed));
            let summary = m.summary();
            assert_eq!(
                meg::nodes(&m),
                g.stats.nodes,
                "{drones} drones, seed {seed}"
            );
            if let Size::Nodes(n) = size {
                assert_eq!(g.stats.nodes, n);
            }
            if let Size::Actions(n) = size {
                assert_eq!(summary.actions + summary.controls["PauseFor"], n);
            }
            assert_eq!(summary.drones.len(), drones);
            assert_eq!(summary.actions, g.stats.actions);
            assert_eq!(summary.seq_blocks, g.stats.seq_blocks);
            assert_eq!(summary.par_blocks, g.stats.par_blocks);
            let controls: std::collections::BTreeMap<String, usize> = g.stats.controls.clone();
            assert_eq!(summary.controls, controls);
            assert_eq!(summary.events.len(), g.stats.sync_pairs);
        }
    }
}

#[test]
fn nodes_are_counted_as_the_paper_counts_experiment_a() {
    // Table 7: experiment A, eight actions and eight pauses, has 18 nodes.
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_a.go");
    let text = std::fs::read_to_string(path).expect("the paper missions are beside the repository");
    let with_pauses: String = text
        .lines()
        .map(|l| {
            if l.starts_with("\tDrone1.") {
                format!("{l}\n\tPauseFor(5)\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let profiles = eamos_profile::builtin();
    for (text, nodes) in [(text, 10), (with_pauses, 18)] {
        let m = compile(&SourceFile::new("experiment_a.go", text), &profiles)
            .expect("experiment A compiles")
            .mission;
        assert_eq!(meg::nodes(&m), nodes);
    }
}

#[test]
fn large_missions_mix_actions_pauses_blocks_and_structures_as_the_paper_does() {
    // Table 4 over experiments A-D: 102 actions of which 23 pauses, 31
    // blocks of which 13 PAR, 8 control structures.
    let (g, _, _) = mission(&Options::new(20, Size::Nodes(20_000), 5));
    let s = &g.stats;
    let actions = s.paper_actions() as f64;
    let pause_share = s.pauses as f64 / actions;
    let blocks = (s.seq_blocks + s.par_blocks) as f64;
    let par_share = s.par_blocks as f64 / blocks;
    let controls = controls_without_pauses(s) as f64 / actions;
    assert!(
        (0.15..=0.30).contains(&pause_share),
        "pauses {pause_share:.2} (paper 0.23)"
    );
    assert!(
        (0.2..=0.5).contains(&(blocks / actions)),
        "blocks per action {:.2} (paper 0.30)",
        blocks / actions
    );
    assert!(
        (0.25..=0.55).contains(&par_share),
        "PAR share {par_share:.2} (paper 0.42)"
    );
    assert!(
        (0.02..=0.12).contains(&controls),
        "structures per action {controls:.3} (paper 0.08)"
    );
    assert!(
        s.sync_pairs > 0 && (s.sync_pairs as f64) < actions / 20.0,
        "{} pairs",
        s.sync_pairs
    );
    for name in ["If", "WaitUntil", "RepeatFor", "DoWhile", "PauseUntil"] {
        assert!(
            s.controls.contains_key(name),
            "no {name} in {:?}",
            s.controls
        );
    }
    assert!(s.controls.contains_key("RepeatUntil") || s.controls.contains_key("RepeatWhile"));
}

#[test]
fn the_checker_proves_generated_missions_free_of_deadlock_and_conflict() {
    let profiles = eamos_profile::builtin();
    // Choices (If, condition loops, Do) in parallel branches multiply the
    // states to explore: the full mix is proved on smaller missions.
    let cases = [
        (1, 34, Constructs::ALL),
        (2, 80, Constructs::ALL),
        (3, 150, Constructs::ALL),
        (6, 400, Constructs::WITHOUT_CHOICES),
        (10, 1000, Constructs::WITHOUT_CHOICES),
    ];
    for seed in 0..12 {
        for (drones, nodes, constructs) in cases {
            let o = Options {
                constructs,
                ..Options::new(drones, Size::Nodes(nodes), seed)
            };
            let (g, file, m) = mission(&o);
            let net = eamos_petri::compile(&m, &profiles);
            let report = check_net(&net, &profiles, Some(&g.text), &CheckOptions::default());
            assert!(
                !report.found_something(),
                "{drones} drones, {nodes} nodes, seed {seed}:\n{}\n{}",
                report.render(&file, false),
                g.text
            );
            // Nothing found by an exploration that gave up is no proof.
            assert_eq!(
                report.undecided().count(),
                0,
                "{drones} drones, {nodes} nodes, seed {seed}: undecided"
            );
        }
    }
}

#[test]
fn risky_missions_may_deadlock_and_the_checker_finds_where() {
    let profiles = eamos_profile::builtin();
    let mut deadlocked = 0;
    let mut risky = 0;
    for seed in 0..40 {
        let o = Options {
            risky: true,
            constructs: Constructs::WITHOUT_CHOICES,
            ..Options::new(3, Size::Nodes(150), seed)
        };
        let (g, _, m) = mission(&o);
        risky += g.stats.risky_pairs;
        let net = eamos_petri::compile(&m, &profiles);
        let report = check_net(&net, &profiles, Some(&g.text), &CheckOptions::default());
        let deadlock = report
            .findings
            .iter()
            .any(|f| f.kind == FindingKind::Deadlock);
        if g.stats.risky_pairs == 0 {
            // Proved free of deadlock: nothing found by an exploration
            // that gave up would not do.
            assert_eq!(
                report.verdict(Property::Deadlock),
                Some(&Verdict::Holds),
                "seed {seed} has no risky pair"
            );
        }
        deadlocked += usize::from(deadlock);
    }
    assert!(risky > 0, "risky asked for, none generated");
    assert!(deadlocked > 0, "{risky} risky pairs and not one deadlock");
}

#[test]
fn a_hundred_drone_mission_is_explored_in_a_few_markings_per_node() {
    // Stubborn sets grown from the first enabled step advance the mission's
    // earliest part first in every marking: the drones' independent steps
    // come back together at once. Grown from whichever step gave the
    // smallest set, this mission took 77,765 markings; the first step takes
    // 10,760. Neither its loops' rounds nor the spatial properties are
    // what is measured here.
    let profiles = eamos_profile::builtin();
    let (g, _, m) = mission(&Options::new(100, Size::Nodes(6000), 5));
    let net = eamos_petri::compile(&m, &profiles);
    let options = CheckOptions {
        spatial: false,
        ..CheckOptions::default()
    };
    let report = check_net(&net, &profiles, Some(&g.text), &options);
    assert!(!report.found_something());
    assert!(
        report.stats.states < 2 * 6000,
        "{} markings for 6,000 nodes",
        report.stats.states
    );
}
