//! The token-passing executor: runs one slice on one drone, starting actions
//! through the middle layer and passing tokens over bridges (in-process
//! channels or zenoh).
//!
//! - [`names`]: peer and control-bridge names every module shares.
//! - [`transport`]: links between peers and exactly-once bridges over them.
//! - [`liveness`]: who is up, who is lost, and what a drone waiting on a
//!   lost peer does (its fleet's policy).
//! - [`abort`]: `eamos abort` and the abort command every drone obeys.
//! - [`executor`]: the token game of one slice, played with a real adapter.
//! - [`guard`]: conditions evaluated over drones' telemetry.
//! - [`journal`]: what an agent did, on its own disk, to resume after a crash.
//! - [`log`]: the per-drone mission, uniform and adapter logs.
//! - [`deploy`]: the roll-out: agents waiting for their signed slice, and the
//!   ground station sending each drone its part.
//! - [`runner`]: a whole fleet in one process, or one peer over zenoh.
//! - [`svg`]: the plot of every drone's path.

pub mod abort;
pub mod deploy;
pub mod executor;
pub mod guard;
pub mod journal;
pub mod liveness;
pub mod log;
pub mod names;
pub mod runner;
pub mod svg;
pub mod transport;

pub use executor::{Agent, Executor, ExecutorOptions, Outcome, Progress, ProgressKind, Report};
