//! The flight an agent keeps on its disk while it flies, and what a
//! restarted agent accepts of it.

use eamos_seal::GroundKey;

use super::{gate, held_and_start, FLEET, SESSION};
use crate::flight::{forget, keep, record_path, resume};
use crate::sessions::Sessions;

/// A flight kept by D2's agent in `dir`, started by `key`.
fn kept(dir: &std::path::Path, key: &GroundKey) -> std::path::PathBuf {
    let (v1, _, start) = held_and_start(key, SESSION);
    let path = record_path(dir, "D2");
    keep(&path, &start, v1.get("D2").unwrap()).unwrap();
    path
}

#[test]
fn a_kept_flight_resumes_with_its_start_and_slice_and_is_gone_once_forgotten() {
    let key = GroundKey::generate().unwrap();
    let g = gate("D2", FLEET, Some(key.public()));
    let dir = tempfile::tempdir().unwrap();
    let path = kept(dir.path(), &key);
    let sessions_file = dir.path().join("D2.sessions");
    let mut sessions = Sessions::load(&sessions_file).unwrap();
    let r = resume(&path, &g, &mut sessions).unwrap().expect("a flight");
    assert_eq!(r.start.session, SESSION);
    assert_eq!(r.slice.drone, "D2");
    assert_eq!(r.slice.mission_id, r.start.identity);
    assert_eq!(Some(&r.digest), r.start.digests.get("D2"));
    // The crash came before the session was recorded: it is now, so the
    // start played back is still refused.
    assert!(Sessions::load(&sessions_file).unwrap().contains(SESSION));

    forget(&path).unwrap();
    forget(&path).unwrap();
    assert!(resume(&path, &g, &mut sessions).unwrap().is_none());
}

#[test]
fn a_damaged_or_foreign_flight_is_refused_naming_its_file_and_never_flown() {
    let key = GroundKey::generate().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = kept(dir.path(), &key);
    let name = path.display().to_string();
    let refused = |g: &crate::gate::Gate| resume(&path, g, &mut Sessions::default()).unwrap_err();

    // Signed by another ground station than the one this agent trusts.
    let other = GroundKey::generate().unwrap();
    let e = refused(&gate("D2", FLEET, Some(other.public())));
    assert!(
        e.starts_with(&name) && e.contains("its start command"),
        "{e}"
    );
    assert!(e.contains("remove the file"), "{e}");
    // Another drone's agent, or another fleet file.
    let e = refused(&gate("D1", FLEET, Some(key.public())));
    assert!(
        e.contains("is not the one its start command gives D1"),
        "{e}"
    );
    let e = refused(&gate("D2", "[drones.D1]\n", Some(key.public())));
    assert!(e.contains("another fleet file"), "{e}");

    // A byte of the slice changed on the disk.
    let mut bytes = std::fs::read(&path).unwrap();
    let last = bytes.len() - 3;
    bytes[last] ^= 0x40;
    std::fs::write(&path, &bytes).unwrap();
    let e = refused(&gate("D2", FLEET, Some(key.public())));
    assert!(e.starts_with(&name) && e.contains("damaged"), "{e}");
    // Cut short.
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = refused(&gate("D2", FLEET, Some(key.public())));
    assert!(e.contains("damaged record"), "{e}");
    // Still there: refusing to fly it loses nothing.
    assert!(path.exists());
}

#[test]
fn a_flight_that_cannot_be_kept_is_an_error_naming_the_file() {
    let key = GroundKey::generate().unwrap();
    let (v1, _, start) = held_and_start(&key, SESSION);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no-such-dir").join("D2.flight");
    let e = keep(&path, &start, v1.get("D2").unwrap()).unwrap_err();
    assert!(e.starts_with("cannot keep the flight in"), "{e}");
    assert!(e.contains("no-such-dir"), "{e}");
}
