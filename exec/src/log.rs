//! The three per-drone logs of the paper (section VII-C), as JSON lines in
//! one directory, every record stamped with mission time:
//!
//! - `<drone>.mission.jsonl`: the mission log, written by the executor:
//!   firings, actions started and finished, bridge messages sent and
//!   received, conditions waited on, how the run ended;
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
use eamos_petri::net::Colour;

/// One line of a mission log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionRecord {
    /// Mission time, seconds.
    pub time: f64,
    pub drone: String,
    #[serde(flatten)]
    pub event: MissionEvent,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum MissionEvent {
    /// The executor of this slice is up.
    Started {
        mission: String,
        mission_id: String,
        places: usize,
        transitions: usize,
        bridges_in: usize,
        bridges_out: usize,
    },
    /// A transition fired with the binding colour.
    Fired {
        transition: String,
        label: String,
        kind: String,
        colour: Colour,
    },
    BridgeSent {
        bridge: u32,
        to: String,
        colour: Colour,
        seq: u64,
    },
    BridgeReceived {
        bridge: u32,
        from: String,
        colour: Colour,
        seq: u64,
    },
    ActionStarted {
        action: String,
        args: Vec<f64>,
        instance: u32,
        colour: Colour,
    },
    /// The adapter reported the end of an action (`ok`, or the error kind).
    ActionFinished {
        action: String,
        instance: u32,
        colour: Colour,
        outcome: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
    /// The agent restarted from its journal: how many records it replayed,
    /// how many actions were running at the crash, how many messages it
    /// sends again.
    Resumed {
        records: usize,
        interrupted: usize,
        unacked: usize,
    },
    /// An action that was running when the agent crashed goes on (a motion
    /// towards the target journaled when it started). Its end is logged as
    /// `action_finished`; it is not a second start.
    ActionResumed {
        action: String,
        args: Vec<f64>,
        instance: u32,
        colour: Colour,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        target: Option<eamos_mid::Vec3>,
    },
    /// An interrupted `Do` cancelled a running action.
    ActionCancelled {
        action: String,
        instance: u32,
        colour: Colour,
    },
    /// A transition has its tokens but its condition does not let it fire
    /// (logged once per transition and colour, when the wait begins).
    ConditionWaiting {
        transition: String,
        condition: String,
        reason: String,
    },
    /// The final place is marked (here, or as told by the peer holding it).
    MissionEnded { by: String },
    /// The mission time limit expired; what was still waiting.
    TimeLimit { waiting: Vec<String> },
    /// The executor stopped.
    Stopped { reason: String },
    /// A peer seen up has gone (its liveliness token was deleted).
    PeerLost { peer: String },
    /// A lost peer is up again.
    PeerBack { peer: String },
    /// This drone waits on peers lost for the grace period and follows
    /// its policy (`hold`, `land`, `home`, `abort`).
    Stuck { lost: Vec<String>, policy: String },
    /// A peer told this one (the ground station) that it is stuck on a
    /// lost peer, and what it does about it.
    PeerStuck {
        /// The drone that is stuck (`drone` names the record's writer).
        peer: String,
        lost: String,
        policy: String,
    },
    /// An abort was obeyed: every action is cancelled, the drone goes to
    /// its failsafe, every other peer is told.
    AbortReceived { from: String, reason: String },
    /// An abort was refused (another mission, not signed by the ground
    /// station, garbled); the flight goes on.
    AbortRefused { from: String, reason: String },
    /// The drone goes to its failsafe (once per run at most).
    Failsafe {
        failsafe: String,
        reason: String,
        airborne: bool,
    },
    /// How the failsafe ended (`ok`, or the error kind).
    FailsafeFinished {
        failsafe: String,
        outcome: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
}

enum Line {
    Mission(String, MissionRecord),
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

    /// The logs of one drone (or of the ground station).
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

    pub fn mission(&self, time: f64, event: MissionEvent) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(Line::Mission(
                self.drone.clone(),
                MissionRecord {
                    time,
                    drone: self.drone.clone(),
                    event,
                },
            ));
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
            Line::Mission(d, r) => (
                root.join(format!("{d}.mission.jsonl")),
                serde_json::to_string(&r).unwrap_or_default(),
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

/// Reads a mission log back (for tests and for tools that check runs).
pub fn read_mission_log(path: &Path) -> Result<Vec<MissionRecord>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            serde_json::from_str(l).map_err(|e| format!("{}:{}: {e}", path.display(), i + 1))
        })
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
        d1.mission(
            1.0,
            MissionEvent::BridgeSent {
                bridge: 3,
                to: "D2".into(),
                colour: vec![0],
                seq: 1,
            },
        );
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
        assert!(matches!(
            log[0].event,
            MissionEvent::BridgeSent { bridge: 3, .. }
        ));
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
