//! Completion. The file is usually broken while someone types, so the
//! context comes from the text before the cursor on its line (after a
//! drone and a dot, inside a `Signal("` or `Await("`, anywhere else), and
//! the names from the last syntax tree.

use eamos_lang::ast::ControlKind;
use eamos_profile::ProfileTable;
use lsp_types::{
    CompletionItem, CompletionItemKind, Documentation, InsertTextFormat, MarkupContent, MarkupKind,
};

use crate::doc::Doc;
use crate::profile_doc;

/// Where the cursor is, for completion.
#[derive(Debug, PartialEq, Eq)]
pub enum Context {
    /// After `name.`: the drone's actions and properties.
    Member { drone: String },
    /// Inside the string of a `Signal(` or `Await(`.
    Event,
    /// Anywhere else: drones, blocks, control structures.
    Statement,
}

/// The context from the text of the line before the cursor.
pub fn context(before: &str) -> Context {
    let trimmed = before.trim_end_matches(|c: char| c.is_alphanumeric() || c == '_');
    if let Some(open) = trimmed.strip_suffix('"') {
        let open = open.trim_end();
        if open.ends_with("Signal(") || open.ends_with("Await(") {
            return Context::Event;
        }
    }
    if let Some(base) = trimmed.strip_suffix('.') {
        let start = base
            .rfind(|c: char| !(c.is_alphanumeric() || c == '_'))
            .map_or(0, |i| i + 1);
        let drone = &base[start..];
        if !drone.is_empty() {
            return Context::Member {
                drone: drone.to_string(),
            };
        }
    }
    Context::Statement
}

pub fn complete(doc: &Doc, profiles: &ProfileTable, offset: usize) -> Vec<CompletionItem> {
    let text = doc.text();
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    match context(&text[line_start..offset]) {
        Context::Member { drone } => members(doc, profiles, offset, &drone),
        Context::Event => doc
            .index
            .events()
            .into_iter()
            .map(|e| item(e, CompletionItemKind::EVENT, "event"))
            .collect(),
        Context::Statement => statements(doc),
    }
}

fn markdown(value: String) -> Documentation {
    Documentation::MarkupContent(MarkupContent {
        kind: MarkupKind::Markdown,
        value,
    })
}

fn item(label: &str, kind: CompletionItemKind, detail: &str) -> CompletionItem {
    CompletionItem {
        label: label.to_string(),
        kind: Some(kind),
        detail: Some(detail.to_string()),
        ..CompletionItem::default()
    }
}

fn snippet(mut item: CompletionItem, text: String) -> CompletionItem {
    item.insert_text = Some(text);
    item.insert_text_format = Some(InsertTextFormat::SNIPPET);
    item
}

fn members(doc: &Doc, profiles: &ProfileTable, offset: usize, drone: &str) -> Vec<CompletionItem> {
    let ix = &doc.index;
    let Some(profile) = ix
        .drone_type(drone, ix.func_at(offset))
        .and_then(|t| profiles.get(t))
    else {
        return Vec::new();
    };
    let actions = profile.actions.iter().map(|(name, sig)| {
        let mut it = item(
            name,
            CompletionItemKind::METHOD,
            &profile_doc::signature(name, &sig.params),
        );
        it.documentation = Some(markdown(profile_doc::action(profile, name, sig)));
        snippet(it, profile_doc::snippet(name, &sig.params))
    });
    let properties = profile.properties.iter().map(|(name, sig)| {
        let mut it = item(
            name,
            CompletionItemKind::PROPERTY,
            &profile_doc::signature(name, &sig.params),
        );
        it.documentation = Some(markdown(profile_doc::property(profile, name, sig)));
        snippet(it, profile_doc::snippet(name, &sig.params))
    });
    actions.chain(properties).collect()
}

/// The arguments of a control structure as tab stops, from its usage line
/// (`RepeatFor(count, Body)`: `RepeatFor(${1:count}, ${2:Body})`).
pub fn control_snippet(kind: ControlKind) -> String {
    let usage = kind.usage().split(" or ").next().unwrap_or(kind.name());
    let inner = usage
        .split_once('(')
        .and_then(|(_, rest)| rest.strip_suffix(')'))
        .unwrap_or("");
    let stops: Vec<String> = inner
        .split(", ")
        .filter(|a| !a.is_empty())
        .enumerate()
        .map(|(i, a)| format!("${{{}:{a}}}", i + 1))
        .collect();
    format!("{}({})", kind.name(), stops.join(", "))
}

fn statements(doc: &Doc) -> Vec<CompletionItem> {
    let ix = &doc.index;
    let mut items: Vec<CompletionItem> = ix
        .drones
        .iter()
        .map(|d| item(&d.name, CompletionItemKind::VARIABLE, &d.ty))
        .collect();
    for f in &ix.funcs {
        let kind = if f.name.starts_with("PAR_") {
            "PAR block"
        } else {
            "SEQ block"
        };
        let stops: Vec<String> = f
            .params
            .iter()
            .enumerate()
            .map(|(i, (n, _))| format!("${{{}:{n}}}", i + 1))
            .collect();
        let it = item(&f.name, CompletionItemKind::FUNCTION, kind);
        items.push(snippet(it, format!("{}({})", f.name, stops.join(", "))));
    }
    for (name, _) in &ix.consts {
        items.push(item(name, CompletionItemKind::CONSTANT, "constant"));
    }
    for k in ControlKind::ALL {
        let mut it = item(k.name(), CompletionItemKind::KEYWORD, k.usage());
        it.documentation = Some(markdown(format!("```go\n{}\n```", k.usage())));
        items.push(snippet(it, control_snippet(k)));
    }
    for sync in ["Signal", "Await"] {
        let it = item(
            sync,
            CompletionItemKind::KEYWORD,
            &format!("{sync}(\"event\")"),
        );
        items.push(snippet(it, format!("{sync}(\"${{1:event}}\")")));
    }
    items
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_context_comes_from_the_text_before_the_cursor() {
        assert_eq!(
            context("\tDrone1.Fl"),
            Context::Member {
                drone: "Drone1".into()
            }
        );
        assert_eq!(context("\tIf(D2."), Context::Member { drone: "D2".into() });
        assert_eq!(context("\tAwait(\"la"), Context::Event);
        assert_eq!(context("\tSignal( \""), Context::Event);
        assert_eq!(context("\tSEQ_"), Context::Statement);
        assert_eq!(context("\tPrint(\"x"), Context::Statement);
    }

    #[test]
    fn a_control_structure_completes_with_its_arguments() {
        assert_eq!(
            control_snippet(ControlKind::RepeatFor),
            "RepeatFor(${1:count}, ${2:Body})"
        );
        assert_eq!(control_snippet(ControlKind::If), "If(${1:cond}, ${2:Then})");
    }
}
