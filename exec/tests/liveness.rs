//! A drone cut off the network mid-mission (the transport fault wrapper's
//! partition, over the in-process link): the drones that do not wait on it
//! carry on untouched, the drone that waits on it follows its fleet's
//! policy once the grace period has passed, the ground station reports who
//! is lost and who is stuck, and no drone flies its failsafe twice.
//!
//! The mission is `examples/dropout.go`: Follow waits for Lead's signal,
//! Free flies on its own. Lead is cut as it sets off on its long leg.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use eamos_exec::event::{Channel, Event, Kind};
use eamos_exec::executor::Report;
use eamos_exec::log::read_mission_log;
use eamos_exec::runner::{run_fleet, RunOptions, RunReport};
use eamos_exec::transport::faulty::Partition;
use eamos_exec::Outcome;
use eamos_fleet::Fleet;
use eamos_lang::SourceFile;
use eamos_mid::Vec3;
use eamos_slicer::Slices;

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples")
        .join(name)
}

fn slices() -> (Slices, Arc<SourceFile>) {
    let path = example("dropout.go");
    slices_of(
        &path.display().to_string(),
        &std::fs::read_to_string(&path).unwrap(),
    )
}

fn slices_of(name: &str, text: &str) -> (Slices, Arc<SourceFile>) {
    let file = SourceFile::new(name.to_string(), text.to_string());
    let profiles = eamos_profile::builtin();
    let mission = eamos_lang::compile(&file, &profiles).unwrap().mission;
    let net = eamos_petri::compile(&mission, &profiles);
    (eamos_slicer::slice(&net).unwrap(), Arc::new(file))
}

/// Whom Lead is cut off from.
#[derive(Clone, Copy)]
enum Cut {
    Everyone,
    /// These peers only: Lead and the rest of the fleet still hear each
    /// other.
    From(&'static [&'static str]),
}

/// When to heal the partition again (the hold test), if ever.
#[derive(Clone, Copy, PartialEq)]
enum Heal {
    Never,
    WhenFollowIsStuck,
}

struct Run {
    report: RunReport,
    dir: tempfile::TempDir,
}

impl Run {
    fn log(&self, peer: &str) -> Vec<Event> {
        read_mission_log(&self.dir.path().join(format!("{peer}.mission.jsonl"))).unwrap()
    }

    fn outcome(&self, peer: &str) -> &Outcome {
        &self.report_of(peer).outcome
    }

    fn report_of(&self, peer: &str) -> &Report {
        self.report
            .reports
            .iter()
            .find(|r| r.drone == peer)
            .unwrap()
    }

    fn failsafes(&self, peer: &str) -> Vec<(String, bool)> {
        self.log(peer)
            .into_iter()
            .filter_map(|r| match r.kind {
                Kind::Failsafe {
                    failsafe, airborne, ..
                } => Some((failsafe, airborne)),
                _ => None,
            })
            .collect()
    }

    fn last_position(&self, drone: &str) -> Vec3 {
        *self.report.trajectories[drone].last().unwrap()
    }

    fn stuck(&self, peer: &str) -> Vec<(Vec<String>, String)> {
        self.log(peer)
            .into_iter()
            .filter_map(|r| match r.kind {
                Kind::Stuck { lost, policy } => Some((lost, policy)),
                _ => None,
            })
            .collect()
    }
}

/// Flies the mission with `fleet`, cutting Lead off as it starts its long
/// leg.
async fn fly_and_cut_lead(fleet: &str, heal: Heal) -> Run {
    fly_mission_and_cut_lead(slices(), fleet, Cut::Everyone, heal).await
}

