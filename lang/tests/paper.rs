//! The five missions of the paper compile, and their summaries are what the
//! files say (counted by hand from the listings, see each test).

use std::path::PathBuf;

use eamos_lang::{compile, hir::Summary, SourceFile};

fn paper(name: &str) -> SourceFile {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/missions/paper")
        .join(name);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    SourceFile::new(name, text)
}

fn summary(name: &str) -> Summary {
    let file = paper(name);
    let profiles = eamos_profile::builtin();
    match compile(&file, &profiles) {
        Ok(c) => {
            assert!(c.warnings.is_empty(), "{name}: {:#?}", c.warnings);
            c.mission.summary()
        }
        Err(diags) => panic!(
            "{name} does not compile:\n{}",
            eamos_lang::render_all(&diags, &file, eamos_lang::Style::PLAIN)
        ),
    }
}

fn drones(s: &Summary) -> Vec<(&str, &str, usize)> {
    s.drones
        .iter()
        .map(|d| (d.name.as_str(), d.profile.as_str(), d.actions))
        .collect()
}

fn controls(s: &Summary) -> Vec<(&str, usize)> {
    s.controls.iter().map(|(k, n)| (k.as_str(), *n)).collect()
}

#[test]
fn experiment_a_is_one_drone_flying_a_square_in_eight_actions() {
    // SEQ_Experiment_A: Arm, Takeoff, 4 FlyBy, Land, Disarm = 8 actions, all
    // of Drone1; the entry is the only block.
    let s = summary("experiment_a.go");
    assert_eq!(s.name, "ExperimentA");
    assert_eq!(s.entry, "SEQ_Experiment_A");
    assert_eq!(drones(&s), [("Drone1", "Quadcopter", 8)]);
    assert_eq!(s.actions, 8);
    assert_eq!((s.seq_blocks, s.par_blocks), (1, 0));
    assert!(s.controls.is_empty());
    assert!(s.events.is_empty());
}

#[test]
fn experiment_b_is_two_drones_with_nine_actions_each() {
    // Entry: Drone1.Arm, Drone2.Arm, FlyByZ x2 = 4 actions, plus 7 PAR blocks
    // (Takeoff, Fly1..Fly4, Land, Disarm) of 2 actions each = 14: 18 in all,
    // 9 per drone (Arm, Takeoff, 4 FlyBy, FlyByZ, Land, Disarm).
    let s = summary("experiment_b.go");
    assert_eq!(s.name, "ExperimentB");
    assert_eq!(
        drones(&s),
        [("Drone1", "Quadcopter", 9), ("Drone2", "Quadcopter", 9)]
    );
    assert_eq!(s.actions, 18);
    assert_eq!((s.seq_blocks, s.par_blocks), (1, 7));
    assert!(s.controls.is_empty());
}

#[test]
fn experiment_c_is_three_drones_with_eight_actions_each() {
    // Entry: six Drone3 moves (Takeoff, 4 FlyBy, Land). PAR_ARM 3, PAR_Takeoff
    // 2, PAR_Fly1..4 2 each, PAR_Land 2, PAR_Disarm 3 = 18. Total 24; each
    // drone: Arm, Takeoff, 4 FlyBy, Land, Disarm = 8.
    let s = summary("experiment_c.go");
    assert_eq!(s.entry, "SEQ_Experiment_C");
    assert_eq!(
        drones(&s),
        [
            ("Drone1", "Quadcopter", 8),
            ("Drone2", "Quadcopter", 8),
            ("Drone3", "Quadcopter", 8)
        ]
    );
    assert_eq!(s.actions, 24);
    assert_eq!((s.seq_blocks, s.par_blocks), (1, 8));
}

#[test]
fn experiment_d_expands_each_exit_block_once_per_loop() {
    // Entry: 3 Arm; PAR_1: 3 Arm; SEQ_2: 3 Takeoff; PAR_Loop: 4 RepeatWhile,
    // each with a body SEQ_IsD..X.. holding one WaitUntil whose block has one
    // FlyByX, and its own PAR_Exit instance (D3.Land): 2 actions per loop.
    // Actions: 9 + 8 = 17. D1: 2 Arm, Takeoff, 2 FlyByX = 5; D2 the same;
    // D3: 2 Arm, Takeoff, 4 Land = 7.
    // Blocks: SEQ = entry, SEQ_2, 4 loop bodies, 4 WaitUntil blocks = 10;
    // PAR = PAR_1, PAR_Loop, 4 PAR_Exit = 6.
    let s = summary("experiment_d.go");
    assert_eq!(
        drones(&s),
        [
            ("D1", "Quadcopter", 5),
            ("D2", "Quadcopter", 5),
            ("D3", "Quadcopter", 7)
        ]
    );
    assert_eq!(s.actions, 17);
    assert_eq!((s.seq_blocks, s.par_blocks), (10, 6));
    assert_eq!(controls(&s), [("RepeatWhile", 4), ("WaitUntil", 4)]);
    assert!(s.events.is_empty());
}

#[test]
fn listing_1_starts_at_init_and_counts_nine_actions() {
    // INIT -> SEQ_Start -> PAR_TurnOn (3 TurnOn), PAR_PreFlightChecks ->
    // SEQ_PreFlight1/2 (PreFlightCheck + Calibrate each), SEQ_ActivateCamera
    // (TurnOnCamera + AdjustCamera): 9 actions. Drone1 3, Drone2 5, Drone3 1.
    // Blocks: SEQ = INIT, SEQ_Start, SEQ_PreFlight1, SEQ_PreFlight2,
    // SEQ_ActivateCamera = 5; PAR = PAR_TurnOn, PAR_PreFlightChecks = 2.
    let s = summary("listing01_demo.go");
    assert_eq!(s.name, "DemoMission1");
    assert_eq!(s.entry, "INIT");
    assert_eq!(
        drones(&s),
        [
            ("Drone1", "Quadcopter", 3),
            ("Drone2", "Quadcopter", 5),
            ("Drone3", "Quadcopter", 1)
        ]
    );
    assert_eq!(s.actions, 9);
    assert_eq!((s.seq_blocks, s.par_blocks), (5, 2));
}

#[test]
fn the_summary_prints_as_a_few_readable_lines() {
    let s = summary("experiment_d.go");
    assert_eq!(
        s.to_string(),
        "mission ExperimentD (entry SEQ_Experiment_D)\n\
         drones: 3\n  D1: Quadcopter, 5 actions\n  D2: Quadcopter, 5 actions\n  D3: Quadcopter, 7 actions\n\
         actions: 17\n\
         blocks: 16 (10 SEQ, 6 PAR)\n\
         control structures: 8 (RepeatWhile 4, WaitUntil 4)\n\
         events: none\n"
    );
}
