//! A MAVLink copter flown through the roll-out, as a drone team flies one:
//! `eamos agent` on the drone's companion computer bound to its autopilot,
//! `eamos deploy` on the ground station with signed slices. The agent can
//! be killed and started again, as a companion computer that reboots.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use super::mavlink::example;

/// A key pair, a fleet file, and the agent of `Copter`.
pub struct Rollout {
    pub dir: tempfile::TempDir,
    pub fleet: PathBuf,
    pub agent: Child,
    /// How many times the agent was started.
    starts: usize,
}

impl Drop for Rollout {
    fn drop(&mut self) {
        let _ = self.agent.kill();
        let _ = self.agent.wait();
    }
}

impl Rollout {
    /// A fleet file binding `Copter` to the vehicle on `port` (with
    /// `failsafe` added to its `[failsafe]` table and `mavlink` to the
    /// drone's `mavlink` table), a roll-out port of its own, a key pair,
    /// and the copter's agent started with `--once`.
    pub fn start(port: u16, failsafe: &str, mavlink: &str) -> Rollout {
        Rollout::start_fleet(
            "",
            failsafe,
            &format!("[drones.Copter]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\n\n[drones.Copter.mavlink]\n{mavlink}"),
        )
    }

    /// [`Rollout::start`] with the fleet file's top (`origin = ...`) and
    /// the copter's tables given whole.
    pub fn start_fleet(top: &str, failsafe: &str, copter: &str) -> Rollout {
        let dir = tempfile::tempdir().unwrap();
        let keygen = Command::new(env!("CARGO_BIN_EXE_eamos"))
            .args(["keygen", "--out"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(keygen.status.success(), "{keygen:?}");
        let rollout = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let fleet = dir.path().join("fleet.toml");
        std::fs::write(
            &fleet,
            format!(
                "{top}[keys]\ngcs = \"gcs.pub\"\n\n[rollout]\nlisten = [\"tcp/127.0.0.1:{rollout}\"]\n\n[failsafe]\non_abort = \"land\"\n{failsafe}\n{copter}"
            ),
        )
        .unwrap();
        let agent = spawn_agent(dir.path(), &fleet, 1);
        Rollout {
            dir,
            fleet,
            agent,
            starts: 1,
        }
    }

    /// Kills the agent with SIGKILL, as a power cut would.
    pub fn kill_agent(&mut self) {
        self.agent.kill().unwrap();
        self.agent.wait().unwrap();
    }

    /// Starts the agent again, with the same fleet file and directory.
    pub fn restart_agent(&mut self) {
        self.starts += 1;
        self.agent = spawn_agent(self.dir.path(), &self.fleet, self.starts);
    }

    /// `eamos deploy` of the square, with this fleet.
    pub fn deploy(&self) -> Command {
        let mut c = Command::new(env!("CARGO_BIN_EXE_eamos"));
        c.arg("deploy")
            .arg(example("square.go"))
            .arg("--fleet")
            .arg(&self.fleet)
            .arg("--out")
            .arg(self.dir.path().join("gcs"))
            .args(["--max-duration", "600", "--wait", "60"]);
        c
    }

    /// Everything every start of the agent printed.
    pub fn agent_said(&self) -> String {
        (1..=self.starts)
            .map(|n| {
                std::fs::read_to_string(self.dir.path().join(format!("agent-{n}.out")))
                    .unwrap_or_default()
            })
            .collect::<Vec<_>>()
            .join("")
    }

    /// Where the agent keeps the mission's logs.
    pub fn mission_logs(&self) -> PathBuf {
        self.dir.path().join("agents").join("Square")
    }

    /// The agent's mission log, as JSON records.
    pub fn mission_log(&self) -> Vec<serde_json::Value> {
        std::fs::read_to_string(self.mission_logs().join("Copter.mission.jsonl"))
            .unwrap_or_default()
            .lines()
            .filter_map(|l| serde_json::from_str(l).ok())
            .collect()
    }

    /// Waits until the agent's mission log holds a record that `seen`
    /// picks, and returns it.
    pub fn wait_log(
        &self,
        what: &str,
        limit: Duration,
        seen: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let deadline = Instant::now() + limit;
        loop {
            if let Some(r) = self.mission_log().into_iter().find(|r| seen(r)) {
                return r;
            }
            assert!(
                Instant::now() < deadline,
                "never saw {what} within {limit:?}; the agent said:\n{}",
                self.agent_said()
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Waits until the agent has printed a line containing `needle`.
    pub fn wait_said(&self, needle: &str, limit: Duration) {
        let deadline = Instant::now() + limit;
        while !self.agent_said().contains(needle) {
            assert!(
                Instant::now() < deadline,
                "the agent never said `{needle}` within {limit:?}:\n{}",
                self.agent_said()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits for the agent to end (`--once`).
    pub fn agent_ends(&mut self, limit: Duration) {
        let deadline = Instant::now() + limit;
        while self.agent.try_wait().unwrap().is_none() {
            assert!(
                Instant::now() < deadline,
                "the agent still runs: {}",
                self.agent_said()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

fn spawn_agent(dir: &Path, fleet: &Path, n: usize) -> Child {
    Command::new(env!("CARGO_BIN_EXE_eamos"))
        .args(["agent", "--drone", "Copter", "--once", "--fleet"])
        .arg(fleet)
        .arg("--out")
        .arg(dir.join("agents"))
        .stdout(Stdio::from(
            std::fs::File::create(dir.join(format!("agent-{n}.out"))).unwrap(),
        ))
        .stderr(Stdio::from(
            std::fs::File::create(dir.join(format!("agent-{n}.err"))).unwrap(),
        ))
        .spawn()
        .unwrap()
}

/// What a finished command printed, both streams.
pub fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}
