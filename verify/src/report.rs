//! What a check found, and how it is told to people and to tools.
//!
//! A [`Report`] is plain data: a verdict per property, findings with spans
//! and counterexamples, and exploration statistics. [`Report::render`] draws
//! each finding with its source lines (through miette, like the front end's
//! diagnostics) and [`Report::to_json`] gives the stable machine form
//! (schema `eamos-check/1`, described on [`Report::to_json`]).

use std::fmt::Write as _;

use eamos_geo::Vec3;
use eamos_lang::span::SourceFile;
use eamos_lang::Span;
use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, NamedSource};
use serde_json::{json, Value};

/// The properties `eamos check` decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Property {
    Deadlock,
    Termination,
    Safety,
    DeadActions,
    Conflicts,
    Conditions,
    Separation,
    Airspace,
    FlightState,
}

impl Property {
    pub const ALL: [Property; 9] = [
        Property::Deadlock,
        Property::Termination,
        Property::Safety,
        Property::DeadActions,
        Property::Conflicts,
        Property::Conditions,
        Property::Separation,
        Property::Airspace,
        Property::FlightState,
    ];

    /// The stable name used in JSON and in the text output.
    pub fn name(self) -> &'static str {
        match self {
            Property::Deadlock => "deadlock",
            Property::Termination => "termination",
            Property::Safety => "safety",
            Property::DeadActions => "dead-actions",
            Property::Conflicts => "conflicts",
            Property::Conditions => "conditions",
            Property::Separation => "separation",
            Property::Airspace => "airspace",
            Property::FlightState => "flight-state",
        }
    }

    fn question(self) -> &'static str {
        match self {
            Property::Deadlock => "no reachable marking is stuck before the end",
            Property::Termination => "the end stays reachable from every reachable marking",
            Property::Safety => "no place ever holds two tokens",
            Property::DeadActions => "every action can start",
            Property::Conflicts => "no drone runs two exclusive actions at once",
            Property::Conditions => "every condition can hold and can fail",
            Property::Separation => "no two drones come closer than the separation",
            Property::Airspace => {
                "every leg stays inside the fence, below the ceiling, above the floor"
            }
            Property::FlightState => {
                "every action starts in a flight state it may, with arguments in range"
            }
        }
    }
}

/// The answer for one property.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Proved.
    Holds,
    /// A finding shows a violation.
    Violated,
    /// Could not be decided (the reason says why: memory bound, ...).
    Unknown(String),
    /// Does not apply to this input (the reason says why).
    NotApplicable(String),
}

impl Verdict {
    pub fn word(&self) -> &'static str {
        match self {
            Verdict::Holds => "holds",
            Verdict::Violated => "violated",
            Verdict::Unknown(_) => "unknown",
            Verdict::NotApplicable(_) => "not-applicable",
        }
    }

    pub fn reason(&self) -> Option<&str> {
        match self {
            Verdict::Unknown(r) | Verdict::NotApplicable(r) => Some(r),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct PropertyResult {
    pub property: Property,
    pub verdict: Verdict,
    /// How it was decided (exploration with which reduction, intervals, ...).
    pub method: String,
    /// What a person should know beside the verdict.
    pub notes: Vec<String>,
}

/// What kind of problem a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FindingKind {
    Deadlock,
    /// A reachable marking from which the end is unreachable.
    NonTermination,
    /// Two tokens in a place: a bug of the net compiler.
    Unsafe,
    /// A place without bound (PNML input).
    Unbounded,
    DeadAction,
    DroneConflict,
    ConditionNeverHolds,
    ConditionAlwaysHolds,
    /// Two drones can come closer than the separation.
    TooClose,
    /// A leg leaves the fence, or climbs above the ceiling or below the floor.
    LeavesAirspace,
    /// A loop moves a drone further every round, without bound.
    Drift,
    /// An action can start in a flight state its profile does not allow.
    FlightState,
    /// An argument is outside the range its profile declares.
    ArgumentRange,
}

impl FindingKind {
    pub fn name(self) -> &'static str {
        match self {
            FindingKind::Deadlock => "deadlock",
            FindingKind::NonTermination => "non-termination",
            FindingKind::Unsafe => "unsafe",
            FindingKind::Unbounded => "unbounded",
            FindingKind::DeadAction => "dead-action",
            FindingKind::DroneConflict => "drone-conflict",
            FindingKind::ConditionNeverHolds => "condition-never-holds",
            FindingKind::ConditionAlwaysHolds => "condition-always-holds",
            FindingKind::TooClose => "too-close",
            FindingKind::LeavesAirspace => "leaves-airspace",
            FindingKind::Drift => "drift",
            FindingKind::FlightState => "flight-state",
            FindingKind::ArgumentRange => "argument-range",
        }
    }

    pub fn property(self) -> Property {
        match self {
            FindingKind::Deadlock => Property::Deadlock,
            FindingKind::NonTermination => Property::Termination,
            FindingKind::Unsafe | FindingKind::Unbounded => Property::Safety,
            FindingKind::DeadAction => Property::DeadActions,
            FindingKind::DroneConflict => Property::Conflicts,
            FindingKind::ConditionNeverHolds | FindingKind::ConditionAlwaysHolds => {
                Property::Conditions
            }
            FindingKind::TooClose => Property::Separation,
            FindingKind::LeavesAirspace | FindingKind::Drift => Property::Airspace,
            FindingKind::FlightState | FindingKind::ArgumentRange => Property::FlightState,
        }
    }

    /// Errors make the mission unfit to fly; warnings look unintended.
    pub fn is_error(self) -> bool {
        !matches!(
            self,
            FindingKind::DeadAction
                | FindingKind::ConditionNeverHolds
                | FindingKind::ConditionAlwaysHolds
        )
    }
}

