//! Name resolution and checks: from the syntax tree to [`hir::Mission`].
//!
//! A pipeline of passes over one shared [`state::Checker`]:
//!
//! 1. [`resolve`]: declarations (drones, constants, functions and their
//!    parameters) enter one namespace; names in statements and conditions
//!    are looked up there.
//! 2. [`fold`]: constants and constant expressions are folded to numbers
//!    (in declaration order, so that a cycle is reported at one place).
//! 3. Check: every function body is lowered once ([`expand`], [`control`],
//!    [`profile`], [`conditions`]), with its parameters standing for "some
//!    drone of this type" or "some number". Every error a person can fix in
//!    that function is reported there, once, however often it is called.
//! 4. [`graph`]: the call graph gives the entry point and finds recursion.
//! 5. Expand: from the entry point, every call is expanded into its own
//!    block instance with its arguments substituted, by the same lowering
//!    code. Only what depends on the expansion is reported there: values
//!    that come from arguments (a negative `RepeatFor` count), and a
//!    `Signal` that ends up inside a loop body. Then the warnings about the
//!    mission as a whole ([`graph`] again).
//!
//! The passes import only [`state`] (the checker, its environments and the
//! shared vocabulary of types), never each other; this module drives them in
//! order. The lowering is recursive as the language is (a constant is an
//! expression, a block call expands a body of statements), so the passes
//! call each other's methods on the one `Checker`, which is where that
//! recursion lives.

mod conditions;
mod control;
mod expand;
mod fold;
mod graph;
mod profile;
mod resolve;
mod state;

use std::collections::BTreeSet;

use eamos_profile::ProfileTable;

use crate::ast;
use crate::diag::Diagnostic;
use crate::hir;
use crate::span::SourceFile;
use state::{Checker, Ctx, Env, Mode};

pub use expand::{MAX_CALL_DEPTH, MAX_EXPANDED_STATEMENTS};

/// Codes whose findings need the whole file: after a syntax error a
/// declaration may be missing, so these would only be echoes of it.
const NEED_COMPLETE_FILE: &[&str] = &[
    "eamos::unknown-drone",
    "eamos::unknown-function",
    "eamos::unknown-name",
    "eamos::unknown-event",
    "eamos::no-entry",
    "eamos::several-entries",
];

/// Warnings about the mission as a whole (a drone never used, a function
/// never called): while there are errors they are only echoes of them.
pub const WHOLE_MISSION_WARNINGS: &[&str] = &[
    "eamos::never-called",
    "eamos::unused-drone",
    "eamos::empty-mission",
    "eamos::event-never-awaited",
];

/// Checks a parsed file. `complete` is false when the parser had to skip
/// parts of the file: findings that may only echo a skipped declaration are
/// then left out, and so are warnings.
pub fn check(
    file: &ast::File,
    source: &SourceFile,
    profiles: &ProfileTable,
    complete: bool,
) -> (Option<hir::Mission>, Vec<Diagnostic>) {
    let mut c = Checker::new(file, source, profiles);
    let mission = run(&mut c);
    let mut diags = c.diags;
    if !complete {
        diags.retain(|d| d.is_error() && !NEED_COMPLETE_FILE.contains(&d.code));
    }
    let mut seen = BTreeSet::new();
    diags.retain(|d| seen.insert((d.code, d.span.start, d.span.end)));
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    let ok = complete && !diags.iter().any(Diagnostic::is_error);
    (if ok { mission } else { None }, diags)
}

/// The passes, in order.
fn run<'a>(c: &mut Checker<'a>) -> Option<hir::Mission> {
    c.declare();
    // In declaration order, so that a cycle is always reported at the
    // same place.
    let const_names: Vec<&'a str> = c
        .file
        .decls
        .iter()
        .filter_map(|d| match d {
            ast::Decl::Const(k) => Some(k.specs.iter().map(|s| s.name.name.as_str())),
            _ => None,
        })
        .flatten()
        .collect();
    for name in const_names {
        c.const_value(name, None);
    }
    c.collect_signals();
    let order = c.func_order.clone();
    for name in &order {
        c.check_func(name);
    }
    let graph = c.call_graph();
    let recursive = c.report_recursion(&graph);
    let entry = c.entry_point(&graph)?;
    if recursive {
        return None;
    }
    c.mode = Mode::Expand;
    let info = &c.funcs[entry];
    let decl = info.decl;
    let mut ctx = Ctx::default();
    let root = c.expand(decl, &Env::default(), decl.name.span, &mut ctx);
    c.mode = Mode::Check;
    c.warn_unused(entry, &graph, &root);
    let name = c
        .file
        .package
        .as_ref()
        .map_or_else(String::new, |p| p.name.clone());
    let drones = c
        .drones
        .iter()
        .map(|d| hir::Drone {
            name: d.name.name.clone(),
            profile: d.ty.name.clone(),
            span: d.name.span,
        })
        .collect();
    Some(hir::Mission {
        name,
        drones,
        entry: entry.to_string(),
        root,
    })
}
