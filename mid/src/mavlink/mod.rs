//! Flying MAVLink autopilots (ArduPilot copters in GUIDED, PX4 in OFFBOARD):
//! the adapter the executor drives. The MAVLink vehicle that imitates them
//! in tests is a crate of its own, `eamos-vehicle`.
//!
//! The pieces are kept apart so that each can be tested on its own:
//!
//! - [`address`]: connection strings as MAVLink tools spell them
//!   (`udpin:`, `udpout:`, `tcpout:`, serial devices).
//! - [`link`]: one MAVLink 2 connection with a receive task that skips
//!   whatever is not MAVLink, shared by every task that sends or listens.
//! - [`command`]: `COMMAND_LONG` with its `COMMAND_ACK`, retried on silence,
//!   a refusal turned into a typed [`command::CommandError`].
//! - [`params`]: reading an autopilot's parameters by name.
//! - [`modes`]: the autopilots' custom flight modes (ArduCopter, PX4) and
//!   how they map onto the middle layer's [`crate::FlightMode`].
//! - [`readiness`]: what an autopilot must report before it may be armed.
//! - [`state`]: the vehicle as the ground station sees it, folded from
//!   incoming messages.
//! - [`strategy`]: what differs between ArduPilot and PX4, one small
//!   strategy each.
//! - [`adapter`]: [`MavlinkAdapter`], the [`crate::Adapter`] over all of it.

pub mod adapter;
pub mod address;
pub mod command;
pub mod link;
pub mod modes;
pub mod params;
pub mod readiness;
pub mod state;
pub mod strategy;

pub use adapter::{LostLinkCheck, MavlinkAdapter, MavlinkError, MavlinkOptions, MavlinkSettings};
pub use address::ConnectAddress;
pub use command::CommandError;
pub use readiness::{Missing, NotReady, Readiness};

/// The dialect every connection speaks: ardupilotmega includes common.
pub use mavlink::dialects::ardupilotmega as dialect;