/// A span and what to say about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    pub span: Span,
    pub text: String,
}

/// One step of a counterexample.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Stable id of the transition (`t42`), to replay the step.
    pub transition: String,
    /// The net's kind of step (`ActionStart`, `Branch`, `Fork`, ...).
    pub kind: String,
    /// In mission terms.
    pub text: String,
    /// Plumbing (forks, joins, merges) that people need not read.
    pub internal: bool,
    pub span: Option<Span>,
    /// For a guarded step: whether its condition held.
    pub condition_held: Option<bool>,
}

/// A firing sequence from the initial marking.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    pub steps: Vec<Step>,
    /// Set when the trace ends in a cycle: the steps from this index on can
    /// repeat forever.
    pub cycle_from: Option<usize>,
    /// Ids of the places marked at the end (with their counts, if above 1).
    pub marking: Vec<(String, u32)>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    pub kind: FindingKind,
    pub message: String,
    /// Where in the source; the first label is the primary one.
    pub labels: Vec<Label>,
    pub notes: Vec<String>,
    pub trace: Option<Trace>,
    /// Where in space, for the findings of the spatial properties.
    pub geometry: Option<Geometry>,
}

/// The shapes a spatial finding is about, in the fleet frame (metres north,
/// east and up of the fleet's origin), for a plan view to draw.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Geometry {
    pub legs: Vec<GeoLeg>,
    /// The two points of closest approach (or, for a leg leaving the
    /// airspace, the point where it leaves, twice).
    pub closest: Option<(Vec3, Vec3)>,
    pub distance: Option<f64>,
}

/// A leg (or a drone at rest: both ends the same) of one drone.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoLeg {
    pub drone: String,
    pub from: Vec3,
    pub to: Vec3,
    /// Somewhere in the box between `from` and `to` (after a cancelled leg).
    pub boxed: bool,
    pub span: Option<Span>,
}

/// Where the checker stopped short of exploring, and why. Not a finding:
/// nothing is wrong with the mission, but the properties that need the
/// exploration are left `unknown`, and this says which part of the mission
/// made it so.
#[derive(Debug, Clone, PartialEq)]
pub struct Limit {
    /// Stable, like the findings' kinds (`too-large-to-explore`).
    pub code: &'static str,
    pub message: String,
    /// Where in the source; the first label is the primary one.
    pub labels: Vec<Label>,
    pub notes: Vec<String>,
}

