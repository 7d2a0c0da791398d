//! Partitions a mission net into one slice per drone (and the ground
//! station). Every place and transition goes to exactly one owner; an arc
//! between two owners becomes a bridge, the only thing that crosses between
//! drones at run time.
//!
//! It never changes what the net does (a slice set plays the same visible
//! events as the net it came from) and never touches the network.
//!
//! ```text
//! slice(&net) -> Slices { slices: [GCS, Drone1, ...], drones, profiles, mission_id }
//! ```
//!
//! # The algorithm
//!
//! 0. **The end** (`end.rs`). The tree of silent joins in front of `final`
//!    (the join of the last PAR block, `Finish`) is taken out of the net
//!    before partitioning: nobody plays it. Each owner consumes the tree's
//!    inputs that it holds into an end of its own (`end.<owner>` marks
//!    `final.<owner>`), and the mission has ended when every owner listed in
//!    [`Slice::ends`] has reached its end. The executors learn it from the
//!    `end` control notice each of them sends on reaching its end; a notice
//!    is delivered exactly once like a token but carries no token of the
//!    net, so it is not a bridge. That is how the paper's drones behave
//!    (each stops when its part is over; the external arcs of its Table 7
//!    are action triggers only), and it saves one bridge per drone that
//!    would otherwise report its last action to the owner of `final`. When the tree is not
//!    of that shape (an input that two branches may mark, a guarded or timed
//!    step, a loop colour), `final` stays on one owner as an ordinary place.
//! 1. **Units** (`partition.rs`). A place and every transition that consumes
//!    or reads it must live together (the invariant of the architecture), and
//!    this is transitive: two places consumed by one transition go together.
//!    Union-find over consume and read arcs gives the units. A unit holding a
//!    node the compiler gave an owner (an action, a guarded transition, the
//!    ground station's `Init`) is *fixed*; two different owners in one unit is
//!    an error ([`SliceError::OwnerConflict`]) naming the place. Because read
//!    arcs never leave their unit, a read arc never crosses owners.
//! 2. **Cost model**. For an owner per unit, the bridges are the produce
//!    arcs between owners after *bundling* (`plan_bundles` in `partition.rs`):
//!    - *fan-out* (the paper's fork proxy): the arcs of one transition into
//!      places of one remote owner cross as one token; a new local fork there
//!      fans it out;
//!    - *pre-join* ("join locally first, then send one token"): the input
//!      places of one join whose producers all sit on one remote owner are
//!      joined there by a new transition, which sends one token to the join;
//!    - *forward*: several producers on one remote owner feeding one place
//!      (the merge after an `If`) merge there and forward one token;
//!    - whatever is left crosses arc by arc.
//!
//!    Bundles are chosen greedily in that order; their number is the cost.
//! 3. **Search** (`assign`). Free units are seeded with the owner they have
//!    the most arcs to, then improved by local search: move one unit, or the
//!    chain of free units around it that share its owner (a join and the fork
//!    after it), to the owner of a neighbour whenever the bridge count drops.
//!    The count is kept as a sum of terms per transition (fan-outs), per join
//!    (pre-joins) and per place (forwards and single arcs), and a move is
//!    judged by the terms within two arcs of it, so a pass costs time linear
//!    in the net (`Cost` in `partition.rs`).
//!    At equal cost the paper's convention decides: a fork lives with the
//!    unit that feeds it, a join with the unit it feeds, so no drone relays
//!    what it does not need; then the smaller owner (ground station, then
//!    drones in declaration order). The search optimises the very number it
//!    reports. Conditions stay where the compiler put them: on the first drone
//!    the condition reads, so a condition is evaluated where its state lives.
//! 4. **Rewrite and cut** (`distribute.rs`). The bundles become new nodes
//!    (ids `t7.out.Drone2`, `t9.in.Drone1`, `p4.fwd.Drone3`, with the span of
//!    the node they stand for), every node gets its owner, and the net is cut
//!    along owners: each crossing produce arc is a bridge, numbered in the
//!    order of (sending transition, receiving place).
//!
//! # Why the slices behave like the net
//!
//! Run the slices together over a network that delays messages arbitrarily
//! (and does not lose them: the transports' job), each slice stopping once
//! it has heard the `end` notice of every owner it lists, and the mission
//! ended when every slice has stopped (see [`compose`]). That is the mission
//! net with two kinds of changes, and neither changes its visible traces
//! (which drone starts, ends or cancels which action with which arguments,
//! which drone decides which condition which way, the delays, and reaching
//! `final`), its dead markings or its 1-safety:
//!
//! - **Delayed production.** A bridge turns `t -> p` into `t -> channel ->
//!   deliver -> p`; a fan-out turns `t -> {p1, p2}` into `t -> inbox -> fork
//!   -> {p1, p2}`; a forward turns `s1, s2 -> p` into `s1, s2 -> p' -> f ->
//!   p`. Each adds a silent transition whose input place nothing else
//!   consumes or reads, so once enabled it stays enabled and disables
//!   nothing. Every run of the original is a run of the rewrite (fire the new
//!   step at once). Conversely, a run of the rewrite maps to the original
//!   with the tokens produced early; nets without inhibitor arcs are
//!   monotonic (more tokens never disable a transition), so that run exists,
//!   with the same visible events. If the rewrite ever put a second token in
//!   a place, the same run would do so in the original, which is 1-safe: so
//!   the rewrite is 1-safe too, and an inbox or a channel never holds two
//!   tokens (one message per bridge in flight at most).
//! - **Pre-joins.** A join `J` with inputs `a1, a2, b` becomes `PJ: a1, a2 ->
//!   j'` and `J: j', b`. It is only done when `J` is the sole consumer of
//!   `a1, a2` (no other consumer, no reader) and all of `J`'s inputs have one
//!   depth: `PJ` then fires exactly when `J` could have taken `a1, a2`, and
//!   nothing else could take them meanwhile. The distributed end is the same
//!   rewrite applied to the whole end tree: its inputs each have one
//!   producer (so every run that ends marks all of them, none is one of two
//!   alternatives), its joins are their only consumers, nobody reads them,
//!   and they share the depth of `final`.
//!
//! Colours follow: a bridge carries the colour after its arc's colour
//! function; a fan-out sends the common function once (or the binding colour
//! when the functions differ, applying each at the far side); pre-joins and
//! forwards keep colours.
//!
//! [`equivalence`] decides this on the composed slices ([`compose`]) against
//! the net: the property test `tests/equivalence.rs` does so, exactly, for
//! thousands of random missions with every construct of the language;
//! `tests/mutation.rs` breaks the slices in the ways a slicer bug would and
//! sees every break told apart, and `tests/reductions.rs` holds the
//! checker's reductions against its plain search.
//!
//! # For the executor
//!
//! See [`slice`]: a slice lists its places, transitions with local arcs,
//! initial marking, bridges in (id, peer, inbox place) and out (id, sending
//! transition, peer, colour function), peers, and the remote drones whose
//! telemetry its guards read. Files: [`Slice::to_json`] / [`Slice::to_bytes`]
//! and back, [`write_dir`] for a whole mission; both forms are the file's
//! own versioned types ([`wire`]), never the compiler's.

pub mod bound;
mod codec;
pub mod compose;
mod distribute;
pub mod dot;
mod end;
pub mod equivalence;
mod error;
mod output;
mod partition;
pub mod slice;
pub mod stats;
pub mod wire;
mod work;

pub use codec::MAGIC;
pub use distribute::{
    cut_along_owners, net_id, slice, slice_as, slice_distributed, Handed, Slices,
};
pub use error::{DecodeError, SliceError};
pub use output::{write_dir, Written};
pub use slice::{BridgeId, BridgeIn, BridgeOut, Slice, SliceTransition, GCS};
pub use stats::{SliceStats, Statistics};
pub use wire::FORMAT_VERSION;
