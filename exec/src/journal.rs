//! The agent's journal: what one peer did, kept on its own disk so that an
//! agent killed mid-mission (`kill -9`, a power cut of the companion
//! computer) and started again resumes where it was, with every action run
//! exactly once.
//!
//! # What is journaled, and when
//! - the bridge messages this peer consumed (sender, bridge, colour and the
//!   sender's sequence number), written and flushed to the disk **before**
//!   the message is acknowledged: a message acknowledged is never lost, and
//!   a copy retransmitted after a restart is still recognised and dropped;
//! - every transition fired (the marking is the replay of the firings and of
//!   the consumed messages);
//! - every message sent, with its sequence number, flushed before it leaves,
//!   and the acknowledgements received: after a restart the messages not
//!   acknowledged are sent again with their original sequence numbers;
//! - every action started, with the absolute target of a motion computed
//!   from where the drone was when it started, flushed **before** the
//!   adapter is asked to start it; and every action's end;
//! - when each pause (`PauseFor`) began counting, in mission time and wall
//!   time: after a restart it waits only for what was left (see
//!   [`Recovered::paused`]).
//!
//! # Format
//! An append-only file of records, each framed as a little-endian `u32`
//! length, a little-endian `u32` CRC-32 of the payload and the payload
//! (postcard). A crash can leave the last record torn (short, or with a
//! checksum that does not match): it is detected, reported and cut off, and
//! the agent resumes from the records before it. A damaged record followed
//! by good ones is not a torn write but a damaged disk: the journal is
//! refused with the offset of the damage, never guessed around.
//!
//! The first record names the mission, the peer and the format
//! ([`FORMAT`]). A journal of a later format is refused with the format it
//! has, never half read; one of format 1 (whose header, `Opened`, has no
//! format number, and which holds no pause) is read as it was written.
//! An eamos of format 1 cannot read a later journal: it refuses it as
//! damaged at byte 0.
//!
//! # Resuming an action that was running at the crash
//! See [`resume_action`]: a motion flies on to the target recorded when it
//! started (not the relative move again, from wherever the crash left the
//! drone); `Takeoff` completes at once when the drone is already at the
//! height; `Arm`, `Disarm` and `Land` are run again, which the adapters do
//! idempotently (arming an armed drone, landing a landed one succeed at
//! once). Other actions (a photo) are run again: whether the first one
//! happened before the crash cannot be known from the drone.

use std::collections::{HashMap, HashSet};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use serde::{Deserialize, Serialize};

use eamos_mid::{
    ActionCall, ActionError, Adapter, Airframe, CancellationToken, MultirotorAction, Vec3,
};
use eamos_petri::net::{Colour, TransitionKind};
use eamos_slicer::Slice;

use crate::names::{PeerId, ABORT, END, ENDED};

/// One record of the journal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Record {
    /// The first record: which mission (its identity) and which peer the
    /// journal belongs to. A journal of another mission is never replayed.
    Opened { mission_id: String, peer: PeerId },
    /// A bridge message handed to the executor, journaled before it is
    /// acknowledged.
    Consumed {
        from: PeerId,
        bridge: String,
        colour: Colour,
        seq: u64,
    },
    /// A transition fired (by its stable id) with its binding colour.
    Fired { transition: String, colour: Colour },
    /// A message sent, journaled before it leaves.
    Sent(Sent),
    /// The receiver acknowledged a message: it is not sent again.
    Acked {
        to: PeerId,
        bridge: String,
        colour: Colour,
    },
    /// An action is about to be started on the drone.
    Started(Started),
    /// The adapter reported the end of an action; `error` is the failure
    /// kind, `None` when it succeeded.
    Finished {
        instance: u32,
        colour: Colour,
        error: Option<String>,
    },
    /// The agent was restarted from this journal at this mission time.
    Resumed { time: f64 },
    /// A timed transition (a `PauseFor`) began counting.
    Paused(Paused),
    /// The first record from format 2 on: [`Record::Opened`] with the
    /// journal's format, so that a later format is refused by name.
    Header {
        format: u32,
        mission_id: String,
        peer: PeerId,
    },
}

/// The format of the journals this version writes: 2 added
/// [`Record::Paused`] and [`Record::Header`].
pub const FORMAT: u32 = 2;

