//! The roll-out: `eamos agent --drone D` processes wait for their slices,
//! `eamos deploy` (or, where a test must send something a real ground
//! station never would, the roll-out library) sends them over zenoh on
//! loopback, signed with a key from `eamos keygen`. `eamos abort` (or,
//! for commands it would never send, the abort library) aborts a deployed
//! mission.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;

use serde_json::Value;

use eamos_exec::abort::{self, AbortCommand};
use eamos_exec::runner::{self, RunOptions};
use eamos_exec::transport::GCS;
use eamos_exec::Outcome;
use eamos_fleet::Fleet;
use eamos_rollout::{self as rollout, Answer, Delivery, RollOut};
use eamos_seal::{GroundKey, Sealed, CONTEXT_SLICE, CONTEXT_START};
use eamos_slicer::Slices;

#[path = "common/processes.rs"]
mod processes;
use processes::free_port;

const DRONES: [&str; 2] = ["Drone1", "Drone2"];

/// The drones of `examples/dropout.go`, whose Lead flies 100 m: long
/// enough to abort it on the way.
const DROPOUT: [&str; 3] = ["Free", "Lead", "Follow"];

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

fn paper(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

/// Kills the agents it still holds when dropped.
struct Agents(Vec<(String, Child)>);

impl Drop for Agents {
    fn drop(&mut self) {
        for (_, c) in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// One test's ground: a directory, a key pair, a fleet file with a roll-out
/// port of its own.
struct Rig {
    dir: tempfile::TempDir,
    fleet: PathBuf,
}

impl Rig {
    /// `extra` is appended to the fleet file; `signed` adds `[keys]`.
    fn new(signed: bool, extra: &str) -> Rig {
        let dir = tempfile::tempdir().unwrap();
        let status = Command::cargo_bin("eamos")
            .unwrap()
            .args(["keygen", "--out"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(status.status.success(), "{status:?}");
        let port = free_port();
        let keys = if signed {
            "[keys]\ngcs = \"gcs.pub\"\n\n"
        } else {
            ""
        };
        let fleet = dir.path().join("fleet.toml");
        std::fs::write(
            &fleet,
            format!("{keys}[rollout]\nlisten = [\"tcp/127.0.0.1:{port}\"]\n{extra}"),
        )
        .unwrap();
        Rig { dir, fleet }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Starts one agent per drone, with `fleet` (the rig's by default).
    fn agents(&self, fleet: Option<&Path>) -> Agents {
        Agents(
            DRONES
                .iter()
                .map(|d| (d.to_string(), self.agent(d, fleet)))
                .collect(),
        )
    }

    /// Starts the agent of `drone`; its output goes to `<drone>.out`
    /// (appended to, so that a restarted agent's follows its first life's).
    fn agent(&self, drone: &str, fleet: Option<&Path>) -> Child {
        let file = |name: String| {
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(self.path(&name))
                .unwrap()
        };
        Command::cargo_bin("eamos")
            .unwrap()
            .args(["agent", "--drone", drone, "--fleet"])
            .arg(fleet.unwrap_or(&self.fleet))
            .arg("--out")
            .arg(self.path("agents"))
            .stdout(Stdio::from(file(format!("{drone}.out"))))
            .stderr(Stdio::from(file(format!("{drone}.err"))))
            .spawn()
            .unwrap()
    }

    /// The records of `event` in the mission log of `drone`'s agent.
    fn events(&self, mission: &str, drone: &str, event: &str) -> Vec<Value> {
        let path = self
            .path("agents")
            .join(mission)
            .join(format!("{drone}.mission.jsonl"));
        std::fs::read_to_string(path)
            .unwrap_or_default()
            .lines()
            .filter_map(|l| serde_json::from_str::<Value>(l).ok())
            .filter(|r| r["event"] == event)
            .collect()
    }

    fn agent_output(&self, drone: &str) -> String {
        std::fs::read_to_string(self.path(&format!("{drone}.out"))).unwrap_or_default()
    }

    /// Runs `eamos deploy` to its end.
    fn deploy(&self, mission: &Path, extra: &[&str]) -> Output {
        let mut cmd = Command::cargo_bin("eamos").unwrap();
        cmd.arg("deploy")
            .arg(mission)
            .arg("--fleet")
            .arg(&self.fleet)
            .arg("--out")
            .arg(self.path("gcs"))
            .args(["--speed", "50", "--max-duration", "600", "--wait", "60"])
            .args(extra);
        let out = cmd.output().unwrap();
        eprintln!(
            "deploy stdout:\n{}\ndeploy stderr:\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        out
    }

    /// The mission's slices as `eamos deploy` cuts them with this fleet.
    fn slices(&self, mission: &Path) -> (Slices, Fleet) {
        let file = eamos_lang::SourceFile::new(
            mission.display().to_string(),
            std::fs::read_to_string(mission).unwrap(),
        );
        let profiles = eamos_profile::builtin();
        let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
        let net = eamos_petri::compile(&m, &profiles);
        let fleet = Fleet::load(&self.fleet, &net.name, &net.drones).unwrap();
        let slices = eamos_fleet::identity::slice(&net, &fleet).unwrap();
        (slices, fleet)
    }

    fn key(&self, name: &str) -> GroundKey {
        GroundKey::load(&self.path(name)).unwrap()
    }
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Waits until every agent's output contains `what`.
fn wait_for_agents_saying(rig: &Rig, what: &str, limit: Duration) {
    wait_for(&DRONES, rig, what, limit)
}

/// Waits until the output of the agents of `drones` contains `what`.
fn wait_for(drones: &[&str], rig: &Rig, what: &str, limit: Duration) {
    let start = Instant::now();
    while !drones.iter().all(|d| rig.agent_output(d).contains(what)) {
        assert!(
            start.elapsed() < limit,
            "agents never said `{what}`: {:?}",
            drones
                .iter()
                .map(|d| rig.agent_output(d))
                .collect::<Vec<_>>()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Waits until `check` holds, polling.
fn wait_until(what: &str, limit: Duration, mut check: impl FnMut() -> bool) {
    let start = Instant::now();
    while !check() {
        assert!(start.elapsed() < limit, "never: {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
}

/// The ground station's roll-out end, in this test process, once both
/// agents are up.
async fn rollout(fleet: &Fleet, key: Option<GroundKey>) -> RollOut {
    let r = RollOut::open(fleet, key).await.unwrap();
    let drones: Vec<String> = DRONES.map(String::from).to_vec();
    let missing = r.wait_for_agents(&drones, Duration::from_secs(60)).await;
    assert!(missing.is_empty(), "agents missing: {missing:?}");
    r
}

#[test]
fn deploying_signed_slices_to_agents_flies_experiment_b_to_completion() {
    let rig = Rig::new(true, "");
    let _agents = rig.agents(None);
    let out = rig.deploy(&paper("experiment_b.go"), &[]);
    let text = stdout(&out);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("signed by ed25519:"), "{text}");
    for d in DRONES {
        assert!(text.contains(&format!("{d}: sent")), "{text}");
    }
    assert!(text.contains("mission ExperimentB completed"), "{text}");
    wait_for_agents_saying(&rig, "ended: completed", Duration::from_secs(60));
    for d in DRONES {
        let said = rig.agent_output(d);
        assert!(
            said.contains("trusts the ground station key ed25519:"),
            "{said}"
        );
        assert!(
            said.contains("accepted the slice of ExperimentB-"),
            "{said}"
        );
    }
}

#[test]
fn after_an_edit_only_the_drone_whose_part_changed_gets_a_new_slice() {
    let rig = Rig::new(true, "");
    let _agents = rig.agents(None);
    let v1 = paper("experiment_b.go");
    let out = rig.deploy(&v1, &["--no-start"]);
    assert!(out.status.success(), "{}", stdout(&out));
    // Drone2 flies its second leg 2 m instead of 1 m; Drone1's part stays.
    let text = std::fs::read_to_string(&v1).unwrap();
    let edited = text.replacen(
        "Drone2.FlyByY(1)\n}\n\nfunc PAR_Fly3",
        "Drone2.FlyByY(2)\n}\n\nfunc PAR_Fly3",
        1,
    );
    assert_ne!(edited, text, "the edit applies");
    let v2 = rig.path("experiment_b_v2.go");
    std::fs::write(&v2, edited).unwrap();
    let out = rig.deploy(&v2, &[]);
    let said = stdout(&out);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("Drone1: unchanged"), "{said}");
    assert!(said.contains("Drone2: sent"), "{said}");
    assert!(said.contains("mission ExperimentB completed"), "{said}");
    wait_for_agents_saying(&rig, "ended: completed", Duration::from_secs(60));
    assert_eq!(
        rig.agent_output("Drone1")
            .matches("accepted the slice")
            .count(),
        1,
        "Drone1 got one slice only"
    );
    assert_eq!(
        rig.agent_output("Drone2")
            .matches("accepted the slice")
            .count(),
        2
    );
}

#[test]
fn a_slice_built_with_another_fleet_file_is_refused_as_a_wrong_mission_version() {
    let rig = Rig::new(true, "");
    // The agents' copy of the fleet file places Drone1 elsewhere.
    let theirs = rig.path("their-fleet.toml");
    let mine = std::fs::read_to_string(&rig.fleet).unwrap();
    std::fs::write(
        &theirs,
        format!("{mine}\n[drones.Drone1]\nhome = {{ x = 5.0, y = 0.0, z = 0.0 }}\n"),
    )
    .unwrap();
    let _agents = rig.agents(Some(&theirs));
    let out = rig.deploy(&paper("experiment_b.go"), &[]);
    let said = stdout(&out);
    assert_eq!(out.status.code(), Some(1), "{said}");
    for d in DRONES {
        assert!(
            said.contains(&format!("{d}: refused: wrong mission version")),
            "{said}"
        );
    }
    assert!(!said.contains("started"), "{said}");
}

#[test]
fn a_tampered_slice_and_an_unsigned_one_are_refused_each_with_its_reason() {
    let rig = Rig::new(true, "");
    let _agents = rig.agents(None);
    let (slices, fleet) = rig.slices(&paper("experiment_b.go"));
    let key = rig.key("gcs.key");
    runtime().block_on(async {
        let r = rollout(&fleet, None).await;
        let slice = slices.get("Drone1").unwrap();
        let bundle = r.offer(&slices, slice, true);
        // Signed, then one byte of the slice changed on the way.
        let mut tampered = key.seal(CONTEXT_SLICE, bundle.to_bytes()).to_bytes();
        let n = tampered.len();
        tampered[n / 2] ^= 0x20;
        match r.send_sealed_slice("Drone1", tampered).await {
            Delivery::Refused { reason } => {
                assert!(reason.starts_with("bad signature"), "{reason}")
            }
            other => panic!("a tampered slice was {other}"),
        }
        let unsigned = Sealed::unsigned(CONTEXT_SLICE, bundle.to_bytes()).to_bytes();
        match r.send_sealed_slice("Drone1", unsigned).await {
            Delivery::Refused { reason } => assert!(reason.starts_with("not signed"), "{reason}"),
            other => panic!("an unsigned slice was {other}"),
        }
        // The genuine one passes.
        let genuine = key.seal(CONTEXT_SLICE, bundle.to_bytes()).to_bytes();
        assert!(matches!(
            r.send_sealed_slice("Drone1", genuine).await,
            Delivery::Sent { .. }
        ));
        r.close().await;
    });
    let said = rig.agent_output("Drone1");
    assert!(said.contains("refused a slice: bad signature"), "{said}");
    assert!(said.contains("refused a slice: not signed"), "{said}");
}

#[test]
fn slices_signed_with_another_key_are_refused_naming_the_key() {
    let rig = Rig::new(true, "");
    let _agents = rig.agents(None);
    let (slices, fleet) = rig.slices(&paper("experiment_b.go"));
    let stranger = GroundKey::generate().unwrap();
    let stranger_print = stranger.public().fingerprint();
    let trusted_print = rig.key("gcs.key").public().fingerprint();
    runtime().block_on(async {
        let r = rollout(&fleet, Some(stranger)).await;
        let delivered = r.deliver(&slices).await;
        for d in DRONES {
            match &delivered[d] {
                Delivery::Refused { reason } => {
                    assert!(reason.starts_with("unknown key"), "{reason}");
                    assert!(reason.contains(&stranger_print), "{reason}");
                    assert!(reason.contains(&trusted_print), "{reason}");
                }
                other => panic!("{d}: a slice of another key was {other}"),
            }
        }
        r.close().await;
    });
}

#[test]
fn an_unsigned_or_misdirected_start_command_is_refused() {
    let rig = Rig::new(true, "");
    let _agents = rig.agents(None);
    let (slices, fleet) = rig.slices(&paper("experiment_b.go"));
    let key = rig.key("gcs.key");
    let drones: Vec<String> = DRONES.map(String::from).to_vec();
    runtime().block_on(async {
        let r = rollout(&fleet, Some(rig.key("gcs.key"))).await;
        let delivered = r.deliver(&slices).await;
        assert!(
            delivered
                .values()
                .all(|d| matches!(d, Delivery::Sent { .. })),
            "{delivered:?}"
        );
        let start = r.start_command(&slices, &RunOptions::default());
        let unsigned = Sealed::unsigned(CONTEXT_START, start.to_bytes()).to_bytes();
        for (d, a) in r.send_start(&drones, unsigned).await {
            match a {
                Answer::Refused { reason } => {
                    assert!(reason.starts_with("not signed"), "{d}: {reason}")
                }
                other => panic!("{d}: an unsigned start was {other:?}"),
            }
        }
        // Signed, but for another version of the mission than the slices held.
        let mut other = start.clone();
        other.identity = "ExperimentB-000000000000000000000000".into();
        other.digests.insert("Drone2".into(), "0".repeat(32));
        let signed = key.seal(CONTEXT_START, other.to_bytes()).to_bytes();
        match &r.send_start(&drones[1..], signed).await["Drone2"] {
            Answer::Refused { reason } => {
                assert!(reason.starts_with("wrong mission version"), "{reason}")
            }
            other => panic!("a start for another version was {other:?}"),
        }
        r.close().await;
    });
    let said = rig.agent_output("Drone2");
    assert!(
        said.contains("refused a start command: not signed"),
        "{said}"
    );
    assert!(!said.contains("started mission"), "{said}");
}

#[test]
fn keygen_never_overwrites_an_existing_key() {
    let rig = Rig::new(true, "");
    let before = std::fs::read(rig.path("gcs.key")).unwrap();
    let out = Command::cargo_bin("eamos")
        .unwrap()
        .args(["keygen", "--out"])
        .arg(rig.dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("gcs.key"), "{err}");
    assert_eq!(std::fs::read(rig.path("gcs.key")).unwrap(), before);
}

#[test]
fn deploying_with_a_key_the_fleet_does_not_trust_is_bad_input_before_anything_is_sent() {
    let rig = Rig::new(true, "");
    let made = Command::cargo_bin("eamos")
        .unwrap()
        .args(["keygen", "--name", "other", "--out"])
        .arg(rig.dir.path())
        .output()
        .unwrap();
    assert!(made.status.success());
    let other = rig.path("other.key");
    let out = rig.deploy(
        &paper("experiment_b.go"),
        &["--key", other.to_str().unwrap()],
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("other.key") && err.contains("the fleet file trusts"),
        "{err}"
    );
    // Without the secret key beside the fleet's public key, likewise.
    std::fs::remove_file(rig.path("gcs.key")).unwrap();
    let out = rig.deploy(&paper("experiment_b.go"), &[]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("gcs.key"), "{err}");
}

/// Sends `command`, sealed by `key` (unsigned without), to every peer of
/// the deployed mission of `slices`, as `eamos abort` would; how many
/// copies were not acknowledged.
fn send_abort(
    slices: &Slices,
    fleet: &Fleet,
    command: &AbortCommand,
    key: Option<GroundKey>,
) -> usize {
    let peers = runner::peers(slices);
    let mut options = fleet.zenoh_options(&slices.mission_id, &peers, GCS);
    options.connect = peers
        .iter()
        .flat_map(|p| fleet.listen(&slices.mission_id, &peers, p))
        .collect();
    options.listen = Vec::new();
    let sealed = |k: Option<GroundKey>| -> abort::CommandSealer {
        let k = k.map(std::sync::Arc::new);
        std::sync::Arc::new(move |payload| abort::seal_command(k.as_deref(), payload))
    };
    runtime()
        .block_on(abort::broadcast(
            command,
            &format!("test-abort-{}", command.nonce),
            &peers,
            &options,
            Some(&sealed(key)),
            Duration::from_secs(20),
        ))
        .unwrap()
        .unacknowledged
}

/// Starts the agents of `examples/dropout.go` and `eamos deploy` in the
/// background (its output in `deploy.out`), and waits until Lead flies its
/// long leg. The deploy process is the last of the processes returned.
fn deploy_dropout_and_wait_for_the_long_leg(rig: &Rig) -> Agents {
    let mut procs: Vec<(String, Child)> = DROPOUT
        .iter()
        .map(|d| (d.to_string(), rig.agent(d, None)))
        .collect();
    let deploy = Command::cargo_bin("eamos")
        .unwrap()
        .arg("deploy")
        .arg(example("dropout.go"))
        .arg("--fleet")
        .arg(&rig.fleet)
        .arg("--out")
        .arg(rig.path("gcs"))
        .args(["--speed", "10", "--max-duration", "300", "--wait", "60"])
        .stdout(Stdio::from(
            std::fs::File::create(rig.path("deploy.out")).unwrap(),
        ))
        .stderr(Stdio::from(
            std::fs::File::create(rig.path("deploy.err")).unwrap(),
        ))
        .spawn()
        .unwrap();
    procs.push(("deploy".to_string(), deploy));
    let procs = Agents(procs);
    wait_for(&DROPOUT, rig, "started mission", Duration::from_secs(120));
    wait_until("Lead flies its 100 m leg", Duration::from_secs(120), || {
        rig.events("Dropout", "Lead", "action_started")
            .iter()
            .any(|e| e["action"] == "FlyByX")
    });
    procs
}

/// Waits for the `eamos deploy` process of `procs` to end.
fn deploy_status(procs: &mut Agents) -> std::process::ExitStatus {
    let start = Instant::now();
    let (_, deploy) = procs.0.last_mut().unwrap();
    loop {
        if let Some(s) = deploy.try_wait().unwrap() {
            return s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "eamos deploy did not end"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_deployed_agent_refuses_unsigned_foreign_and_replayed_aborts_flies_on_and_obeys_a_signed_one_with_one_failsafe(
) {
    let rig = Rig::new(true, "");
    let mission = example("dropout.go");
    let (slices, fleet) = rig.slices(&mission);
    let mut procs = deploy_dropout_and_wait_for_the_long_leg(&rig);

    let issued_by = "a test that is not the ground station";
    let unsigned = AbortCommand::new(&slices.mission_id, issued_by);
    assert_eq!(send_abort(&slices, &fleet, &unsigned, None), 0);
    let stranger = GroundKey::generate().unwrap();
    let foreign = AbortCommand::new(&slices.mission_id, issued_by);
    assert_eq!(send_abort(&slices, &fleet, &foreign, Some(stranger)), 0);
    // Signed by the ground station, but in a flight that ended before this
    // one began: a recording played back.
    let mut recorded = AbortCommand::new(&slices.mission_id, issued_by);
    recorded.issued_at_ms -= 10 * abort::ABORT_CLOCK_SKEW_MS;
    assert_eq!(
        send_abort(&slices, &fleet, &recorded, Some(rig.key("gcs.key"))),
        0
    );
    for d in DROPOUT {
        wait_until(
            &format!("{d} refuses three aborts"),
            Duration::from_secs(60),
            || rig.events("Dropout", d, "abort_refused").len() >= 3,
        );
        let refused: Vec<String> = rig
            .events("Dropout", d, "abort_refused")
            .iter()
            .map(|e| e["reason"].as_str().unwrap_or_default().to_string())
            .collect();
        for why in ["not signed", "unknown key", "replayed abort command"] {
            assert!(
                refused.iter().any(|r| r.contains(why)),
                "{d}: no refusal saying `{why}`: {refused:?}"
            );
        }
        assert!(rig.events("Dropout", d, "failsafe").is_empty(), "{d}");
        assert!(rig.events("Dropout", d, "abort_received").is_empty(), "{d}");
    }
    assert!(
        !rig.agent_output("Lead").contains("ended"),
        "Lead flies on: {}",
        rig.agent_output("Lead")
    );

    // `eamos abort` signs with the key beside the fleet's public key.
    let out = Command::cargo_bin("eamos")
        .unwrap()
        .arg("abort")
        .arg(&mission)
        .arg("--fleet")
        .arg(&rig.fleet)
        .args(["--timeout", "20"])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{said}");
    assert!(said.contains("0 not acknowledged"), "{said}");
    wait_for(&DROPOUT, &rig, "ended", Duration::from_secs(120));
    for d in DROPOUT {
        let received = rig.events("Dropout", d, "abort_received");
        assert_eq!(received.len(), 1, "{d}: {received:?}");
        let failsafe = rig.events("Dropout", d, "failsafe");
        assert_eq!(failsafe.len(), 1, "{d}: {failsafe:?}");
        assert_eq!(failsafe[0]["failsafe"], "land", "{d}");
        assert!(!rig.agent_output(d).contains("ended: completed"), "{d}");
    }
    let status = deploy_status(&mut procs);
    assert_eq!(status.code(), Some(1), "an aborted mission is no success");
}

#[test]
fn eamos_abort_without_the_secret_key_of_a_fleet_that_names_one_is_bad_input() {
    let rig = Rig::new(true, "");
    std::fs::remove_file(rig.path("gcs.key")).unwrap();
    let out = Command::cargo_bin("eamos")
        .unwrap()
        .arg("abort")
        .arg(example("dropout.go"))
        .arg("--fleet")
        .arg(&rig.fleet)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot sign the abort") && err.contains("gcs.key"),
        "{err}"
    );
}

#[test]
fn ctrl_c_on_eamos_deploy_aborts_every_deployed_drone_with_a_signed_command_and_one_failsafe() {
    let rig = Rig::new(true, "");
    let mut procs = deploy_dropout_and_wait_for_the_long_leg(&rig);
    let pid = procs.0.last().unwrap().1.id();
    let kill = Command::new("kill")
        .args(["-INT", &pid.to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    assert_eq!(deploy_status(&mut procs).code(), Some(1));
    wait_for(&DROPOUT, &rig, "ended", Duration::from_secs(120));
    for d in DROPOUT {
        let received = rig.events("Dropout", d, "abort_received");
        assert_eq!(received.len(), 1, "{d}: {received:?}");
        // Obeyed as the ground station's command (checked against its
        // key), not as a peer's abort.
        let reason = received[0]["reason"].as_str().unwrap_or_default();
        assert!(reason.contains("aborted by GCS (stopped)"), "{d}: {reason}");
        assert!(rig.events("Dropout", d, "abort_refused").is_empty(), "{d}");
        assert_eq!(rig.events("Dropout", d, "failsafe").len(), 1, "{d}");
    }
}

#[test]
fn a_recorded_offer_and_start_played_back_after_the_flight_are_refused_even_by_a_restarted_agent() {
    let rig = Rig::new(true, "");
    let mut agents = rig.agents(None);
    let (slices, fleet) = rig.slices(&paper("experiment_b.go"));
    let drones: Vec<String> = DRONES.map(String::from).to_vec();
    let run = RunOptions {
        speed: 50.0,
        max_duration: Some(600.0),
        out: rig.path("gcs"),
        ..RunOptions::default()
    };
    // The ground station's deploy, recorded envelope by envelope.
    let (offers, start) = runtime().block_on(async {
        let r = rollout(&fleet, Some(rig.key("gcs.key"))).await;
        let mut offers = Vec::new();
        for d in DRONES {
            let offer = r.seal_offer(&r.offer(&slices, slices.get(d).unwrap(), true));
            assert!(matches!(
                r.send_sealed_slice(d, offer.clone()).await,
                Delivery::Sent { .. }
            ));
            offers.push((d, offer));
        }
        let start = r.seal_start(&r.start_command(&slices, &run));
        for (d, a) in r.send_start(&drones, start.clone()).await {
            assert!(matches!(a, Answer::Accepted { .. }), "{d}: {a:?}");
        }
        r.close().await;
        let profiles = eamos_profile::builtin();
        let report = rollout::fly_ground_station(&slices, &fleet, &profiles, &run)
            .await
            .unwrap();
        assert_eq!(report.reports[0].outcome, Outcome::Completed);
        (offers, start)
    });
    wait_for_agents_saying(&rig, "ended: completed", Duration::from_secs(60));

    // Played back to the agents that flew it.
    let replay = |what: &str| {
        runtime().block_on(async {
            let r = rollout(&fleet, None).await;
            for (d, offer) in &offers {
                match r.send_sealed_slice(d, offer.clone()).await {
                    Delivery::Refused { reason } => {
                        assert!(reason.starts_with("replayed slice"), "{what} {d}: {reason}")
                    }
                    other => panic!("{what} {d}: a recorded offer was {other}"),
                }
            }
            for (d, a) in r.send_start(&drones, start.clone()).await {
                match a {
                    Answer::Refused { reason } => assert!(
                        reason.starts_with("replayed start command"),
                        "{what} {d}: {reason}"
                    ),
                    other => panic!("{what} {d}: a recorded start was {other:?}"),
                }
            }
            r.close().await;
        })
    };
    replay("after the flight:");

    // Drone1's agent restarts, holding nothing: its disk remembers.
    let (_, first) = &mut agents.0[0];
    first.kill().unwrap();
    first.wait().unwrap();
    agents.0[0].1 = rig.agent("Drone1", None);
    replay("after a restart:");
    let said = rig.agent_output("Drone1");
    assert_eq!(said.matches("started mission").count(), 1, "{said}");
    assert!(said.contains("refused a start command: replayed"), "{said}");
}
