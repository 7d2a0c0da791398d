//! Partitions a mission net into one slice per drone (and the ground
//! station). Every place and transition goes to exactly one owner; an arc
//! between two owners becomes a bridge, the only thing that crosses between
//! drones at run time.

pub mod bound;
mod codec;
pub mod compose;
mod distribute;
pub mod dot;
pub mod equivalence;
mod error;
mod output;
mod partition;
pub mod slice;
pub mod stats;

pub use codec::{FORMAT_VERSION, MAGIC};
pub use distribute::{mission_id, slice, Slices};
pub use error::{DecodeError, SliceError};
pub use output::{write_dir, Written};
pub use slice::{BridgeId, BridgeIn, BridgeOut, Slice, SliceTransition, GCS};
pub use stats::{SliceStats, Statistics};
