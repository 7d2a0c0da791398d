//! What can go wrong when slicing a net or reading a slice back.

use eamos_lang::Span;

/// A net the slicer cannot cut. Each of these is a net-compiler bug or a
/// hand-made net that breaks the net model's rules, never a property of a
/// mission text the front end accepted.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SliceError {
    #[error(
        "place `{place}` is consumed or read by transitions of {}: a place and all \
         the transitions that consume or read it must live on one drone",
        owners.join(" and ")
    )]
    OwnerConflict {
        place: String,
        owners: Vec<String>,
        span: Option<Span>,
    },
    #[error("arc {from} -> {to} has weight {weight}: a 1-safe mission net has unit weights")]
    ArcWeight {
        from: String,
        to: String,
        weight: u32,
    },
    #[error("a drone is named `{0}`, the name of the ground station; rename the drone")]
    ReservedName(String),
    #[error("the net names {drones} drones but {profiles} profiles")]
    Profiles { drones: usize, profiles: usize },
    #[error("node {node} is owned by drone #{index}, but the mission has {drones} drones")]
    UnknownDrone {
        node: String,
        index: u16,
        drones: usize,
    },
}

/// A slice file that cannot be used. The message says what is wrong in
/// terms a person can act on (wrong file, other version, damaged file).
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("not an eamos slice file: it does not start with the slice header")]
    NotASlice,
    #[error(
        "slice format version {found}; this eamos reads version {expected}: rebuild the mission"
    )]
    Version { found: u16, expected: u16 },
    #[error("slice file is truncated: the header announces {expected} bytes of content, {found} are there")]
    Truncated { expected: u64, found: u64 },
    #[error("slice file has {extra} bytes after its end: it was altered or appended to")]
    TrailingBytes { extra: u64 },
    #[error("slice file is damaged: its checksum does not match its content")]
    Checksum,
    #[error("slice file is damaged: {0}")]
    Binary(String),
    #[error("slice file is not valid JSON for a slice: {0}")]
    Json(#[from] serde_json::Error),
    #[error("not an eamos slice file: format is `{0}`")]
    Format(String),
    #[error("slice is inconsistent: {0}")]
    Inconsistent(String),
}
