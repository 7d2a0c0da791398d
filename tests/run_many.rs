//! A large fleet, one process per drone, on one computer, as a user runs
//! it with no fleet file: [`DRONES`] drones, each flown by its own `eamos
//! run --slices DIR --drone Dk` from the slices `eamos build --out DIR`
//! cut once, and the ground station by `eamos run MISSION --gcs`, which
//! compiles and checks the mission. Beyond 32 drones the default fleet
//! joins through the ground station, which routes for the drones, instead
//! of a full mesh (`Fleet::hub`).
//!
//! Start-up must scale: a drone's agent reads its own slice, and waits
//! only to see the few peers it exchanges tokens or telemetry with, the
//! ground station only for every drone's `ready` token. (When every agent
//! compiled the mission, checked it, and the ground station waited until
//! every two peers saw each other, a fleet of 50 did not start within a
//! minute: a check per process, and n² liveliness tokens each heard by n
//! peers; and a full mesh of 101 peers is 5,000 zenoh sessions.)
//!
//! The two flights run one after the other: their default loopback ports
//! are derived from their missions and may meet. `eamos bench-report
//! --fleets` measures 50, 100 and 250 drones with a release build.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use serde_json::Value;

#[path = "common/processes.rs"]
mod processes;
use processes::Processes;

/// Drones of each mission, one process each.
const DRONES: usize = 100;
/// How long the ground station waits for every drone to be ready. The
/// mission must have started by then, counted from the launch.
const STARTUP: Duration = Duration::from_secs(60);

static SERIAL: Mutex<()> = Mutex::new(());

fn eamos() -> Command {
    Command::new(env!("CARGO_BIN_EXE_eamos"))
}

