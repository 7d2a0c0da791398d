//! Random missions for property tests, written as mission text and compiled
//! by the front end, so every test mission is one a user could write and a
//! failing case prints as a file to paste into `eamos check`.
//!
//! Shape: up to 5 drones; every construct of the language (SEQ/PAR nesting,
//! If with and without Else, Wait, RepeatWhile/Until with and without exit,
//! RepeatFor, PauseWhile/Until/For, DoWhile/Until, Signal and Await), nested;
//! `Await` inside loops too (the language refuses a `Signal` inside a loop
//! body, since an event happens once, so the generator writes a pause there
//! instead); blocks called from several places (shared bodies without
//! parameters, and library blocks with a drone and a number as parameters),
//! each call its own instance; arguments from a spread of values per action;
//! conditions over every property of the quadcopter profile (`X`, `Y`, `Z`,
//! `Battery`, `IsArmed`, `DistanceTo`), with arithmetic, `!`, `&&`, `||` and
//! constants. The tree is generated with `prop_recursive`, whose shrinking
//! replaces subtrees by leaves and drops statements, so a failing mission
//! shrinks to a few statements.

use eamos_lang::hir::{Block, Mission, Stmt};
use eamos_lang::SourceFile;
use eamos_slicer::equivalence::explore;
use proptest::prelude::*;

use super::write::{write, ACTIONS, COMPARE, NUMBERS, NUMERIC, SECONDS};

pub const MAX_DRONES: u16 = 5;
pub const MAX_ACTIONS: usize = 40;

/// A mission tree before it is written out.
#[derive(Debug, Clone)]
pub enum G {
    Action(u16, usize, usize),
    PauseFor(usize),
    Pause(bool, C),
    Signal(u8),
    Await(u8),
    /// A call of shared body `i` (no parameters).
    Shared(usize),
    /// A call of library block `l` with a drone and a number.
    Library(usize, u16, usize),
    Seq(Vec<G>),
    Par(Vec<G>),
    If(C, Box<G>, Option<Box<G>>),
    Wait(bool, C, Box<G>),
    Repeat(bool, C, Box<G>, Option<Box<G>>),
    RepeatFor(u32, Box<G>),
    Do(bool, C, Box<G>),
}

/// A condition.
#[derive(Debug, Clone)]
pub enum C {
    Const(bool),
    /// `D.P() op n` over a numeric property.
    Compare(u16, usize, usize, usize),
    Armed(u16),
    /// `A.DistanceTo(B) op n`.
    Distance(u16, u16, usize, usize),
    /// `A.P() + B.Q() op n`.
    Sum(u16, usize, u16, usize, usize, usize),
    Not(Box<C>),
    And(Box<C>, Box<C>),
    Or(Box<C>, Box<C>),
}

/// A statement of a library block: `d` and `k` are its parameters.
#[derive(Debug, Clone)]
pub enum L {
    Fly,
    Hover,
    Photo,
    Pause,
    PauseUntilHigh,
    PauseWhileLow,
}

/// The generated mission: the tree, the bodies shared by several calls and
/// the library blocks.
#[derive(Debug, Clone)]
pub struct Spec {
    pub drones: u16,
    pub root: Vec<G>,
    pub shared: Vec<G>,
    pub library: Vec<(bool, Vec<L>)>,
}

/// A generated mission: its text and what the front end made of it.
#[derive(Clone)]
pub struct Case {
    pub source: String,
    pub mission: Result<Mission, String>,
}

impl std::fmt::Debug for Case {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "\n{}", self.source)
    }
}

