//! Coloured Petri nets of missions: the model ([`net`]), the compiler from a
//! checked mission ([`compile()`]), the reference token game ([`game`]), the
//! exports ([`export`]) and size statistics ([`stats`]).
//!
//! It never touches the network, never runs an adapter and never decides a
//! property: the net it compiles is the one artefact that the checker
//! proves, the slicer cuts and the executor plays.
//!
//! ```
//! use eamos_lang::SourceFile;
//! use eamos_petri::game::{self, oracle, Outcome};
//!
//! let profiles = eamos_profile::builtin();
//! let file = SourceFile::new(
//!     "m.go",
//!     "package M\nvar D1 Quadcopter\nfunc INIT() {\n\tD1.Takeoff(1)\n\tD1.Land()\n}\n",
//! );
//! let mission = eamos_lang::compile(&file, &profiles).expect("valid").mission;
//! let net = eamos_petri::compile(&mission, &profiles);
//! // Play the token game with a world that answers conditions at random.
//! let run = game::run_random(&net, 7, oracle::random(7, 0.5), 1_000);
//! assert_eq!(run.outcome, Outcome::Final);
//! assert!(run.marking.is_marked(net.final_place));
//! ```

pub mod compile;
pub mod export;
pub mod game;
pub mod name;
pub mod net;
pub mod pretty;
pub mod stats;

pub use compile::compile;
pub use game::{Marking, Outcome, Run};
pub use name::Name;
pub use net::{
    Guard, GuardKind, Net, Node, Owner, Place, PlaceKind, SharedAction, Transition, TransitionKind,
};