/// A pause began counting: when, by the mission clock and by the wall
/// clock, so that a restart can tell how much of it has passed whichever
/// clock the mission runs on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Paused {
    /// The timed transition (by its stable id) and its binding colour.
    pub transition: String,
    pub colour: Colour,
    /// Mission time at which it became enabled.
    pub time: f64,
    /// Wall time at which it became enabled, in milliseconds since the
    /// Unix epoch.
    pub wall_ms: u64,
}

impl Paused {
    /// The wall clock now, as [`Paused::wall_ms`] counts it.
    pub fn wall_now_ms() -> u64 {
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64)
    }
}

/// A message sent over a bridge (or an `end`/`abort` notice).
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Sent {
    pub to: PeerId,
    pub bridge: String,
    pub colour: Colour,
    pub seq: u64,
}

/// An action started: what was called and, for a motion, where it goes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Started {
    pub instance: u32,
    pub colour: Colour,
    pub call: ActionCall,
    /// The absolute target (local frame) of a motion to a point.
    pub target: Option<Vec3>,
    /// Mission time of the start.
    pub time: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("cannot {what} the journal {path}: {error}")]
    Io {
        what: &'static str,
        path: String,
        error: std::io::Error,
    },
    #[error("the journal {path} is damaged at byte {offset}: {reason} (records after it are intact, so this is not an interrupted write; move the file away to start afresh)")]
    Damaged {
        path: String,
        offset: u64,
        reason: String,
    },
    #[error("the journal {path} belongs to {found}, not to {expected}: it is not replayed (use another journal directory, or remove the file to start afresh)")]
    Foreign {
        path: String,
        found: String,
        expected: String,
    },
    #[error("the journal {path} does not fit this peer's slice: {reason}")]
    Mismatch { path: String, reason: String },
    #[error("the journal {path} is in format {found}, which this eamos cannot read (it reads formats 1 to {FORMAT}): resume with the eamos that wrote it, or move the file away to start afresh")]
    Format { path: String, found: u32 },
}

/// Bytes of a record's frame before its payload: length and checksum.
const HEADER: usize = 8;
/// No record is anywhere near this long; a longer length is damage.
const MAX_RECORD: u32 = 1 << 20;

/// What reading a journal found.
#[derive(Debug, Clone, PartialEq)]
pub struct Contents {
    pub records: Vec<Record>,
    /// Where the intact records end.
    pub intact: u64,
    /// Bytes of a torn last record cut off (0 when the file ended cleanly).
    pub torn: u64,
}

/// Reads every intact record of a journal's bytes. A torn last record is
/// left out (and counted); damage before intact records is an error.
pub fn decode(path: &str, bytes: &[u8]) -> Result<Contents, JournalError> {
    let mut records = Vec::new();
    let mut at = 0usize;
    let damaged = |offset: usize, reason: String| JournalError::Damaged {
        path: path.to_string(),
        offset: offset as u64,
        reason,
    };
    while at < bytes.len() {
        let rest = &bytes[at..];
        let torn = || Contents {
            records: Vec::new(),
            intact: at as u64,
            torn: rest.len() as u64,
        };
        // A file system may leave the end of a file zero-filled after a
        // power cut: nothing was written there.
        if rest.iter().all(|b| *b == 0) {
            return Ok(Contents { records, ..torn() });
        }
        if rest.len() < HEADER {
            return Ok(Contents { records, ..torn() });
        }
        let len = u32::from_le_bytes(rest[0..4].try_into().expect("four bytes"));
        let crc = u32::from_le_bytes(rest[4..8].try_into().expect("four bytes"));
        if len > MAX_RECORD {
            // A wild length is damage, unless nothing could follow it.
            if looks_like_later_records(&rest[HEADER..]) {
                return Err(damaged(at, format!("a record claims {len} bytes")));
            }
            return Ok(Contents { records, ..torn() });
        }
        let end = HEADER + len as usize;
        if rest.len() < end {
            return Ok(Contents { records, ..torn() });
        }
        let payload = &rest[HEADER..end];
        if crc32fast::hash(payload) != crc {
            if end == rest.len() {
                // The last record, written in part: the crash came mid-write.
                return Ok(Contents { records, ..torn() });
            }
            return Err(damaged(at, "the checksum does not match".to_string()));
        }
        let record: Record = postcard::from_bytes(payload)
            .map_err(|e| damaged(at, format!("the record cannot be read: {e}")))?;
        records.push(record);
        at += end;
    }
    Ok(Contents {
        records,
        intact: at as u64,
        torn: 0,
    })
}

