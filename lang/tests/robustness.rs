//! No input, however malformed, makes the front end panic, and every span it
//! reports lies inside the file. Random bytes and randomly mutated paper
//! missions (characters and whole tokens deleted, inserted, swapped).

use std::path::PathBuf;

use eamos_lang::{compile, hir, lexer, render, SourceFile, Style};
use proptest::prelude::*;

fn paper_missions() -> Vec<String> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/missions/paper");
    let mut texts: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "go"))
        .map(|e| std::fs::read_to_string(e.path()).expect("paper mission"))
        .collect();
    texts.sort();
    // A mission using the extensions too, so mutations reach their checks.
    texts.push(
        "package Ext\nconst Side = 2.5\nconst (\n\tN = 3\n)\nvar (\n\tD1, D2 Quadcopter\n)\n\
         func INIT() {\n\tPAR_Go()\n\tSEQ_Square(D1, Side / 2)\n\tRepeatFor(N, SEQ_Lap)\n\
         \tDoUntil(D1.DistanceTo(D2) < 1 || !D2.IsArmed(), SEQ_Lap)\n\tPauseFor(1.5)\n}\n\
         func PAR_Go() {\n\tSEQ_A()\n\tSEQ_B()\n}\n\
         func SEQ_A() {\n\tD1.Takeoff(1)\n\tSignal(\"up\")\n}\n\
         func SEQ_B() {\n\tAwait(\"up\")\n\tD2.Takeoff(1)\n\tIf(D2.Battery() >= 20, SEQ_Lap, SEQ_Home)\n}\n\
         func SEQ_Lap() {\n\tD2.FlyByX(1)\n}\n\
         func SEQ_Home() {\n\tD2.ReturnHome()\n}\n\
         func SEQ_Square(d Quadcopter, side float64) {\n\td.FlyByX(side)\n\td.FlyByY(-side)\n}\n"
            .to_string(),
    );
    texts
}

fn profiles() -> eamos_profile::ProfileTable {
    eamos_profile::builtin()
}

fn check_spans_of_mission(m: &hir::Mission, len: u32) {
    let inside =
        |s: eamos_lang::Span| assert!(s.start <= s.end && s.end <= len, "{s:?} outside 0..{len}");
    for d in &m.drones {
        inside(d.span);
    }
    m.root.walk_blocks(&mut |b| inside(b.span));
    m.root.walk(&mut |s| {
        inside(s.span());
        let conds: Vec<&hir::Expr> = match s {
            hir::Stmt::If { cond, .. }
            | hir::Stmt::Wait { cond, .. }
            | hir::Stmt::Repeat { cond, .. }
            | hir::Stmt::Pause { cond, .. }
            | hir::Stmt::Do { cond, .. } => vec![cond],
            _ => vec![],
        };
        for c in conds {
            c.visit(&mut |e| inside(e.span()));
        }
    });
}

/// Compiles, checks every span, and draws every diagnostic.
fn front_end_holds(text: &str) {
    let file = SourceFile::new("fuzz.go", text);
    let len = text.len() as u32;
    let diags = match compile(&file, &profiles()) {
        Ok(c) => {
            check_spans_of_mission(&c.mission, len);
            let _ = c.mission.summary().to_string();
            c.warnings
        }
        Err(diags) => {
            assert!(
                diags.iter().any(|d| d.is_error()),
                "a failed compile names an error"
            );
            diags
        }
    };
    for d in &diags {
        assert!(d.span.start <= d.span.end && d.span.end <= len, "{d:?}");
        for l in &d.labels {
            assert!(l.span.start <= l.span.end && l.span.end <= len, "{d:?}");
        }
        assert!(d.code.starts_with("eamos::"), "{d:?}");
        let drawn = render(d, &file, Style::PLAIN);
        assert!(drawn.contains(d.code), "{drawn}");
    }
}

