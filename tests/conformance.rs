//! Executor conformance: what flies is what the net says. Random generated
//! missions (2 or 3 drones, 20 to 60 nodes, every construct of the
//! language) are sliced and flown by the real executor, every drone's slice
//! in one process (`run_fleet`), on simulated drones with random airframes,
//! random durations of the actions that do not move, a random telemetry
//! period and a random simulation speed, over the in-process transport or
//! zenoh on loopback, with the transport's fault injection (dropped,
//! duplicated, reordered frames) on some runs. Then:
//!
//! - the merged observed trace (every drone's action starts, ends and
//!   cancellations, from the one event stream) is a trace of the *global*
//!   mission net: a firing sequence of its token game shows the same
//!   visible events, in an order of their mission times, each condition
//!   guard taking the value the drones observed (what "is a trace of"
//!   means exactly: `conformance/replay.rs`);
//! - every condition decision was right about the world: the guard held on
//!   the drones' sampled telemetry about when it fired
//!   (`conformance/world.rs`), so the replay may take the decisions as the
//!   drones took them;
//! - a mission `eamos check` proves free of deadlock completes on every
//!   peer, and its trace is complete: the game then reaches the final
//!   marking.
//!
//! Forty cases by default (about half a minute in a debug build);
//! `PROPTEST_CASES=200` runs more by hand.

#[path = "conformance/replay.rs"]
mod replay;
#[path = "conformance/trace.rs"]
mod trace;
#[path = "conformance/world.rs"]
mod world;

use std::sync::Arc;
use std::time::Duration;

use proptest::prelude::*;

use eamos_exec::event::{Channel, Event};
use eamos_exec::runner::{run_fleet, RunOptions, TransportKind};
use eamos_exec::transport::faulty::Faults;
use eamos_exec::Outcome;
use eamos_fleet::Fleet;
use eamos_gen::{generate, Options as GenOptions, Size};
use eamos_lang::SourceFile;
use eamos_verify::{check_net, Options as CheckOptions, Property, Verdict};

/// One flight of one generated mission.
#[derive(Debug, Clone)]
struct Case {
    drones: usize,
    nodes: usize,
    seed: u64,
    /// Per drone: horizontal speed, climb rate, descent rate (m/s).
    airframes: Vec<(f64, f64, f64)>,
    /// Seconds `TakePhoto`, `AdjustCamera`, `TurnOnCamera` take.
    durations: (f64, f64, f64),
    /// Simulated seconds between two telemetry updates of a drone.
    telemetry_period: f64,
    /// Simulated seconds per real second.
    speed: f64,
    transport: TransportKind,
    /// Drop, duplicate, reorder probabilities of the links' frames.
    faults: Option<(f64, f64, f64)>,
}

fn case() -> impl Strategy<Value = Case> {
    (2usize..=3).prop_flat_map(|drones| {
        let transport = prop_oneof![
            5 => Just(TransportKind::InProcess),
            1 => Just(TransportKind::Zenoh),
        ];
        let faults = prop_oneof![
            1 => Just(None),
            1 => (0.0f64..0.2, 0.0f64..0.2, 0.0f64..0.3).prop_map(Some),
        ];
        (
            Just(drones),
            20usize..=60,
            any::<u64>(),
            prop::collection::vec((1.5f64..8.0, 1.0f64..4.0, 1.0f64..3.0), drones),
            (0.0f64..2.0, 0.0f64..2.0, 0.0f64..2.0),
            0.05f64..0.5,
            60.0f64..200.0,
            transport,
            faults,
        )
            .prop_map(
                |(
                    drones,
                    nodes,
                    seed,
                    airframes,
                    durations,
                    telemetry_period,
                    speed,
                    transport,
                    faults,
                )| Case {
                    drones,
                    nodes,
                    seed,
                    airframes,
                    durations,
                    telemetry_period,
                    speed,
                    transport,
                    faults,
                },
            )
    })
}

impl Case {
    /// The fleet file: the simulated airframes and action durations.
    fn fleet_text(&self) -> String {
        let (photo, adjust, camera) = self.durations;
        let mut t = format!(
            "[sim]\ntelemetry_period = {}\n[sim.durations]\nTakePhoto = {photo}\nAdjustCamera = {adjust}\nTurnOnCamera = {camera}\n",
            self.telemetry_period
        );
        for (i, (speed, climb, descent)) in self.airframes.iter().enumerate() {
            t += &format!(
                "[drones.D{}]\nvehicle = {{ max_horizontal_speed = {speed}, climb_rate = {climb}, descent_rate = {descent} }}\n",
                i + 1
            );
        }
        t
    }