/// Whether some intact record starts somewhere in `bytes`: then what came
/// before it was damaged, not torn by a crash.
fn looks_like_later_records(bytes: &[u8]) -> bool {
    (0..bytes.len()).any(|i| {
        let rest = &bytes[i..];
        if rest.len() < HEADER {
            return false;
        }
        let len = u32::from_le_bytes(rest[0..4].try_into().expect("four bytes")) as usize;
        let crc = u32::from_le_bytes(rest[4..8].try_into().expect("four bytes"));
        len > 0
            && rest.len() >= HEADER + len
            && crc32fast::hash(&rest[HEADER..HEADER + len]) == crc
            && postcard::from_bytes::<Record>(&rest[HEADER..HEADER + len]).is_ok()
    })
}

/// The frame of one record: length, checksum, payload.
pub fn encode(record: &Record) -> Vec<u8> {
    let payload = postcard::to_stdvec(record).expect("records always serialise");
    let mut frame = Vec::with_capacity(HEADER + payload.len());
    frame.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    frame.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    frame.extend_from_slice(&payload);
    frame
}

/// An open journal, appended to by the executor and the bridges of one
/// peer. Writes go straight to the file (no user-space buffer, so a killed
/// process loses nothing it wrote); `durable` writes are also flushed to the
/// disk before they return.
pub struct Journal {
    file: Mutex<File>,
    path: PathBuf,
}

/// A journal opened for a peer, with what it held.
pub struct Opened {
    pub journal: Journal,
    /// The records before this run (without the `Opened` header); empty for
    /// a new journal.
    pub records: Vec<Record>,
    /// Bytes of a torn last record that were cut off.
    pub torn: u64,
}

impl Journal {
    /// The journal file of `peer` in `dir`.
    pub fn path(dir: &Path, peer: &str) -> PathBuf {
        dir.join(format!("{peer}.journal"))
    }

    /// Opens (or creates) the journal of `peer` for the mission
    /// `mission_id`: reads what it holds, cuts off a torn last record, and
    /// positions for appending.
    pub fn open(path: &Path, mission_id: &str, peer: &str) -> Result<Opened, JournalError> {
        let name = path.display().to_string();
        let io = |what: &'static str| {
            let name = name.clone();
            move |error| JournalError::Io {
                what,
                path: name,
                error,
            }
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io("create the directory of"))?;
        }
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)
            .map_err(io("open"))?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes).map_err(io("read"))?;
        let read = decode(&name, &bytes)?;
        let expected = format!("mission {mission_id}, peer {peer}");
        let mut records = read.records.into_iter();
        let header = match records.next() {
            None => None,
            Some(Record::Opened {
                mission_id: m,
                peer: p,
            }) => Some((1, m, p)),
            Some(Record::Header {
                format,
                mission_id: m,
                peer: p,
            }) => Some((format, m, p)),
            Some(other) => {
                return Err(JournalError::Damaged {
                    path: name,
                    offset: 0,
                    reason: format!("it starts with {other:?} instead of its header"),
                })
            }
        };
        let fresh = match header {
            None => true,
            Some((format, _, _)) if format > FORMAT => {
                return Err(JournalError::Format {
                    path: name,
                    found: format,
                });
            }
            Some((_, m, p)) => {
                if m != mission_id || p != peer {
                    return Err(JournalError::Foreign {
                        path: name,
                        found: format!("mission {m}, peer {p}"),
                        expected,
                    });
                }
                false
            }
        };
        if read.torn > 0 {
            tracing::warn!(
                "{name}: the last record was torn by a crash ({} bytes); resuming from the records before it",
                read.torn
            );
        }
        file.set_len(read.intact)
            .map_err(io("cut the torn end of"))?;
        file.seek(SeekFrom::Start(read.intact))
            .map_err(io("seek in"))?;
        let journal = Journal {
            file: Mutex::new(file),
            path: path.to_path_buf(),
        };
        if fresh {
            journal.append(
                &Record::Header {
                    format: FORMAT,
                    mission_id: mission_id.to_string(),
                    peer: peer.to_string(),
                },
                true,
            )?;
        }
        Ok(Opened {
            journal,
            records: records.collect(),
            torn: read.torn,
        })
    }

    /// Appends one record; with `durable`, returns only once it is on the
    /// disk.
    pub fn append(&self, record: &Record, durable: bool) -> Result<(), JournalError> {
        let frame = encode(record);
        let mut file = self.file.lock().unwrap_or_else(|p| p.into_inner());
        let io = |what: &'static str| {
            let path = self.path.display().to_string();
            move |error| JournalError::Io { what, path, error }
        };
        file.write_all(&frame).map_err(io("write to"))?;
        if durable {
            file.sync_data().map_err(io("flush to the disk"))?;
        }
        Ok(())
    }

    pub fn file(&self) -> &Path {
        &self.path
    }
}

