//! Diagnostics: what the front end tells a person about a mission.
//!
//! A [`Diagnostic`] is plain data (a stable code, a severity, a message,
//! labelled spans, a hint) so that every stage can build one cheaply and
//! tests can compare them; rendering is separate: [`render`] draws the
//! source line with markers through miette for people, [`Diagnostic::record`]
//! gives the flat machine form (code, file, line, column) for tools and CI.

use std::fmt;

use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, NamedSource, SourceCode};
use serde::{Deserialize, Serialize};

use crate::span::{SourceFile, Span};

/// Every diagnostic code the front end emits, with what it means. Codes are
/// stable: tools and tests key on them, messages may be reworded.
pub const CODES: &[(&str, &str)] = &[
    // Reading the file.
    (
        "eamos::not-utf8",
        "a file whose bytes are not UTF-8 text (saved in another encoding)",
    ),
    // Lexical and syntax errors.
    (
        "eamos::syntax",
        "the text does not follow the grammar (unexpected token, unclosed bracket, missing type)",
    ),
    (
        "eamos::missing-package",
        "the file does not start with `package Name`",
    ),
    (
        "eamos::stray-character",
        "a character that is not part of the language",
    ),
    (
        "eamos::unterminated-string",
        "a string not closed on its line (or a raw string not closed at all)",
    ),
    ("eamos::unterminated-comment", "a `/*` comment never closed"),
    ("eamos::bad-number", "a malformed number literal"),
    (
        "eamos::bad-escape",
        "an unknown escape sequence in a string",
    ),
    (
        "eamos::too-complex",
        "a statement with more operators and brackets than the front end checks",
    ),
    (
        "eamos::not-a-statement",
        "an expression that runs nothing (`Drone1.Arm` without parentheses)",
    ),
    // Names.
    ("eamos::unknown-drone", "a drone that is not declared"),
    (
        "eamos::unknown-profile",
        "a drone type that no capability profile names",
    ),
    (
        "eamos::unknown-action",
        "an action the drone's profile does not offer",
    ),
    (
        "eamos::unknown-property",
        "a property the drone's profile does not offer",
    ),
    ("eamos::unknown-function", "a block that no function names"),
    (
        "eamos::unknown-name",
        "a name in an expression that is no constant, parameter or boolean",
    ),
    (
        "eamos::unknown-type",
        "a parameter or constant type that is no drone type or number type",
    ),
    (
        "eamos::unknown-event",
        "an `Await` of an event that no `Signal` names",
    ),
    (
        "eamos::duplicate",
        "a drone, constant, function or parameter declared twice",
    ),
    (
        "eamos::reserved-name",
        "a declaration named like a control structure, `Signal`, `Await` or a boolean",
    ),
    (
        "eamos::not-a-drone",
        "a constant, block or number where a drone is expected",
    ),
    (
        "eamos::not-a-block",
        "something other than a function name where a block is expected",
    ),
    // Structure.
    (
        "eamos::no-entry",
        "no function to start from (no `INIT` and no function that nobody calls)",
    ),
    (
        "eamos::several-entries",
        "several functions nobody calls and no `INIT`",
    ),
    ("eamos::entry-params", "the entry point takes parameters"),
    ("eamos::call-entry", "`INIT` called or passed as a block"),
    (
        "eamos::recursion",
        "a function that calls itself, directly or through others",
    ),
    (
        "eamos::mission-too-large",
        "the expanded mission exceeds the statement limit",
    ),
    (
        "eamos::too-many-drones",
        "more drones than a drone id can number",
    ),
    // Arguments and types.
    (
        "eamos::arg-count",
        "a call with the wrong number of arguments",
    ),
    (
        "eamos::arg-kind",
        "an argument of the wrong kind (a number for a drone, a fraction for an `int`, ...)",
    ),
    (
        "eamos::block-call-as-argument",
        "a block passed with parentheses (`SEQ_Body()` instead of `SEQ_Body`)",
    ),
    (
        "eamos::block-with-params",
        "a block with parameters passed by name",
    ),
    (
        "eamos::type-mismatch",
        "a number where a boolean is needed or the other way round",
    ),
    (
        "eamos::not-constant",
        "a value read at run time where a constant is needed",
    ),
    ("eamos::division-by-zero", "a division by a constant zero"),
    (
        "eamos::overflow",
        "constant arithmetic beyond the range of numbers",
    ),
    (
        "eamos::const-cycle",
        "constants defined in terms of each other",
    ),
    (
        "eamos::property-as-action",
        "a property used as a statement",
    ),
    (
        "eamos::property-without-call",
        "a property read without parentheses",
    ),
    (
        "eamos::action-in-condition",
        "an action used in a condition",
    ),
    (
        "eamos::same-drone",
        "a property that relates two drones given one drone twice (`D1.DistanceTo(D1)`)",
    ),
    (
        "eamos::bad-repeat-count",
        "a `RepeatFor` count that is negative or not whole",
    ),
    (
        "eamos::negative-pause",
        "a `PauseFor` with a negative duration",
    ),
    (
        "eamos::signal-in-loop",
        "a `Signal` inside a loop body: an event happens once",
    ),
    (
        "eamos::unsupported",
        "a profile parameter kind the language cannot pass yet",
    ),
    // Warnings.
    ("eamos::unused-drone", "a drone declared but never used"),
    (
        "eamos::never-called",
        "a function not reached from the entry point",
    ),
    ("eamos::empty-mission", "a mission that runs no action"),
    ("eamos::event-never-awaited", "a `Signal` nothing waits for"),
    (
        "eamos::zero-repeat",
        "a `RepeatFor(0, ...)` that never runs its body",
    ),
];

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// The mission is still compiled; something looks unintended.
    Warning,
    /// The mission cannot be compiled.
    Error,
}

