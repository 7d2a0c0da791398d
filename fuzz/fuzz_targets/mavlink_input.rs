//! The `mavlink_input` target: see `fuzz/src/mavlink_input.rs`, which the test suite also
//! replays over every committed seed (`tests/fuzz_corpus.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| eamos_fuzz::mavlink_input::run(data));
