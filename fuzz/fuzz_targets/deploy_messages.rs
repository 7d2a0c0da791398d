//! The `deploy_messages` target: see `fuzz/src/deploy_messages.rs`, which the test suite also
//! replays over every committed seed (`tests/fuzz_corpus.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| eamos_fuzz::deploy_messages::run(data));
