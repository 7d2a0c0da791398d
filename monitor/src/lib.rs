//! The live monitor behind `eamos run --monitor` (and `eamos monitor`): the
//! mission report of `eamos view`, served over HTTP, and the run's events
//! streamed to it as they happen (server-sent events), so that the page
//! moves each drone, shows its current action, altitude and battery, marks
//! the places each slice holds, lists signals, awaits and lost peers, and
//! plots the closest distance between two drones.
//!
//! [`Feed`] is one more [`eamos_exec::event::Sink`] of the run's one
//! stream of events: the page reads the executor's own vocabulary, as its
//! log writes it, through the view's `update(event)`; nothing here invents
//! a second one. [`serve`] answers `GET /` (the page) and `GET /events`
//! (the stream) and nothing else.
//!
//! Architecture Invariant: the drones never depend on the monitor. The
//! feed never blocks and never waits: it keeps a bounded history and hands
//! each event to a bounded broadcast; a browser too slow to keep up loses
//! telemetry samples, never holds up the executor, and catches up from the
//! latest state. The server listens on the loopback unless told otherwise,
//! and it has no route that commands a drone unless its process holds the
//! ground station's key: then `POST /abort` (behind a confirmation on the
//! page, and a header no other site can send) aborts as `eamos abort` does.

mod feed;
mod server;

pub use feed::Feed;
pub use server::{bind, serve, Abort, Monitor, CONFIRM_HEADER};
