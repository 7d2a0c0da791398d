//! Frames and geometry, shared by every crate that reasons about where a
//! drone is: the middle layer (adapters, simulator), the checker's spatial
//! properties, the trajectory plot and the views.
//!
//! - [`Vec3`]: a point or a vector of a local frame (X north, Y east, Z up,
//!   metres), the mission's own frame.
//! - [`Ned`]: the same space as MAVLink's local north-east-down frame.
//! - [`Wgs84`]: a point on the earth (degrees, metres above the ellipsoid's
//!   reference as the autopilot reports it).
//! - [`LocalFrame`]: a local frame anchored at a WGS84 origin, and the
//!   conversions between the two (on the WGS84 ellipsoid, through the
//!   `map_3d` crate: no hand-made flat-earth approximations).
//! - [`Home`]: a drone's home, given in local metres or in WGS84.
//! - [`distance`]: closest approach of points and segments in 3D.
//! - [`Airspace`]: a fence, a ceiling, a floor and the separation drones
//!   keep.
//! - [`Fence`]: a polygon of the local plane, and whether a point or a whole
//!   leg stays inside it.
//!
//! Architecture invariant: pure geometry. This crate knows nothing of
//! missions, nets, drones or transports; it does no I/O and never panics on
//! any input (a degenerate polygon or segment is an answer, not a crash).

mod airspace;
pub mod distance;
mod fence;
mod frame;
mod home;
mod ned;
mod vec3;
mod wgs84;

pub use airspace::{Airspace, Breach, DEFAULT_SEPARATION};
pub use distance::{point_segment, segment_segment, Approach};
pub use fence::{Fence, FenceError};
pub use frame::LocalFrame;
pub use home::{default_home, Home, HomeError, LocalHome};
pub use ned::Ned;
pub use vec3::Vec3;
pub use wgs84::Wgs84;
