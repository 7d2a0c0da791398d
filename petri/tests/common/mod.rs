//! A small builder of checked missions for tests, so that the net compiler
//! can be specified construct by construct without the parser, plus helpers
//! to find nodes and read runs.
#![allow(dead_code)]

use std::sync::atomic::{AtomicU32, Ordering};

use eamos_lang::hir::{
    Action, BinaryOp, Block, BlockKind, CondMode, Drone, DroneId, Expr, Mission, Stmt, UnaryOp,
};
use eamos_lang::Span;
use eamos_petri::game::{self, Outcome, Run};
use eamos_petri::net::{Net, NodeId, TransitionKind};
use eamos_profile::ProfileTable;

static NEXT: AtomicU32 = AtomicU32::new(1);

/// A fresh span, so every statement of a test mission can be told apart.
pub fn span() -> Span {
    let s = NEXT.fetch_add(10, Ordering::Relaxed);
    Span::new(s as usize, s as usize + 5)
}

pub fn profiles() -> ProfileTable {
    eamos_mid::profiles::builtin()
}

/// A mission whose drones are Quadcopters named `names`.
pub fn mission(names: &[&str], root: Block) -> Mission {
    Mission {
        name: "Test".into(),
        drones: names
            .iter()
            .map(|n| Drone {
                name: n.to_string(),
                profile: "Quadcopter".into(),
                span: span(),
            })
            .collect(),
        entry: root.name.clone(),
        root,
    }
}

pub fn compile(names: &[&str], root: Block) -> Net {
    eamos_petri::compile(&mission(names, root), &profiles())
}

pub fn seq(stmts: Vec<Stmt>) -> Block {
    Block {
        kind: BlockKind::Seq,
        name: "SEQ_Test".into(),
        span: span(),
        stmts,
    }
}

pub fn par(stmts: Vec<Stmt>) -> Block {
    Block {
        kind: BlockKind::Par,
        name: "PAR_Test".into(),
        span: span(),
        stmts,
    }
}

pub fn block(b: Block) -> Stmt {
    Stmt::Block(b)
}

/// `D<d+1>.<name>(args)`: an action of drone `d`.
pub fn act(d: u16, name: &str, args: &[f64]) -> Stmt {
    Stmt::Action(Action {
        drone: DroneId(d),
        name: name.into(),
        args: args.to_vec(),
        span: span(),
    })
}

/// `FlyByX(x)` of drone `d`: the workhorse action of these tests, told apart
/// by its distance.
pub fn fly(d: u16, x: f64) -> Stmt {
    act(d, "FlyByX", &[x])
}

pub fn num(v: f64) -> Expr {
    Expr::Number {
        value: v,
        span: span(),
    }
}

pub fn prop(d: u16, name: &str) -> Expr {
    Expr::Property {
        drone: DroneId(d),
        name: name.into(),
        args: vec![],
        span: span(),
    }
}

pub fn bin(op: BinaryOp, l: Expr, r: Expr) -> Expr {
    Expr::Binary {
        op,
        lhs: Box::new(l),
        rhs: Box::new(r),
        span: span(),
    }
}

pub fn gt(l: Expr, r: Expr) -> Expr {
    bin(BinaryOp::Gt, l, r)
}

pub fn not(e: Expr) -> Expr {
    Expr::Unary {
        op: UnaryOp::Not,
        operand: Box::new(e),
        span: span(),
    }
}

/// `D<d+1>.X() > v`.
pub fn x_above(d: u16, v: f64) -> Expr {
    gt(prop(d, "X"), num(v))
}

pub fn if_(cond: Expr, then: Block, otherwise: Option<Block>) -> Stmt {
    Stmt::If {
        cond,
        then,
        otherwise,
        span: span(),
    }
}

pub fn repeat(mode: CondMode, cond: Expr, body: Block, exit: Option<Block>) -> Stmt {
    Stmt::Repeat {
        mode,
        cond,
        body,
        exit,
        span: span(),
    }
}

pub fn repeat_for(count: u32, body: Block) -> Stmt {
    Stmt::RepeatFor {
        count,
        body,
        span: span(),
    }
}

pub fn wait(mode: CondMode, cond: Expr, body: Block) -> Stmt {
    Stmt::Wait {
        mode,
        cond,
        body,
        span: span(),
    }
}

pub fn pause(mode: CondMode, cond: Expr) -> Stmt {
    Stmt::Pause {
        mode,
        cond,
        span: span(),
    }
}

pub fn pause_for(seconds: f64) -> Stmt {
    Stmt::PauseFor {
        seconds,
        span: span(),
    }
}

pub fn do_(mode: CondMode, cond: Expr, body: Block) -> Stmt {
    Stmt::Do {
        mode,
        cond,
        body,
        span: span(),
    }
}

pub fn signal(event: &str) -> Stmt {
    Stmt::Signal {
        event: event.into(),
        span: span(),
    }
}

pub fn await_(event: &str) -> Stmt {
    Stmt::Await {
        event: event.into(),
        span: span(),
    }
}

/// The one transition with this label.
pub fn transition(net: &Net, label: &str) -> NodeId {
    let found: Vec<NodeId> = net
        .transitions()
        .filter(|(_, t)| t.label == label)
        .map(|(n, _)| n)
        .collect();
    assert_eq!(found.len(), 1, "transitions labelled {label:?}: {found:?}");
    found[0]
}

/// Every transition with this label.
pub fn transitions(net: &Net, label: &str) -> Vec<NodeId> {
    net.transitions()
        .filter(|(_, t)| t.label == label)
        .map(|(n, _)| n)
        .collect()
}

/// The labels of the action starts of a run, in firing order.
pub fn started(net: &Net, run: &Run) -> Vec<String> {
    run.transitions()
        .filter_map(|t| net.transition(t))
        .filter(|t| matches!(t.kind, TransitionKind::ActionStart(_)))
        .map(|t| t.label.clone())
        .collect()
}

/// How often transitions of a kind fired in a run.
pub fn count(net: &Net, run: &Run, pred: impl Fn(&TransitionKind) -> bool) -> usize {
    run.transitions()
        .filter_map(|t| net.transition(t))
        .filter(|t| pred(&t.kind))
        .count()
}

/// A random run with a random world; it must end properly.
pub fn run_to_final(net: &Net, seed: u64) -> Run {
    let run = game::run_random(net, seed, game::oracle::random(seed ^ 0x5eed, 0.5), 100_000);
    assert_eq!(
        run.outcome,
        Outcome::Final,
        "seed {seed}: run ended {:?} in {:?} after {:?}",
        run.outcome,
        marked_labels(net, &run),
        run.ids(net)
    );
    run
}

pub fn marked_labels(net: &Net, run: &Run) -> Vec<String> {
    run.marking
        .places()
        .map(|p| net.place(p).unwrap().label.clone())
        .collect()
}

/// Every place and its consumers can live on one drone.
pub fn assert_sliceable(net: &Net) {
    let v = net.ownership_violations();
    assert!(
        v.is_empty(),
        "places pulled onto several owners: {:?}",
        v.iter()
            .map(|x| (net.place(x.place).unwrap().label.clone(), x.owners.clone()))
            .collect::<Vec<_>>()
    );
}
