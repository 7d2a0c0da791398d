//! The `front_end` target: see `fuzz/src/front_end.rs`, which the test suite also
//! replays over every committed seed (`tests/fuzz_corpus.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| eamos_fuzz::front_end::run(data));
