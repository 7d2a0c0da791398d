//! What a report is made from, read by every part of its model (the
//! drones and legs, the net's drawing, the timeline).

use eamos_geo::Wgs84;
use eamos_lang::{SourceFile, Span};
use eamos_petri::Net;
use eamos_profile::ProfileTable;
use eamos_verify::{Plan, Report, Space};

/// What the report is made from.
pub struct Input<'a> {
    pub source: &'a SourceFile,
    pub net: &'a Net,
    pub profiles: &'a ProfileTable,
    /// The checker's report, with its spatial findings.
    pub report: &'a Report,
    /// Every leg of every drone, or why the mission was too large to
    /// follow them.
    pub plan: &'a Result<Plan, String>,
    pub space: &'a Space,
    /// The fleet frame's origin on the earth, if the fleet file gives one.
    pub origin: Option<Wgs84>,
}

/// 1-based line of a span's start.
pub(crate) fn line_of(source: &SourceFile, span: Span) -> u32 {
    source.line_col(span.start).line
}
