//! Random checked missions for property tests, generated directly as
//! `hir::Mission` values (no parser in the loop).
//!
//! Shape: up to 5 drones and 40 actions; every construct of the language
//! (SEQ/PAR nesting, If with and without Else, Wait, RepeatWhile/Until with
//! and without exit, RepeatFor, PauseWhile/Until/For, DoWhile/Until, Signal
//! and Await), nested. The missions respect what the front end guarantees:
//! no `Signal` inside a loop body, every awaited event is signalled
//! somewhere. The tree is generated with `prop_recursive`, whose shrinking
//! replaces subtrees by leaves and drops statements, so a failing mission
//! shrinks to a few statements.

use eamos_lang::hir::{
    Action, BinaryOp, Block, BlockKind, CondMode, Drone, DroneId, Expr, Mission, Stmt,
};
use eamos_lang::Span;
use proptest::prelude::*;

/// Actions of the built-in quadcopter with the number of arguments each
/// takes.
const ACTIONS: &[(&str, usize)] = &[
    ("Takeoff", 1),
    ("Land", 0),
    ("FlyByX", 1),
    ("FlyByY", 1),
    ("Hover", 1),
    ("TakePhoto", 0),
    ("Arm", 0),
];

pub const MAX_DRONES: u16 = 5;
pub const MAX_ACTIONS: usize = 40;

/// A mission tree before it is made into blocks.
#[derive(Debug, Clone)]
pub enum G {
    Action(u16, usize),
    PauseFor,
    Pause(CondMode, C),
    Signal(u8),
    Await(u8),
    Seq(Vec<G>),
    Par(Vec<G>),
    If(C, Box<G>, Option<Box<G>>),
    Wait(CondMode, C, Box<G>),
    Repeat(CondMode, C, Box<G>, Option<Box<G>>),
    RepeatFor(u32, Box<G>),
    Do(CondMode, C, Box<G>),
}

/// A condition: which drones it reads (none is a constant condition).
#[derive(Debug, Clone)]
pub enum C {
    Const(bool),
    One(u16),
    Two(u16, u16),
}

fn mode() -> impl Strategy<Value = CondMode> {
    prop_oneof![Just(CondMode::While), Just(CondMode::Until)]
}

fn cond(nd: u16) -> impl Strategy<Value = C> {
    prop_oneof![
        4 => (0..nd).prop_map(C::One),
        1 => any::<bool>().prop_map(C::Const),
        1 => (0..nd, 0..nd).prop_map(|(a, b)| C::Two(a, b)),
    ]
}

fn leaf(nd: u16) -> impl Strategy<Value = G> {
    prop_oneof![
        8 => (0..nd, 0..ACTIONS.len()).prop_map(|(d, a)| G::Action(d, a)),
        1 => Just(G::PauseFor),
        1 => (mode(), cond(nd)).prop_map(|(m, c)| G::Pause(m, c)),
        1 => (0..3u8).prop_map(G::Signal),
        1 => (0..3u8).prop_map(G::Await),
    ]
}

/// A mission tree over `nd` drones.
pub fn tree(nd: u16) -> impl Strategy<Value = G> {
    leaf(nd).prop_recursive(5, 64, 3, move |inner| {
        let b = || inner.clone().prop_map(Box::new);
        prop_oneof![
            3 => prop::collection::vec(inner.clone(), 1..5).prop_map(G::Seq),
            3 => prop::collection::vec(inner.clone(), 2..4).prop_map(G::Par),
            1 => (cond(nd), b(), prop::option::of(b())).prop_map(|(c, t, e)| G::If(c, t, e)),
            1 => (mode(), cond(nd), b()).prop_map(|(m, c, t)| G::Wait(m, c, t)),
            1 => (mode(), cond(nd), b(), prop::option::of(b()))
                .prop_map(|(m, c, t, x)| G::Repeat(m, c, t, x)),
            1 => (0..3u32, b()).prop_map(|(n, t)| G::RepeatFor(n, t)),
            1 => (mode(), cond(nd), b()).prop_map(|(m, c, t)| G::Do(m, c, t)),
        ]
    })
}

/// A whole mission: the number of drones first, then the tree.
pub fn mission() -> impl Strategy<Value = Mission> {
    (1..=MAX_DRONES)
        .prop_flat_map(|nd| (Just(nd), prop::collection::vec(tree(nd), 1..8)))
        .prop_map(|(nd, g)| build(nd, &G::Seq(g)))
        .prop_filter("at most 40 actions", |m| actions(&m.root) <= MAX_ACTIONS)
}

pub fn actions(b: &Block) -> usize {
    let mut n = 0;
    b.walk(&mut |s| {
        if matches!(s, Stmt::Action(_)) {
            n += 1
        }
    });
    n
}

fn sp() -> Span {
    Span::default()
}