    fn options(&self, events: Channel, dir: &std::path::Path) -> RunOptions {
        RunOptions {
            speed: self.speed,
            // Generated waits and loops end in flight; this only bounds a
            // run that would not.
            max_duration: Some(1800.0),
            out: dir.to_path_buf(),
            transport: self.transport,
            faults: self.faults.map(|(drop, duplicate, reorder)| Faults {
                drop,
                duplicate,
                reorder,
                max_delay: Duration::from_millis(20),
                seed: self.seed,
            }),
            linger: Duration::ZERO,
            events: Some(Arc::new(events)),
            ..RunOptions::default()
        }
    }
}

fn run_case(c: &Case) -> Result<(), TestCaseError> {
    let size = Size::Nodes(c.nodes.max(eamos_gen::min_size(c.drones, Size::Nodes(0))));
    let generated = generate(&GenOptions::new(c.drones, size, c.seed)).expect("generates");
    let file = SourceFile::new("generated.go", generated.text.clone());
    let profiles = eamos_profile::builtin();
    let mission = eamos_lang::compile(&file, &profiles)
        .unwrap_or_else(|d| {
            panic!(
                "{}",
                eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN)
            )
        })
        .mission;
    let net = eamos_petri::compile(&mission, &profiles);
    let check = check_net(
        &net,
        &profiles,
        Some(&generated.text),
        &CheckOptions::default(),
    );
    let deadlock_free = check.verdict(Property::Deadlock) == Some(&Verdict::Holds);

    let fleet_text = c.fleet_text();
    let fleet = Fleet::parse(&fleet_text, "fleet.toml", &net.name, &net.drones).expect("fleet");
    let slices = eamos_fleet::identity::slice(&net, &fleet).expect("slices");
    let dir = tempfile::tempdir().unwrap();
    let (sink, mut rx) = Channel::new();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let report = runtime
        .block_on(run_fleet(
            &slices,
            &fleet,
            &profiles,
            &c.options(sink, dir.path()),
        ))
        .expect("the run");
    drop(runtime);
    let events: Vec<Event> = std::iter::from_fn(|| rx.try_recv().ok()).collect();
    let context = || format!("{c:?}\n{fleet_text}\n{}", generated.text);

    let completed = report
        .reports
        .iter()
        .all(|r| r.outcome == Outcome::Completed);
    let observed = trace::observe(&net, &events);
    if std::env::var_os("CONFORMANCE_MEASURE").is_some() {
        eprintln!(
            "{} drones, {} nodes, {:?}, faults {} ({} retransmitted, {} duplicates): \
             {} visible events, {} decisions, deadlock free {deadlock_free}, \
             completed {completed}, {:.1} s",
            c.drones,
            c.nodes,
            c.transport,
            c.faults.is_some(),
            report
                .reports
                .iter()
                .map(|r| r.bridges.retransmissions)
                .sum::<u64>(),
            report
                .reports
                .iter()
                .map(|r| r.bridges.duplicates)
                .sum::<u64>(),
            observed.seen.len(),
            observed.decided.len(),
            report.wall.as_secs_f64()
        );
    }
    prop_assert!(
        observed.broken.is_empty(),
        "{}\n{}",
        observed.broken.join("\n"),
        context()
    );
    // Before: a telemetry period, and what the executor may lag behind
    // the simulator, some 20 ms of wall time at this speed. After: what
    // the sampling task may lag behind the executor, some 10 ms.
    let window = (c.telemetry_period + 0.02 * c.speed, 0.01 * c.speed);
    let misjudged = world::misjudged(&net, &fleet.homes(&net.drones), &events, window);
    prop_assert!(
        misjudged.is_empty(),
        "{}\n{}",
        misjudged.join("\n"),
        context()
    );
    if let Err(why) = replay::conforms(&net, &observed, completed) {
        return Err(TestCaseError::fail(format!("{why}\n{}", context())));
    }
    // Last: a run that broke the net's rules says how, before it says
    // that it did not end.
    if deadlock_free {
        for r in &report.reports {
            prop_assert_eq!(
                &r.outcome,
                &Outcome::Completed,
                "{} did not complete a mission proved free of deadlock\n{}",
                r.drone,
                context()
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 40,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn every_flight_is_a_trace_of_the_global_net(c in case()) {
        run_case(&c)?;
    }
}
