//! Records of the per-drone logs the paper keeps (section VII-C): the
//! uniform log (every API call, its arguments, outcome and duration) and
//! the adapter log (what the adapter did to the platform, and where the
//! drone was).
//!
//! The middle layer only produces records; the executor decides where they
//! go (one JSON line per record in per-drone files, a test's memory, or
//! nowhere) by handing a [`LogSink`] to the adapters and to
//! [`crate::uniform::Uniform`].

use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;

use crate::api::{FlightMode, Vec3};

/// One line of a per-drone log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "log", rename_all = "snake_case")]
pub enum LogRecord {
    Uniform(UniformRecord),
    Adapter(AdapterRecord),
}

impl LogRecord {
    /// The drone the record is about.
    pub fn drone(&self) -> &str {
        match self {
            LogRecord::Uniform(r) => &r.drone,
            LogRecord::Adapter(r) => &r.drone,
        }
    }

    /// Mission time of the record, in seconds.
    pub fn time(&self) -> f64 {
        match self {
            LogRecord::Uniform(r) => r.time,
            LogRecord::Adapter(r) => r.time,
        }
    }

    /// The record as one JSON line (no trailing newline).
    pub fn to_json_line(&self) -> String {
        serde_json::to_string(self).expect("log records contain only finite numbers and strings")
    }
}

/// A call through the uniform API: one record when it starts, one when it
/// ends (with the outcome and how long it took in mission time). `call`
/// pairs the two.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UniformRecord {
    pub time: f64,
    pub drone: String,
    /// Sequence number of the call on this drone.
    pub call: u64,
    pub action: String,
    pub args: Vec<f64>,
    pub phase: CallPhase,
    /// `ok`, or the error kind (`refused`, `cancelled`, ...); only when
    /// finished.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outcome: Option<String>,
    /// The error message a pilot reads; only for failures.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Mission seconds from start to end; only when finished.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub duration: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CallPhase {
    Started,
    Finished,
}

/// Something the adapter did or saw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AdapterRecord {
    pub time: f64,
    pub drone: String,
    /// The adapter kind (`sim`, `mavlink`).
    pub adapter: String,
    #[serde(flatten)]
    pub event: AdapterEvent,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum AdapterEvent {
    /// Where the drone is, written at a modest rate while it is armed.
    Position {
        position: Vec3,
        velocity: Vec3,
        battery: f64,
        armed: bool,
        mode: FlightMode,
    },
    /// The adapter passed an action on to the platform, in the platform's
    /// own terms (a target, a mode, a MAVLink command).
    Command {
        action: String,
        args: Vec<f64>,
        detail: String,
    },
    /// The platform finished (or gave up) an action.
    Completed {
        action: String,
        outcome: String,
        detail: String,
    },
    /// A change of state not asked for by an action: touchdown, low
    /// battery, a pilot taking over, a link coming back.
    State { detail: String },
    /// Something the crew must read before or during the flight, such as
    /// an autopilot that would leave the drone with nobody in charge on a
    /// lost link. Whoever runs the mission shows it, not only the log.
    Warning { detail: String },
}

/// Where records go. Implementations must not block: records are produced
/// from inside the simulation step and from adapters' receive loops.
pub trait LogSink: Send + Sync {
    fn record(&self, record: LogRecord);
}

/// A sink shared by the adapters and the uniform layer of one drone.
pub type SharedSink = Arc<dyn LogSink>;

/// Drops every record.
#[derive(Debug, Default, Clone, Copy)]
pub struct NullSink;

impl LogSink for NullSink {
    fn record(&self, _record: LogRecord) {}
}

/// Keeps every record in memory (tests, short runs, reports).
#[derive(Debug, Default)]
pub struct MemorySink {
    records: Mutex<Vec<LogRecord>>,
}

impl MemorySink {
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// A copy of what was recorded so far.
    pub fn records(&self) -> Vec<LogRecord> {
        self.records
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}

impl LogSink for MemorySink {
    fn record(&self, record: LogRecord) {
        self.records
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(record);
    }
}

/// Forwards records to a task that writes them (the executor's log
/// writer). A closed channel drops records: losing the log must not stop a
/// flight.
impl LogSink for mpsc::UnboundedSender<LogRecord> {
    fn record(&self, record: LogRecord) {
        let _ = self.send(record);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_adapter_record_is_one_flat_json_line_and_reads_back() {
        let r = LogRecord::Adapter(AdapterRecord {
            time: 1.5,
            drone: "D1".into(),
            adapter: "sim".into(),
            event: AdapterEvent::Command {
                action: "FlyByX".into(),
                args: vec![1.0],
                detail: "target (1.00, 0.00, 1.50)".into(),
            },
        });
        let line = r.to_json_line();
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v["log"], "adapter");
        assert_eq!(v["event"], "command");
        assert_eq!(v["drone"], "D1");
        assert_eq!(v["args"][0], 1.0);
        let back: LogRecord = serde_json::from_str(&line).unwrap();
        assert_eq!(back, r);
    }

    #[test]
    fn a_finished_uniform_record_carries_outcome_and_duration() {
        let r = LogRecord::Uniform(UniformRecord {
            time: 4.0,
            drone: "D2".into(),
            call: 3,
            action: "Takeoff".into(),
            args: vec![1.5],
            phase: CallPhase::Finished,
            outcome: Some("ok".into()),
            error: None,
            duration: Some(2.5),
        });
        let v: serde_json::Value = serde_json::from_str(&r.to_json_line()).unwrap();
        assert_eq!(v["log"], "uniform");
        assert_eq!(v["phase"], "finished");
        assert_eq!(v["duration"], 2.5);
        assert!(v.get("error").is_none());
    }

    #[test]
    fn a_channel_sink_forwards_and_survives_a_closed_receiver() {
        let (tx, mut rx) = mpsc::unbounded_channel();
        let rec = LogRecord::Adapter(AdapterRecord {
            time: 0.0,
            drone: "D1".into(),
            adapter: "sim".into(),
            event: AdapterEvent::State {
                detail: "armed".into(),
            },
        });
        tx.record(rec.clone());
        assert_eq!(rx.try_recv().unwrap(), rec);
        drop(rx);
        tx.record(rec);
    }
}