fn expr(c: &C) -> Expr {
    let x = |d: u16| Expr::Property {
        drone: DroneId(d),
        name: "X".into(),
        args: Vec::new(),
        span: sp(),
    };
    let gt = |l: Expr, v: f64| Expr::Binary {
        op: BinaryOp::Gt,
        lhs: Box::new(l),
        rhs: Box::new(Expr::Number {
            value: v,
            span: sp(),
        }),
        span: sp(),
    };
    match *c {
        C::Const(value) => Expr::Bool { value, span: sp() },
        C::One(d) => gt(x(d), 1.0),
        C::Two(a, b) => Expr::Binary {
            op: BinaryOp::And,
            lhs: Box::new(gt(x(a), 1.0)),
            rhs: Box::new(gt(
                Expr::Property {
                    drone: DroneId(b),
                    name: "DistanceTo".into(),
                    args: vec![DroneId(a)],
                    span: sp(),
                },
                2.0,
            )),
            span: sp(),
        },
    }
}

struct Builder {
    blocks: usize,
    signalled: Vec<u8>,
}

impl Builder {
    fn block(&mut self, g: &G, in_loop: bool) -> Block {
        self.blocks += 1;
        let name = format!("B{}", self.blocks);
        let (kind, items): (BlockKind, Vec<&G>) = match g {
            G::Seq(v) => (BlockKind::Seq, v.iter().collect()),
            G::Par(v) => (BlockKind::Par, v.iter().collect()),
            other => (BlockKind::Seq, vec![other]),
        };
        let stmts = items.into_iter().map(|g| self.stmt(g, in_loop)).collect();
        Block {
            kind,
            name,
            span: sp(),
            stmts,
        }
    }

    fn stmt(&mut self, g: &G, in_loop: bool) -> Stmt {
        match g {
            G::Action(d, a) => {
                let (name, n) = ACTIONS[*a];
                Stmt::Action(Action {
                    drone: DroneId(*d),
                    name: name.into(),
                    args: vec![1.0; n],
                    span: sp(),
                })
            }
            G::PauseFor => Stmt::PauseFor {
                seconds: 1.0,
                span: sp(),
            },
            G::Pause(m, c) => Stmt::Pause {
                mode: *m,
                cond: expr(c),
                span: sp(),
            },
            // The front end refuses a signal inside a loop body: it would
            // fire once per repetition.
            G::Signal(_) if in_loop => Stmt::PauseFor {
                seconds: 1.0,
                span: sp(),
            },
            G::Signal(k) => {
                self.signalled.push(*k);
                Stmt::Signal {
                    event: format!("e{k}"),
                    span: sp(),
                }
            }
            G::Await(k) => Stmt::Await {
                event: format!("e{k}"),
                span: sp(),
            },
            G::Seq(_) | G::Par(_) => Stmt::Block(self.block(g, in_loop)),
            G::If(c, t, e) => Stmt::If {
                cond: expr(c),
                then: self.block(t, in_loop),
                otherwise: e.as_ref().map(|e| self.block(e, in_loop)),
                span: sp(),
            },
            G::Wait(m, c, t) => Stmt::Wait {
                mode: *m,
                cond: expr(c),
                body: self.block(t, in_loop),
                span: sp(),
            },
            G::Repeat(m, c, t, x) => Stmt::Repeat {
                mode: *m,
                cond: expr(c),
                body: self.block(t, true),
                exit: x.as_ref().map(|x| self.block(x, in_loop)),
                span: sp(),
            },
            G::RepeatFor(n, t) => Stmt::RepeatFor {
                count: *n,
                body: self.block(t, true),
                span: sp(),
            },
            G::Do(m, c, t) => Stmt::Do {
                mode: *m,
                cond: expr(c),
                body: self.block(t, in_loop),
                span: sp(),
            },
        }
    }
}

/// Turns awaits of events that nothing signals into pauses, as the front
/// end would refuse them.
fn drop_unsignalled(b: &mut Block, signalled: &[u8]) {
    for s in &mut b.stmts {
        if let Stmt::Await { event, .. } = s {
            let k: u8 = event[1..].parse().expect("generated name");
            if !signalled.contains(&k) {
                *s = Stmt::PauseFor {
                    seconds: 1.0,
                    span: sp(),
                };
            }
        }
        match s {
            Stmt::Block(b) => drop_unsignalled(b, signalled),
            Stmt::If {
                then, otherwise, ..
            } => {
                drop_unsignalled(then, signalled);
                if let Some(o) = otherwise {
                    drop_unsignalled(o, signalled);
                }
            }
            Stmt::Wait { body, .. } | Stmt::RepeatFor { body, .. } | Stmt::Do { body, .. } => {
                drop_unsignalled(body, signalled)
            }
            Stmt::Repeat { body, exit, .. } => {
                drop_unsignalled(body, signalled);
                if let Some(x) = exit {
                    drop_unsignalled(x, signalled);
                }
            }
            _ => {}
        }
    }
}

pub fn build(nd: u16, g: &G) -> Mission {
    let mut b = Builder {
        blocks: 0,
        signalled: Vec::new(),
    };
    let mut root = b.block(g, false);
    root.name = "INIT".into();
    let signalled = b.signalled.clone();
    drop_unsignalled(&mut root, &signalled);
    Mission {
        name: "Random".into(),
        drones: (0..nd)
            .map(|i| Drone {
                name: format!("D{}", i + 1),
                profile: "Quadcopter".into(),
                span: sp(),
            })
            .collect(),
        entry: "INIT".into(),
        root,
    }
}