/// Counts of the exploration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Stats {
    pub places: usize,
    pub transitions: usize,
    pub states: usize,
    pub edges: u64,
    pub full_expansions: usize,
    pub seconds: f64,
    pub memory_bytes: usize,
    /// Which reduction the exploration used.
    pub reduction: String,
    pub complete: bool,
    /// Highest token count seen in a place.
    pub max_tokens: u32,
}

/// The outcome of `eamos check`.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The net's (or mission's) name.
    pub name: String,
    /// Whether the input was a mission or a plain PNML net.
    pub input: InputKind,
    pub properties: Vec<PropertyResult>,
    pub findings: Vec<Finding>,
    /// Why the exploration did not run (empty when it did).
    pub limits: Vec<Limit>,
    pub stats: Stats,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    Mission,
    Pnml,
}

impl Report {
    pub fn verdict(&self, p: Property) -> Option<&Verdict> {
        self.properties
            .iter()
            .find(|r| r.property == p)
            .map(|r| &r.verdict)
    }

    pub fn findings_of(&self, kind: FindingKind) -> impl Iterator<Item = &Finding> {
        self.findings.iter().filter(move |f| f.kind == kind)
    }

    /// Whether anything was found (the exit status of `eamos check`).
    pub fn found_something(&self) -> bool {
        !self.findings.is_empty()
    }