/// Flies `mission` with `fleet`, cutting Lead off (from everyone or from
/// some peers) as it starts its first `FlyByX`.
async fn fly_mission_and_cut_lead(
    (slices, source): (Slices, Arc<SourceFile>),
    fleet: &str,
    cut_from: Cut,
    heal: Heal,
) -> Run {
    let fleet = Fleet::parse(fleet, "fleet.toml", &slices.mission, &slices.drones).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let partition = Partition::new();
    let (events, mut events_rx) = Channel::new();
    let options = RunOptions {
        speed: 50.0,
        out: dir.path().to_path_buf(),
        source: Some(source),
        max_duration: Some(300.0),
        events: Some(Arc::new(events)),
        partition: Some(partition.clone()),
        ..RunOptions::default()
    };
    let watcher = tokio::spawn(async move {
        let mut cut = false;
        while let Some(e) = events_rx.recv().await {
            match (&e.drone[..], &e.kind) {
                ("Lead", Kind::ActionStarted { action, .. })
                    if action.starts_with("FlyByX") && !cut =>
                {
                    match cut_from {
                        Cut::Everyone => partition.cut("Lead"),
                        Cut::From(peers) => {
                            for p in peers {
                                partition.cut_between("Lead", p);
                            }
                        }
                    }
                    cut = true;
                }
                ("Follow", Kind::Stuck { .. }) if heal == Heal::WhenFollowIsStuck => {
                    partition.heal("Lead");
                }
                _ => {}
            }
        }
        cut
    });
    let profiles = eamos_profile::builtin();
    let report = run_fleet(&slices, &fleet, &profiles, &options)
        .await
        .unwrap();
    drop(options);
    assert!(watcher.await.unwrap(), "Lead was never cut");
    Run { report, dir }
}