fn simple(nd: u16) -> impl Strategy<Value = C> {
    let d = move || 0..nd;
    prop_oneof![
        1 => any::<bool>().prop_map(C::Const),
        4 => (d(), 0..NUMERIC.len(), 0..COMPARE.len(), 0..NUMBERS.len())
            .prop_map(|(d, p, o, n)| C::Compare(d, p, o, n)),
        1 => d().prop_map(C::Armed),
        2 => (d(), 1..MAX_DRONES, 0..COMPARE.len(), 0..NUMBERS.len())
            .prop_map(move |(a, k, o, n)| C::Distance(a, (a + k) % nd, o, n)),
        1 => (d(), 0..NUMERIC.len(), d(), 0..NUMERIC.len(), 0..COMPARE.len(), 0..NUMBERS.len())
            .prop_map(|(a, p, b, q, o, n)| C::Sum(a, p, b, q, o, n)),
    ]
}

fn cond(nd: u16) -> impl Strategy<Value = C> {
    prop_oneof![
        6 => simple(nd),
        1 => simple(nd).prop_map(|c| C::Not(Box::new(c))),
        1 => (simple(nd), simple(nd)).prop_map(|(a, b)| C::And(Box::new(a), Box::new(b))),
        1 => (simple(nd), simple(nd)).prop_map(|(a, b)| C::Or(Box::new(a), Box::new(b))),
    ]
}

fn leaf(nd: u16) -> impl Strategy<Value = G> {
    let action = (0..nd, 0..ACTIONS.len(), 0..3usize)
        .prop_map(|(d, a, v)| G::Action(d, a, v % ACTIONS[a].1.len()));
    prop_oneof![
        12 => action,
        1 => (0..SECONDS.len()).prop_map(G::PauseFor),
        1 => (any::<bool>(), cond(nd)).prop_map(|(m, c)| G::Pause(m, c)),
        2 => (0..3u8).prop_map(G::Signal),
        2 => (0..3u8).prop_map(G::Await),
        2 => (0..2usize).prop_map(G::Shared),
        2 => (0..2usize, 0..nd, 0..SECONDS.len()).prop_map(|(l, d, k)| G::Library(l, d, k)),
    ]
}

/// A mission tree over `nd` drones, `depth` levels deep at most.
pub fn tree(nd: u16, depth: u32) -> impl Strategy<Value = G> {
    leaf(nd).prop_recursive(depth, 48, 3, move |inner| {
        let b = || inner.clone().prop_map(Box::new);
        prop_oneof![
            3 => prop::collection::vec(inner.clone(), 1..5).prop_map(G::Seq),
            3 => prop::collection::vec(inner.clone(), 2..4).prop_map(G::Par),
            1 => (cond(nd), b(), prop::option::of(b())).prop_map(|(c, t, e)| G::If(c, t, e)),
            1 => (any::<bool>(), cond(nd), b()).prop_map(|(m, c, t)| G::Wait(m, c, t)),
            1 => (any::<bool>(), cond(nd), b(), prop::option::of(b()))
                .prop_map(|(m, c, t, x)| G::Repeat(m, c, t, x)),
            1 => (0..3u32, b()).prop_map(|(n, t)| G::RepeatFor(n, t)),
            1 => (any::<bool>(), cond(nd), b()).prop_map(|(m, c, t)| G::Do(m, c, t)),
        ]
    })
}

fn library() -> impl Strategy<Value = (bool, Vec<L>)> {
    let stmt = prop_oneof![
        Just(L::Fly),
        Just(L::Hover),
        Just(L::Photo),
        Just(L::Pause),
        Just(L::PauseUntilHigh),
        Just(L::PauseWhileLow),
    ];
    (any::<bool>(), prop::collection::vec(stmt, 1..4))
}

/// How large the generated missions get.
#[derive(Debug, Clone, Copy)]
pub struct Size {
    pub drones: u16,
    /// Statements of the entry function.
    pub statements: usize,
    /// Nesting of control structures and blocks.
    pub depth: u32,
    /// Action instances once every call is expanded.
    pub actions: usize,
    /// Reachable markings of the mission net (as the equivalence checker
    /// walks them). Independent actions interleave, so a few wide `PAR`s
    /// can make a small mission's state space huge; a mission above this is
    /// not generated, which keeps every comparison within its budget.
    pub markings: usize,
}