#[derive(Debug, Clone)]
enum Mutation {
    DeleteChars { at: usize, len: usize },
    InsertChar { at: usize, c: char },
    SwapChars { a: usize, b: usize },
    DeleteToken { i: usize },
    DuplicateToken { i: usize },
    SwapTokens { a: usize, b: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let interesting = prop::sample::select(vec![
        '(', ')', '{', '}', ',', ';', '.', '"', '`', '\n', '/', '*', '!', '&', '|', '<', '=', '-',
        '0', '9', 'x', 'e', '_', 'é', '@', '\t', ' ',
    ]);
    prop_oneof![
        (any::<usize>(), 1usize..8).prop_map(|(at, len)| Mutation::DeleteChars { at, len }),
        (any::<usize>(), interesting).prop_map(|(at, c)| Mutation::InsertChar { at, c }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapChars { a, b }),
        any::<usize>().prop_map(|i| Mutation::DeleteToken { i }),
        any::<usize>().prop_map(|i| Mutation::DuplicateToken { i }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapTokens { a, b }),
    ]
}

fn apply(text: &str, m: &Mutation) -> String {
    let chars: Vec<char> = text.chars().collect();
    let n = chars.len().max(1);
    let mut out = chars;
    let tokens: Vec<(usize, usize)> = lexer::lex(text)
        .tokens
        .iter()
        .filter(|(l, _, r)| r > l)
        .map(|(l, _, r)| (*l, *r))
        .collect();
    let tok = |i: usize| tokens.get(i % tokens.len().max(1)).copied();
    match *m {
        Mutation::DeleteChars { at, len } => {
            let at = at % n;
            let end = (at + len).min(out.len());
            out.drain(at.min(end)..end);
        }
        Mutation::InsertChar { at, c } => {
            let at = (at % n).min(out.len());
            out.insert(at, c);
        }
        Mutation::SwapChars { a, b } => {
            let len = out.len();
            if len > 0 {
                out.swap(a % len, b % len);
            }
        }
        Mutation::DeleteToken { i } => {
            if let Some((l, r)) = tok(i) {
                return format!("{}{}", &text[..l], &text[r..]);
            }
        }
        Mutation::DuplicateToken { i } => {
            if let Some((l, r)) = tok(i) {
                return format!("{}{}{}", &text[..r], &text[l..r], &text[r..]);
            }
        }
        Mutation::SwapTokens { a, b } => {
            if let (Some(x), Some(y)) = (tok(a), tok(b)) {
                let (x, y) = if x.0 <= y.0 { (x, y) } else { (y, x) };
                if x.1 <= y.0 {
                    return format!(
                        "{}{}{}{}{}",
                        &text[..x.0],
                        &text[y.0..y.1],
                        &text[x.1..y.0],
                        &text[x.0..x.1],
                        &text[y.1..]
                    );
                }
            }
        }
    }
    out.into_iter().collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_make_the_front_end_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        front_end_holds(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn random_go_like_text_never_makes_the_front_end_panic(
        text in "(package|var|const|func|[A-Za-z_]{1,8}|[0-9.xe_]{1,5}|[(){},;.\"`\n/*!&|<>=+-]|\t| ){0,80}"
    ) {
        front_end_holds(&text);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

    #[test]
    fn mutated_paper_missions_never_make_the_front_end_panic(
        which in any::<prop::sample::Index>(),
        mutations in prop::collection::vec(mutation(), 1..5),
    ) {
        let missions = paper_missions();
        let mut text = missions[which.index(missions.len())].clone();
        for m in &mutations {
            text = apply(&text, m);
        }
        front_end_holds(&text);
    }
}

#[test]
fn the_unmutated_missions_compile_so_mutations_start_from_valid_input() {
    for text in paper_missions() {
        let file = SourceFile::new("m.go", text.as_str());
        if let Err(d) = compile(&file, &profiles()) {
            panic!("{}", eamos_lang::render_all(&d, &file, Style::PLAIN));
        }
    }
}
