//! The roll-out: `eamos agent --drone D` processes wait for their slices,
//! `eamos deploy` (or, where a test must send something a real ground
//! station never would, the roll-out library) sends them over zenoh on
//! loopback, signed with a key from `eamos keygen`.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;

use eamos_exec::deploy::{Answer, Delivery, RollOut, SliceBundle};
use eamos_exec::fleet::Fleet;
use eamos_exec::runner::RunOptions;
use eamos_seal::{GroundKey, Sealed, CONTEXT_SLICE, CONTEXT_START};
use eamos_slicer::Slices;

const DRONES: [&str; 2] = ["Drone1", "Drone2"];

fn paper(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/missions/paper")
        .join(name)
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
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
        let mut agents = Agents(Vec::new());
        for d in DRONES {
            let child = Command::cargo_bin("eamos")
                .unwrap()
                .args(["agent", "--drone", d, "--fleet"])
                .arg(fleet.unwrap_or(&self.fleet))
                .arg("--out")
                .arg(self.path("agents"))
                .stdout(Stdio::from(
                    std::fs::File::create(self.path(&format!("{d}.out"))).unwrap(),
                ))
                .stderr(Stdio::from(
                    std::fs::File::create(self.path(&format!("{d}.err"))).unwrap(),
                ))
                .spawn()
                .unwrap();
            agents.0.push((d.to_string(), child));
        }
        agents
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
        let profiles = eamos_mid::profiles::builtin();
        let m = eamos_lang::compile(&file, &profiles).unwrap().mission;
        let net = eamos_petri::compile(&m, &profiles);
        let mut slices = eamos_slicer::slice(&net).unwrap();
        let fleet = Fleet::load(&self.fleet, &slices.mission, &net.drones).unwrap();
        eamos_exec::identity::bind(&mut slices, &fleet);
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
    let start = Instant::now();
    while !DRONES.iter().all(|d| rig.agent_output(d).contains(what)) {
        assert!(
            start.elapsed() < limit,
            "agents never said `{what}`: {:?}",
            DRONES.map(|d| rig.agent_output(d))
        );
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
        let bundle = SliceBundle {
            identity: slices.mission_id.clone(),
            fleet: eamos_exec::identity::fleet_version(&fleet),
            slice: slice.to_bytes(),
        };
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