/// A span with what to say about it. The primary label is where the problem
/// is; secondary labels point at related places (the first declaration of a
/// duplicate, the bracket that was opened).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Label {
    pub span: Span,
    pub message: String,
    pub primary: bool,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    /// Stable, documented identifier such as `eamos::unknown-action`: tools
    /// and tests key on it, messages may be reworded.
    pub code: &'static str,
    pub severity: Severity,
    pub message: String,
    /// The primary span (also the first primary label, if any).
    pub span: Span,
    pub labels: Vec<Label>,
    pub help: Option<String>,
}

impl Diagnostic {
    pub fn error(code: &'static str, span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            code,
            severity: Severity::Error,
            message: message.into(),
            span,
            labels: Vec::new(),
            help: None,
        }
    }

    pub fn warning(code: &'static str, span: Span, message: impl Into<String>) -> Self {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(code, span, message)
        }
    }

    /// Adds the primary label, at the diagnostic's own span.
    pub fn with_label(mut self, message: impl Into<String>) -> Self {
        self.labels.push(Label {
            span: self.span,
            message: message.into(),
            primary: true,
        });
        self
    }

    /// Adds a secondary label elsewhere.
    pub fn with_note_at(mut self, span: Span, message: impl Into<String>) -> Self {
        self.labels.push(Label {
            span,
            message: message.into(),
            primary: false,
        });
        self
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The flat form: one record per diagnostic, positions resolved.
    pub fn record(&self, file: &SourceFile) -> Record {
        let start = file.line_col(self.span.start);
        let end = file.line_col(self.span.end);
        Record {
            code: self.code.to_string(),
            severity: self.severity,
            message: self.message.clone(),
            file: file.name.clone(),
            line: start.line,
            col: start.col,
            end_line: end.line,
            end_col: end.col,
            help: self.help.clone(),
        }
    }
}

/// The machine form of a diagnostic (one JSON object per finding).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub code: String,
    pub severity: Severity,
    pub message: String,
    pub file: String,
    pub line: u32,
    pub col: u32,
    pub end_line: u32,
    pub end_col: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub help: Option<String>,
}

