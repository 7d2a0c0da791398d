//! zenoh over TLS with mutual authentication, as a drone team sets it up: a
//! certificate authority of the fleet, one certificate and key per peer, a
//! fleet file naming them, one process per drone plus the ground station.
//! The certificates are made in the test, as `openssl` would make them.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::Mutex;
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

/// Every test flies experiment B, whose peers listen on loopback ports
/// derived from the mission: one test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// A throwaway certificate authority writing PEM files into a directory.
struct Ca {
    key: rcgen::KeyPair,
    params: rcgen::CertificateParams,
}

impl Ca {
    fn new(dir: &Path, name: &str) -> Ca {
        let key = rcgen::KeyPair::generate().unwrap();
        let mut params = rcgen::CertificateParams::new(Vec::<String>::new()).unwrap();
        params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
        params
            .distinguished_name
            .push(rcgen::DnType::CommonName, name);
        let cert = params.self_signed(&key).unwrap();
        std::fs::write(dir.join(format!("{name}.pem")), cert.pem()).unwrap();
        Ca { key, params }
    }

    /// `<peer>.pem` and `<peer>.key` in `dir`, valid for loopback.
    fn issue(&self, dir: &Path, peer: &str) {
        let key = rcgen::KeyPair::generate().unwrap();
        let mut params =
            rcgen::CertificateParams::new(vec!["127.0.0.1".to_string(), "localhost".into()])
                .unwrap();
        params
            .distinguished_name
            .push(rcgen::DnType::CommonName, peer);
        params.extended_key_usages = vec![
            rcgen::ExtendedKeyUsagePurpose::ServerAuth,
            rcgen::ExtendedKeyUsagePurpose::ClientAuth,
        ];
        let issuer = rcgen::Issuer::from_params(&self.params, &self.key);
        let cert = params.signed_by(&key, &issuer).unwrap();
        std::fs::write(dir.join(format!("{peer}.pem")), cert.pem()).unwrap();
        std::fs::write(dir.join(format!("{peer}.key")), key.serialize_pem()).unwrap();
    }
}

/// The fleet file of experiment B over TLS: the CA fleet-wide, each peer's
/// certificate in its own table, paths relative to the fleet file.
const FLEET: &str = r#"
[zenoh.tls]
ca = "certs/fleet-ca.pem"

[gcs]
tls = { certificate = "certs/GCS.pem", key = "certs/GCS.key" }

[drones.Drone1.zenoh.tls]
certificate = "certs/Drone1.pem"
key = "certs/Drone1.key"

[drones.Drone2.zenoh.tls]
certificate = "certs/Drone2.pem"
key = "certs/Drone2.key"
"#;

/// A fleet directory: `fleet.toml` and `certs/`, every peer's certificate
/// signed by the fleet's CA except those listed in `strangers`, which are
/// signed by another CA.
fn fleet_dir(strangers: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let certs = dir.path().join("certs");
    std::fs::create_dir(&certs).unwrap();
    let fleet = Ca::new(&certs, "fleet-ca");
    let other = Ca::new(&certs, "other-ca");
    for peer in ["GCS", "Drone1", "Drone2"] {
        let ca = if strangers.contains(&peer) {
            &other
        } else {
            &fleet
        };
        ca.issue(&certs, peer);
    }
    std::fs::write(dir.path().join("fleet.toml"), FLEET).unwrap();
    dir
}

fn spawn(fleet: &Path, out: &Path, role: &[&str], extra: &[&str]) -> Child {
    let tag = role.join("");
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(paper("experiment_b.go"))
        .args(role)
        .arg("--fleet")
        .arg(fleet)
        .arg("--out")
        .arg(out)
        // A drone counts its time limit from its own start, and waits there
        // until every peer is connected: at 50x, a few seconds of process
        // starts and connection retries on a loaded machine are minutes of
        // mission time (600 s was once used up before the start token came);
        // 6000 s is 120 s of wall clock, inside the 180 s this test waits.
        .args(["--speed", "50", "--max-duration", "6000"])
        .args(extra)
        .stdout(Stdio::from(
            std::fs::File::create(out.join(format!("{tag}.out"))).unwrap(),
        ))
        .stderr(Stdio::from(
            std::fs::File::create(out.join(format!("{tag}.err"))).unwrap(),
        ))
        .spawn()
        .unwrap()
}

