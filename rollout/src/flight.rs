//! The flight an agent has started, kept on its disk until the flight
//! ends, so that an agent killed mid-flight (`kill -9`, a companion
//! computer that reboots) and started again flies on from its journal
//! instead of waiting for a start command that will never come again: the
//! ground station started that session once, and the agent never starts a
//! session twice.
//!
//! What is kept is what the agent flew: the start command still sealed as
//! the ground station sent it, and the slice it started. On a restart the
//! seal is opened again with the trusted key and the slice must be the one
//! the start command names for this drone (by digest), so a damaged or
//! altered record is refused, never flown. The record is written, and
//! flushed to the disk, before the start is obeyed; it is removed once the
//! flight has ended, whatever its outcome.
//!
//! Where the flight's journal lives is a function of the deploy session
//! ([`journal_dir`]): every session flies once, so a journal is never
//! replayed into another flight, and none is deleted.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use eamos_fleet::identity::slice_digest;
use eamos_seal::{Sealed, CONTEXT_START};
use eamos_slicer::Slice;

use crate::gate::Gate;
use crate::sessions::{check_session, Sessions};
use crate::wire::{decode, encode, StartCommand};

/// The record of a started flight, as kept on the agent's disk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Record {
    /// The start command, sealed as it was received.
    start: Vec<u8>,
    /// The slice started, in its binary form (with its own checksum).
    slice: Vec<u8>,
}

/// A flight to resume: its start command and its slice, both checked.
#[derive(Debug)]
pub struct Resumed {
    pub start: StartCommand,
    pub slice: Slice,
    pub digest: String,
}

/// Where the agent of `drone` keeps its started flight.
pub fn record_path(out: &Path, drone: &str) -> PathBuf {
    out.join(format!("{drone}.flight"))
}

/// The journal of the flight of `session` of `mission`.
pub fn journal_dir(out: &Path, mission: &str, session: &str) -> PathBuf {
    out.join(mission).join("journal").join(session)
}

/// Keeps the started flight on the disk, flushed before it returns: a
/// start that cannot be kept is not obeyed (a crash would lose it).
pub fn keep(path: &Path, sealed_start: &[u8], slice: &Slice) -> Result<(), String> {
    let bytes = encode(&Record {
        start: sealed_start.to_vec(),
        slice: slice.to_bytes(),
    });
    let fail = |e: std::io::Error| format!("cannot keep the flight in {}: {e}", path.display());
    // Written aside and renamed: a crash leaves the old record or the new
    // one, never half of one.
    let aside = path.with_extension("flight.new");
    let mut f = std::fs::File::create(&aside).map_err(fail)?;
    f.write_all(&bytes).map_err(fail)?;
    f.sync_all().map_err(fail)?;
    std::fs::rename(&aside, path).map_err(fail)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::File::open(dir)
            .and_then(|d| d.sync_all())
            .map_err(fail)?;
    }
    Ok(())
}

/// Forgets the flight once it has ended.
pub fn forget(path: &Path) -> Result<(), String> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!(
            "cannot remove the ended flight {}: {e}",
            path.display()
        )),
    }
}

/// The flight kept in `path`, if any, checked by `gate` as it was when it
/// started: sealed by the trusted key, of this fleet, and naming by digest
/// the very slice kept beside it. The session is recorded as started if
/// the crash came between keeping the flight and recording it.
pub fn resume(path: &Path, gate: &Gate, started: &mut Sessions) -> Result<Option<Resumed>, String> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("cannot read {}: {e}", path.display())),
    };
    let refuse = |why: String| {
        format!(
            "{}: the flight this agent started cannot be resumed: {why}; remove the file to give it up",
            path.display()
        )
    };
    let record: Record = decode(&bytes).map_err(|e| refuse(format!("damaged record: {e}")))?;
    let start = Sealed::from_bytes(&record.start)
        .map_err(|e| e.to_string())
        .and_then(|s| {
            s.open_with(gate.trusted.as_ref(), CONTEXT_START)
                .map(<[u8]>::to_vec)
                .map_err(|e| e.to_string())
        })
        .and_then(|payload| StartCommand::from_bytes(&payload))
        .map_err(|e| refuse(format!("its start command: {e}")))?;
    check_session(&start.session).map_err(refuse)?;
    if start.fleet != gate.fleet_digest() {
        return Err(refuse(format!(
            "it was started with another fleet file than {}",
            gate.fleet_name
        )));
    }
    let mut slice =
        Slice::from_bytes(&record.slice).map_err(|e| refuse(format!("damaged slice: {e}")))?;
    let digest = slice_digest(&slice);
    if slice.drone != gate.drone || start.digests.get(&gate.drone) != Some(&digest) {
        return Err(refuse(format!(
            "its slice ({digest}, of {}) is not the one its start command gives {}",
            slice.drone, gate.drone
        )));
    }
    slice.mission_id = start.identity.clone();
    if !started.contains(&start.session) {
        started.record(&start.session, &start.identity)?;
    }
    Ok(Some(Resumed {
        start,
        slice,
        digest,
    }))
}
