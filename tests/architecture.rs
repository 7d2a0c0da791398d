//! The shape ARCHITECTURE.md promises, held: inside each crate of the
//! workspace no two modules import each other, directly or around a
//! circle. A circle makes two files one unit that can be read, tested
//! and changed only together; the fix is to move what both need into a
//! module below them.
//!
//! A module's imports are the paths it names through `crate::`, `super::`
//! or `self::` (in `use` or in code), outside its `#[cfg(test)]` part.
//! A path resolves to the deepest module it names; a name the crate's root
//! re-exports counts as an import of the root. A `pub use` is a module's
//! face, not an import: lib.rs re-exporting a module's types does not tie
//! it to that module.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use petgraph::algo::tarjan_scc;
use petgraph::graph::DiGraph;

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every crate of the workspace: its `src` directory.
fn crates() -> Vec<PathBuf> {
    let manifest = std::fs::read_to_string(workspace().join("Cargo.toml")).unwrap();
    let members = manifest
        .lines()
        .find(|l| l.starts_with("members"))
        .expect("a workspace lists its members");
    let mut dirs: Vec<PathBuf> = members
        .split('"')
        .skip(1)
        .step_by(2)
        .map(|m| workspace().join(m).join("src"))
        .collect();
    dirs.push(workspace().join("src"));
    dirs
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a file under `src`: `a/b.rs` and `a/b/mod.rs` are
/// `["a", "b"]`, the crate's root `[]`.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    // `src/bin/x.rs` and the like are roots of their own.
    if parts.first().is_some_and(|p| p == "bin") {
        return vec![format!("bin/{}", parts[1..].join("/"))];
    }
    parts
}

/// The code of a file that counts: without line comments and without its
/// tests (everything from its first `#[cfg(test)]` on).
fn code(text: &str) -> String {
    let body = text.split("#[cfg(test)]").next().unwrap_or_default();
    body.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The paths named from `module` through `crate::`, `super::` and
/// `self::` in `code`, made absolute (a `use` group gives one path per
/// branch).
fn named_paths(module: &[String], code: &str) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    let bytes = code.as_bytes();
    for start in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(i) = code[from..].find(start) {
            let at = from + i;
            from = at + start.len();
            // Inside a longer path (`super::super::`, `x::crate::`): that
            // path's own start is what counts.
            let inside = at > 0
                && (bytes[at - 1].is_ascii_alphanumeric()
                    || bytes[at - 1] == b'_'
                    || code[..at].ends_with("::"));
            if inside || re_export(code, at) {
                continue;
            }
            let mut base: Vec<String> = match start {
                "crate::" => Vec::new(),
                "self::" => module.to_vec(),
                _ => module[..module.len().saturating_sub(1)].to_vec(),
            };
            let mut rest = &code[from..];
            if start == "super::" {
                while let Some(r) = rest.strip_prefix("super::") {
                    base.pop();
                    rest = r;
                }
            }
            let tail = words(rest);
            if tail.is_empty() && rest.starts_with('{') {
                // `use crate::{a::X, b::{c, d}}`: each branch's path.
                for branch in branches(&rest[1..]) {
                    let mut p = base.clone();
                    p.extend(words(branch));
                    paths.push(p);
                }
                continue;
            }
            base.extend(tail);
            paths.push(base);
        }
    }
    paths
}

/// The branches of a `use` group whose `{` came just before `group`,
/// split at its own commas (not those of nested groups).
fn branches(group: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let (mut depth, mut from) = (0, 0);
    for (i, c) in group.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => {
                out.push(&group[from..i]);
                break;
            }
            '}' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&group[from..i]);
                from = i + 1;
            }
            _ => {}
        }
    }
    out
}

/// The leading words of a path, up to and with the first that ends it
/// (`a::b::{c}` gives `a`, `b`; `a::B;` gives `a`, `B`).
fn words(path: &str) -> Vec<String> {
    let mut out = Vec::new();
    for seg in path.trim_start().split("::") {
        let word: String = seg
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if word.is_empty() {
            break;
        }
        let whole = word.len() == seg.len();
        out.push(word);
        if !whole {
            break;
        }
    }
    out
}

/// Whether the path at `at` is part of a `pub use` (a re-export).
fn re_export(code: &str, at: usize) -> bool {
    let line_start = code[..at].rfind(['\n', ';', '}']).map_or(0, |i| i + 1);
    let stmt = code[line_start..at].trim_start();
    stmt.starts_with("pub use") || stmt.starts_with("pub(crate) use")
}

/// The module a path names: its longest prefix that is a module of the
/// crate (the root when none is).
fn resolve<'a>(modules: &'a BTreeSet<Vec<String>>, path: &[String]) -> &'a Vec<String> {
    (0..=path.len())
        .rev()
        .find_map(|n| modules.get(&path[..n]))
        .expect("the root is a module")
}

/// The circles of imports among the modules of the crate under `src`.
fn circles(src: &Path) -> Vec<Vec<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let texts: BTreeMap<Vec<String>, String> = files
        .iter()
        .map(|f| (module_of(src, f), std::fs::read_to_string(f).unwrap()))
        .collect();
    let mut modules: BTreeSet<Vec<String>> = texts.keys().cloned().collect();
    modules.insert(Vec::new());
    let mut graph = DiGraph::<Vec<String>, ()>::new();
    let nodes: BTreeMap<Vec<String>, _> = modules
        .iter()
        .map(|m| (m.clone(), graph.add_node(m.clone())))
        .collect();
    for (module, text) in &texts {
        for path in named_paths(module, &code(text)) {
            let target = resolve(&modules, &path);
            if target != module {
                graph.update_edge(nodes[module], nodes[target], ());
            }
        }
    }
    tarjan_scc(&graph)
        .into_iter()
        .filter(|scc| scc.len() > 1)
        .map(|scc| {
            let mut names: Vec<String> = scc
                .iter()
                .map(|&n| match graph[n].join("/") {
                    root if root.is_empty() => "(root)".to_string(),
                    m => m,
                })
                .collect();
            names.sort();
            names
        })
        .collect()
}

#[test]
fn no_two_modules_of_a_crate_import_each_other() {
    let mut found = Vec::new();
    for src in crates() {
        for circle in circles(&src) {
            found.push(format!(
                "{}: {}",
                src.strip_prefix(workspace()).unwrap().display(),
                circle.join(" <-> ")
            ));
        }
    }
    assert!(
        found.is_empty(),
        "modules that import each other:\n{}",
        found.join("\n")
    );
}

#[test]
fn a_circle_is_seen_through_use_groups_super_and_paths_in_code() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("net")).unwrap();
    std::fs::write(src.join("lib.rs"), "mod a;\nmod net;\npub use a::A;\n").unwrap();
    std::fs::write(
        src.join("a.rs"),
        "use crate::{net::place::P};\npub struct A;\n",
    )
    .unwrap();
    std::fs::write(src.join("net/mod.rs"), "pub mod place;\n").unwrap();
    std::fs::write(
        src.join("net/place.rs"),
        "pub struct P;\nfn f() { super::super::a::A; }\n#[cfg(test)]\nmod tests { use crate::a::A; }\n",
    )
    .unwrap();
    assert_eq!(
        circles(src),
        vec![vec!["a".to_string(), "net/place".to_string()]]
    );
    // Without the call in code, only the tests import `a`: no circle.
    std::fs::write(
        src.join("net/place.rs"),
        "pub struct P;\n// crate::a::A in a comment\n#[cfg(test)]\nmod tests { use crate::a::A; }\n",
    )
    .unwrap();
    assert!(circles(src).is_empty());
}
