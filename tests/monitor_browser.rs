//! The live monitor in a real browser: `eamos run experiment_c.go
//! --monitor` flies the simulated fleet while headless Chromium reads the
//! page it serves, and what the page shows is read back from the DOM as
//! the flight goes on: a drone's marker moves, the current actions change,
//! the marking advances. Every wait is bounded and generous (a loaded
//! machine runs the flight and the browser on two cores) and waits for the
//! page to show a change, never for a time.
//!
//! Screenshots go beside the test's output (`<target>/tmp/monitor_browser/`)
//! and to `docs/img/` for the README when `EAMOS_UPDATE_SCREENSHOTS` is set.

#[allow(dead_code)] // Each test uses its own few of the client's commands.
mod browser;

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use browser::Browser;

const PATIENCE: Duration = Duration::from_secs(90);

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn out_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("monitor_browser")
}

fn screenshot(b: &Browser, selector: Option<&str>, name: &str) {
    let to = out_dir().join(name);
    b.screenshot(selector, &to);
    if std::env::var_os("EAMOS_UPDATE_SCREENSHOTS").is_some() {
        std::fs::copy(&to, repo("docs/img").join(name)).unwrap();
    }
}

/// A process that is killed when the test ends, however it ends.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `eamos` with `args` and returns it with the monitor's address,
/// read from what it prints (`monitor: http://ADDR/`): the port is the
/// system's choice (`--monitor 127.0.0.1:0`), so no two tests collide.
pub fn start_monitored(args: &[&str]) -> (Killed, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_eamos"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("eamos starts");
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if let Some(url) = line.strip_prefix("monitor: ") {
                let _ = tx.send(url.to_string());
            }
        }
    });
    let url = rx
        .recv_timeout(PATIENCE)
        .expect("eamos says where its monitor listens");
    (Killed(child), url)
}

/// Where the drones' markers are over the plan.
const PLAN_MARKERS: &str =
    "return Array.from(document.querySelectorAll('#plan circle.live-drone'))\
    .map(m => m.getAttribute('cx') + ',' + m.getAttribute('cy')).join(' ');";

/// The text of every drone's current action, in order.
const ACTIONS: &str = "return Array.from(document.querySelectorAll('#drones-live td.action'))\
    .map(e => e.textContent).join('|');";
/// The places marked in the graph.
const MARKED: &str = "return Array.from(document.querySelectorAll('#graph .node.place.marked'))\
    .map(e => e.dataset.id).sort().join(' ');";
/// Where the drones' markers are, from above and from the side (a
/// take-off moves them only in the side view).
const MARKERS: &str = "return Array.from(document.querySelectorAll('.live-drone'))\
    .map(m => m.getAttribute('cx') + ',' + m.getAttribute('cy')).join(' ');";

fn changed(b: &Browser, probe: &str, what: &str) {
    let before = b.eval(probe);
    let script = format!("return (function () {{ {probe} }})() !== {before};");
    b.wait_long(&script, PATIENCE, what);
}

