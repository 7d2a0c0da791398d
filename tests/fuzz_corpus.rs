//! Every committed fuzz seed replayed as an ordinary test, through the same
//! bodies the libFuzzer targets run (`fuzz/src/`), in the normal build: a
//! seed that makes a target panic fails here, on every machine, without
//! building the fuzz package or a sanitizer. Longer fuzzing runs stay
//! `scripts/fuzz-smoke`.

use std::fs;
use std::path::{Path, PathBuf};

#[path = "../fuzz/src/bridge_frames.rs"]
mod bridge_frames;
#[path = "../fuzz/src/deploy_messages.rs"]
mod deploy_messages;
#[path = "../fuzz/src/front_end.rs"]
mod front_end;
#[path = "../fuzz/src/mavlink_input.rs"]
mod mavlink_input;
#[path = "../fuzz/src/slice_binary.rs"]
mod slice_binary;
#[path = "../fuzz/src/slice_json.rs"]
mod slice_json;

/// The files of `dirs` (relative to the workspace), sorted so that a failure
/// names the same seed on every run.
fn seeds(dirs: &[&str]) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in dirs {
        let dir = root.join(dir);
        let entries = fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        for entry in entries {
            let path = entry.expect("a readable directory entry").path();
            if path.is_file() {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// Runs `body` on every seed of `dirs`, naming the seed that panicked, and
/// returns how many were replayed.
fn replay(dirs: &[&str], body: fn(&[u8])) -> usize {
    let files = seeds(dirs);
    for file in &files {
        let data = fs::read(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        if std::panic::catch_unwind(|| body(&data)).is_err() {
            panic!("fuzz seed {} makes its target panic", file.display());
        }
    }
    files.len()
}

#[test]
fn every_bridge_frame_seed_decodes_without_panic() {
    assert!(replay(&["fuzz/corpus/bridge_frames"], bridge_frames::run) > 0);
}

#[test]
fn every_roll_out_message_seed_is_checked_without_panic() {
    assert!(replay(&["fuzz/corpus/deploy_messages"], deploy_messages::run) > 0);
}

#[test]
fn every_mission_of_the_repository_goes_through_the_front_end_without_panic() {
    // The front end's seeds are the language's test missions and examples.
    assert!(replay(&["lang/tests/catalogue", "examples"], front_end::run) > 0);
}

#[test]
fn every_mavlink_seed_is_read_without_panic() {
    assert!(replay(&["fuzz/corpus/mavlink_input"], mavlink_input::run) > 0);
}

#[test]
fn every_binary_slice_seed_decodes_without_panic() {
    assert!(replay(&["fuzz/corpus/slice_binary"], slice_binary::run) > 0);
}

#[test]
fn every_json_slice_seed_reads_without_panic() {
    assert!(replay(&["fuzz/corpus/slice_json"], slice_json::run) > 0);
}

#[test]
fn a_panicking_body_is_reported_with_its_seed() {
    let caught =
        std::panic::catch_unwind(|| replay(&["fuzz/corpus/slice_json"], |_| panic!("planted")));
    let message = caught.expect_err("a body that panics fails the replay");
    let text = message
        .downcast_ref::<String>()
        .expect("the replay names the seed");
    assert!(text.contains("fuzz/corpus/slice_json/"), "{text}");
}
