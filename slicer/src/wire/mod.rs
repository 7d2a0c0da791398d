//! The slice file's own types, one module per format version, and the one
//! conversion between them and the compiler's.
//!
//! A drone in the field reads slices written by a ground station that may
//! run another build of eamos. The compiler's types (`hir::Expr`, the net's
//! places and transitions) change whenever the language does; the slice file
//! must change only on purpose. So the codec serialises [`v3`] and nothing
//! else, the compiler's types never reach `serde` on the way to a drone, and
//! a change to this format is a new version beside the old one.
//!
//! Versions: up to 2 the codec serialised the compiler's types directly
//! (such files are refused by number: rebuild the mission); 3 is [`v3`].

mod convert;
pub mod v3;

pub use convert::MAX_CONDITION_DEPTH;

/// The version [`crate::Slice::to_bytes`] and [`crate::Slice::to_json`]
/// write, and the only one they read.
pub const FORMAT_VERSION: u16 = 3;

#[cfg(test)]
mod tests {
    /// The format's types are plain data: they name serde and nothing of
    /// the compiler or of this crate, so no change there can change the
    /// file by accident.
    #[test]
    fn the_format_types_name_nothing_of_the_compiler() {
        for (file, text) in [("v3.rs", include_str!("v3.rs"))] {
            for (n, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or_default();
                let n = n + 1;
                assert!(
                    !code.trim_start().starts_with("use ") || code.contains("use serde::"),
                    "{file}:{n} imports more than serde: {line}"
                );
                for forbidden in ["eamos_", "crate::", "super::", "petri", "hir::"] {
                    assert!(
                        !code.contains(forbidden),
                        "{file}:{n} names `{forbidden}`: {line}"
                    );
                }
            }
        }
    }
}
