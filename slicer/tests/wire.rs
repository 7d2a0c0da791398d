//! The slice file format: every mission of the repository survives both
//! forms unchanged, and a file of another version or with a condition that
//! is not one tree is refused with a message, never a panic.

mod common;

use std::path::PathBuf;

use eamos_lang::SourceFile;
use eamos_slicer::wire::{v3, MAX_CONDITION_DEPTH};
use eamos_slicer::{slice, DecodeError, Slice, FORMAT_VERSION, MAGIC};
use sha3::{Digest, Sha3_256};

/// The missions of the paper, the examples and the language's catalogue
/// that compile, sliced.
fn every_mission() -> Vec<(String, eamos_slicer::Slices)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut out: Vec<_> = common::PAPER
        .iter()
        .map(|name| {
            let net = common::paper_net(name);
            (
                name.to_string(),
                slice(&net).expect("a paper mission slices"),
            )
        })
        .collect();
    for dir in ["examples", "lang/tests/catalogue"] {
        let mut files: Vec<_> = std::fs::read_dir(root.join(dir))
            .expect("the directory is there")
            .map(|e| e.expect("an entry").path())
            .filter(|p| p.extension().is_some_and(|x| x == "go"))
            .collect();
        files.sort();
        for path in files {
            let text = std::fs::read_to_string(&path).expect("a readable mission");
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            let file = SourceFile::new(name.clone(), text);
            let Ok(compiled) = eamos_lang::compile(&file, &common::profiles()) else {
                continue;
            };
            let net = eamos_petri::compile(&compiled.mission, &common::profiles());
            out.push((name, slice(&net).expect("a checked mission slices")));
        }
    }
    out
}

#[test]
fn every_mission_of_the_repository_round_trips_through_both_forms() {
    let missions = every_mission();
    assert!(missions.len() > common::PAPER.len() + 2, "examples compile");
    let mut guarded = 0;
    for (name, slices) in &missions {
        for s in &slices.slices {
            assert_eq!(
                &Slice::from_json(&s.to_json()).unwrap(),
                s,
                "{name} {}",
                s.drone
            );
            assert_eq!(
                &Slice::from_bytes(&s.to_bytes()).unwrap(),
                s,
                "{name} {}",
                s.drone
            );
            guarded += s
                .transitions
                .iter()
                .filter(|t| t.transition.guard.is_some())
                .count();
        }
    }
    assert!(guarded > 0, "some missions have conditions");
}

fn experiment_d_with_a_condition() -> (Slice, usize) {
    let s = slice(common::paper_net("experiment_d")).unwrap();
    s.slices
        .iter()
        .find_map(|s| {
            let t = s.transitions.iter().position(|t| {
                t.transition
                    .guard
                    .as_ref()
                    .is_some_and(|g| g.condition().is_some())
            })?;
            Some((s.clone(), t))
        })
        .expect("experiment D waits on a condition")
}

/// The JSON form around a wire slice, as `Slice::to_json` writes it.
fn json_of(wire: &v3::Slice, version: u16) -> String {
    serde_json::json!({"format": "eamos-slice", "version": version, "slice": wire}).to_string()
}

/// The binary form around a wire slice, as `Slice::to_bytes` writes it.
fn binary_of(wire: &v3::Slice, version: u16) -> Vec<u8> {
    let payload = postcard::to_allocvec(wire).unwrap();
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(&payload);
    out.extend_from_slice(&Sha3_256::digest(&payload));
    out
}

#[test]
fn a_slice_file_of_another_version_is_refused_by_number() {
    let (s, _) = experiment_d_with_a_condition();
    let wire = v3::Slice::from(&s);
    assert!(Slice::from_json(&json_of(&wire, FORMAT_VERSION)).is_ok());
    assert!(Slice::from_bytes(&binary_of(&wire, FORMAT_VERSION)).is_ok());
    for old in [1, 2, FORMAT_VERSION + 1] {
        for e in [
            Slice::from_json(&json_of(&wire, old)).unwrap_err(),
            Slice::from_bytes(&binary_of(&wire, old)).unwrap_err(),
        ] {
            assert!(
                matches!(e, DecodeError::Version { found, expected: FORMAT_VERSION } if found == old),
                "{e}"
            );
            let message = e.to_string();
            assert!(
                message.contains(&format!("version {old}")) && message.contains("rebuild"),
                "{message}"
            );
        }
    }
}

