//! Coloured Petri nets of missions: the model ([`net`]), the compiler from a
//! checked mission ([`compile()`]), the reference token game ([`game`]), the
//! exports ([`export`]) and size statistics ([`stats`]).

pub mod compile;
pub mod export;
pub mod game;
pub mod net;
pub mod pretty;
pub mod stats;

pub use compile::compile;
pub use game::{Marking, Outcome, Run};
pub use net::{Guard, GuardKind, Net, Node, Owner, Place, PlaceKind, Transition, TransitionKind};