fn log(dir: &Path, peer: &str) -> Vec<Value> {
    std::fs::read_to_string(dir.join("logs").join(format!("{peer}.mission.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .collect()
}

fn count(log: &[Value], event: &str) -> usize {
    log.iter().filter(|r| r["event"] == event).count()
}

/// A fleet in flight: the drones first (D1 to D`DRONES`), the ground
/// station last.
struct Flight {
    dir: PathBuf,
    procs: Processes,
    launched: Instant,
}

impl Flight {
    /// Cuts `mission` into slices in `dir`, then launches a process per
    /// drone and the ground station, all with the default fleet, at
    /// `speed` times real time.
    fn launch(dir: &Path, mission: &str, speed: &str) -> Flight {
        let file = dir.join("mission.go");
        std::fs::write(&file, mission).unwrap();
        let slices = dir.join("slices");
        let built = eamos()
            .arg("build")
            .arg(&file)
            .arg("--out")
            .arg(&slices)
            .output()
            .unwrap();
        assert!(built.status.success(), "{built:?}");
        let out = |name: &str| Stdio::from(std::fs::File::create(dir.join(name)).unwrap());
        let launched = Instant::now();
        let mut procs = Processes(Vec::new());
        let roles = (1..=DRONES)
            .map(|k| {
                let d = format!("D{k}");
                let args = vec![
                    "--slices".into(),
                    slices.clone().into_os_string(),
                    "--drone".into(),
                    d.clone().into(),
                ];
                (d, args)
            })
            .chain(std::iter::once((
                "GCS".to_string(),
                vec![file.clone().into_os_string(), "--gcs".into()],
            )));
        for (tag, role) in roles {
            let child = eamos()
                .arg("run")
                .args(&role)
                // Each drone counts its time limit from its own start and
                // then waits for the ground station's start: generous, the
                // start-up is bounded by the ground station's timeout.
                .args(["--speed", speed, "--max-duration", "6000"])
                .args(["--startup-timeout", &STARTUP.as_secs().to_string()])
                .arg("--out")
                .arg(dir.join("logs"))
                .stdout(out(&format!("{tag}.out")))
                .stderr(out(&format!("{tag}.err")))
                .spawn()
                .unwrap();
            procs.0.push((tag, child));
        }
        Flight {
            dir: dir.to_path_buf(),
            procs,
            launched,
        }
    }

    /// When the ground station sent its first token: every drone was ready.
    fn started(&mut self) -> Duration {
        loop {
            if count(&log(&self.dir, "GCS"), "bridge_sent") > 0 {
                return self.launched.elapsed();
            }
            let gcs = &mut self.procs.0.last_mut().unwrap().1;
            if let Some(status) = gcs.try_wait().unwrap() {
                let err = std::fs::read_to_string(self.dir.join("GCS.err")).unwrap();
                panic!("the ground station ended before the mission started ({status}): {err}");
            }
            assert!(
                self.launched.elapsed() < STARTUP + Duration::from_secs(30),
                "the mission did not start"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits for every process; each one's exit status with its output.
    fn wait(&mut self, limit: Duration) -> Vec<(String, std::process::ExitStatus, String)> {
        let deadline = Instant::now() + limit;
        let mut ended = Vec::new();
        for (tag, child) in self.procs.0.iter_mut() {
            let status = loop {
                if let Some(s) = child.try_wait().unwrap() {
                    break s;
                }
                assert!(Instant::now() < deadline, "{tag} still running");
                std::thread::sleep(Duration::from_millis(50));
            };
            let out = std::fs::read_to_string(self.dir.join(format!("{tag}.out"))).unwrap();
            let err = std::fs::read_to_string(self.dir.join(format!("{tag}.err"))).unwrap();
            ended.push((tag.clone(), status, format!("{out}\n{err}")));
        }
        ended
    }

    fn kill(&mut self, drone: &str) {
        let (_, child) = self.procs.0.iter_mut().find(|(t, _)| t == drone).unwrap();
        child.kill().unwrap();
        child.wait().unwrap();
    }
}

#[test]
fn a_hundred_drones_in_a_process_each_with_the_default_fleet_start_and_complete() {
    let _one_at_a_time = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let out = eamos()
        .args(["gen", "--drones", &DRONES.to_string()])
        .args(["--nodes", &(DRONES * 10).to_string(), "--seed", "12"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let mut flight = Flight::launch(dir.path(), &String::from_utf8(out.stdout).unwrap(), "50");
    let started = flight.started();
    for (tag, status, said) in flight.wait(Duration::from_secs(120)) {
        assert!(status.success(), "{tag}: {status}\n{said}");
    }
    let done = flight.launched.elapsed();
    let gcs = std::fs::read_to_string(dir.path().join("GCS.out")).unwrap();
    assert!(gcs.starts_with("Stress: completed"), "{gcs}");
    // Every drone flew its part: each action it started also finished.
    for k in 1..=DRONES {
        let log = log(dir.path(), &format!("D{k}"));
        let started = count(&log, "action_started");
        assert!(started > 0, "D{k} started nothing");
        assert_eq!(started, count(&log, "action_finished"), "D{k}");
    }
    eprintln!(
        "{DRONES} drones: the mission started {:.1} s after the launch, completed after {:.1} s",
        started.as_secs_f64(),
        done.as_secs_f64()
    );
}

/// D1 hovers, then signals; every other drone waits for the signal in
/// the air before it lands.
fn waiting_on_one() -> String {
    let mut m = String::from("package WaitOnOne\n\nvar (\n");
    for k in 1..=DRONES {
        m += &format!("\tD{k} Quadcopter\n");
    }
    m += ")\n\nfunc PAR_Mission() {\n";
    for k in 1..=DRONES {
        m += &format!("\tSEQ_D{k}()\n");
    }
    m += "}\n\nfunc SEQ_D1() {\n\tD1.Arm()\n\tD1.Takeoff(3)\n\tD1.Hover(3000)\n\tSignal(\"done\")\n\tD1.Land()\n}\n";
    for k in 2..=DRONES {
        m += &format!("\nfunc SEQ_D{k}() {{\n\tD{k}.Arm()\n\tD{k}.Takeoff(3)\n\tAwait(\"done\")\n\tD{k}.Land()\n}}\n");
    }
    m
}

/// [`waiting_on_one`] flown from `dir` at 10 times real time (a tenth of
/// a second of a loaded machine is then one second of mission time, as
/// the grace period is measured), once D1 hovers: every other drone is
/// then waiting on it in the air.
fn hovering(dir: &Path) -> Flight {
    let mut flight = Flight::launch(dir, &waiting_on_one(), "10");
    flight.started();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !log(dir, "D1")
        .iter()
        .any(|r| r["event"] == "action_started" && r["action"] == "Hover")
    {
        assert!(Instant::now() < deadline, "D1 never hovered");
        std::thread::sleep(Duration::from_millis(20));
    }
    flight
}

#[test]
fn a_drone_killed_among_a_hundred_is_reported_and_the_drones_waiting_on_it_land() {
    let _one_at_a_time = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut flight = hovering(dir.path());
    flight.kill("D1");
    let ended = flight.wait(Duration::from_secs(90));
    for (tag, status, said) in &ended {
        if tag != "D1" {
            assert_eq!(
                status.code(),
                Some(1),
                "{tag} must end without completing: {said}"
            );
        }
    }
    let gcs = log(dir.path(), "GCS");
    assert!(
        gcs.iter()
            .any(|r| r["event"] == "peer_lost" && r["peer"] == "D1"),
        "the ground station never said D1 was lost"
    );
    for k in 2..=DRONES {
        let d = format!("D{k}");
        let log = log(dir.path(), &d);
        let stuck: Vec<&Value> = log.iter().filter(|r| r["event"] == "stuck").collect();
        assert_eq!(stuck.len(), 1, "{d}: {stuck:?}");
        assert_eq!(stuck[0]["lost"], serde_json::json!(["D1"]), "{d}");
        // The default policy, after the default grace period.
        assert_eq!(stuck[0]["policy"], "land", "{d}");
        let lost = log
            .iter()
            .find(|r| r["event"] == "peer_lost" && r["peer"] == "D1")
            .unwrap_or_else(|| panic!("{d} never saw D1 lost"));
        let waited = stuck[0]["time"].as_f64().unwrap() - lost["time"].as_f64().unwrap();
        assert!(
            (3.5..=8.0).contains(&waited),
            "{d} applied its policy {waited:.1} s of mission time after losing D1, not after the 5 s grace"
        );
        let failsafe: Vec<&Value> = log.iter().filter(|r| r["event"] == "failsafe").collect();
        assert_eq!(failsafe.len(), 1, "{d}: {failsafe:?}");
        assert_eq!(failsafe[0]["failsafe"], "land", "{d}");
    }
}

#[test]
fn an_abort_reaches_each_of_a_hundred_drones_once() {
    let _one_at_a_time = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut flight = hovering(dir.path());
    // Joins through the ground station, as a client, like every drone.
    let stdout = processes::abort(&dir.path().join("mission.go"), 30);
    let peers = DRONES + 1;
    assert!(
        stdout.contains(&format!(
            "abort sent to {peers} peers ({peers} up), 0 not acknowledged"
        )),
        "{stdout}"
    );
    for (tag, status, said) in flight.wait(Duration::from_secs(90)) {
        assert_eq!(status.code(), Some(1), "{tag} must end aborted: {said}");
    }
    for k in 1..=DRONES {
        let d = format!("D{k}");
        let log = log(dir.path(), &d);
        assert_eq!(count(&log, "abort_received"), 1, "{d}");
        // Each drone lands and leaves: it does not wait out its flush
        // (10 s of wall time, 100 s of mission time) on copies of the
        // abort nobody acknowledges. When every drone passed the abort on
        // to every other, 10,000 copies through the ground station, each
        // did, and the ground station left before them.
        let time = |e: &str| log.iter().find(|r| r["event"] == e).unwrap()["time"].as_f64();
        let ended = time("stopped").unwrap() - time("abort_received").unwrap();
        assert!(ended < 60.0, "{d} ended {ended:.0} s after the abort");
        let failsafe: Vec<&Value> = log.iter().filter(|r| r["event"] == "failsafe").collect();
        assert_eq!(failsafe.len(), 1, "{d}: {failsafe:?}");
        assert_eq!(failsafe[0]["failsafe"], "land", "{d}");
    }
    assert_eq!(count(&log(dir.path(), "GCS"), "abort_received"), 1);
}