fn events(out: &Path, peer: &str, event: &str) -> usize {
    std::fs::read_to_string(out.join(format!("{peer}.mission.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter(|l| serde_json::from_str::<Value>(l).unwrap()["event"] == event)
        .count()
}

fn read(out: &Path, file: &str) -> String {
    std::fs::read_to_string(out.join(file)).unwrap_or_default()
}

/// `eamos monitor` on the fleet, started first, and everything its page
/// is sent (`/events`, server-sent events), as it arrives.
struct Monitor {
    _process: Processes,
    heard: std::sync::Arc<Mutex<String>>,
}

impl Monitor {
    fn start(fleet: &Path) -> Monitor {
        let mut child = Command::cargo_bin("eamos")
            .unwrap()
            .arg("monitor")
            .arg(paper("experiment_b.go"))
            .arg("--fleet")
            .arg(fleet)
            .args(["--listen", "127.0.0.1:0"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let stderr = child.stderr.take().unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            use std::io::BufRead;
            for line in std::io::BufReader::new(stderr)
                .lines()
                .map_while(Result::ok)
            {
                if let Some(url) = line.strip_prefix("monitor: http://") {
                    let _ = tx.send(url.trim_end_matches('/').to_string());
                }
            }
        });
        let addr = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("the monitor says where it listens");
        let heard = std::sync::Arc::new(Mutex::new(String::new()));
        let into = heard.clone();
        std::thread::spawn(move || {
            use std::io::{Read, Write};
            let mut s = std::net::TcpStream::connect(&addr).unwrap();
            write!(s, "GET /events HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
            let mut buf = [0u8; 8192];
            while let Ok(n) = s.read(&mut buf) {
                if n == 0 {
                    break;
                }
                let text = String::from_utf8_lossy(&buf[..n]).to_string();
                into.lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push_str(&text);
            }
        });
        Monitor {
            _process: Processes(vec![("monitor".into(), child)]),
            heard,
        }
    }

    /// Whether the page was sent an event of `peer` of kind `event`.
    fn heard(&self, peer: &str, event: &str) -> bool {
        let heard = self.heard.lock().unwrap_or_else(|p| p.into_inner());
        heard.lines().any(|l| {
            l.starts_with("data: ")
                && l.contains(&format!("\"drone\":\"{peer}\""))
                && l.contains(&format!("\"event\":\"{event}\""))
        })
    }
}

#[test]
fn experiment_b_flies_over_mutual_tls_with_one_process_per_peer() {
    let _serial = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let fleet = fleet_dir(&[]);
    let out = tempfile::tempdir().unwrap();
    let fleet_file = fleet.path().join("fleet.toml");
    // A monitor that is no peer joins over TLS with the ground station's
    // certificate, and hears what each peer does, not only where it is.
    let monitor = Monitor::start(&fleet_file);
    let mut procs = Processes(Vec::new());
    for role in [
        &["--drone", "Drone1"][..],
        &["--drone", "Drone2"],
        &["--gcs"],
    ] {
        procs
            .0
            .push((role.join(" "), spawn(&fleet_file, out.path(), role, &[])));
    }
    let start = Instant::now();
    for (role, child) in &mut procs.0 {
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            assert!(
                start.elapsed() < Duration::from_secs(180),
                "`{role}` did not finish"
            );
            std::thread::sleep(Duration::from_millis(50));
        };
        let tag = role.replace(' ', "");
        assert!(
            status.success(),
            "`{role}` failed ({status}):\n{}\n{}",
            read(out.path(), &format!("{tag}.out")),
            read(out.path(), &format!("{tag}.err"))
        );
    }
    for peer in ["GCS", "Drone1", "Drone2"] {
        assert_eq!(events(out.path(), peer, "mission_ended"), 1, "{peer}");
    }
    assert!(events(out.path(), "Drone1", "bridge_received") > 0);
    assert!(events(out.path(), "Drone2", "bridge_received") > 0);
    // At 50 times real time the flight may be over before the monitor's
    // connections are up: what it missed, it asks each peer for when it
    // sees it (the latest marking, action and end). The latest action
    // event is its start or, once a drone's last action is done, its end.
    let heard_all = || {
        ["Drone1", "Drone2"].iter().all(|d| {
            monitor.heard(d, "marking")
                && (monitor.heard(d, "action_started") || monitor.heard(d, "action_finished"))
                && monitor.heard(d, "stopped")
        }) && monitor.heard("GCS", "marking")
    };
    let waited = Instant::now();
    while !heard_all() && waited.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(
        heard_all(),
        "the monitor heard: {}",
        monitor.heard.lock().unwrap_or_else(|p| p.into_inner())
    );
}

#[test]
fn a_drone_whose_certificate_another_ca_signed_is_never_connected_and_nothing_starts() {
    let _serial = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let fleet = fleet_dir(&["Drone2"]);
    let out = tempfile::tempdir().unwrap();
    let fleet_file = fleet.path().join("fleet.toml");
    let mut procs = Processes(Vec::new());
    for role in [&["--drone", "Drone1"][..], &["--drone", "Drone2"]] {
        procs
            .0
            .push((role.join(" "), spawn(&fleet_file, out.path(), role, &[])));
    }
    let mut gcs = spawn(
        &fleet_file,
        out.path(),
        &["--gcs"],
        &["--startup-timeout", "8"],
    );
    let start = Instant::now();
    let status = loop {
        if let Some(s) = gcs.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = gcs.kill();
            panic!("the ground station did not give up");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let said = read(out.path(), "--gcs.out") + &read(out.path(), "--gcs.err");
    assert!(!status.success(), "{said}");
    assert!(said.contains("Drone2"), "{said}");
    assert!(
        !said.contains("\"Drone1\""),
        "Drone1 holds a certificate of the fleet: {said}"
    );
    // The mission never started: no drone took off.
    for drone in ["Drone1", "Drone2"] {
        assert_eq!(events(out.path(), drone, "action_started"), 0, "{drone}");
    }
}

fn run_whole_fleet(fleet: &Path) -> Output {
    let out = tempfile::tempdir().unwrap();
    Command::cargo_bin("eamos")
        .unwrap()
        .arg("run")
        .arg(paper("experiment_b.go"))
        .arg("--fleet")
        .arg(fleet)
        .args(["--transport", "zenoh", "--speed", "50"])
        .arg("--out")
        .arg(out.path())
        .output()
        .unwrap()
}

#[test]
fn a_missing_private_key_is_named_with_its_path() {
    let _serial = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let fleet = fleet_dir(&[]);
    std::fs::remove_file(fleet.path().join("certs/Drone2.key")).unwrap();
    let o = run_whole_fleet(&fleet.path().join("fleet.toml"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("private key") && err.contains("certs/Drone2.key"),
        "{err}"
    );
}

#[test]
fn a_certificate_file_that_is_not_a_certificate_is_named_with_its_path() {
    let _serial = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let fleet = fleet_dir(&[]);
    std::fs::write(fleet.path().join("certs/GCS.pem"), "not a certificate\n").unwrap();
    let o = run_whole_fleet(&fleet.path().join("fleet.toml"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("certificate") && err.contains("certs/GCS.pem"),
        "{err}"
    );
}
