//! Names in mission terms, shared by every finding: an action as the
//! mission writes it (`D1.FlyByX(0.5)`) and the line a span starts on.

use eamos_lang::span::SourceFile;
use eamos_lang::Span;
use eamos_petri::net::{ActionRef, Net};

/// A number as a mission author writes it: `5`, not `5.0`.
pub(crate) fn fmt_num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

/// `D1.FlyByX(0.5)`; `?` for a drone the mission does not have.
pub(crate) fn action_text(drones: &[String], a: &ActionRef) -> String {
    let drone = drones.get(a.drone.0 as usize).map_or("?", String::as_str);
    let args: Vec<String> = a.args.iter().map(|&v| fmt_num(v)).collect();
    format!("{drone}.{}({})", a.name, args.join(", "))
}

/// The drones of a mission and its text, to name actions and lines.
pub(crate) struct Names {
    drones: Vec<String>,
    source: Option<SourceFile>,
}

impl Names {
    pub(crate) fn new(net: &Net, src: Option<&str>) -> Self {
        Names {
            drones: net.drones.clone(),
            source: src.map(|s| SourceFile::new(String::new(), s)),
        }
    }

    pub(crate) fn drones(&self) -> &[String] {
        &self.drones
    }

    pub(crate) fn drone(&self, d: u16) -> String {
        self.drones.get(d as usize).cloned().unwrap_or_default()
    }

    pub(crate) fn action(&self, a: &ActionRef) -> String {
        action_text(&self.drones, a)
    }

    /// `line N` of a span, or nothing without the source.
    pub(crate) fn line(&self, span: Span) -> String {
        self.source.as_ref().map_or(String::new(), |s| {
            format!("line {}", s.line_col(span.start).line)
        })
    }
}
