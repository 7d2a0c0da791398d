//! The fleet file and the mission identity.
//!
//! This crate owns what a fleet file says and what it means once read:
//! which adapter flies which drone, homes (in local metres or WGS84, placed
//! through the fleet's origin), the airspace the spatial check holds
//! missions to (fence, ceiling, floor, separation), the failsafe policies,
//! how the peers reach each other over zenoh (endpoints, TLS files, every
//! path resolved once, against the file's directory), who signs what
//! agents run; and the mission identity, computed once from the net and
//! the fleet before the net is cut, with one meaning everywhere.
//!
//! It reads the fleet file and the GeoJSON fence that file names, nothing
//! else: it must never open a connection, read a key or a certificate, fly
//! anything or depend on the executor: it is data the executor, the
//! roll-out, the checker and the command line read.
//!
//! - [`file`]: the file, its tables and their checks (with TLS in
//!   `file/tls.rs`, the origin and the airspace in `file/airspace.rs`,
//!   a GeoJSON fence in `file/geojson.rs`).
//! - [`policy`]: what a drone does when a peer is lost or the mission is
//!   aborted.
//! - [`zenoh`] and [`peers`]: each peer's endpoints and TLS files.
//! - [`identity`]: the mission identity and slice digests.

mod canonical;
pub mod file;
pub mod identity;
pub mod peers;
pub mod policy;
pub mod zenoh;

pub use canonical::{canonical_json, fleet_digest};
pub use file::{
    default_home, AdapterKind, DroneEntry, FailsafeSettings, Fleet, FleetError, FleetTls,
    KeySettings, PeerNet, PeerTls, ZenohSettings,
};
pub use identity::MissionId;
pub use peers::loopback_port;
pub use policy::{Grace, Liveness, OnLost};
pub use zenoh::{Mode, TlsFiles, ZenohOptions, GCS};