/// The missions of the equivalence and mutation tests.
pub const FULL: Size = Size {
    drones: MAX_DRONES,
    statements: 8,
    depth: 5,
    actions: MAX_ACTIONS,
    markings: 3_000,
};

/// Missions small enough for the plain search, without reductions, of
/// their composed slices.
pub const SMALL: Size = Size {
    drones: 3,
    statements: 4,
    depth: 3,
    actions: 10,
    markings: 300,
};

/// The mission's parts, not yet written.
pub fn spec(size: Size) -> impl Strategy<Value = Spec> {
    (1..=size.drones)
        .prop_flat_map(move |nd| {
            (
                Just(nd),
                prop::collection::vec(tree(nd, size.depth), 1..size.statements),
                prop::collection::vec(
                    leaf(nd).prop_recursive(2, 6, 3, |inner| {
                        prop::collection::vec(inner, 1..4).prop_map(G::Seq)
                    }),
                    0..3,
                ),
                prop::collection::vec(library(), 0..3),
            )
        })
        .prop_map(|(drones, root, shared, library)| Spec {
            drones,
            root,
            shared,
            library,
        })
}

/// A whole mission, written and compiled, of at most `size`.
pub fn mission_of(size: Size) -> impl Strategy<Value = Case> {
    spec(size)
        .prop_map(|s| compile(&write(&s)))
        .prop_filter("beyond the size", move |c| {
            let Ok(m) = &c.mission else {
                return true;
            };
            let net = || eamos_petri::compile(m, &super::profiles());
            actions(&m.root) <= size.actions && explore(&net(), size.markings).is_some()
        })
}

/// A mission of the full size without conditions or loops: what the lower
/// bound of bridges is defined for.
pub fn plain_mission() -> impl Strategy<Value = Case> {
    spec(FULL)
        .prop_map(|mut s| {
            s.root = s.root.into_iter().map(plain).collect();
            s.shared = s.shared.into_iter().map(plain).collect();
            for (_, stmts) in &mut s.library {
                stmts.retain(|l| !matches!(l, L::PauseUntilHigh | L::PauseWhileLow));
                stmts.push(L::Photo);
            }
            compile(&write(&s))
        })
        .prop_filter("too many action instances", |c| {
            c.mission
                .as_ref()
                .map_or(true, |m| actions(&m.root) <= MAX_ACTIONS)
        })
}

/// `g` with every condition and loop replaced by what it runs.
fn plain(g: G) -> G {
    let b = |g: Box<G>| plain(*g);
    match g {
        G::Pause(..) => G::PauseFor(0),
        G::Seq(v) => G::Seq(v.into_iter().map(plain).collect()),
        G::Par(v) => G::Par(v.into_iter().map(plain).collect()),
        G::If(_, t, e) | G::Repeat(_, _, t, e) => {
            G::Seq(std::iter::once(b(t)).chain(e.map(b)).collect())
        }
        G::Wait(_, _, t) | G::RepeatFor(_, t) | G::Do(_, _, t) => b(t),
        other => other,
    }
}

/// A mission of the full size.
pub fn mission() -> impl Strategy<Value = Case> {
    mission_of(FULL)
}

/// A mission of the small size.
pub fn small_mission() -> impl Strategy<Value = Case> {
    mission_of(SMALL)
}

/// The front end's verdict on a mission text.
pub fn compile(source: &str) -> Case {
    let file = SourceFile::new("random.go", source.to_string());
    let mission = eamos_lang::compile(&file, &super::profiles())
        .map(|c| c.mission)
        .map_err(|ds| {
            ds.iter()
                .map(|d| format!("{} at {}: {}", d.code, d.span.start, d.message))
                .collect::<Vec<_>>()
                .join("; ")
        });
    Case {
        source: source.to_string(),
        mission,
    }
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