/// The condition of transition `t` of `s`, in the file's postfix form.
fn condition(wire: &mut v3::Slice, t: usize) -> &mut Vec<v3::Term> {
    match wire.transitions[t].guard.as_mut() {
        Some(v3::Guard::Cond { cond, .. }) => &mut cond.nodes,
        other => panic!("not a condition: {other:?}"),
    }
}

/// Breaks a condition's postfix nodes.
type Damage = fn(&mut Vec<v3::Term>, v3::Span);

#[test]
fn a_condition_that_is_not_one_tree_is_refused_naming_its_transition() {
    let (s, t) = experiment_d_with_a_condition();
    let id = s.transitions[t].transition.id.clone();
    let span = v3::Span { start: 0, end: 0 };
    let damages: [(&str, Damage); 4] = [
        ("is empty", |c, _| c.clear()),
        ("leaves 2 values", |c, span| {
            c.push(v3::Term::Bool { value: true, span })
        }),
        ("applies a two-operand operator", |c, span| {
            c.insert(
                0,
                v3::Term::Binary {
                    op: v3::BinaryOp::And,
                    span,
                },
            )
        }),
        ("applies an operator to nothing", |c, span| {
            c.insert(
                0,
                v3::Term::Unary {
                    op: v3::UnaryOp::Not,
                    span,
                },
            )
        }),
    ];
    for (why, damage) in damages {
        let mut wire = v3::Slice::from(&s);
        damage(condition(&mut wire, t), span);
        for e in [
            Slice::from_json(&json_of(&wire, FORMAT_VERSION)).unwrap_err(),
            Slice::from_bytes(&binary_of(&wire, FORMAT_VERSION)).unwrap_err(),
        ] {
            assert!(matches!(e, DecodeError::Inconsistent(_)), "{e}");
            let message = e.to_string();
            assert!(
                message.contains(why) && message.contains(&format!("`{id}`")),
                "{why}: {message}"
            );
        }
    }
}

/// A hundred thousand nested negations are a few hundred kilobytes of
/// file: reading them must not recurse, and the tree must not be built.
#[test]
fn a_condition_nested_beyond_the_bound_is_refused_without_recursion() {
    let (s, t) = experiment_d_with_a_condition();
    let span = v3::Span { start: 0, end: 0 };
    let not = v3::Term::Unary {
        op: v3::UnaryOp::Not,
        span,
    };
    let mut at_bound = v3::Slice::from(&s);
    let c = condition(&mut at_bound, t);
    let depth = {
        let back = Slice::try_from(v3::Slice::from(&s)).unwrap();
        fn depth(e: &eamos_lang::hir::Expr) -> usize {
            use eamos_lang::hir::Expr;
            match e {
                Expr::Unary { operand, .. } => 1 + depth(operand),
                Expr::Binary { lhs, rhs, .. } => 1 + depth(lhs).max(depth(rhs)),
                _ => 1,
            }
        }
        depth(
            back.transitions[t]
                .transition
                .guard
                .as_ref()
                .unwrap()
                .condition()
                .unwrap()
                .0,
        )
    };
    c.extend(std::iter::repeat_n(
        not.clone(),
        MAX_CONDITION_DEPTH - depth,
    ));
    assert!(Slice::from_bytes(&binary_of(&at_bound, FORMAT_VERSION)).is_ok());

    let mut deep = v3::Slice::from(&s);
    condition(&mut deep, t).extend(std::iter::repeat_n(not, 100_000));
    let e = Slice::from_bytes(&binary_of(&deep, FORMAT_VERSION)).unwrap_err();
    assert!(e.to_string().contains("nests deeper than"), "{e}");
}
