//! Coloured Petri nets of missions: the model ([`net`]), the compiler from a
//! checked mission, the reference token game and the exports.

pub mod net;

pub use net::{Net, Node, Owner, Place, PlaceKind, Transition, TransitionKind};
