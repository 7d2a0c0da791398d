//! The spatial properties: `separation`, `airspace` and `flight-state`.
//!
//! [`model`] finds, per drone, every leg it can fly (from where it really
//! is on each branch and in each round of a counted loop) and what it can
//! rest at between legs. The properties are then decided in three ways:
//! - `airspace` and `flight-state` need no interleaving: a leg leaves the
//!   fence whoever else flies, and a drone's flight state is its own.
//!   [`airspace`] and [`flight`] decide them from the model alone.
//! - `separation` needs to know which legs can be under way at once. That
//!   is what the net says, and the exploration answers it exactly on the
//!   net's skeleton: [`extend`] gives each drone whose legs are ordered a
//!   record of what it rests at (one token in one of its "last" places,
//!   moved by each of its legs' ends) and adds a monitor for every leg and
//!   leg, or leg and rest, of two drones that come within the separation
//!   somewhere. A monitor that the exploration finds enabled is a finding,
//!   with the interleaving that leads there.
//!
//! Conservative about timing (two legs under way at once are compared
//! whole, wherever each drone is along its own), exact about causality
//! (two legs that sequencing or `Signal`/`Await` orders are never both
//! running in any reachable marking, so their monitor never fires).

pub(crate) mod airspace;
mod block;
mod chain;
pub(crate) mod flight;
pub(crate) mod model;
mod near;
pub(crate) mod shape;
mod step;
mod too_close;
pub(crate) mod walk;

pub use eamos_geo::default_home;
use eamos_geo::{Airspace, Vec3};

pub(crate) use crate::names::Names;
pub(crate) use near::{extend, MAX_WATCHED};
pub(crate) use too_close::{homes_findings, near_findings};

/// Where the fleet flies: each drone's home in the fleet frame (in the
/// order of the mission's drones) and the airspace.
#[derive(Debug, Clone, PartialEq)]
pub struct Space {
    pub homes: Vec<Vec3>,
    pub airspace: Airspace,
}

impl Space {
    /// The fleet `eamos run` flies without a fleet file: drones in a row
    /// along Y (east), 3 m apart, no fence, no ceiling, the default
    /// separation.
    pub fn default_for(drones: usize) -> Space {
        Space {
            homes: (0..drones).map(default_home).collect(),
            airspace: Airspace::default(),
        }
    }

    pub(crate) fn home(&self, drone: u16) -> Vec3 {
        self.homes
            .get(drone as usize)
            .copied()
            .unwrap_or_else(|| default_home(drone as usize))
    }
}

/// What the spatial properties need from the mission, prepared with the
/// rest of the checker's subject.
pub(crate) struct Prepared {
    pub space: Space,
    pub positions: Result<model::Positions, String>,
    /// Findings decided without exploring (airspace, flight states).
    pub airspace: Result<Vec<crate::report::Finding>, String>,
    pub flight: Result<Vec<crate::report::Finding>, String>,
    /// Per motion of `positions`: its running place and the transitions
    /// (indices of the compact net) that end and cancel it.
    pub running: Vec<u32>,
    pub ends: Vec<Vec<u32>>,
    pub cancels: Vec<Vec<u32>>,
    pub names: Names,
}
