//! The `bridge_frames` target: see `fuzz/src/bridge_frames.rs`, which the test suite also
//! replays over every committed seed (`tests/fuzz_corpus.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| eamos_fuzz::bridge_frames::run(data));