#[test]
fn during_a_flight_of_experiment_c_markers_move_actions_change_and_the_marking_advances() {
    std::fs::create_dir_all(out_dir()).unwrap();
    let logs = out_dir().join("run");
    let mission = repo("../shared/missions/paper/experiment_c.go");
    let (_run, url) = start_monitored(&[
        "run",
        mission.to_str().unwrap(),
        "--monitor",
        "127.0.0.1:0",
        // About two minutes of flight: time enough for a browser started
        // on a loaded machine to see it under way.
        "--speed",
        "0.25",
        "--out",
        logs.to_str().unwrap(),
    ]);
    let b = Browser::start(1300, 1400);
    b.navigate(&url);
    b.wait_long(
        "return typeof window.eamosView === 'object' && !!window.eamosView.source;",
        PATIENCE,
        "the served page connects to its events",
    );
    // Every drone's marker is on the plan once its first sample arrived.
    b.wait_long(
        "return document.querySelectorAll('#plan .live-drone').length === 3;",
        PATIENCE,
        "three drones' markers",
    );
    assert_eq!(b.count("#drones-live tr[data-drone]"), 3);
    b.wait_long(
        "return document.querySelectorAll('#graph .node.place.marked').length > 0;",
        PATIENCE,
        "a marking",
    );

    changed(&b, MARKERS, "a drone's marker moves");
    // The page times each event from the monitor's stamp to its handler
    // and to the frame drawn (what the monitor's benchmark reports).
    let latency = b.eval("return EamosLive.latency(window.eamosView);");
    assert!(
        latency["handled"]["count"].as_u64() > Some(0)
            && latency["handled"]["p50"]
                .as_f64()
                .is_some_and(|ms| ms >= 0.0),
        "{latency}"
    );
    assert!(
        b.count("#plan .trail") >= 1,
        "a trail behind a moving drone"
    );
    screenshot(&b, None, "monitor-experiment-c.png");

    // Over the plan too, where its trail is drawn behind it (the marker,
    // not the trail, is what moves).
    changed(&b, PLAN_MARKERS, "a drone's marker moves over the plan");
    changed(&b, ACTIONS, "a drone's current action changes");
    screenshot(&b, Some("#live"), "monitor-experiment-c-live.png");

    changed(&b, MARKED, "the marking advances");
    b.eval("document.querySelector('#graph .node.place.marked').scrollIntoView();");
    screenshot(&b, Some("#graph-view"), "monitor-experiment-c-graph.png");

    // The tokens between peers (experiment C's joins; a `Signal` or an
    // `Await` is listed the same way) are listed as they arrive, and the
    // closest distance between two drones is plotted.
    b.wait_long(
        "return document.querySelectorAll('#events li.bridge').length > 0;",
        PATIENCE,
        "a token between peers in the event list",
    );
    b.wait_long(
        "return document.getElementById('closest').hasAttribute('data-closest');",
        PATIENCE,
        "the closest distance",
    );

    // What the page keeps is bounded however long the flight: ten
    // thousand more samples and tokens leave the trail, the event list and
    // the distance plot at their bounds.
    b.eval(
        r#"var v = window.eamosView;
        for (var k = 0; k < 10000; k++) {
          v.update({time: 1000 + k, drone: "Drone1", event: "telemetry",
                    position: {x: k % 7, y: 0, z: 2}, altitude: 2, battery: 50});
          v.update({time: 1000 + k, drone: "Drone1", event: "bridge_received",
                    bridge: 0, from: "GCS", colour: [], seq: k});
        }"#,
    );
    let kept = b.eval(
        "return [document.querySelector('#plan .trail[data-drone=\"0\"]').points.numberOfItems, \
         document.querySelectorAll('#events li').length, \
         document.querySelector('#closest .closest-line').points.numberOfItems];",
    );
    assert_eq!(
        kept,
        serde_json::json!([300, 200, 600]),
        "trail, events, plot"
    );

    // A place stays marked while any peer holds it: two peers that say
    // they hold one nobody held, then give it up one after the other.
    let shared = b.eval(
        r#"var v = window.eamosView;
        var id = Object.keys(v.graph.nodes).find(k => v.graph.nodes[k].classList.contains("place")
                                                       && !v.graph.nodes[k].classList.contains("marked"));
        var marked = () => v.graph.nodes[id].classList.contains("marked");
        var said = [];
        v.update({time: 1, drone: "Drone1", event: "marking", marked: [id]});
        v.update({time: 1, drone: "Drone2", event: "marking", marked: [id]});
        said.push(marked());
        v.update({time: 2, drone: "Drone1", event: "marking", marked: []});
        said.push(marked());
        v.update({time: 3, drone: "Drone2", event: "marking", marked: []});
        said.push(marked());
        return said;"#,
    );
    assert_eq!(
        shared,
        serde_json::json!([true, true, false]),
        "marked by two, by one, by none"
    );
}

/// Starts `eamos` with `args`, its output dropped.
fn start(args: &[&str]) -> Killed {
    Killed(
        Command::new(env!("CARGO_BIN_EXE_eamos"))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("eamos starts"),
    )
}