    /// The properties left undecided (the exploration stopped early). Nothing
    /// found is then not a proof, and a team about to fly must not read it
    /// as one: `eamos check` gives them their own exit status.
    pub fn undecided(&self) -> impl Iterator<Item = Property> + '_ {
        self.properties
            .iter()
            .filter(|r| matches!(r.verdict, Verdict::Unknown(_)))
            .map(|r| r.property)
    }

    /// The report for people. `color` selects ANSI colours (for terminals).
    pub fn render(&self, source: &SourceFile, color: bool) -> String {
        let mut out = String::new();
        let theme = if color {
            GraphicalTheme::unicode()
        } else {
            GraphicalTheme::unicode_nocolor()
        };
        let handler = GraphicalReportHandler::new_themed(theme).with_context_lines(1);
        for f in &self.findings {
            let diag = FindingDiagnostic::new(f, source);
            let _ = handler.render_report(&mut out, &diag);
            if let Some(trace) = &f.trace {
                render_trace(&mut out, trace, source);
            }
            out.push('\n');
        }
        for l in &self.limits {
            let diag = FindingDiagnostic::limit(l, source);
            let _ = handler.render_report(&mut out, &diag);
            out.push('\n');
        }
        let _ = writeln!(out, "{} `{}`:", self.title(), self.name);
        for r in &self.properties {
            let mark = match r.verdict {
                Verdict::Holds => "ok",
                Verdict::Violated => "FAIL",
                Verdict::Unknown(_) => "??",
                Verdict::NotApplicable(_) => "--",
            };
            let _ = write!(
                out,
                "  {mark:>4}  {:<13} {}: {}",
                r.property.name(),
                r.property.question(),
                r.verdict.word()
            );
            if let Some(reason) = r.verdict.reason() {
                let _ = write!(out, " ({reason})");
            }
            let _ = writeln!(out, "  [{}]", r.method);
            for n in &r.notes {
                let _ = writeln!(out, "        note: {n}");
            }
        }
        let s = &self.stats;
        let _ = writeln!(
            out,
            "  {} places, {} transitions; {} states, {} edges explored{} in {:.3} s ({}, {:.1} MB)",
            s.places,
            s.transitions,
            s.states,
            s.edges,
            if s.complete { "" } else { " (stopped early)" },
            s.seconds,
            s.reduction,
            s.memory_bytes as f64 / 1e6
        );
        let errors = self.findings.iter().filter(|f| f.kind.is_error()).count();
        let warnings = self.findings.len() - errors;
        let _ = writeln!(
            out,
            "{}",
            if self.findings.is_empty() {
                match self.undecided().count() {
                    0 => "nothing found".to_string(),
                    n => format!(
                        "nothing found, but not proved: {n} propert{} undecided",
                        if n == 1 { "y" } else { "ies" }
                    ),
                }
            } else {
                format!("found {errors} error(s) and {warnings} warning(s)")
            }
        );
        out
    }

    fn title(&self) -> &'static str {
        match self.input {
            InputKind::Mission => "check of mission",
            InputKind::Pnml => "check of net",
        }
    }

    /// The machine form. Schema `eamos-check/1`:
    ///
    /// ```text
    /// { "schema": "eamos-check/1", "name": str, "input": "mission" | "pnml",
    ///   "file": str, "found": bool,
    ///   "properties": [ { "property": str, "verdict": "holds" | "violated" |
    ///       "unknown" | "not-applicable", "reason": str?, "method": str,
    ///       "notes": [str] } ],
    ///   "findings": [ { "kind": str, "property": str,
    ///       "severity": "error" | "warning", "message": str,
    ///       "spans": [ { "file", "line", "col", "end_line", "end_col", "label" } ],
    ///       "notes": [str],
    ///       "counterexample": null | { "steps": [ { "transition", "kind",
    ///           "text", "internal", "span": span?, "condition_held": bool? } ],
    ///         "cycle_from": int?, "marking": [ { "place", "tokens" } ] },
    ///       "geometry": null | { "legs": [ { "drone", "from": [x, y, z],
    ///           "to": [x, y, z], "boxed": bool, "span": span? } ],
    ///         "closest": [[x, y, z], [x, y, z]]?, "distance": float? } } ],
    ///   "limits": [ { "code": str, "message": str, "spans": [ span ],
    ///       "notes": [str] } ],
    ///   "stats": { "places", "transitions", "states", "edges",
    ///       "full_expansions", "seconds", "memory_bytes", "reduction",
    ///       "complete", "max_tokens" } }
    /// ```
    pub fn to_json(&self, source: &SourceFile) -> Value {
        let span = |s: Span| {
            let a = source.line_col(s.start);
            let b = source.line_col(s.end);
            json!({"file": source.name, "line": a.line, "col": a.col,
                   "end_line": b.line, "end_col": b.col})
        };
        let findings: Vec<Value> = self
            .findings
            .iter()
            .map(|f| {
                let spans: Vec<Value> = f
                    .labels
                    .iter()
                    .map(|l| {
                        let mut v = span(l.span);
                        v["label"] = json!(l.text);
                        v
                    })
                    .collect();
                let trace = f.trace.as_ref().map(|t| {
                    json!({
                        "steps": t.steps.iter().map(|s| json!({
                            "transition": s.transition,
                            "kind": s.kind,
                            "text": s.text,
                            "internal": s.internal,
                            "span": s.span.map(span),
                            "condition_held": s.condition_held,
                        })).collect::<Vec<_>>(),
                        "cycle_from": t.cycle_from,
                        "marking": t.marking.iter().map(|(p, n)| json!({"place": p, "tokens": n})).collect::<Vec<_>>(),
                    })
                });
                let xyz = |v: Vec3| json!([v.x, v.y, v.z]);
                let geometry = f.geometry.as_ref().map(|g| {
                    json!({
                        "legs": g.legs.iter().map(|l| json!({
                            "drone": l.drone,
                            "from": xyz(l.from),
                            "to": xyz(l.to),
                            "boxed": l.boxed,
                            "span": l.span.map(span),
                        })).collect::<Vec<_>>(),
                        "closest": g.closest.map(|(a, b)| json!([xyz(a), xyz(b)])),
                        "distance": g.distance,
                    })
                });
                json!({
                    "kind": f.kind.name(),
                    "property": f.kind.property().name(),
                    "severity": if f.kind.is_error() { "error" } else { "warning" },
                    "message": f.message,
                    "spans": spans,
                    "notes": f.notes,
                    "counterexample": trace,
                    "geometry": geometry,
                })
            })
            .collect();
        let limits: Vec<Value> = self
            .limits
            .iter()
            .map(|l| {
                let spans: Vec<Value> = l
                    .labels
                    .iter()
                    .map(|x| {
                        let mut v = span(x.span);
                        v["label"] = json!(x.text);
                        v
                    })
                    .collect();
                json!({"code": l.code, "message": l.message, "spans": spans, "notes": l.notes})
            })
            .collect();
        let s = &self.stats;
        json!({
            "schema": "eamos-check/1",
            "name": self.name,
            "input": match self.input { InputKind::Mission => "mission", InputKind::Pnml => "pnml" },
            "file": source.name,
            "found": self.found_something(),
            "properties": self.properties.iter().map(|r| json!({
                "property": r.property.name(),
                "verdict": r.verdict.word(),
                "reason": r.verdict.reason(),
                "method": r.method,
                "notes": r.notes,
            })).collect::<Vec<_>>(),
            "findings": findings,
            "limits": limits,
            "stats": {
                "places": s.places, "transitions": s.transitions, "states": s.states,
                "edges": s.edges, "full_expansions": s.full_expansions,
                "seconds": s.seconds, "memory_bytes": s.memory_bytes,
                "reduction": s.reduction, "complete": s.complete, "max_tokens": s.max_tokens,
            },
        })
    }
}

