//! One open mission file: its text and what the front end made of it.
//!
//! The analysis is a pure function of the text, so a document keeps the
//! hash of the text it analysed and skips the work when the text is the
//! one analysed (a save that sends the text, keystrokes undone before the
//! front end saw them).

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};

use eamos_lang::{Analysis, SourceFile, Span};
use eamos_profile::ProfileTable;
use lsp_types::{Position, Range};

use crate::index::Index;
use crate::position::LineIndex;

pub struct Doc {
    pub version: i32,
    pub source: SourceFile,
    pub lines: LineIndex,
    /// The front end's result for `source`; `None` until analysed.
    pub analysis: Option<Analysis>,
    pub index: Index,
    /// Hash of the text `analysis` is of.
    analysed: Option<u64>,
}

pub fn hash(text: &str) -> u64 {
    let mut h = DefaultHasher::new();
    text.hash(&mut h);
    h.finish()
}

impl Doc {
    pub fn new(name: &str, text: String, version: i32) -> Doc {
        Doc {
            version,
            lines: LineIndex::new(&text),
            source: SourceFile::new(name, text),
            analysis: None,
            index: Index::default(),
            analysed: None,
        }
    }

    pub fn text(&self) -> &str {
        &self.source.text
    }

    /// Replaces the text (an edit); the analysis goes stale until
    /// [`Doc::analyse`].
    pub fn set_text(&mut self, text: String, version: i32) {
        self.version = version;
        self.lines = LineIndex::new(&text);
        self.source = SourceFile::new(self.source.name.clone(), text);
    }

    /// Runs the front end if the text changed since it last ran; whether it
    /// ran.
    pub fn analyse(&mut self, profiles: &ProfileTable) -> bool {
        let h = hash(self.text());
        if self.analysed == Some(h) {
            return false;
        }
        let analysis = eamos_lang::analyse(&self.source, profiles);
        self.index = Index::new(&analysis.ast, self.text());
        self.analysis = Some(analysis);
        self.analysed = Some(h);
        true
    }

    /// The front end's diagnostics of the current analysis.
    pub fn diagnostics(&self) -> &[eamos_lang::Diagnostic] {
        match self.analysis.as_ref().map(|a| &a.result) {
            Some(Ok(c)) => &c.warnings,
            Some(Err(d)) => d,
            None => &[],
        }
    }

    pub fn range(&self, span: Span) -> Range {
        self.lines.range(self.text(), span)
    }

    pub fn offset(&self, pos: Position) -> usize {
        self.lines.offset(self.text(), pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_edit_that_leaves_the_text_as_it_was_is_not_analysed_again() {
        let profiles = eamos_profile::builtin();
        let text = "package M\nvar D1 Quadcopter\nfunc INIT() { D1.Arm() }\n";
        let mut doc = Doc::new("m.go", text.to_string(), 1);
        assert!(doc.analyse(&profiles));
        doc.set_text(format!("{text}x"), 2);
        assert!(doc.analyse(&profiles), "a change is analysed");
        doc.set_text(text.to_string(), 3);
        assert!(doc.analyse(&profiles), "an undo is a change too");
        doc.set_text(text.to_string(), 4);
        assert!(!doc.analyse(&profiles), "the same text again is not");
        assert_eq!(doc.version, 4);
    }
}
