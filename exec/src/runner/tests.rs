//! Whole runs with journals: what the journals of a completed run replay
//! to, what every sink of a run sees, and an agent killed mid-pause and
//! restarted from its journal.

use std::path::Path;

use crate::journal::tests::{pausing, slices};
use crate::journal::{replay, Journal};

fn run_options(dir: &Path) -> crate::runner::RunOptions {
    crate::runner::RunOptions {
        speed: 200.0,
        max_duration: Some(600.0),
        out: dir.join("logs"),
        journal: Some(dir.join("journal")),
        linger: std::time::Duration::ZERO,
        ..crate::runner::RunOptions::default()
    }
}

fn action_starts(dir: &Path, peer: &str) -> usize {
    crate::log::read_mission_log(&dir.join("logs").join(format!("{peer}.mission.jsonl")))
        .map(|log| {
            log.iter()
                .filter(|r| matches!(r.kind, crate::event::Kind::ActionStarted { .. }))
                .count()
        })
        .unwrap_or(0)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn replaying_the_journals_of_a_completed_run_gives_its_final_marking_and_resuming_runs_nothing_again(
) {
    let s = slices("experiment_b.go");
    let dir = tempfile::tempdir().unwrap();
    let options = run_options(dir.path());
    let fleet = eamos_fleet::Fleet::default();
    let profiles = eamos_profile::builtin();
    let report = crate::runner::run_fleet(&s, &fleet, &profiles, &options)
        .await
        .unwrap();
    assert!(report
        .reports
        .iter()
        .all(|r| r.outcome == crate::Outcome::Completed));

    let mut marked = Vec::new();
    for slice in &s.slices {
        let path = Journal::path(&dir.path().join("journal"), &slice.drone);
        let opened = Journal::open(&path, &slice.mission_id, &slice.drone).unwrap();
        let r = replay(slice, "j", &opened.records).unwrap();
        assert!(r.completed, "{}", slice.drone);
        assert!(r.interrupted.is_empty() && r.not_started.is_empty());
        let report = report
            .reports
            .iter()
            .find(|x| x.drone == slice.drone)
            .unwrap();
        assert_eq!(r.started, report.started_actions, "{}", slice.drone);
        assert_eq!(r.actions, report.actions, "{}", slice.drone);
        assert_eq!(r.sent, report.sent, "{}", slice.drone);
        assert_eq!(r.received, report.received, "{}", slice.drone);
        for (p, tokens) in r.marking.iter().enumerate() {
            assert!(tokens.len() <= 1, "1-safe");
            if !tokens.is_empty() {
                marked.push((
                    slice.final_place == Some(p as u32),
                    slice.places[p].id.clone(),
                ));
            }
        }
    }
    // The final marking of the net: the final places, and event states.
    let file = eamos_lang::SourceFile::new(
        "experiment_b.go",
        std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../shared/missions/paper/experiment_b.go"),
        )
        .unwrap(),
    );
    let profiles = eamos_profile::builtin();
    let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&m, &profiles);
    assert!(marked.iter().any(|(is_final, _)| *is_final), "{marked:?}");
    for (is_final, id) in &marked {
        let event = net
            .places()
            .any(|(_, p)| &p.id == id && p.kind.is_event_state());
        assert!(*is_final || event, "{id} is still marked");
    }

    // Started again with the same journals: nothing runs twice.
    let before: Vec<usize> = s
        .slices
        .iter()
        .map(|x| action_starts(dir.path(), &x.drone))
        .collect();
    let again = crate::runner::run_fleet(&s, &fleet, &profiles, &options)
        .await
        .unwrap();
    assert!(again
        .reports
        .iter()
        .all(|r| r.outcome == crate::Outcome::Completed));
    let after: Vec<usize> = s
        .slices
        .iter()
        .map(|x| action_starts(dir.path(), &x.drone))
        .collect();
    assert_eq!(before, after);
    assert!(before.iter().sum::<usize>() > 0);
}

