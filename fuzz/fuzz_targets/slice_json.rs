//! The `slice_json` target: see `fuzz/src/slice_json.rs`, which the test suite also
//! replays over every committed seed (`tests/fuzz_corpus.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| eamos_fuzz::slice_json::run(data));