impl fmt::Display for Record {
    /// `file:line:col: error[code]: message`, the line compilers print and
    /// editors jump to.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sev = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        write!(
            f,
            "{}:{}:{}: {sev}[{}]: {}",
            self.file, self.line, self.col, self.code, self.message
        )
    }
}

/// A diagnostic bound to its source, in the shape miette draws.
struct Bound<'a> {
    diag: &'a Diagnostic,
    source: NamedSource<String>,
}

impl fmt::Debug for Bound<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.diag.fmt(f)
    }
}

impl fmt::Display for Bound<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.diag.message)
    }
}

impl std::error::Error for Bound<'_> {}

impl miette::Diagnostic for Bound<'_> {
    fn code<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        Some(Box::new(self.diag.code))
    }

    fn severity(&self) -> Option<miette::Severity> {
        Some(match self.diag.severity {
            Severity::Error => miette::Severity::Error,
            Severity::Warning => miette::Severity::Warning,
        })
    }

    fn help<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.diag
            .help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }

    fn source_code(&self) -> Option<&dyn SourceCode> {
        Some(&self.source)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        let len = self.source.inner().len();
        let clamp = move |s: Span| {
            let start = (s.start as usize).min(len);
            let end = (s.end as usize).clamp(start, len);
            (start, end - start)
        };
        let mut labels: Vec<LabeledSpan> = self
            .diag
            .labels
            .iter()
            .map(|l| {
                let msg = (!l.message.is_empty()).then(|| l.message.clone());
                if l.primary {
                    LabeledSpan::new_primary_with_span(msg, clamp(l.span))
                } else {
                    LabeledSpan::new_with_span(msg, clamp(l.span))
                }
            })
            .collect();
        if !self.diag.labels.iter().any(|l| l.primary) {
            labels.insert(
                0,
                LabeledSpan::new_primary_with_span(None, clamp(self.diag.span)),
            );
        }
        Some(Box::new(labels.into_iter()))
    }
}

/// How to draw diagnostics for a person.
#[derive(Debug, Clone, Copy)]
pub struct Style {
    /// Columns to wrap at.
    pub width: usize,
    pub colour: bool,
}

impl Style {
    /// The form tests snapshot: fixed width, no colour, no terminal links.
    pub const PLAIN: Style = Style {
        width: 100,
        colour: false,
    };
}

/// Draws one diagnostic: header with code, message, `file:line:col`, the
/// source lines with markers under the labelled spans, and the hint.
pub fn render(diag: &Diagnostic, file: &SourceFile, style: Style) -> String {
    let theme = if style.colour {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    let handler = GraphicalReportHandler::new_themed(theme)
        .with_width(style.width)
        .with_links(false)
        .without_syntax_highlighting();
    let bound = Bound {
        diag,
        source: NamedSource::new(file.name.clone(), file.text.clone()),
    };
    let mut out = String::new();
    if handler.render_report(&mut out, &bound).is_err() {
        // miette only fails on a span it cannot read; fall back to the flat
        // form rather than lose the diagnostic.
        out = format!("{}\n", diag.record(file));
    }
    out
}

/// Draws diagnostics one after the other, then a closing count line.
pub fn render_all(diags: &[Diagnostic], file: &SourceFile, style: Style) -> String {
    let mut out = String::new();
    for d in diags {
        out.push_str(&render(d, file, style));
        out.push('\n');
    }
    let errors = diags.iter().filter(|d| d.is_error()).count();
    let warnings = diags.len() - errors;
    let plural = |n: usize, w: &str| format!("{n} {w}{}", if n == 1 { "" } else { "s" });
    match (errors, warnings) {
        (0, 0) => {}
        (0, w) => out.push_str(&format!("{}: {}\n", file.name, plural(w, "warning"))),
        (e, 0) => out.push_str(&format!("{}: {}\n", file.name, plural(e, "error"))),
        (e, w) => out.push_str(&format!(
            "{}: {}, {}\n",
            file.name,
            plural(e, "error"),
            plural(w, "warning")
        )),
    }
    out
}

/// The names from `candidates` close enough to `name` to be a likely typo,
/// best first (case differences count as close).
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let lower = name.to_lowercase();
    let mut best: Option<(f64, &str)> = None;
    for c in candidates {
        if c == name {
            continue;
        }
        let score = if c.to_lowercase() == lower {
            1.0
        } else {
            strsim::jaro_winkler(&lower, &c.to_lowercase())
        };
        let close_edit = strsim::levenshtein(name, c) <= (name.chars().count().max(3) / 3);
        // Ties go to the alphabetically first name, whatever the order of
        // `candidates`, so messages do not change from run to run.
        if (score >= 0.85 || close_edit)
            && best.is_none_or(|(s, b)| score > s || (score == s && c < b))
        {
            best = Some((score, c));
        }
    }
    best.map(|(_, c)| c)
}