/// One simulated run read by two sinks, its mission logs and a channel:
/// each peer's events agree one by one, in order; and each peer's last
/// marking is the marking its journal replays to, the final place marked
/// where the mission ends.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_sink_of_a_run_sees_the_same_events_in_order_and_the_last_marking_is_the_journals() {
    use crate::event::{Channel, Event, Kind};

    let s = slices("experiment_b.go");
    let dir = tempfile::tempdir().unwrap();
    let (events, mut rx) = Channel::new();
    let options = crate::runner::RunOptions {
        events: Some(std::sync::Arc::new(events)),
        ..run_options(dir.path())
    };
    let report = crate::runner::run_fleet(
        &s,
        &eamos_fleet::Fleet::default(),
        &eamos_profile::builtin(),
        &options,
    )
    .await
    .unwrap();
    assert!(report
        .reports
        .iter()
        .all(|r| r.outcome == crate::Outcome::Completed));
    let seen: Vec<Event> = std::iter::from_fn(|| rx.try_recv().ok()).collect();
    assert!(
        seen.iter()
            .any(|e| matches!(e.kind, Kind::Telemetry { .. })),
        "the drones' telemetry is in the stream"
    );
    let mut finals = 0;
    for slice in &s.slices {
        let peer = &slice.drone;
        let streamed: Vec<Event> = seen
            .iter()
            .filter(|e| &e.drone == peer && !matches!(e.kind, Kind::Telemetry { .. }))
            .cloned()
            .collect();
        let logged = crate::log::read_mission_log(
            &dir.path()
                .join("logs")
                .join(format!("{peer}.mission.jsonl")),
        )
        .unwrap();
        assert!(logged.len() > 3, "{peer}: {logged:?}");
        assert_eq!(logged, streamed, "{peer}");

        let last: Vec<String> = streamed
            .iter()
            .rev()
            .find_map(|e| match &e.kind {
                Kind::Marking { marked } => Some(marked.clone()),
                _ => None,
            })
            .expect("a marking");
        let path = Journal::path(&dir.path().join("journal"), peer);
        let opened = Journal::open(&path, &slice.mission_id, peer).unwrap();
        let replayed = replay(slice, "j", &opened.records).unwrap();
        let mut journaled: Vec<String> = replayed
            .marking
            .iter()
            .zip(&slice.places)
            .filter(|(tokens, _)| !tokens.is_empty())
            .map(|(_, p)| p.id.to_string())
            .collect();
        journaled.sort();
        assert_eq!(last, journaled, "{peer}");
        if let Some(f) = slice.final_place {
            if last.iter().any(|m| *m == slice.places[f as usize].id) {
                finals += 1;
            }
        }
        // A marking follows every firing and every token delivered.
        let changes = streamed
            .iter()
            .filter(|e| matches!(e.kind, Kind::Fired { .. } | Kind::BridgeReceived { .. }))
            .count();
        let markings = streamed
            .iter()
            .filter(|e| matches!(e.kind, Kind::Marking { .. }))
            .count();
        assert_eq!(
            markings,
            changes + 1,
            "{peer}: one at the start, one per change"
        );
    }
    assert!(finals > 0, "the mission ended in a final place");
}

/// When `event` (the first match) happened in D1's mission log.
fn logged_at(dir: &Path, what: impl Fn(&crate::event::Kind) -> bool) -> Option<f64> {
    crate::log::read_mission_log(&dir.join("logs").join("D1.mission.jsonl"))
        .unwrap()
        .into_iter()
        .find(|r| what(&r.kind))
        .map(|r| r.time)
}

#[test]
fn an_agent_killed_mid_pause_and_restarted_from_its_journal_waits_only_for_the_rest_of_the_pause() {
    use crate::event::Kind;
    use crate::runner::{run_fleet, RunOptions};

    let dir = tempfile::tempdir().unwrap();
    let options = RunOptions {
        speed: 20.0,
        ..run_options(dir.path())
    };
    let s = pausing();

    // First flight, killed like `kill -9` a while into the pause: its
    // runtime is torn down with every task in it, nothing runs to its end.
    let first = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let (events, mut watch) = crate::event::Channel::new();
    {
        let (s, options) = (
            s.clone(),
            RunOptions {
                events: Some(std::sync::Arc::new(events)),
                ..options.clone()
            },
        );
        first.spawn(async move {
            let profiles = eamos_profile::builtin();
            let _ = run_fleet(&s, &eamos_fleet::Fleet::default(), &profiles, &options).await;
        });
    }
    loop {
        let e = watch.blocking_recv().expect("the first flight reports");
        if matches!(&e.kind, Kind::ActionFinished { action, .. } if action.starts_with("Takeoff")) {
            break;
        }
    }
    // 1 s of wall time is 20 s into the 60 s pause.
    std::thread::sleep(std::time::Duration::from_secs(1));
    first.shutdown_timeout(std::time::Duration::from_secs(5));
    let began = logged_at(
        dir.path(),
        |e| matches!(e, Kind::ActionFinished { action, .. } if action.starts_with("Takeoff")),
    )
    .unwrap();
    assert!(
        logged_at(
            dir.path(),
            |e| matches!(e, Kind::Fired { kind, .. } if kind == "pause")
        )
        .is_none(),
        "the first flight was killed before its pause was over"
    );

    // Started again from its journal.
    let again = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let report = again
        .block_on(run_fleet(
            &s,
            &eamos_fleet::Fleet::default(),
            &eamos_profile::builtin(),
            &options,
        ))
        .unwrap();
    assert!(report
        .reports
        .iter()
        .all(|r| r.outcome == crate::Outcome::Completed));
    let resumed = logged_at(dir.path(), |e| matches!(e, Kind::Resumed { .. })).unwrap();
    let over = logged_at(
        dir.path(),
        |e| matches!(e, Kind::Fired { kind, .. } if kind == "pause"),
    )
    .unwrap();
    assert!(
        resumed > began + 5.0,
        "killed well into the pause: began {began}, resumed {resumed}"
    );
    // Over 60 s after it began, not 60 s after the restart; the slack is
    // the simulator's: it goes on from its last recorded airframe.
    assert!(
        over >= began + 59.5 && over < resumed + 55.0,
        "the pause began at {began}, the agent resumed at {resumed}, the pause ended at {over}"
    );
    assert_eq!(
        action_starts(dir.path(), "D1"),
        3,
        "Arm, Takeoff, Land once each"
    );
}

