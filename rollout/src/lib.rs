//! The roll-out, the paper's deployment step: each drone's agent waits on
//! its companion computer for its slice; the ground station compiles the
//! mission, signs each drone's slice, sends it, and once every drone holds
//! and has verified its part, sends the signed start.
//!
//! Agents and the ground station meet on the fleet's *roll-out* endpoints
//! (`[rollout]` in the fleet file, or a loopback port derived from the
//! fleet file): the ground station listens, agents connect. There is no
//! mission yet, so nothing here is scoped by a mission identity; the
//! messages name drones:
//!
//! | key | what |
//! | --- | --- |
//! | `eamos/rollout/<drone>/agent` | liveliness token: the agent of `drone` waits |
//! | `eamos/rollout/<drone>/status` | query: which slice the agent holds ([`AgentStatus`]) |
//! | `eamos/rollout/<drone>/slice` | query with a sealed [`SliceBundle`]: [`Answer`] |
//! | `eamos/rollout/<drone>/start` | query with a sealed [`StartCommand`]: [`Answer`] |
//!
//! Every exchange is a query and its reply, so the ground station knows that
//! each agent got its slice *and verified it* (or why it refused). An agent
//! configured with the ground station's public key (`[keys] gcs`) refuses
//! unsigned envelopes, envelopes signed by another key and altered ones;
//! and, signed or not, a slice built with another fleet file or a start
//! command for another version of the mission than the slice it holds.
//!
//! Partial redeployment: an agent reports the digest of the slice it holds
//! ([`eamos_fleet::identity::slice_digest`]); a drone whose new slice has the same
//! digest is not sent anything, and the start command binds the slice it
//! keeps to the new mission identity. The start command lists every drone's
//! digest, so an agent holding any other slice refuses to start.
//!
//! # Replay
//!
//! A signature says who sent a message, not when: a recorded signed start
//! would fly the mission again, and a recorded abort would end a later
//! flight of the same version. So every `eamos deploy` is a *deploy
//! session* with a fresh random id ([`RollOut::session`]): each slice
//! offer (a new slice, or, for a drone whose part did not change, a
//! [`SliceBundle`] without one that says "keep yours") and the start name
//! it, inside the signature. An agent starts only the session its slice
//! was offered in, and never starts one session twice: it writes each
//! session it starts to `<out>/<drone>.sessions` before it answers, so a
//! restarted agent refuses it too. Sessions rather than clocks, because a
//! drone's clock and the ground station's need not agree for this; the
//! only time compared is the abort's against the start, both issued by the
//! ground station (see [`eamos_exec::abort::opener_since`]).
//!
//! # What this crate owns
//!
//! `eamos agent` and `eamos deploy`'s side of the network: the signed
//! messages of a roll-out ([`wire`]), where agents and the ground station
//! meet ([`link`]), the keys the fleet file names ([`keys`]), the deploy
//! sessions an agent has started ([`sessions`]), an agent's checks of
//! what it is sent ([`gate`]), the flight an agent has started, kept on
//! its disk so that a restarted agent flies on from its journal
//! ([`flight`]), the agent's loop ([`agent`]) and the ground station's
//! side ([`ground`]). Flying a slice is the executor's
//! (`eamos_exec::runner`); deciding whether a message is signed by the
//! trusted key is the seal's (`eamos_seal`). This crate must never fly
//! anything itself, nor open a sealed message any other way.

pub mod agent;
pub mod flight;
pub mod gate;
pub mod ground;
pub mod keys;
pub mod link;
pub mod sessions;
pub mod wire;

#[cfg(test)]
mod tests;

pub use agent::{describe, run_agent, AgentConfig};
pub use gate::{Gate, Offer};
pub use ground::{fly_ground_station, Delivery, RollOut};
pub use keys::{ground_key, trusted_key};
pub use link::{rollout_endpoints, DeployError};
pub use sessions::{new_session, Sessions};
pub use tokio_util::sync::CancellationToken;
pub use wire::{rollout_key, AgentStatus, Answer, Held, SliceBundle, StartCommand};
