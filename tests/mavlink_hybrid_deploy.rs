//! Experiment C deployed as a drone team flies it: an `eamos agent` per
//! drone (an ArduPilot-like copter, a PX4-like copter, each bound to its
//! autopilot, and a simulated drone) and `eamos deploy` on the ground
//! station, with signed slices. `tests/mavlink_experiment_c.rs` flies the
//! same fleet through `eamos run --fleet`.

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::mavlink::free_udp_port;
use common::rollout::text;

/// A process killed when the test ends, however it ends.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn eamos() -> Command {
    Command::new(env!("CARGO_BIN_EXE_eamos"))
}

fn sim_vehicle(port: u16, extra: &[&str]) -> Running {
    Running(
        eamos()
            .args(["sim-vehicle", "--connect"])
            .arg(format!("udpout:127.0.0.1:{port}"))
            .args(["--ready-after", "10", "--speed", "5", "--exit-after", "300"])
            .args(extra)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    )
}

fn agent(dir: &Path, fleet: &Path, drone: &str) -> Running {
    let file =
        |ext: &str| Stdio::from(std::fs::File::create(dir.join(format!("{drone}.{ext}"))).unwrap());
    Running(
        eamos()
            .args(["agent", "--drone", drone, "--once", "--fleet"])
            .arg(fleet)
            .arg("--out")
            .arg(dir.join(format!("agent-{drone}")))
            .stdout(file("out"))
            .stderr(file("err"))
            .spawn()
            .unwrap(),
    )
}

fn adapter_log(dir: &Path, drone: &str) -> Vec<serde_json::Value> {
    let path = dir
        .join(format!("agent-{drone}"))
        .join("ExperimentC")
        .join(format!("{drone}.adapter.jsonl"));
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

#[test]
fn experiment_c_deployed_to_an_ardupilot_agent_a_px4_agent_and_a_simulated_one_completes() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let keygen = eamos().args(["keygen", "--out"]).arg(dir).output().unwrap();
    assert!(keygen.status.success(), "{}", text(&keygen));
    let (p1, p2) = (free_udp_port(), free_udp_port());
    let _v1 = sim_vehicle(p1, &[]);
    // See experiment C through `eamos run` for the offboard-loss time.
    let _v2 = sim_vehicle(
        p2,
        &[
            "--sysid",
            "2",
            "--autopilot",
            "px4",
            "--offboard-loss-after",
            "3",
        ],
    );
    let rollout = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mavlink = |drone: &str, port: u16, y: f64| {
        format!("[drones.{drone}]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\nhome = {{ x = 0.0, y = {y}, z = 0.0 }}\n\n")
    };
    let fleet = dir.join("fleet.toml");
    std::fs::write(
        &fleet,
        format!(
            "[keys]\ngcs = \"gcs.pub\"\n\n[rollout]\nlisten = [\"tcp/127.0.0.1:{rollout}\"]\n\n{}{}[drones.Drone3]\nhome = {{ x = 0.0, y = 6.0, z = 0.0 }}\n",
            mavlink("Drone1", p1, 0.0),
            mavlink("Drone2", p2, 3.0),
        ),
    )
    .unwrap();
    let mut agents: Vec<(&str, Running)> = ["Drone1", "Drone2", "Drone3"]
        .into_iter()
        .map(|d| (d, agent(dir, &fleet, d)))
        .collect();

    let deployed = eamos()
        .arg("deploy")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/missions/paper/experiment_c.go"))
        .arg("--fleet")
        .arg(&fleet)
        .arg("--out")
        .arg(dir.join("gcs"))
        .args(["--speed", "5", "--max-duration", "600", "--wait", "60"])
        .output()
        .unwrap();
    let said =
        |drone: &str| std::fs::read_to_string(dir.join(format!("{drone}.out"))).unwrap_or_default();
    assert!(
        deployed.status.success(),
        "{}\n{}\n{}\n{}",
        text(&deployed),
        said("Drone1"),
        said("Drone2"),
        said("Drone3")
    );
    let deadline = Instant::now() + Duration::from_secs(60);
    for (drone, Running(child)) in &mut agents {
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            assert!(Instant::now() < deadline, "the agent of {drone} still runs");
            std::thread::sleep(Duration::from_millis(50));
        };
        assert!(status.success(), "{drone}: {status}\n{}", said(drone));
        assert!(said(drone).contains("ended: completed"), "{}", said(drone));
    }
    // Each agent flew its drone through its own adapter, every action well.
    // (The simulator logs the motions it completes, not arming.)
    for (drone, adapter, actions, guided) in [
        ("Drone1", "mavlink", 8, Some("GUIDED")),
        ("Drone2", "mavlink", 8, Some("OFFBOARD")),
        ("Drone3", "sim", 6, None),
    ] {
        let log = adapter_log(dir, drone);
        assert!(
            !log.is_empty() && log.iter().all(|r| r["adapter"] == adapter),
            "{drone}"
        );
        let completed: Vec<_> = log.iter().filter(|r| r["event"] == "completed").collect();
        assert_eq!(completed.len(), actions, "{drone}: {completed:?}");
        assert!(
            completed.iter().all(|r| r["outcome"] == "ok"),
            "{drone}: {completed:?}"
        );
        if let Some(mode) = guided {
            assert!(
                log.iter()
                    .any(|r| r["detail"] == format!("mode {mode} set and confirmed")),
                "{drone}"
            );
            assert!(log.iter().any(|r| r["detail"] == "disarmed"), "{drone}");
        }
    }
}
