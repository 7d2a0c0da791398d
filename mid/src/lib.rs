//! The middle layer: one drone API for every platform, the capability
//! profiles that describe what each drone type offers, and the adapters that
//! drive a platform (the built-in simulator, MAVLink autopilots).

pub mod profiles;
