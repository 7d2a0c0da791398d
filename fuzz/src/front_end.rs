//! Feeds arbitrary text to the whole front end (lexer, parser, checks,
//! expansion, rendering): it must never panic, and every span it reports
//! must lie inside the file.

use std::sync::OnceLock;

use eamos_lang::{compile, render, SourceFile, Style};
use eamos_profile::ProfileTable;

/// The built-in profiles, read once.
fn profiles() -> &'static ProfileTable {
    static TABLE: OnceLock<ProfileTable> = OnceLock::new();
    TABLE.get_or_init(eamos_profile::builtin)
}

/// One input: it must not panic.
pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let file = SourceFile::new("fuzz.go", text);
    let len = text.len() as u32;
    let diags = match compile(&file, profiles()) {
        Ok(compiled) => {
            let _ = compiled.mission.summary().to_string();
            compiled.warnings
        }
        Err(diags) => diags,
    };
    for d in &diags {
        assert!(d.span.start <= d.span.end && d.span.end <= len, "{d:?}");
        for label in &d.labels {
            assert!(
                label.span.start <= label.span.end && label.span.end <= len,
                "{d:?}"
            );
        }
        let _ = render(d, &file, Style::PLAIN);
    }
}
