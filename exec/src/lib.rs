//! The token-passing executor: runs one slice on one drone, starting actions
//! through the middle layer and passing tokens over bridges (in-process
//! channels or zenoh).
//!
//! - [`names`]: peer and control-bridge names every module shares.
//! - [`transport`]: links between peers and exactly-once bridges over them.
//! - [`liveness`]: who is up, who is lost, and what a drone waiting on a
//!   lost peer does (its fleet's policy).
//! - [`abort`]: `eamos abort` and the abort command every drone obeys.
//! - [`event`]: the one stream of mission events and the sinks that read
//!   it (logs, terminal, plot, monitor).
//! - [`executor`]: the token game of one slice, played with a real adapter.
//! - [`guard`]: conditions evaluated over drones' telemetry.
//! - [`journal`]: what an agent did, on its own disk, to resume after a crash.
//! - [`log`]: the per-drone mission, uniform and adapter logs (the mission
//!   log is a sink of events).
//! - [`runner`]: a whole fleet in one process, or one peer over zenoh.
//! - [`svg`]: the plot of every drone's path.
//!
//! It reads the fleet as `eamos-fleet` gives it and never parses a fleet
//! file or resolves a path itself; it never knows how a slice reached its
//! drone (that is the roll-out's, `eamos-rollout`, which sits above it).

pub mod abort;
pub mod event;
pub mod executor;
pub mod guard;
pub mod journal;
pub mod liveness;
pub mod log;
pub mod names;
pub mod runner;
pub mod svg;
pub mod transport;

pub use event::{Event, Kind, Sink};
pub use executor::{Agent, Executor, ExecutorOptions, Outcome, Report};
