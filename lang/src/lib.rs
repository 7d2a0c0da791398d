//! The front end of the EAMOS mission language (a subset of Go).
//!
//! `source text -> tokens (logos, with Go's automatic semicolons) -> syntax
//! tree (lalrpop) -> checked mission ([`hir::Mission`])`. This crate knows
//! nothing of Petri nets, slices or adapters: it only checks a mission
//! against the capability profiles it is handed.
//!
//! ```
//! # use eamos_lang::{compile, SourceFile};
//! # let profiles = eamos_profile::ProfileTable::new();
//! let file = SourceFile::new("m.go", "package M\nfunc INIT() {}\n");
//! let compiled = compile(&file, &profiles).expect("an empty mission compiles");
//! assert_eq!(compiled.mission.name, "M");
//! assert_eq!(compiled.warnings[0].code, "eamos::empty-mission");
//! ```

pub mod ast;
pub mod check;
pub mod diag;
pub mod hir;
pub mod lexer;
pub mod parser;
pub mod span;

pub use diag::{render, render_all, Diagnostic, Record, Severity, Style};
pub use span::{SourceFile, Span};

use eamos_profile::ProfileTable;

/// A mission file's bytes as a [`SourceFile`].
///
/// A file that is not UTF-8 cannot be lexed. Instead of an I/O error
/// without a place, the error is a diagnostic at the first bad byte (line
/// and column, like any other), and comes with the file decoded lossily
/// (each bad sequence shown as U+FFFD, which keeps every offset before it)
/// so that it renders with its source line.
pub fn decode(
    name: impl Into<String>,
    bytes: Vec<u8>,
) -> Result<SourceFile, (SourceFile, Vec<Diagnostic>)> {
    let err = match String::from_utf8(bytes) {
        Ok(text) => return Ok(SourceFile::new(name, text)),
        Err(e) => e,
    };
    let at = err.utf8_error().valid_up_to();
    let bytes = err.as_bytes();
    let bad_len = err.utf8_error().error_len().unwrap_or(bytes.len() - at);
    let shown: Vec<String> = bytes[at..at + bad_len]
        .iter()
        .map(|b| format!("0x{b:02X}"))
        .collect();
    let text = String::from_utf8_lossy(bytes).into_owned();
    let file = SourceFile::new(name, text);
    let d = Diagnostic::error(
        "eamos::not-utf8",
        Span::new(at, at + char::REPLACEMENT_CHARACTER.len_utf8()),
        "the file is not valid UTF-8",
    )
    .with_label(match shown.as_slice() {
        [one] => format!("byte {one} is not UTF-8"),
        several => format!("bytes {} are not UTF-8", several.join(" ")),
    })
    .with_help("a mission is UTF-8 text, as Go source is: save the file as UTF-8");
    Err((file, vec![d]))
}

/// A mission that compiled, and what is worth a look in it anyway.
#[derive(Debug, Clone)]
pub struct Compiled {
    pub mission: hir::Mission,
    pub warnings: Vec<Diagnostic>,
}

/// Compiles one mission file against the given capability profiles.
///
/// On failure, every diagnostic found (errors and warnings, in source order)
/// is returned: syntax errors do not stop the checks of what could be read.
pub fn compile(file: &SourceFile, profiles: &ProfileTable) -> Result<Compiled, Vec<Diagnostic>> {
    analyse(file, profiles).result
}

/// A mission compiled, with the syntax tree it was read into: what an
/// editor needs beside the diagnostics (where each name is, what is called
/// where), from one parse.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The syntax tree, with `Error` nodes where the parser skipped text.
    pub ast: ast::File,
    /// What [`compile`] returns for the same file.
    pub result: Result<Compiled, Vec<Diagnostic>>,
}

/// [`compile`], keeping the syntax tree.
pub fn analyse(file: &SourceFile, profiles: &ProfileTable) -> Analysis {
    let (ast, mut diags) = parser::parse(file);
    // Syntax errors and runaway strings or comments may hide declarations;
    // other lexical errors (a stray character, a bad number) do not.
    let complete = !diags.iter().any(|d| {
        d.is_error()
            && matches!(
                d.code,
                "eamos::syntax"
                    | "eamos::too-complex"
                    | "eamos::unterminated-comment"
                    | "eamos::unterminated-string"
            )
    });
    let (mission, checked) = check::check(&ast, file, profiles, complete);
    diags.extend(checked);
    if diags.iter().any(Diagnostic::is_error) {
        diags.retain(|d| d.is_error() || !check::WHOLE_MISSION_WARNINGS.contains(&d.code));
    }
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    let result = match mission {
        Some(mission) if !diags.iter().any(Diagnostic::is_error) => Ok(Compiled {
            mission,
            warnings: diags,
        }),
        _ => Err(diags),
    };
    Analysis { ast, result }
}
