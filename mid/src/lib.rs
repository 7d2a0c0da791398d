//! The middle layer: one drone API for every platform, and the adapters
//! that drive a platform (the built-in simulator, MAVLink autopilots). What
//! each drone type offers is its capability profile (`eamos-profile`): the
//! adapters read arities and nominal durations there.
//!
//! - [`api`]: the [`Adapter`] trait every platform implements, typed
//!   [`ActionError`]s, [`Telemetry`] and property evaluation.
//! - [`uniform`]: [`Uniform`], the profile-checked, logged entry point the
//!   executor calls.
//! - [`clock`]: mission time, shared by a whole fleet.
//! - [`log`]: records of the uniform and adapter logs.
//! - [`sim`]: the built-in simulator ([`SimFleet`], [`SimDrone`]) and its
//!   multirotor kinematics.
//! - [`mavlink`]: the MAVLink adapter (ArduPilot, PX4). The MAVLink vehicle
//!   that imitates them in tests is the `eamos-vehicle` crate, built on
//!   [`sim::kinematics`].
//!
//! It knows drones, not missions: nothing here may depend on the mission
//! language, the net, slices or the executor (its only crates of the
//! workspace are `eamos-profile` and `eamos-geo`), so that a new platform
//! is an adapter and nothing else.

pub mod api;
pub mod clock;
pub mod failsafe;
pub mod log;
pub mod mavlink;
pub mod sim;
pub mod uniform;

pub use api::{
    evaluate_property, ActionCall, ActionError, Adapter, AdapterInfo, Axis, CancellationToken,
    Control, FlightMode, MultirotorAction, PropertyArg, PropertyError, Telemetry, Value, Vec3,
};
pub use clock::{ClockFeed, MissionClock};
pub use failsafe::Failsafe;
pub use log::{LogRecord, LogSink, MemorySink, NullSink, SharedSink};
pub use sim::{Airframe, SimConfig, SimDrone, SimDroneSpec, SimError, SimFleet};
pub use uniform::Uniform;