/// An agent's journal as the executor and the bridges share it.
#[derive(Clone)]
pub struct AgentJournal {
    pub journal: Arc<Journal>,
    /// What the journal held when the agent started.
    pub recovered: Arc<Recovered>,
}

/// Opens the journal of `slice`'s peer in `dir` and replays it.
pub fn open_agent(dir: &Path, slice: &Slice) -> Result<AgentJournal, JournalError> {
    let path = Journal::path(dir, &slice.drone);
    let opened = Journal::open(&path, &slice.mission_id, &slice.drone)?;
    let recovered = replay(slice, &path.display().to_string(), &opened.records)?;
    Ok(AgentJournal {
        journal: Arc::new(opened.journal),
        recovered: Arc::new(recovered),
    })
}

/// The file the simulated airframe of `drone` is recorded in.
pub fn airframe_path(dir: &Path, drone: &str) -> PathBuf {
    dir.join(format!("{drone}.airframe.json"))
}

/// Records a simulated airframe: written aside and renamed over the last
/// record, so that a crash leaves either the old record or the new one.
pub fn write_airframe(path: &Path, airframe: &Airframe) -> std::io::Result<()> {
    let tmp = path.with_extension("json.tmp");
    let text = serde_json::to_vec(airframe).map_err(std::io::Error::other)?;
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, path)
}

