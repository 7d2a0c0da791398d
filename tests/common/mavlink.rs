//! What the MAVLink end-to-end tests share: a test vehicle in the test's
//! own process (so that the test can be its pilot and its radio), and
//! `eamos run` flying a mission in a process of its own, its progress
//! lines read as they come. Every wait is bounded.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use eamos_mid::mavlink::modes::CopterMode;
use eamos_mid::mavlink::ConnectAddress;
use eamos_vehicle::{SimVehicle, SimVehicleOptions, VehicleSnapshot};

pub fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free loopback port")
        .port()
}

pub fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

/// A copter behind a MAVLink endpoint, in this process, `speed` times as
/// fast as real time, that sends to `port` as SITL's `--out` does.
pub struct Copter {
    runtime: tokio::runtime::Runtime,
    vehicle: Option<SimVehicle>,
}

impl Copter {
    pub fn start(port: u16, speed: f64, params: &[(&str, f64)]) -> Copter {
        Copter::start_with(port, |o| {
            o.speed = speed;
            o.params = params.iter().map(|(n, v)| (n.to_string(), *v)).collect();
        })
    }

    pub fn start_with(port: u16, set: impl FnOnce(&mut SimVehicleOptions)) -> Copter {
        let runtime = tokio::runtime::Runtime::new().expect("a tokio runtime");
        let mut options = SimVehicleOptions {
            connect: ConnectAddress::UdpOut(format!("127.0.0.1:{port}")),
            ready_after: 2.0,
            ..SimVehicleOptions::default()
        };
        set(&mut options);
        let vehicle = runtime
            .block_on(SimVehicle::start(options))
            .expect("the test vehicle starts");
        Copter {
            runtime,
            vehicle: Some(vehicle),
        }
    }

    pub fn vehicle(&self) -> &SimVehicle {
        self.vehicle.as_ref().expect("the vehicle runs")
    }

    pub fn snapshot(&self) -> VehicleSnapshot {
        self.vehicle().snapshot()
    }

    pub fn mode(&self) -> Option<CopterMode> {
        CopterMode::from_custom_mode(self.snapshot().custom_mode)
    }
}

impl Drop for Copter {
    fn drop(&mut self) {
        if let Some(v) = self.vehicle.take() {
            self.runtime.block_on(v.shutdown());
        }
    }
}

/// `eamos run` flying a mission, its progress lines read as they come.
pub struct Flight {
    pub child: Child,
    lines: mpsc::Receiver<String>,
    seen: Vec<String>,
    stdout: Option<JoinHandle<String>>,
}

impl Flight {
    pub fn start(mission: &Path, fleet: &Path, out: &Path) -> Flight {
        Flight::start_with(mission, fleet, out, &[])
    }

    /// [`Flight::start`] with more arguments for `eamos run`.
    pub fn start_with(mission: &Path, fleet: &Path, out: &Path, more: &[&str]) -> Flight {
        let mut child = Command::new(env!("CARGO_BIN_EXE_eamos"))
            .arg("run")
            .arg(mission)
            .arg("--fleet")
            .arg(fleet)
            .args(["--max-duration", "600", "--out"])
            .arg(out)
            .args(more)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("eamos run starts");
        let stderr = child.stderr.take().unwrap();
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                if tx.send(line.unwrap_or_default()).is_err() {
                    break;
                }
            }
        });
        let mut stdout = child.stdout.take().unwrap();
        let stdout = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut stdout, &mut s);
            s
        });
        Flight {
            child,
            lines,
            seen: Vec::new(),
            stdout: Some(stdout),
        }
    }

    /// The first progress line containing `needle`, within `limit`.
    pub fn wait_for(&mut self, needle: &str, limit: Duration) -> String {
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    self.seen.push(line.clone());
                    if line.contains(needle) {
                        return line;
                    }
                }
                Err(_) => panic!(
                    "no line with `{needle}` within {limit:?}; seen:\n{}",
                    self.seen.join("\n")
                ),
            }
        }
    }

    /// Waits for the run to end; its exit code, its summary and every
    /// progress line.
    pub fn finish(mut self, limit: Duration) -> (Option<i32>, String, String) {
        let deadline = Instant::now() + limit;
        let code = loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                break status.code();
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!(
                    "eamos run still running after {limit:?}; seen:\n{}",
                    self.seen.join("\n")
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        };
        let stdout = self.stdout.take().unwrap().join().unwrap();
        while let Ok(line) = self.lines.recv_timeout(Duration::from_millis(500)) {
            self.seen.push(line);
        }
        (code, stdout, self.seen.join("\n"))
    }
}

impl Drop for Flight {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub fn fleet(dir: &Path, port: u16, mavlink: &str) -> PathBuf {
    fleet_of(dir, "Copter", port, mavlink)
}

pub fn fleet_of(dir: &Path, drone: &str, port: u16, mavlink: &str) -> PathBuf {
    let path = dir.join("fleet.toml");
    std::fs::write(
        &path,
        format!(
            "[failsafe]\non_abort = \"land\"\n\n[drones.{drone}]\nadapter = \"mavlink\"\nconnect = \"udpin:127.0.0.1:{port}\"\n\n[drones.{drone}.mavlink]\n{mavlink}"
        ),
    )
    .unwrap();
    path
}

/// Waits until the vehicle's state satisfies `done`.
pub fn vehicle_until(copter: &Copter, limit: Duration, done: impl Fn(&VehicleSnapshot) -> bool) {
    let deadline = Instant::now() + limit;
    while !done(&copter.snapshot()) {
        assert!(
            Instant::now() < deadline,
            "the vehicle did not get there within {limit:?}: {:?}",
            copter.snapshot()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The adapter log's lines, as JSON.
pub fn adapter_log(out: &Path, drone: &str) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join(format!("{drone}.adapter.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The mission log's records of `event`.
pub fn mission_events(out: &Path, drone: &str, event: &str) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join(format!("{drone}.mission.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|r| r["event"] == event)
        .collect()
}

/// The mission and wall seconds the summary reports (`... after 12.3 s of
/// mission time (4.5 s wall, ...`).
pub fn times(stdout: &str) -> (f64, f64) {
    let number = |after: &str, before: &str| -> f64 {
        stdout
            .split(after)
            .nth(1)
            .and_then(|t| t.split(before).next())
            .and_then(|t| t.trim().parse().ok())
            .unwrap_or_else(|| panic!("no `{after}...{before}` in: {stdout}"))
    };
    (
        number(" after ", " s of mission time"),
        number("mission time (", " s wall"),
    )
}
