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
            range.end.character = range.end.character.saturating_sub(1);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn fixes(text: &str) -> Vec<(String, String)> {
        let mut doc = Doc::new("m.go", text.to_string(), 1);
        doc.analyse(&eamos_profile::builtin());
        let uri: Uri = "file:///m.go".parse().unwrap();
        let diags: Vec<Diagnostic> = doc
            .diagnostics()
            .iter()
            .map(|d| crate::proto::diagnostic(d, &doc, &uri))
            .collect();
        quick_fixes(&doc, &uri, &diags)
            .into_iter()
            .map(|a| {
                let CodeActionOrCommand::CodeAction(a) = a else {
                    panic!("a command")
                };
                let edit = a.edit.unwrap().changes.unwrap()[&uri][0].clone();
                let span = doc.lines.span(doc.text(), edit.range);
                let old = doc.text()[span.start as usize..span.end as usize].to_string();
                (old, edit.new_text)
            })
            .collect()
    }

    #[test]
    fn a_misspelt_action_is_replaced_by_the_hinted_one() {
        let got =
            fixes("package M\nvar D1 Quadcopter\nfunc INIT() {\n\tD1.Arm()\n\tD1.FlyBX(1)\n}\n");
        assert_eq!(got, vec![("FlyBX".to_string(), "FlyByX".to_string())]);
    }

    #[test]
    fn a_misspelt_event_is_replaced_inside_its_quotes() {
        let got = fixes("package M\nvar D1 Quadcopter\nfunc PAR_Go() {\n\tSEQ_A()\n\tAwait(\"landd\")\n}\nfunc SEQ_A() {\n\tD1.Arm()\n\tSignal(\"landed\")\n}\n");
        assert_eq!(got, vec![("landd".to_string(), "landed".to_string())]);
    }
}
