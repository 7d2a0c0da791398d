//! The bodies of the fuzz targets, one module per place where bad input
//! enters. Each `run` takes one input and panics only on a bug.
//!
//! They live here rather than inside `fuzz_target!` so that two drivers
//! share one body: libFuzzer (`fuzz_targets/*.rs`, `scripts/fuzz-smoke`)
//! for long runs, and the ordinary test suite (`tests/fuzz_corpus.rs`),
//! which replays every committed seed under `corpus/<target>/` in the
//! normal build. A module must therefore use only crates the root package
//! also has.

pub mod bridge_frames;
pub mod deploy_messages;
pub mod front_end;
pub mod mavlink_input;
pub mod slice_binary;
pub mod slice_json;
