//! `eamos run --drone D --journal DIR`, killed with SIGKILL mid-mission and
//! started again with the same journal: one process per drone plus the
//! ground station, over zenoh on loopback. The mission completes, every
//! action of every drone runs exactly once (read from the mission logs of
//! every process, the killed one's two runs included), and a motion cut by
//! the kill ends at the target it had when it started.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use serde_json::Value;

#[path = "common/processes.rs"]
mod processes;
use processes::Processes;

fn paper(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

struct Flight {
    mission: &'static str,
    dir: tempfile::TempDir,
    procs: Processes,
    speed: &'static str,
    grace: u32,
}

impl Flight {
    fn out(&self) -> PathBuf {
        self.dir.path().join("logs")
    }

    fn journal(&self) -> PathBuf {
        self.dir.path().join("journal")
    }

    /// A fleet file whose grace period outlasts a restart: the peers that
    /// wait on the killed drone see it lost, and back before they give up.
    /// (Each test's differs, and so its mission identity and loopback
    /// ports: the tests run side by side.)
    fn fleet(&self) -> PathBuf {
        let path = self.dir.path().join("fleet.toml");
        if !path.exists() {
            let text = format!(
                "[failsafe]\non_lost = \"hold\"\ngrace = \"{}s\"\n",
                self.grace
            );
            std::fs::write(&path, text).unwrap();
        }
        path
    }

    /// Starts one peer (`--drone D` or `--gcs`); `run` numbers its runs.
    fn start(&mut self, role: &[&str], run: u32) {
        let tag = format!("{}-{run}", role.join(""));
        let child = Command::cargo_bin("eamos")
            .unwrap()
            .arg("run")
            .arg(paper(self.mission))
            .args(role)
            .arg("--out")
            .arg(self.out())
            .arg("--journal")
            .arg(self.journal())
            .arg("--fleet")
            .arg(self.fleet())
            .args(["--speed", self.speed, "--max-duration", "900"])
            .stdout(Stdio::from(
                std::fs::File::create(self.dir.path().join(format!("{tag}.out"))).unwrap(),
            ))
            .stderr(Stdio::from(
                std::fs::File::create(self.dir.path().join(format!("{tag}.err"))).unwrap(),
            ))
            .spawn()
            .unwrap();
        self.procs.0.push((tag, child));
    }

    /// Sends SIGKILL to the running process of `tag` and reaps it.
    fn kill(&mut self, tag: &str) {
        let i = self.procs.0.iter().position(|(t, _)| t == tag).unwrap();
        let (_, mut child) = self.procs.0.remove(i);
        child.kill().unwrap();
        let status = child.wait().unwrap();
        assert!(!status.success(), "{tag} had already ended: {status}");
    }

    /// The mission log of `peer` so far (every run of it, in order).
    fn log(&self, peer: &str) -> Vec<Value> {
        std::fs::read_to_string(self.out().join(format!("{peer}.mission.jsonl")))
            .unwrap_or_default()
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect()
    }

    /// Waits until `peer`'s mission log has a record `pred` accepts.
    fn wait_for(&self, peer: &str, what: &str, limit: Duration, pred: impl Fn(&Value) -> bool) {
        let start = Instant::now();
        while !self.log(peer).iter().any(&pred) {
            assert!(
                start.elapsed() < limit,
                "{}: {peer} never logged {what}",
                self.mission
            );
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// Waits for every process to end successfully within `limit`.
    fn finish(&mut self, limit: Duration) {
        let start = Instant::now();
        let mut done = vec![false; self.procs.0.len()];
        while done.iter().any(|d| !d) {
            assert!(
                start.elapsed() < limit,
                "{}: not all peers finished within {limit:?}",
                self.mission
            );
            for (i, (tag, child)) in self.procs.0.iter_mut().enumerate() {
                if done[i] {
                    continue;
                }
                if let Some(status) = child.try_wait().unwrap() {
                    done[i] = true;
                    if !status.success() {
                        let out =
                            std::fs::read_to_string(self.dir.path().join(format!("{tag}.out")));
                        let err =
                            std::fs::read_to_string(self.dir.path().join(format!("{tag}.err")));
                        panic!(
                            "{}: `{tag}` failed ({status}):\n{out:?}\n{err:?}",
                            self.mission
                        );
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

fn slices(mission: &str) -> eamos_slicer::Slices {
    let file =
        eamos_lang::SourceFile::new(mission, std::fs::read_to_string(paper(mission)).unwrap());
    let profiles = eamos_profile::builtin();
    let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
    eamos_slicer::slice(eamos_petri::compile(&m, &profiles)).unwrap()
}

/// Starts every drone, then the ground station, all journaling.
fn fly(mission: &'static str, speed: &'static str, grace: u32) -> Flight {
    let mut f = Flight {
        mission,
        dir: tempfile::tempdir().unwrap(),
        procs: Processes(Vec::new()),
        speed,
        grace,
    };
    for d in &slices(mission).drones {
        f.start(&["--drone", d], 1);
    }
    f.start(&["--gcs"], 1);
    f
}

fn is(r: &Value, event: &str) -> bool {
    r["event"] == event
}

/// Every action of every drone started once and finished well once, over
/// all the runs of its process; every token arrived once; the mission
/// ended once for every peer.
fn assert_exactly_once(f: &Flight) {
    let slices = slices(f.mission);
    for slice in &slices.slices {
        let log = f.log(&slice.drone);
        let mut expected: Vec<u32> = slice
            .transitions
            .iter()
            .filter_map(|t| match &t.transition.kind {
                eamos_petri::net::TransitionKind::ActionStart(a) => Some(a.instance),
                _ => None,
            })
            .collect();
        expected.sort();
        let mut started: BTreeMap<u32, usize> = BTreeMap::new();
        let mut finished: BTreeMap<u32, usize> = BTreeMap::new();
        for r in &log {
            let instance = r["instance"].as_u64().map(|i| i as u32);
            match (r["event"].as_str(), instance) {
                (Some("action_started"), Some(i)) if i != u32::MAX => {
                    *started.entry(i).or_default() += 1
                }
                (Some("action_finished"), Some(i)) if i != u32::MAX && r["outcome"] == "ok" => {
                    *finished.entry(i).or_default() += 1
                }
                _ => {}
            }
        }
        let peer = &slice.drone;
        assert_eq!(
            started.keys().copied().collect::<Vec<_>>(),
            expected,
            "{peer}: actions started"
        );
        assert!(
            started.values().all(|n| *n == 1),
            "{peer}: an action started twice: {started:?}"
        );
        assert_eq!(
            finished.keys().copied().collect::<Vec<_>>(),
            expected,
            "{peer}: actions finished"
        );
        assert!(
            finished.values().all(|n| *n == 1),
            "{peer}: an action finished twice: {finished:?}"
        );
        let received = log.iter().filter(|r| is(r, "bridge_received")).count();
        assert_eq!(received, slice.bridges_in.len(), "{peer}: tokens received");
        let ended = log.iter().filter(|r| is(r, "mission_ended")).count();
        assert!(ended >= 1, "{peer}: the mission never ended");
        let stopped: Vec<&Value> = log.iter().filter(|r| is(r, "stopped")).collect();
        assert_eq!(
            stopped.last().map(|r| r["reason"].clone()),
            Some(Value::from("completed")),
            "{peer}"
        );
    }
}

/// The sim adapter's record of where the drone was when an action ended.
fn ended_at(f: &Flight, drone: &str, action: &str) -> Vec<[f64; 3]> {
    std::fs::read_to_string(f.out().join(format!("{drone}.adapter.jsonl")))
        .unwrap()
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .filter(|r| r["event"] == "completed" && r["action"] == action && r["outcome"] == "ok")
        .filter_map(|r| {
            let d = r["detail"]
                .as_str()?
                .strip_prefix("at (")?
                .strip_suffix(')')?;
            let v: Vec<f64> = d.split(", ").filter_map(|x| x.parse().ok()).collect();
            (v.len() == 3).then(|| [v[0], v[1], v[2]])
        })
        .collect()
}

#[test]
fn a_drone_killed_in_the_middle_of_a_motion_and_restarted_resumes_it_and_the_mission_runs_every_action_once(
) {
    let mut f = fly("experiment_c.go", "4", 600);
    // Drone3's FlyByX(5): from 5 m above its home to 5 m north of it.
    f.wait_for(
        "Drone3",
        "the start of FlyByX",
        Duration::from_secs(120),
        |r| is(r, "action_started") && r["action"] == "FlyByX",
    );
    f.kill("--droneDrone3-1");
    let log = f.log("Drone3");
    assert!(
        !log.iter()
            .any(|r| is(r, "action_finished") && r["action"] == "FlyByX(5)"),
        "the motion had ended before the kill; the test needs it running"
    );
    f.start(&["--drone", "Drone3"], 2);
    f.finish(Duration::from_secs(240));
    assert_exactly_once(&f);

    let log = f.log("Drone3");
    let resumed: Vec<&Value> = log.iter().filter(|r| is(r, "action_resumed")).collect();
    assert_eq!(resumed.len(), 1, "{resumed:?}");
    assert_eq!(resumed[0]["action"], "FlyByX");
    let target: Vec<f64> = resumed[0]["target"]
        .as_object()
        .map(|t| {
            ["x", "y", "z"]
                .iter()
                .map(|k| t[*k].as_f64().unwrap())
                .collect()
        })
        .unwrap();
    for (got, want) in target.iter().zip([5.0, 0.0, 5.0]) {
        assert!((got - want).abs() < 0.3, "journaled target {target:?}");
    }
    // The resumed motion ended at that target, not 5 m further on.
    let first_fly = ended_at(&f, "Drone3", "FlyByX");
    let p = first_fly.first().expect("the resumed FlyByX ended");
    let d = ((p[0] - 5.0).powi(2) + p[1].powi(2) + (p[2] - 5.0).powi(2)).sqrt();
    assert!(d < 0.3, "the resumed motion ended at {p:?}");
    assert!(log.iter().any(|r| is(r, "resumed")));
}

#[test]
fn a_drone_killed_between_two_actions_and_restarted_misses_no_token_and_repeats_no_action() {
    let mut f = fly("experiment_c.go", "10", 601);
    // Drone3 has taken off and waits for the two others to do so.
    f.wait_for(
        "Drone3",
        "the end of its take-off",
        Duration::from_secs(120),
        |r| is(r, "action_finished") && r["action"] == "Takeoff(5)",
    );
    f.kill("--droneDrone3-1");
    std::thread::sleep(Duration::from_millis(500));
    f.start(&["--drone", "Drone3"], 2);
    f.finish(Duration::from_secs(240));
    assert_exactly_once(&f);
    let log = f.log("Drone3");
    assert!(
        !log.iter().any(|r| is(r, "action_resumed")),
        "no action was running at the kill"
    );
    assert!(log.iter().any(|r| is(r, "resumed")));
    // Drone3 came back where it was: its square closes above its home.
    let last = ended_at(&f, "Drone3", "FlyByY");
    let p = last.last().expect("Drone3's last FlyByY ended");
    assert!(p[0].abs() < 0.3 && p[1].abs() < 0.3, "{p:?}");
}
