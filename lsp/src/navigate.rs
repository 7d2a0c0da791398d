//! Go to definition, find references, rename and the outline: all read
//! the index's occurrences of one symbol (a block, an event, a drone, a
//! constant).

use std::collections::HashMap;

use lsp_types::{DocumentSymbol, Location, Range, SymbolKind, TextEdit, Uri, WorkspaceEdit};

use crate::doc::Doc;
use crate::index::{Kind, Occurrence};

/// Symbols that have a declaration in the file: actions, properties and
/// control structures belong to the profile and the language.
fn is_symbol(o: &Occurrence) -> bool {
    matches!(
        o.kind,
        Kind::Block | Kind::Event | Kind::Drone | Kind::Const
    )
}

/// Where the symbol under the cursor is declared: a block's `func`, a
/// drone's `var`, an event's `Signal` (an `Await` jumps to it).
pub fn definition(doc: &Doc, uri: &Uri, offset: usize) -> Vec<Location> {
    let Some(o) = doc.index.at(offset).filter(|o| is_symbol(o)) else {
        return Vec::new();
    };
    doc.index
        .all_of(o.kind, &o.name)
        .filter(|d| d.def)
        .map(|d| Location::new(uri.clone(), doc.range(d.span)))
        .collect()
}

pub fn references(doc: &Doc, uri: &Uri, offset: usize, declaration: bool) -> Vec<Location> {
    let Some(o) = doc.index.at(offset).filter(|o| is_symbol(o)) else {
        return Vec::new();
    };
    doc.index
        .all_of(o.kind, &o.name)
        .filter(|r| declaration || !r.def)
        .map(|r| Location::new(uri.clone(), doc.range(r.span)))
        .collect()
}

/// The range a rename would change, if the cursor is on a block, an event
/// or a drone.
pub fn prepare_rename(doc: &Doc, offset: usize) -> Option<Range> {
    let o = doc.index.at(offset).filter(|o| renamable(o))?;
    Some(doc.range(o.span))
}

fn renamable(o: &Occurrence) -> bool {
    matches!(o.kind, Kind::Block | Kind::Event | Kind::Drone)
}

/// Whether `name` may be the new name: an identifier for a block or a
/// drone (a block keeps its `PAR_` or `SEQ_` nature as the user spells
/// it); any text without quotes or line breaks for an event.
pub fn valid_name(kind: Kind, name: &str) -> bool {
    match kind {
        Kind::Event => !name.is_empty() && !name.contains(['"', '`', '\\', '\n', '\r']),
        _ => {
            let mut chars = name.chars();
            chars.next().is_some_and(|c| c.is_alphabetic() || c == '_')
                && chars.all(|c| c.is_alphanumeric() || c == '_')
        }
    }
}

/// Every occurrence of the symbol under the cursor renamed; `Err` with
/// what is wrong otherwise.
pub fn rename(
    doc: &Doc,
    uri: &Uri,
    offset: usize,
    new_name: &str,
) -> Result<WorkspaceEdit, String> {
    let o = doc
        .index
        .at(offset)
        .filter(|o| renamable(o))
        .ok_or("only a block, an event or a drone can be renamed")?;
    if !valid_name(o.kind, new_name) {
        return Err(format!("`{new_name}` is not a valid name here"));
    }
    let edits: Vec<TextEdit> = doc
        .index
        .all_of(o.kind, &o.name)
        .map(|r| TextEdit::new(doc.range(r.span), new_name.to_string()))
        .collect();
    Ok(WorkspaceEdit {
        changes: Some(HashMap::from([(uri.clone(), edits)])),
        ..WorkspaceEdit::default()
    })
}

