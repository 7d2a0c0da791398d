//! Quick fixes: the front end's "did you mean" hints, applied. The
//! suggestion travels in the diagnostic's `data` (see `proto`), so the fix
//! is exactly what the hint says.

use std::collections::HashMap;

use lsp_types::{
    CodeAction, CodeActionKind, CodeActionOrCommand, Diagnostic, TextEdit, Uri, WorkspaceEdit,
};

use crate::doc::Doc;

pub fn quick_fixes(doc: &Doc, uri: &Uri, diagnostics: &[Diagnostic]) -> Vec<CodeActionOrCommand> {
    let mut out = Vec::new();
    for d in diagnostics {
        let Some(with) = d
            .data
            .as_ref()
            .and_then(|v| v.get("replace_with"))
            .and_then(|v| v.as_str())
        else {
            continue;
        };
        // An event's diagnostic covers its string: keep the quotes.
        let mut range = d.range;
        let span = doc.lines.span(doc.text(), range);
        let written = doc
            .text()
            .get(span.start as usize..span.end as usize)
            .unwrap_or("");
        if written.len() >= 2 && written.starts_with('"') && written.ends_with('"') {
            range.start.character += 1;
            range.end.character -= 1;
        }
        let edit = TextEdit::new(range, with.to_string());
        out.push(CodeActionOrCommand::CodeAction(CodeAction {
            title: format!("replace with `{with}`"),
            kind: Some(CodeActionKind::QUICKFIX),
            diagnostics: Some(vec![d.clone()]),
            edit: Some(WorkspaceEdit {
                changes: Some(HashMap::from([(uri.clone(), vec![edit])])),
                ..WorkspaceEdit::default()
            }),
            is_preferred: Some(true),
            ..CodeAction::default()
        }));
    }
    out
}