/// The end of the mission costs a notice per peer, not one per pair: each
/// owner of an end tells the ground station alone, and the ground station
/// tells each other peer once (every notice told to every peer by every
/// owner grew with the square of the fleet, and kept a hundred-drone
/// fleet retransmitting for seconds after its last action).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_end_goes_through_the_ground_station_one_notice_per_peer() {
    let s = slices("experiment_c.go");
    let dir = tempfile::tempdir().unwrap();
    let mut options = run_options(dir.path());
    options.journal = None;
    let report = crate::runner::run_fleet(
        &s,
        &eamos_fleet::Fleet::default(),
        &eamos_profile::builtin(),
        &options,
    )
    .await
    .unwrap();
    let peers = s.slices.len() as u64;
    assert!(peers >= 4, "three drones and the ground station");
    for r in &report.reports {
        assert_eq!(r.outcome, crate::Outcome::Completed, "{}", r.drone);
        // What the bridges carried besides the slice's own tokens.
        let notices = r.bridges.sent - r.sent;
        if r.drone == crate::names::GCS {
            assert_eq!(notices, peers - 1, "{}", r.drone);
        } else {
            assert!(notices <= 1, "{} sent {notices} notices", r.drone);
        }
    }
}

/// The ground station of a hub fleet routes for the drones: it leaves
/// once the last drone has, not before, and not for an outsider.
#[tokio::test(start_paused = true)]
async fn a_hub_ground_station_routes_until_the_last_drone_has_left() {
    use crate::transport::inproc::InProcessHub;
    use std::time::Duration;
    let hub = InProcessHub::new();
    let gcs = hub.connect("GCS", &[]);
    let (_d1, _d2, _monitor) = (
        hub.connect("D1", &[]),
        hub.connect("D2", &[]),
        hub.connect("monitor", &[]),
    );
    let drones = ["D1".to_string(), "D2".to_string()];
    let stop = tokio_util::sync::CancellationToken::new();
    let limit = Duration::from_secs(120);
    let mut routing = Box::pin(super::route_until_gone(
        gcs.link.as_ref(),
        &drones,
        &stop,
        limit,
    ));
    let second = Duration::from_secs(1);
    let still = tokio::time::timeout(10 * second, &mut routing).await;
    assert!(still.is_err(), "left with both drones up");
    hub.leave("D1");
    let still = tokio::time::timeout(second, &mut routing).await;
    assert!(still.is_err(), "left with D2 up");
    hub.leave("D2");
    // The monitor is still up: it does not hold the ground station.
    tokio::time::timeout(second, routing)
        .await
        .expect("still routing once every drone had left");
}

/// A drone that never leaves holds the ground station `limit` at most,
/// and Ctrl-C sooner.
#[tokio::test(start_paused = true)]
async fn a_hub_ground_station_stops_routing_after_its_limit_or_when_stopped() {
    use crate::transport::inproc::InProcessHub;
    use std::time::Duration;
    let hub = InProcessHub::new();
    let gcs = hub.connect("GCS", &[]);
    let _d1 = hub.connect("D1", &[]);
    let drones = ["D1".to_string()];
    let stop = tokio_util::sync::CancellationToken::new();
    let began = tokio::time::Instant::now();
    super::route_until_gone(gcs.link.as_ref(), &drones, &stop, Duration::from_secs(120)).await;
    assert_eq!(began.elapsed().as_secs(), 120);
    stop.cancel();
    let began = tokio::time::Instant::now();
    super::route_until_gone(gcs.link.as_ref(), &drones, &stop, Duration::from_secs(120)).await;
    assert_eq!(began.elapsed().as_secs(), 0);
}
