//! The one place where the front end's and the checker's findings become
//! the protocol's diagnostics (rust-analyzer's `to_proto`): codes, hints,
//! secondary labels and counterexamples all cross here.

use eamos_lang::{Diagnostic as LangDiagnostic, Severity};
use eamos_verify::report::{Finding, Limit};
use lsp_types::{
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString, Uri,
};
use serde_json::json;

use crate::doc::Doc;

/// Where the "did you mean" hint puts its suggestion, for the quick fix.
pub fn suggestion(help: &str) -> Option<&str> {
    help.strip_prefix("did you mean `")?.strip_suffix("`?")
}

/// A front-end diagnostic, as `eamos build` reports it: same code, message
/// and hint; secondary labels as related information.
pub fn diagnostic(d: &LangDiagnostic, doc: &Doc, uri: &Uri) -> Diagnostic {
    let mut message = d.message.clone();
    if let Some(help) = &d.help {
        message.push_str("\nhelp: ");
        message.push_str(help);
    }
    let related: Vec<_> = d
        .labels
        .iter()
        .filter(|l| !l.primary && !l.message.is_empty())
        .map(|l| DiagnosticRelatedInformation {
            location: Location::new(uri.clone(), doc.range(l.span)),
            message: l.message.clone(),
        })
        .collect();
    let fix = d.help.as_deref().and_then(suggestion);
    Diagnostic {
        range: doc.range(d.span),
        severity: Some(match d.severity {
            Severity::Error => DiagnosticSeverity::ERROR,
            Severity::Warning => DiagnosticSeverity::WARNING,
        }),
        code: Some(NumberOrString::String(d.code.to_string())),
        source: Some("eamos".into()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        data: fix.map(|s| json!({ "replace_with": s })),
        ..Diagnostic::default()
    }
}

/// A finding of `eamos check`: its first label is where it is; the other
/// labels and every step of the counterexample that has a place in the
/// mission are related information, in order.
pub fn finding(f: &Finding, doc: &Doc, uri: &Uri) -> Diagnostic {
    let span = f.labels.first().map(|l| l.span).unwrap_or_default();
    let mut message = f.message.clone();
    for n in &f.notes {
        message.push_str("\nnote: ");
        message.push_str(n);
    }
    let mut related: Vec<_> = f
        .labels
        .iter()
        .skip(1)
        .map(|l| DiagnosticRelatedInformation {
            location: Location::new(uri.clone(), doc.range(l.span)),
            message: l.text.clone(),
        })
        .collect();
    if let Some(trace) = &f.trace {
        let visible = trace.steps.iter().enumerate().filter(|(_, s)| !s.internal);
        for (n, (i, step)) in visible.enumerate() {
            let Some(at) = step.span else { continue };
            let cycle = if trace.cycle_from.is_some_and(|c| i >= c) {
                " (repeats forever)"
            } else {
                ""
            };
            related.push(DiagnosticRelatedInformation {
                location: Location::new(uri.clone(), doc.range(at)),
                message: format!("counterexample step {}: {}{cycle}", n + 1, step.text),
            });
        }
    }
    Diagnostic {
        range: doc.range(span),
        severity: Some(if f.kind.is_error() {
            DiagnosticSeverity::ERROR
        } else {
            DiagnosticSeverity::WARNING
        }),
        code: Some(NumberOrString::String(format!("check::{}", f.kind.name()))),
        source: Some("eamos check".into()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        ..Diagnostic::default()
    }
}

/// Where the checker stopped short: information, not a finding.
pub fn limit(l: &Limit, doc: &Doc) -> Diagnostic {
    let span = l.labels.first().map(|l| l.span).unwrap_or_default();
    Diagnostic {
        range: doc.range(span),
        severity: Some(DiagnosticSeverity::INFORMATION),
        code: Some(NumberOrString::String(format!("check::{}", l.code))),
        source: Some("eamos check".into()),
        message: l.message.clone(),
        ..Diagnostic::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_suggestion_is_read_from_the_front_ends_hint() {
        assert_eq!(suggestion("did you mean `FlyByX`?"), Some("FlyByX"));
        assert_eq!(suggestion("declare it first"), None);
    }
}