/// The recorded airframe, if there is one.
pub fn read_airframe(path: &Path) -> Result<Option<Airframe>, JournalError> {
    let name = path.display().to_string();
    match std::fs::read(path) {
        Ok(bytes) => serde_json::from_slice(&bytes)
            .map(Some)
            .map_err(|e| JournalError::Damaged {
                path: name,
                offset: e.column() as u64,
                reason: format!("the airframe record cannot be read: {e}"),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(error) => Err(JournalError::Io {
            what: "read",
            path: name,
            error,
        }),
    }
}

/// An action that was started and had not ended when the journal stops.
#[derive(Debug, Clone, PartialEq)]
pub struct Interrupted {
    pub instance: u32,
    pub colour: Colour,
    pub call: ActionCall,
    pub target: Option<Vec3>,
    /// Mission time of the start.
    pub time: f64,
}

/// The state of a peer as its journal tells it: what the executor and the
/// bridges start from after a restart.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Recovered {
    /// Records replayed.
    pub records: usize,
    /// Tokens per local place.
    pub marking: Vec<Vec<Colour>>,
    /// Bridge messages already consumed, by (sender, bridge, colour): a
    /// copy arriving again is acknowledged and dropped.
    pub delivered: HashSet<(PeerId, String, Colour)>,
    /// Messages sent and not acknowledged, to send again as they were.
    pub unacked: Vec<Sent>,
    /// Messages a journaled firing sends whose sending was not journaled
    /// (the crash came in between): to send now.
    pub unsent: Vec<(PeerId, String, Colour)>,
    /// The highest sequence number used so far.
    pub last_seq: u64,
    /// Every action started, in order.
    pub started: Vec<(u32, Colour)>,
    /// Actions that were running at the crash.
    pub interrupted: Vec<Interrupted>,
    /// Actions whose start transition fired but which were never started.
    pub not_started: Vec<(u32, Colour)>,
    /// Actions that ended well and whose end has not fired yet.
    pub succeeded: HashSet<(u32, Colour)>,
    /// Actions counted as the executor counts them.
    pub actions: u32,
    pub actions_cancelled: u32,
    pub sent: u64,
    pub received: u64,
    /// Who announced reaching the end of the mission: the senders of `end`
    /// notices consumed, and this peer itself when its final place is
    /// marked. The executor takes them as it takes live notices.
    pub ends: Vec<PeerId>,
    /// The senders of `ended` notices consumed (the ground station's word
    /// that every end is reached).
    pub ended: Vec<PeerId>,
    /// The senders of `abort` notices consumed.
    pub aborts: Vec<PeerId>,
    /// The end of the mission was reached (the final place was marked here, or the end
    /// notice came).
    pub completed: bool,
    /// The mission failed (an action here, or a peer's abort notice).
    pub failed: Option<String>,
    /// Mission time of the last `Started` record, for a simulator whose
    /// clock restarts.
    pub last_time: f64,
    /// Pauses that had begun counting and whose transition had not fired
    /// at the crash: the executor resumes each with what was left of it.
    pub paused: Vec<Paused>,
}

impl Recovered {
    /// Whether there is anything to resume (the journal held more than
    /// its header).
    pub fn is_resume(&self) -> bool {
        self.records > 0
    }
}

/// Replays a journal's records over `slice`, as the executor played them.
pub fn replay(slice: &Slice, path: &str, records: &[Record]) -> Result<Recovered, JournalError> {
    let mismatch = |reason: String| JournalError::Mismatch {
        path: path.to_string(),
        reason,
    };
    let mut r = Recovered {
        records: records.len(),
        marking: vec![Vec::new(); slice.places.len()],
        ..Recovered::default()
    };
    for &p in &slice.initial_marking {
        if r.marking[p as usize].is_empty() {
            r.marking[p as usize].push(Vec::new());
        }
    }
    let inboxes: HashMap<String, u32> = slice
        .bridges_in
        .iter()
        .map(|b| (b.id.to_string(), b.inbox))
        .collect();
    let mut sent: Vec<Sent> = Vec::new();
    let mut sent_keys: HashSet<(PeerId, String, Colour)> = HashSet::new();
    let mut acked: HashSet<(PeerId, String, Colour)> = HashSet::new();
    let mut expected: Vec<(PeerId, String, Colour)> = Vec::new();
    // Running on the drone: started, not ended, not cancelled.
    let mut running: Vec<Interrupted> = Vec::new();
    // Started and not yet ended or cancelled in the net.
    let mut open: HashSet<(u32, Colour)> = HashSet::new();
    // Pauses counting and not yet over.
    let mut paused: Vec<Paused> = Vec::new();
    for record in records {
        match record {
            Record::Opened { .. } | Record::Header { .. } => {
                return Err(mismatch("a second header in the middle".to_string()));
            }
            Record::Paused(p) => {
                if slice.transition_by_id(&p.transition).is_none() {
                    return Err(mismatch(format!(
                        "it paused on transition {}, which is not in this slice",
                        p.transition
                    )));
                }
                paused.retain(|q| (&q.transition, &q.colour) != (&p.transition, &p.colour));
                paused.push(p.clone());
            }
            Record::Resumed { .. } => {}
            Record::Consumed {
                from,
                bridge,
                colour,
                seq: _,
            } => {
                if !r
                    .delivered
                    .insert((from.clone(), bridge.clone(), colour.clone()))
                {
                    continue;
                }
                match bridge.as_str() {
                    END => {
                        r.completed = true;
                        r.ends.push(from.clone());
                    }
                    ENDED => {
                        r.completed = true;
                        r.ended.push(from.clone());
                    }
                    ABORT => r.aborts.push(from.clone()),
                    _ => {
                        let Some(&inbox) = inboxes.get(bridge) else {
                            return Err(mismatch(format!(
                                "it consumed a message on bridge {bridge}, which does not come into this slice"
                            )));
                        };
                        r.received += 1;
                        r.marking[inbox as usize].push(colour.clone());
                    }
                }
            }
            Record::Fired { transition, colour } => {
                paused.retain(|q| (&q.transition, &q.colour) != (transition, colour));
                let Some(t) = slice.transition_by_id(transition) else {
                    return Err(mismatch(format!(
                        "it fired transition {transition}, which is not in this slice"
                    )));
                };
                let st = &slice.transitions[t as usize];
                for &p in &st.consume {
                    let tokens = &mut r.marking[p as usize];
                    if !tokens.is_empty() {
                        tokens.remove(0);
                    }
                }
                for pr in &st.produce {
                    r.marking[pr.place as usize].push(pr.colour.apply(colour));
                }
                for b in slice.sends(t) {
                    expected.push((b.to.clone(), b.id.to_string(), b.colour.apply(colour)));
                }
                match &st.transition.kind {
                    TransitionKind::ActionStart(a) => {
                        r.not_started.push((a.instance, colour.clone()));
                    }
                    TransitionKind::ActionEnd(a) => {
                        let key = (a.instance, colour.clone());
                        r.succeeded.remove(&key);
                        open.remove(&key);
                        r.actions += 1;
                    }
                    TransitionKind::ActionCancel(a) => {
                        let key = (a.instance, colour.clone());
                        let was_open = open.remove(&key);
                        if r.succeeded.remove(&key) {
                            r.actions += 1;
                        } else if was_open {
                            r.actions_cancelled += 1;
                            running.retain(|i| (i.instance, &i.colour) != (key.0, &key.1));
                        }
                        r.not_started.retain(|k| *k != key);
                    }
                    _ => {}
                }
                if slice
                    .final_place
                    .is_some_and(|f| !r.marking[f as usize].is_empty())
                    && !r.ends.contains(&slice.drone)
                {
                    r.completed = true;
                    r.ends.push(slice.drone.clone());
                }
            }
            Record::Sent(s) => {
                r.last_seq = r.last_seq.max(s.seq);
                if s.bridge != END && s.bridge != ENDED && s.bridge != ABORT {
                    r.sent += 1;
                }
                sent_keys.insert((s.to.clone(), s.bridge.clone(), s.colour.clone()));
                sent.push(s.clone());
            }
            Record::Acked { to, bridge, colour } => {
                acked.insert((to.clone(), bridge.clone(), colour.clone()));
            }
            Record::Started(s) => {
                let key = (s.instance, s.colour.clone());
                r.not_started.retain(|k| *k != key);
                r.started.push(key.clone());
                open.insert(key);
                r.last_time = r.last_time.max(s.time);
                running.push(Interrupted {
                    instance: s.instance,
                    colour: s.colour.clone(),
                    call: s.call.clone(),
                    target: s.target,
                    time: s.time,
                });
            }
            Record::Finished {
                instance,
                colour,
                error,
            } => {
                let key = (*instance, colour.clone());
                let was_running = running
                    .iter()
                    .any(|i| (i.instance, &i.colour) == (key.0, &key.1));
                running.retain(|i| (i.instance, &i.colour) != (key.0, &key.1));
                if !was_running || !open.contains(&key) {
                    continue;
                }
                match error {
                    None => {
                        r.succeeded.insert(key);
                    }
                    Some(kind) => {
                        open.remove(&key);
                        r.failed.get_or_insert_with(|| {
                            format!(
                                "{}: action instance {instance} failed ({kind})",
                                slice.drone
                            )
                        });
                    }
                }
            }
        }
    }
    r.unacked = sent
        .into_iter()
        .filter(|s| !acked.contains(&(s.to.clone(), s.bridge.clone(), s.colour.clone())))
        .collect();
    r.unsent = expected
        .into_iter()
        .filter(|k| !sent_keys.contains(k))
        .collect();
    r.interrupted = running;
    r.paused = paused;
    Ok(r)
}

/// Runs again an action that was running when the agent crashed, as the
/// drone's state now requires (see the module docs).
pub async fn resume_action(
    drone: &dyn Adapter,
    call: &ActionCall,
    target: Option<Vec3>,
    started: f64,
    cancel: CancellationToken,
) -> Result<(), ActionError> {
    let now = *drone.telemetry().borrow();
    match (MultirotorAction::parse(call), target) {
        // Still on the ground: the climb never began.
        (Ok(MultirotorAction::Takeoff { .. }), Some(_)) if now.landed => {
            drone.run(call, cancel).await
        }
        (Ok(action), Some(target)) if action.is_motion() => {
            drone.fly_to_target(call, target, cancel).await
        }
        (Ok(MultirotorAction::Hover { seconds }), None) => {
            let elapsed = (drone.clock().now() - started).clamp(0.0, seconds);
            let rest = ActionCall::new(call.name.clone(), vec![seconds - elapsed]);
            drone.run(&rest, cancel).await
        }
        _ => drone.run(call, cancel).await,
    }
}

/// When a pause journaled as `p` began, on the clock of a restarted agent
/// whose mission clock reads `now`: a simulated clock goes on from the
/// recorded airframes' time (nothing flew while the agent was down), so
/// the pause's mission time stands; a wall clock restarts with the agent
/// while the world went on, so what passed is told by the wall clock.
/// Never later than `now`: a pause does not grow by a restart.
pub fn pause_began(p: &Paused, simulated: bool, now: f64, wall_now_ms: u64) -> f64 {
    let began = if simulated {
        p.time
    } else {
        now - wall_now_ms.saturating_sub(p.wall_ms) as f64 / 1000.0
    };
    began.min(now)
}

#[cfg(test)]
pub(crate) mod tests;
