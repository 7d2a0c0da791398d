//! The three per-drone logs of the paper (section VII-C), as JSON lines in
//! one directory, every record stamped with mission time:
//!
//! - `<drone>.mission.jsonl`: the mission log, the sink [`MissionLog`] of
//!   the peer's [`crate::event`]s: firings, markings, actions started and
//!   finished, bridge messages sent and received, conditions waited on,
//!   how the run ended; one event a line, with the log's version `"v"`;
//! - `<drone>.uniform.jsonl`: every call through the uniform API (from the
//!   middle layer's [`eamos_mid::Uniform`]);
//! - `<drone>.adapter.jsonl`: what the adapter did and where the drone was.
//!
//! Writing happens on a thread of its own, so that a slow disk never holds
//! up a flight; a record that cannot be written is reported once and the
//! flight goes on.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc as std_mpsc;
use std::thread::JoinHandle;

use serde::{Deserialize, Serialize};

use eamos_mid::log::{LogRecord, LogSink};

use crate::event::{Event, Kind, Sink};

/// The version of the mission log's lines (`"v"` in each): a reader
/// refuses a later one rather than misread it. Lines written before the
/// field existed read as version 1.
pub const MISSION_LOG_VERSION: u32 = 1;

/// One line of a mission log as written: the version, then the event.
#[derive(Serialize)]
struct LineOut<'a> {
    v: u32,
    #[serde(flatten)]
    event: &'a Event,
}

/// One line of a mission log as read.
#[derive(Deserialize)]
struct LineIn {
    #[serde(default = "first_version")]
    v: u32,
    #[serde(flatten)]
    event: Event,
}

fn first_version() -> u32 {
    1
}

enum Line {
    Mission(Event),
    Mid(String, LogRecord),
    /// Close the files: handles may outlive the run (an adapter task that
    /// has not noticed the end yet), so the writer cannot wait for them.
    Close,
}

/// Writes the logs of every drone of one process into one directory.
pub struct LogWriter {
    tx: Option<std_mpsc::Sender<Line>>,
    thread: Option<JoinHandle<Vec<String>>>,
    dir: PathBuf,
}

impl LogWriter {
    /// Creates `dir` if needed; files are created on their first record and
    /// truncated then (a new run replaces the old logs).
    pub fn create(dir: &Path) -> std::io::Result<LogWriter> {
        Self::open(dir, false)
    }

    /// Like [`LogWriter::create`], but appends to the files that exist: an
    /// agent resumed from its journal keeps the records of its first run.
    pub fn append(dir: &Path) -> std::io::Result<LogWriter> {
        Self::open(dir, true)
    }