fn render_trace(out: &mut String, trace: &Trace, source: &SourceFile) {
    let visible: Vec<(usize, &Step)> = trace
        .steps
        .iter()
        .enumerate()
        .filter(|(_, s)| !s.internal)
        .collect();
    let _ = writeln!(
        out,
        "  counterexample ({} steps, {} of them internal):",
        trace.steps.len(),
        trace.steps.len() - visible.len()
    );
    let mut n = 0;
    let mut announced = false;
    for (i, s) in visible {
        if trace.cycle_from.is_some_and(|c| i >= c) && !announced {
            announced = true;
            let _ = writeln!(out, "     then, forever:");
        }
        n += 1;
        let at = s
            .span
            .map(|sp| format!("  ({})", source.location(sp)))
            .unwrap_or_default();
        let _ = writeln!(out, "    {n:>3}. {}{at}", s.text);
    }
    if trace.cycle_from.is_some() {
        let _ = writeln!(out, "     (and round again)");
    }
}

/// A finding as a miette diagnostic, for drawing.
#[derive(Debug)]
struct FindingDiagnostic {
    message: String,
    code: String,
    severity: miette::Severity,
    source: NamedSource<String>,
    labels: Vec<LabeledSpan>,
    help: Option<String>,
}

impl FindingDiagnostic {
    fn new(f: &Finding, source: &SourceFile) -> Self {
        let severity = if f.kind.is_error() {
            miette::Severity::Error
        } else {
            miette::Severity::Warning
        };
        let code = format!("eamos::{}", f.kind.name());
        Self::drawn(&f.message, code, severity, &f.labels, &f.notes, source)
    }

    fn limit(l: &Limit, source: &SourceFile) -> Self {
        let code = format!("eamos::{}", l.code);
        let severity = miette::Severity::Advice;
        Self::drawn(&l.message, code, severity, &l.labels, &l.notes, source)
    }

    fn drawn(
        message: &str,
        code: String,
        severity: miette::Severity,
        labels: &[Label],
        notes: &[String],
        source: &SourceFile,
    ) -> Self {
        let len = source.text.len() as u32;
        let labels = labels
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let start = l.span.start.min(len) as usize;
                let end = l.span.end.clamp(l.span.start, len) as usize;
                let text = Some(l.text.clone()).filter(|t| !t.is_empty());
                if i == 0 {
                    LabeledSpan::new_primary_with_span(text, (start, end - start))
                } else {
                    LabeledSpan::new_with_span(text, (start, end - start))
                }
            })
            .collect();
        FindingDiagnostic {
            message: message.to_string(),
            code,
            severity,
            source: NamedSource::new(source.name.clone(), source.text.clone()),
            labels,
            help: (!notes.is_empty()).then(|| notes.join("\n")),
        }
    }
}

impl std::fmt::Display for FindingDiagnostic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for FindingDiagnostic {}

impl miette::Diagnostic for FindingDiagnostic {
    fn code<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        Some(Box::new(&self.code))
    }
    fn severity(&self) -> Option<miette::Severity> {
        Some(self.severity)
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        (!self.labels.is_empty()).then_some(&self.source as &dyn miette::SourceCode)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        (!self.labels.is_empty())
            .then(|| Box::new(self.labels.iter().cloned()) as Box<dyn Iterator<Item = LabeledSpan>>)
    }
    fn help<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        self.help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn std::fmt::Display>)
    }
}