/// What every test checks: unless Follow's policy aborts the whole mission,
/// Free flew all its actions; the ground station reported Lead lost and
/// Follow stuck on it; nobody flew a failsafe twice.
fn check_common(run: &Run, policy: &str) {
    if policy != "abort" {
        let free = run.report_of("Free");
        assert_eq!(
            free.actions, 5,
            "Free carries on untouched: {:?}",
            free.outcome
        );
        assert!(
            run.failsafes("Free").iter().all(|(_, airborne)| !airborne),
            "Free was never sent to a failsafe in the air"
        );
    }
    let gcs = run.log("GCS");
    assert!(
        gcs.iter().any(|r| r.kind
            == Kind::PeerLost {
                peer: "Lead".into()
            }),
        "the ground station reports Lead lost"
    );
    assert!(
        gcs.iter().any(|r| r.kind
            == Kind::PeerStuck {
                peer: "Follow".into(),
                lost: "Lead".into(),
                policy: policy.into(),
            }),
        "the ground station reports Follow stuck on Lead"
    );
    assert_eq!(
        run.stuck("Follow"),
        vec![(vec!["Lead".to_string()], policy.to_string())]
    );
    for peer in ["GCS", "Free", "Lead", "Follow"] {
        assert!(
            run.failsafes(peer).len() <= 1,
            "{peer} failsafes: {:?}",
            run.failsafes(peer)
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_waiting_on_a_lost_peer_lands_where_it_waits_when_its_policy_is_land() {
    let run = fly_and_cut_lead(
        "[drones.Follow]\non_lost = \"land\"\ngrace = 2\n",
        Heal::Never,
    )
    .await;
    check_common(&run, "land");
    assert!(
        matches!(run.outcome("Follow"), Outcome::PeerLost { lost, .. } if lost == &["Lead"]),
        "{:?}",
        run.outcome("Follow")
    );
    assert_eq!(run.failsafes("Follow"), vec![("land".to_string(), true)]);
    // Follow waited 5 m east of its home, 4 m up; it landed right there.
    let home = run.report.trajectories["Follow"][0];
    let end = run.last_position("Follow");
    assert!(end.z < 0.2, "Follow landed: {end}");
    assert!(
        (end - (home + Vec3::new(0.0, 5.0, 0.0))).horizontal_norm() < 0.5,
        "Follow landed where it waited: {end}, home {home}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_waiting_on_a_lost_peer_returns_home_and_lands_when_its_policy_is_home() {
    let run = fly_and_cut_lead(
        "[failsafe]\non_lost = \"home\"\ngrace = \"2s\"\n",
        Heal::Never,
    )
    .await;
    check_common(&run, "home");
    assert_eq!(run.failsafes("Follow"), vec![("home".to_string(), true)]);
    let path = &run.report.trajectories["Follow"];
    let home = path[0];
    let end = run.last_position("Follow");
    assert!(
        path.iter().any(|p| (p.y - home.y) > 4.5),
        "Follow had flown east first"
    );
    assert!(end.z < 0.2, "Follow landed: {end}");
    assert!(
        (end - home).horizontal_norm() < 0.5,
        "Follow landed at home: {end}, home {home}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_waiting_on_a_lost_peer_holds_and_goes_on_when_the_peer_is_back_if_its_policy_is_hold(
) {
    let run = fly_and_cut_lead(
        "[drones.Follow]\non_lost = \"hold\"\ngrace = 2\n",
        Heal::WhenFollowIsStuck,
    )
    .await;
    check_common(&run, "hold");
    for r in &run.report.reports {
        assert_eq!(r.outcome, Outcome::Completed, "{}", r.drone);
    }
    assert!(
        run.failsafes("Follow").is_empty(),
        "holding flies no failsafe"
    );
    let follow = run.log("Follow");
    let stuck = follow
        .iter()
        .position(|r| matches!(r.kind, Kind::Stuck { .. }))
        .unwrap();
    let back = follow
        .iter()
        .position(|r| {
            r.kind
                == Kind::PeerBack {
                    peer: "Lead".into(),
                }
        })
        .expect("Follow saw Lead back");
    let second_leg = follow
        .iter()
        .position(|r| matches!(&r.kind, Kind::ActionStarted { action, .. } if action == "FlyByX"))
        .expect("Follow flew its second leg");
    assert!(stuck < back && back < second_leg);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_waiting_on_a_lost_peer_aborts_the_mission_and_every_drone_lands_once_if_its_policy_is_abort(
) {
    let run = fly_and_cut_lead(
        "[failsafe]\ngrace = 2\n\n[drones.Follow]\non_lost = \"abort\"\n",
        Heal::Never,
    )
    .await;
    check_common(&run, "abort");
    assert!(matches!(run.outcome("Follow"), Outcome::Aborted { .. }));
    assert!(
        matches!(run.outcome("GCS"), Outcome::Aborted { reason } if reason.contains("Follow")),
        "{:?}",
        run.outcome("GCS")
    );
    for drone in ["Free", "Lead", "Follow"] {
        assert_eq!(run.failsafes(drone).len(), 1, "{drone}");
        assert!(run.last_position(drone).z < 0.2, "{drone} landed");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_cut_off_from_everyone_decides_alone_once_it_has_nothing_left_to_do() {
    let run = fly_and_cut_lead("[failsafe]\ngrace = 2\non_lost = \"land\"\n", Heal::Never).await;
    // Lead finished its leg and its landing on its own, then found itself
    // alone: the ground station and every peer lost.
    let lead = run.stuck("Lead");
    assert_eq!(lead.len(), 1, "{lead:?}");
    assert_eq!(lead[0].0, vec!["Follow", "Free", "GCS"]);
    assert!(matches!(run.outcome("Lead"), Outcome::PeerLost { .. }));
    let lead_log = run.log("Lead");
    assert!(
        lead_log.iter().any(|r| matches!(
            &r.kind,
            Kind::ActionFinished { action, outcome, .. } if action == "Land()" && outcome == "ok"
        )),
        "{:#?}",
        lead_log.iter().map(|r| &r.kind).collect::<Vec<_>>()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_that_lost_its_neighbours_decides_alone_though_another_drone_is_still_up() {
    // Lead's neighbours are Follow (its signal's bridge) and the ground
    // station; Free, with which it shares nothing, stays in reach.
    let run = fly_mission_and_cut_lead(
        slices(),
        "[failsafe]\ngrace = 2\non_lost = \"land\"\n",
        Cut::From(&["Follow", "GCS"]),
        Heal::Never,
    )
    .await;
    let lead = run.stuck("Lead");
    assert_eq!(
        lead,
        vec![(
            vec!["Follow".to_string(), "GCS".to_string()],
            "land".to_string()
        )],
        "Lead is stuck on its neighbours, not on Free"
    );
    assert!(
        matches!(run.outcome("Lead"), Outcome::PeerLost { lost, .. } if lost == &["Follow", "GCS"]),
        "{:?}",
        run.outcome("Lead")
    );
    let free = run.report_of("Free");
    assert_eq!(free.actions, 5, "Free flew its part: {:?}", free.outcome);
    assert!(
        run.stuck("Free").is_empty(),
        "Free lost nobody it follows: {:?}",
        run.stuck("Free")
    );
}

/// The mission of the condition tests: Free hovers a while on its own,
/// Lead sets off on a long leg (and is cut as it does), Follow flies out,
/// pauses, and then its part depends on `follow_waits`, a guard leading to
/// `SEQ_Near` (a leg and a landing) or `SEQ_Far` (a landing).
fn watching(follow_waits: &str) -> (Slices, Arc<SourceFile>) {
    watching_declared(["Free", "Lead", "Follow"], follow_waits)
}

/// [`watching`] with the drones declared in `order`: a condition is decided
/// by the first drone it reads in declaration order.
fn watching_declared(order: [&str; 3], follow_waits: &str) -> (Slices, Arc<SourceFile>) {
    let [first, second, third] = order;
    let text = format!(
        r#"package Watching

var (
	{first} Quadcopter
	{second} Quadcopter
	{third} Quadcopter
)

func PAR_Mission() {{
	SEQ_Free()
	SEQ_Lead()
	SEQ_Follow()
}}

func SEQ_Free() {{
	Free.Arm()
	Free.Takeoff(3)
	Free.Hover(40)
	Free.Land()
}}

func SEQ_Lead() {{
	Lead.Arm()
	Lead.Takeoff(3)
	Lead.FlyByX(100)
	Lead.Land()
}}

func SEQ_Follow() {{
	Follow.Arm()
	Follow.Takeoff(4)
	Follow.FlyByY(5)
	PauseFor(5)
	{follow_waits}
}}
"#
    );
    let mut text = text;
    if follow_waits.contains("SEQ_Near") {
        text.push_str("\nfunc SEQ_Near() {\n\tFollow.FlyByX(20)\n\tFollow.Land()\n}\n");
    }
    if follow_waits.contains("SEQ_Far") {
        text.push_str("\nfunc SEQ_Far() {\n\tFollow.Land()\n}\n");
    }
    slices_of("watching.go", &text)
}

fn actions_started(run: &Run, peer: &str) -> Vec<String> {
    run.log(peer)
        .into_iter()
        .filter_map(|r| match r.kind {
            Kind::ActionStarted { action, .. } => Some(action),
            _ => None,
        })
        .collect()
}

/// What the condition tests check when Follow is stuck on Lead: Follow
/// says so once, with its policy, the ground station reports it, Follow
/// landed where it waited and took no branch on Lead's frozen telemetry.
fn check_stuck_on_a_condition(run: &Run) {
    assert_eq!(
        run.stuck("Follow"),
        vec![(vec!["Lead".to_string()], "land".to_string())]
    );
    assert!(
        matches!(run.outcome("Follow"), Outcome::PeerLost { lost, .. } if lost == &["Lead"]),
        "{:?}",
        run.outcome("Follow")
    );
    assert!(
        run.log("GCS").iter().any(|r| r.kind
            == Kind::PeerStuck {
                peer: "Follow".into(),
                lost: "Lead".into(),
                policy: "land".into(),
            }),
        "the ground station reports Follow stuck on Lead"
    );
    assert_eq!(run.failsafes("Follow"), vec![("land".to_string(), true)]);
    assert_eq!(
        actions_started(run, "Follow"),
        ["Arm", "Takeoff", "FlyByY"],
        "Follow took no branch"
    );
    let home = run.report.trajectories["Follow"][0];
    let end = run.last_position("Follow");
    assert!(end.z < 0.2, "Follow landed: {end}");
    assert!(
        (end - (home + Vec3::new(0.0, 5.0, 0.0))).horizontal_norm() < 0.5,
        "Follow landed where it waited: {end}, home {home}"
    );
    let free = run.report_of("Free");
    assert_eq!(free.actions, 4, "Free carries on untouched");
}

const LAND_AFTER_2S: &str = "[drones.Follow]\non_lost = \"land\"\ngrace = 2\n";

/// Flies a condition test's mission: Lead is cut for good, and Follow lands
/// once it has been stuck on Lead for 2 s.
async fn fly_watching_and_cut_lead(mission: (Slices, Arc<SourceFile>)) -> Run {
    fly_mission_and_cut_lead(mission, LAND_AFTER_2S, Cut::Everyone, Heal::Never).await
}

/// Follow never counted itself stuck on anyone.
fn assert_follow_not_stuck(run: &Run) {
    assert!(run.stuck("Follow").is_empty(), "{:?}", run.stuck("Follow"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_waiting_on_a_condition_over_a_lost_drone_follows_its_policy() {
    let run = fly_watching_and_cut_lead(watching("WaitUntil(Lead.X() > 90, SEQ_Near)")).await;
    check_stuck_on_a_condition(&run);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drone_deciding_a_condition_over_its_own_and_a_lost_drones_telemetry_follows_its_policy()
{
    // Declared before Lead, Follow decides the condition itself: it holds
    // the token and waits for telemetry that only Lead would send.
    let mission = watching_declared(
        ["Free", "Follow", "Lead"],
        "WaitUntil(Follow.Z() > 1 && Lead.X() > 90, SEQ_Near)",
    );
    let follow = mission.0.get("Follow").unwrap();
    assert!(
        follow
            .transitions
            .iter()
            .any(|t| t.transition.guard.is_some()),
        "Follow decides the condition"
    );
    let run = fly_watching_and_cut_lead(mission).await;
    check_stuck_on_a_condition(&run);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_branch_over_a_lost_drone_is_not_decided_on_its_frozen_telemetry_and_the_drone_follows_its_policy(
) {
    // Lead's last telemetry says it is near home: taken as an answer, it
    // would send Follow down SEQ_Near.
    let run = fly_watching_and_cut_lead(watching("If(Lead.X() < 50, SEQ_Near, SEQ_Far)")).await;
    check_stuck_on_a_condition(&run);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_condition_that_a_drone_still_up_may_answer_is_not_stuck_on_a_lost_drone_it_also_reads() {
    // Free lands at the end of its 40 s hover, long after Lead was lost for
    // the grace period; Follow waits for that, not for Lead.
    let run = fly_watching_and_cut_lead(watching(
        "WaitUntil(Free.Z() < 1 || Lead.X() > 90, SEQ_Far)",
    ))
    .await;
    assert_follow_not_stuck(&run);
    assert_eq!(
        actions_started(&run, "Follow"),
        ["Arm", "Takeoff", "FlyByY", "Land"]
    );
    assert!(run
        .failsafes("Follow")
        .iter()
        .all(|(_, airborne)| !airborne));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_condition_over_a_drones_own_telemetry_is_not_stuck_on_a_lost_peer() {
    // Follow never climbs to 100 m: it waits on itself, to the time limit,
    // and Lead being lost changes nothing about that.
    let run = fly_watching_and_cut_lead(watching("WaitUntil(Follow.Z() > 100, SEQ_Far)")).await;
    assert_follow_not_stuck(&run);
    assert!(
        matches!(run.outcome("Follow"), Outcome::TimeLimit { .. }),
        "{:?}",
        run.outcome("Follow")
    );
    assert_eq!(
        actions_started(&run, "Follow"),
        ["Arm", "Takeoff", "FlyByY"]
    );
}
