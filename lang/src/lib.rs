//! The front end of the EAMOS mission language (a subset of Go).
//!
//! `source text -> tokens (logos, with Go's automatic semicolons) -> syntax
//! tree (lalrpop) -> checked mission ([`hir::Mission`])`. This crate knows
//! nothing of Petri nets, slices or adapters: it only checks a mission
//! against the capability profiles it is handed.

pub mod hir;
pub mod span;

pub use span::{SourceFile, Span};