/// The help for a name that is not known: `did you mean `X`?` when a close
/// name exists, else `otherwise()` (what to do instead). Every unknown name
/// the checker reports gets its help here, so suggestions read the same
/// everywhere and are computed one way.
pub fn did_you_mean<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
    otherwise: impl FnOnce() -> String,
) -> String {
    match suggest(name, candidates) {
        Some(s) => format!("did you mean `{s}`?"),
        None => otherwise(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_the_front_end_emits_is_listed_once() {
        let sources = [
            include_str!("check/mod.rs"),
            include_str!("check/state.rs"),
            include_str!("check/resolve.rs"),
            include_str!("check/fold.rs"),
            include_str!("check/graph.rs"),
            include_str!("check/expand.rs"),
            include_str!("check/profile.rs"),
            include_str!("check/control.rs"),
            include_str!("check/conditions.rs"),
            include_str!("lexer.rs"),
            include_str!("parser.rs"),
            include_str!("lib.rs"),
        ];
        for src in sources {
            for piece in src.split('"').skip(1).step_by(2) {
                if let Some(code) = piece.strip_prefix("eamos::") {
                    if code.ends_with('-') || code == "unterminated" {
                        continue;
                    }
                    assert!(
                        CODES.iter().any(|(c, _)| *c == piece),
                        "`{piece}` is emitted but not listed in CODES"
                    );
                }
            }
        }
        let mut names: Vec<&str> = CODES.iter().map(|(c, _)| *c).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), CODES.len(), "a code is listed twice");
    }

    #[test]
    fn a_typo_suggests_the_close_name() {
        let names = ["FlyByX", "FlyByY", "Takeoff", "Land"];
        assert_eq!(suggest("FlyBX", names), Some("FlyByX"));
        assert_eq!(suggest("takeoff", names), Some("Takeoff"));
        assert_eq!(suggest("Teleport", names), None);
    }

    #[test]
    fn the_record_names_file_line_and_column() {
        let f = SourceFile::new("m.go", "package M\n\tfoo\n");
        let d = Diagnostic::error("eamos::test", Span::new(11, 14), "bad");
        let r = d.record(&f);
        assert_eq!((r.line, r.col, r.end_col), (2, 2, 5));
        assert_eq!(r.to_string(), "m.go:2:2: error[eamos::test]: bad");
    }

    #[test]
    fn rendering_shows_the_source_line_and_the_code() {
        let f = SourceFile::new("m.go", "package M\nfoo\n");
        let d = Diagnostic::error("eamos::test", Span::new(10, 13), "bad thing")
            .with_label("here")
            .with_help("do better");
        let out = render(&d, &f, Style::PLAIN);
        assert!(out.contains("eamos::test"), "{out}");
        assert!(out.contains("m.go:2:1"), "{out}");
        assert!(out.contains("foo"), "{out}");
        assert!(out.contains("do better"), "{out}");
    }
}