#[test]
fn eamos_monitor_watches_separate_processes_and_shows_a_killed_drone_lost() {
    std::fs::create_dir_all(out_dir()).unwrap();
    let logs = out_dir().join("peers");
    let mission = repo("../shared/missions/paper/experiment_c.go");
    let mission = mission.to_str().unwrap();
    // The observer first: it must see every peer come up to see one go.
    let (_monitor, url) = start_monitored(&["monitor", mission, "--listen", "127.0.0.1:0"]);
    let mut peers = Vec::new();
    for role in [
        ["--drone", "Drone1"],
        ["--drone", "Drone2"],
        ["--drone", "Drone3"],
    ] {
        peers.push(start(&[
            "run",
            mission,
            role[0],
            role[1],
            "--speed",
            "0.25",
            "--out",
            logs.to_str().unwrap(),
        ]));
    }
    let _gcs = start(&[
        "run",
        mission,
        "--gcs",
        "--speed",
        "0.25",
        "--out",
        logs.to_str().unwrap(),
    ]);
    let b = Browser::start(1300, 1400);
    b.navigate(&url);
    // Each drone's telemetry, heard on the mission's network.
    b.wait_long(
        "return document.querySelectorAll('#plan .live-drone').length === 3;",
        PATIENCE,
        "three drones' markers, from their telemetry on zenoh",
    );
    assert_eq!(b.count("#drones-live tr.lost"), 0, "nobody is lost yet");
    assert_eq!(b.count("#abort"), 0, "no abort without the ground key");
    // What each drone does, published by its process for observers: the
    // marking on the graph and the current action in the panel.
    b.wait_long(
        "return document.querySelectorAll('#graph .node.place.marked').length > 0;",
        PATIENCE,
        "the peers' markings, from their events on zenoh",
    );
    b.wait_long(
        "return Array.from(document.querySelectorAll('#drones-live td.action'))\
         .some(e => e.textContent.indexOf('(') > 0);",
        PATIENCE,
        "a drone's current action, from its events on zenoh",
    );

    // Drone2's process dies: its liveliness token goes, and the page says so.
    let mut drone2 = peers.remove(1);
    drone2.0.kill().unwrap();
    let _ = drone2.0.wait();
    b.wait_long(
        "return document.querySelector('#drones-live tr.lost[data-drone=\"1\"]') !== null;",
        PATIENCE,
        "Drone2 shown lost",
    );
    assert_eq!(b.count("#drones-live tr.lost"), 1, "only Drone2 is lost");
    assert!(b.count("#events li.lost") >= 1);
    screenshot(&b, Some("#live"), "monitor-lost.png");
}

fn count_in_log(dir: &std::path::Path, peer: &str, event: &str) -> usize {
    std::fs::read_to_string(dir.join(format!("{peer}.mission.jsonl")))
        .unwrap_or_default()
        .lines()
        .filter(|l| l.contains(&format!("\"event\":\"{event}\"")))
        .count()
}

#[test]
fn with_the_ground_key_the_monitors_abort_button_aborts_the_flight() {
    let dir = out_dir().join("abort");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let keygen = Command::new(env!("CARGO_BIN_EXE_eamos"))
        .args(["keygen", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(keygen.status.success(), "{keygen:?}");
    // The drones obey only aborts sealed by this key.
    let fleet = dir.join("fleet.toml");
    std::fs::write(&fleet, "[keys]\ngcs = \"gcs.pub\"\n").unwrap();
    let (fleet, key, logs) = (
        fleet.to_str().unwrap().to_string(),
        dir.join("gcs.key").to_str().unwrap().to_string(),
        dir.join("logs").to_str().unwrap().to_string(),
    );
    let mission = repo("../shared/missions/paper/experiment_c.go");
    let mission = mission.to_str().unwrap();
    let (_monitor, url) = start_monitored(&[
        "monitor",
        mission,
        "--fleet",
        &fleet,
        "--listen",
        "127.0.0.1:0",
        "--key",
        &key,
    ]);
    let mut peers = Vec::new();
    for role in [
        vec!["--drone", "Drone1"],
        vec!["--drone", "Drone2"],
        vec!["--drone", "Drone3"],
        vec!["--gcs"],
    ] {
        let mut args = vec![
            "run", mission, "--fleet", &fleet, "--speed", "0.25", "--out", &logs,
        ];
        args.extend(role);
        peers.push(start(&args));
    }
    let b = Browser::start(1300, 1400);
    b.navigate(&url);
    b.wait_long(
        "return document.querySelectorAll('#plan .live-drone').length === 3;",
        PATIENCE,
        "three drones' markers",
    );
    assert_eq!(b.count("#abort"), 1, "the abort button, with the key");
    // The crew confirms.
    b.eval("window.confirm = function () { return true; };");
    b.click("#abort");
    b.wait_long(
        "return document.getElementById('abort-result').textContent.indexOf('abort sent') >= 0;",
        PATIENCE,
        "the abort sent",
    );
    screenshot(&b, Some("#live"), "monitor-abort.png");
    let logs = PathBuf::from(logs);
    let started = std::time::Instant::now();
    while count_in_log(&logs, "Drone1", "abort_received") == 0 {
        assert!(
            started.elapsed() < PATIENCE,
            "Drone1 never obeyed the monitor's abort"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    assert_eq!(count_in_log(&logs, "Drone1", "abort_refused"), 0);
}
