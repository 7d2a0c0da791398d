//! The names every part of the executor agrees on: who the peers are, and
//! the control bridges beside the slicer's.
//!
//! They live here, below the executor, the journal, the abort and the
//! transports, so that each of those can name them without importing
//! another (the journal replays `end` and `abort` notices; the abort sends
//! on `abort`; the executor plays both).

/// A peer of the mission: a drone name, or [`GCS`].
pub type PeerId = String;

/// The peer name of the ground station (the fleet file names it too).
pub use eamos_fleet::GCS;

/// The bridge name of the "mission has ended" notice.
pub const END: &str = "end";
/// The bridge name of the "every end of the mission is reached" notice,
/// sent by the ground station to every peer once each owner of an end has
/// told it (on [`END`]): two notices per peer, where every owner telling
/// every peer took a number that grows with the square of the fleet.
pub const ENDED: &str = "ended";
/// The bridge name of the "a drone failed, land" notice.
pub const ABORT: &str = "abort";