    fn open(dir: &Path, append: bool) -> std::io::Result<LogWriter> {
        std::fs::create_dir_all(dir)?;
        let (tx, rx) = std_mpsc::channel::<Line>();
        let root = dir.to_path_buf();
        let thread = std::thread::Builder::new()
            .name("eamos-logs".into())
            .spawn(move || write_all(&root, rx, append))?;
        Ok(LogWriter {
            tx: Some(tx),
            thread: Some(thread),
            dir: dir.to_path_buf(),
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The mission logs of every peer, as a sink of their events.
    pub fn missions(&self) -> MissionLog {
        MissionLog {
            tx: self.tx.clone(),
        }
    }

    /// The uniform and adapter logs of one drone.
    pub fn drone(&self, drone: &str) -> DroneLog {
        DroneLog {
            drone: drone.to_string(),
            tx: self.tx.clone(),
        }
    }

    /// Closes every file once all records so far are written. Returns the
    /// write errors met (each file's first).
    pub fn finish(mut self) -> Vec<String> {
        if let Some(tx) = self.tx.take() {
            let _ = tx.send(Line::Close);
        }
        self.thread
            .take()
            .map(|t| t.join().unwrap_or_default())
            .unwrap_or_default()
    }
}

/// Where one drone's records go. Cheap to clone; a handle with no writer
/// (see [`DroneLog::discard`]) drops every record.
#[derive(Clone)]
pub struct DroneLog {
    drone: String,
    tx: Option<std_mpsc::Sender<Line>>,
}

impl DroneLog {
    /// A log that keeps nothing.
    pub fn discard(drone: &str) -> DroneLog {
        DroneLog {
            drone: drone.to_string(),
            tx: None,
        }
    }

    pub fn drone(&self) -> &str {
        &self.drone
    }
}

/// A drone's middle-layer log that also hands its adapter's warnings to
/// the run's event stream, where the crew reads them (the terminal, the
/// mission log), as the same event every consumer sees.
pub struct WarningTap {
    log: DroneLog,
    events: std::sync::Arc<dyn Sink>,
}

impl WarningTap {
    pub fn new(log: DroneLog, events: std::sync::Arc<dyn Sink>) -> WarningTap {
        WarningTap { log, events }
    }
}

impl LogSink for WarningTap {
    fn record(&self, record: LogRecord) {
        if let LogRecord::Adapter(a) = &record {
            if let eamos_mid::log::AdapterEvent::Warning { detail } = &a.event {
                self.events.event(&Event {
                    time: a.time,
                    drone: a.drone.clone(),
                    kind: Kind::AdapterWarning {
                        detail: detail.clone(),
                    },
                });
            }
        }
        self.log.record(record);
    }
}

/// Writes each event to its peer's mission log, `<drone>.mission.jsonl`.
/// Telemetry samples are left out: the adapter log records where each
/// drone was, at the adapter's own rate. Roll-out events belong to no
/// mission and are left out too.
#[derive(Clone)]
pub struct MissionLog {
    tx: Option<std_mpsc::Sender<Line>>,
}

impl Sink for MissionLog {
    fn event(&self, e: &Event) {
        if matches!(e.kind, Kind::Telemetry { .. }) || e.kind.is_rollout() {
            return;
        }
        if let Some(tx) = &self.tx {
            let _ = tx.send(Line::Mission(e.clone()));
        }
    }
}

/// The middle layer's uniform and adapter records of this drone go to its
/// uniform and adapter logs.
impl LogSink for DroneLog {
    fn record(&self, record: LogRecord) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(Line::Mid(self.drone.clone(), record));
        }
    }
}

fn write_all(root: &Path, rx: std_mpsc::Receiver<Line>, append: bool) -> Vec<String> {
    let mut files: HashMap<PathBuf, Option<BufWriter<File>>> = HashMap::new();
    let mut errors = Vec::new();
    loop {
        // Whenever no record is waiting, what was written goes to the
        // files: a process killed outright loses no record it had written.
        let line = match rx.try_recv() {
            Ok(line) => line,
            Err(std_mpsc::TryRecvError::Disconnected) => break,
            Err(std_mpsc::TryRecvError::Empty) => {
                flush_all(&mut files, &mut errors);
                match rx.recv() {
                    Ok(line) => line,
                    Err(_) => break,
                }
            }
        };
        let (path, text) = match line {
            Line::Mission(e) => (
                root.join(format!("{}.mission.jsonl", e.drone)),
                line_of(&e).unwrap_or_default(),
            ),
            Line::Mid(d, r) => {
                let kind = match r {
                    LogRecord::Uniform(_) => "uniform",
                    LogRecord::Adapter(_) => "adapter",
                };
                (root.join(format!("{d}.{kind}.jsonl")), r.to_json_line())
            }
            Line::Close => break,
        };
        let file = files
            .entry(path.clone())
            .or_insert_with(|| match open_file(&path, append) {
                Ok(f) => Some(BufWriter::new(f)),
                Err(e) => {
                    errors.push(format!("cannot create {}: {e}", path.display()));
                    None
                }
            });
        if let Some(f) = file {
            if let Err(e) = writeln!(f, "{text}") {
                errors.push(format!("cannot write {}: {e}", path.display()));
                *file = None;
            }
        }
    }
    flush_all(&mut files, &mut errors);
    errors
}

fn open_file(path: &Path, append: bool) -> std::io::Result<File> {
    if append {
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
    } else {
        File::create(path)
    }
}

fn flush_all(files: &mut HashMap<PathBuf, Option<BufWriter<File>>>, errors: &mut Vec<String>) {
    for (path, file) in files.iter_mut() {
        if let Some(f) = file {
            if let Err(e) = f.flush() {
                errors.push(format!("cannot write {}: {e}", path.display()));
                *file = None;
            }
        }
    }
}

/// One event as a line of the mission log (without its newline): the
/// versioned JSON that the log files hold and that a peer publishes to the
/// mission's observers. `None` only for an event JSON cannot hold.
pub fn line_of(event: &Event) -> Option<String> {
    serde_json::to_string(&LineOut {
        v: MISSION_LOG_VERSION,
        event,
    })
    .ok()
}

/// One line of a mission log read back: its event, or why it is not one
/// this eamos reads.
pub fn event_of(line: &str) -> Result<Event, String> {
    let line: LineIn = serde_json::from_str(line).map_err(|e| e.to_string())?;
    if line.v > MISSION_LOG_VERSION {
        return Err(format!(
            "a mission log of version {}, newer than this eamos reads ({MISSION_LOG_VERSION})",
            line.v
        ));
    }
    Ok(line.event)
}

/// Reads a mission log back (for tests and for tools that check runs).
pub fn read_mission_log(path: &Path) -> Result<Vec<Event>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| event_of(l).map_err(|e| format!("{}:{}: {e}", path.display(), i + 1)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use eamos_mid::log::{AdapterEvent, AdapterRecord};

    #[test]
    fn each_kind_of_record_lands_in_its_own_file_per_drone() {
        let dir = tempfile::tempdir().unwrap();
        let w = LogWriter::create(dir.path()).unwrap();
        let d1 = w.drone("D1");
        w.missions().event(&Event {
            time: 1.0,
            drone: "D1".into(),
            kind: Kind::BridgeSent {
                bridge: 3,
                to: "D2".into(),
                colour: vec![0],
                seq: 1,
            },
        });
        d1.record(LogRecord::Adapter(AdapterRecord {
            time: 1.5,
            drone: "D1".into(),
            adapter: "sim".into(),
            event: AdapterEvent::State {
                detail: "armed".into(),
            },
        }));
        assert!(w.finish().is_empty());
        let log = read_mission_log(&dir.path().join("D1.mission.jsonl")).unwrap();
        assert_eq!(log.len(), 1);
        assert!(matches!(log[0].kind, Kind::BridgeSent { bridge: 3, .. }));
        let text = std::fs::read_to_string(dir.path().join("D1.mission.jsonl")).unwrap();
        assert!(text.starts_with(r#"{"v":1,"time":1.0,"drone":"D1","event":"bridge_sent""#));
        let adapter = std::fs::read_to_string(dir.path().join("D1.adapter.jsonl")).unwrap();
        assert!(adapter.contains("\"event\":\"state\""));
        assert!(!dir.path().join("D1.uniform.jsonl").exists());
    }

    #[test]
    fn a_log_directory_that_cannot_be_created_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain-file");
        std::fs::write(&file, "x").unwrap();
        assert!(LogWriter::create(&file.join("sub")).is_err());
    }

    #[test]
    fn a_line_without_a_version_reads_as_the_first_and_a_later_version_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("D1.mission.jsonl");
        std::fs::write(
            &p,
            "{\"time\":0,\"drone\":\"D1\",\"event\":\"stopped\",\"reason\":\"x\"}\n",
        )
        .unwrap();
        let log = read_mission_log(&p).unwrap();
        assert_eq!(log[0].kind, Kind::Stopped { reason: "x".into() });
        std::fs::write(
            &p,
            "{\"v\":2,\"time\":0,\"drone\":\"D1\",\"event\":\"stopped\",\"reason\":\"x\"}\n",
        )
        .unwrap();
        let err = read_mission_log(&p).unwrap_err();
        assert!(err.contains("version 2"), "{err}");
    }

    #[test]
    fn telemetry_and_rollout_events_stay_out_of_the_mission_log() {
        let dir = tempfile::tempdir().unwrap();
        let w = LogWriter::create(dir.path()).unwrap();
        let at = |kind| Event {
            time: 0.0,
            drone: "D1".into(),
            kind,
        };
        w.missions().event(&at(Kind::Telemetry {
            position: eamos_mid::Vec3::ZERO,
            altitude: 0.0,
            battery: 100.0,
        }));
        w.missions().event(&at(Kind::RolloutStarted {
            identity: "m-1".into(),
        }));
        w.missions()
            .event(&at(Kind::PeerBack { peer: "D2".into() }));
        assert!(w.finish().is_empty());
        let log = read_mission_log(&dir.path().join("D1.mission.jsonl")).unwrap();
        assert_eq!(log.len(), 1);
        assert_eq!(log[0].kind, Kind::PeerBack { peer: "D2".into() });
    }

    #[test]
    fn a_malformed_mission_log_line_is_named_by_line_number() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("D1.mission.jsonl");
        std::fs::write(
            &p,
            "{\"time\":0,\"drone\":\"D1\",\"event\":\"stopped\",\"reason\":\"x\"}\nnot json\n",
        )
        .unwrap();
        let err = read_mission_log(&p).unwrap_err();
        assert!(err.contains(":2:"), "{err}");
    }
}