/// The outline: drones, constants, and each block with its kind and,
/// inside it, what it runs.
#[allow(deprecated)] // `DocumentSymbol::deprecated` must still be written.
pub fn symbols(doc: &Doc) -> Vec<DocumentSymbol> {
    let ix = &doc.index;
    let symbol =
        |name: &str, detail: String, kind, range: Range, selection: Range| DocumentSymbol {
            name: name.to_string(),
            detail: Some(detail),
            kind,
            tags: None,
            deprecated: None,
            range,
            selection_range: selection,
            children: None,
        };
    let mut out = Vec::new();
    for d in &ix.drones {
        let r = doc.range(d.span);
        out.push(symbol(&d.name, d.ty.clone(), SymbolKind::VARIABLE, r, r));
    }
    for (name, span) in &ix.consts {
        let r = doc.range(*span);
        out.push(symbol(name, "constant".into(), SymbolKind::CONSTANT, r, r));
    }
    for (i, f) in ix.funcs.iter().enumerate() {
        let kind = if f.name.starts_with("PAR_") {
            "PAR"
        } else {
            "SEQ"
        };
        let mut block = symbol(
            &f.name,
            kind.to_string(),
            SymbolKind::FUNCTION,
            doc.range(f.span),
            doc.range(f.name_span),
        );
        // Inside a block: the blocks it runs, its control structures and
        // its events, in order.
        let children: Vec<DocumentSymbol> = ix
            .occurrences
            .iter()
            .filter(|o| o.func == Some(i))
            .filter_map(|o| {
                let (name, kind) = match o.kind {
                    Kind::Block if !o.def => (o.name.clone(), SymbolKind::FUNCTION),
                    Kind::Control => (o.name.clone(), SymbolKind::OPERATOR),
                    Kind::Event if o.def => (format!("Signal(\"{}\")", o.name), SymbolKind::EVENT),
                    Kind::Event => (format!("Await(\"{}\")", o.name), SymbolKind::EVENT),
                    _ => return None,
                };
                let r = doc.range(o.span);
                Some(symbol(&name, String::new(), kind, r, r))
            })
            .collect();
        block.children = (!children.is_empty()).then_some(children);
        out.push(block);
    }
    out.sort_by_key(|s| (s.range.start.line, s.range.start.character));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const MISSION: &str = "package M\nvar D1 Quadcopter\nfunc INIT() { PAR_Go() }\nfunc PAR_Go() {\n\tSEQ_A()\n\tAwait(\"up\")\n}\nfunc SEQ_A() {\n\tD1.Arm()\n\tSignal(\"up\")\n\tIf(D1.Z() > 1, SEQ_B)\n}\nfunc SEQ_B() {}\n";

    fn doc() -> Doc {
        let mut d = Doc::new("m.go", MISSION.to_string(), 1);
        d.analyse(&eamos_profile::builtin());
        d
    }

    fn uri() -> Uri {
        "file:///m.go".parse().unwrap()
    }

    fn edited(edit: &WorkspaceEdit) -> String {
        let d = doc();
        let mut edits = edit.changes.as_ref().unwrap()[&uri()].clone();
        edits.sort_by_key(|e| std::cmp::Reverse(d.offset(e.range.start)));
        let mut text = MISSION.to_string();
        for e in edits {
            text.replace_range(d.offset(e.range.start)..d.offset(e.range.end), &e.new_text);
        }
        text
    }

    #[test]
    fn renaming_an_event_changes_every_site_and_keeps_the_quotes() {
        let d = doc();
        let at = MISSION.find("\"up\"").unwrap() + 1;
        let text = edited(&rename(&d, &uri(), at, "landed").unwrap());
        assert_eq!(text.matches("\"landed\"").count(), 2, "{text}");
        assert!(!text.contains("\"up\""));
    }

    #[test]
    fn renaming_a_block_changes_its_declaration_calls_and_block_arguments() {
        let d = doc();
        let at = MISSION.find("SEQ_B)").unwrap();
        let text = edited(&rename(&d, &uri(), at, "SEQ_High").unwrap());
        assert_eq!(text.matches("SEQ_High").count(), 2, "{text}");
        assert!(rename(&d, &uri(), at, "not a name").is_err());
    }

    #[test]
    fn the_outline_shows_what_each_block_runs() {
        let d = doc();
        let outline = symbols(&d);
        let seq_a = outline.iter().find(|s| s.name == "SEQ_A").unwrap();
        let inside: Vec<&str> = seq_a
            .children
            .iter()
            .flatten()
            .map(|c| c.name.as_str())
            .collect();
        assert_eq!(inside, ["Signal(\"up\")", "If", "SEQ_B"]);
    }

    #[test]
    fn an_await_goes_to_its_signal() {
        let d = doc();
        let at = MISSION.find("Await(\"up").unwrap() + 7;
        let defs = definition(&d, &uri(), at);
        assert_eq!(defs.len(), 1);
        assert_eq!(defs[0].range.start.line, 9);
    }
}
