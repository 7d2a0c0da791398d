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
    eamos_profile::builtin()
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
        .map(|t| t.label.to_string())
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
        .map(|p| net.place(p).unwrap().label.to_string())
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

/// The five missions of the paper, by file stem.
pub const PAPER: &[&str] = &[
    "listing01_demo",
    "experiment_a",
    "experiment_b",
    "experiment_c",
    "experiment_d",
];

/// A paper mission through the real front end, with its source file.
pub fn paper(stem: &str) -> (eamos_lang::SourceFile, Net) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/missions/paper");
    let path = dir.join(format!("{stem}.go"));
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let file = eamos_lang::SourceFile::new(format!("{stem}.go"), text);
    let compiled = eamos_lang::compile(&file, &profiles()).unwrap_or_else(|d| {
        panic!(
            "{stem} does not compile: {}",
            eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN)
        )
    });
    let net = eamos_petri::compile(&compiled.mission, &profiles());
    (file, net)
}

/// An XML element, read with quick-xml: enough of a tree to check exports.
#[derive(Debug, Default, Clone)]
pub struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub text: String,
    pub children: Vec<Element>,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// Every element below this one (not itself), depth first.
    pub fn descendants(&self) -> Vec<&Element> {
        let mut out = Vec::new();
        for c in &self.children {
            out.push(c);
            out.extend(c.descendants());
        }
        out
    }

    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }

    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }
}

/// Parses a whole XML document; any malformation is a test failure.
pub fn parse_xml(text: &str) -> Element {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(text);
    let mut stack = vec![Element::default()];
    let element = |e: &quick_xml::events::BytesStart| Element {
        name: String::from_utf8(e.local_name().as_ref().to_vec()).unwrap(),
        attrs: e
            .attributes()
            .map(|a| {
                let a = a.expect("well-formed attribute");
                (
                    String::from_utf8(a.key.as_ref().to_vec()).unwrap(),
                    a.unescape_value().expect("attribute value").into_owned(),
                )
            })
            .collect(),
        ..Element::default()
    };
    loop {
        match reader.read_event().expect("well-formed XML") {
            Event::Start(e) => stack.push(element(&e)),
            Event::Empty(e) => {
                let el = element(&e);
                stack.last_mut().unwrap().children.push(el);
            }
            Event::End(_) => {
                let el = stack.pop().unwrap();
                stack.last_mut().expect("balanced tags").children.push(el);
            }
            Event::Text(t) => stack
                .last_mut()
                .unwrap()
                .text
                .push_str(&t.decode().unwrap()),
            Event::GeneralRef(r) => {
                let c = match r.resolve_char_ref().expect("character reference") {
                    Some(c) => c,
                    None => match &*r.decode().unwrap() {
                        "lt" => '<',
                        "gt" => '>',
                        "amp" => '&',
                        "quot" => '"',
                        "apos" => '\'',
                        other => panic!("unknown entity {other}"),
                    },
                };
                stack.last_mut().unwrap().text.push(c);
            }
            Event::Eof => break,
            _ => {}
        }
    }
    assert_eq!(stack.len(), 1, "unclosed elements");
    let mut root = stack.pop().unwrap();
    assert_eq!(root.children.len(), 1, "one root element");
    root.children.pop().unwrap()
}

/// A mission with every kind of node the exports must carry: loops with
/// colours, a region with remote owners, events, a timed pause, and names
/// that need escaping.
pub fn showcase() -> Net {
    use eamos_lang::hir::CondMode;
    let mut m = mission(
        &["D<1>", "D&2"],
        seq(vec![block(par(vec![
            do_(
                CondMode::Until,
                x_above(1, 5.0),
                seq(vec![
                    fly(0, 1.0),
                    signal("go \"now\" <&>\u{1}"),
                    repeat_for(2, seq(vec![fly(0, 2.0)])),
                    pause_for(1.5),
                ]),
            ),
            block(seq(vec![
                await_("go \"now\" <&>\u{1}"),
                repeat(
                    CondMode::While,
                    x_above(1, 0.0),
                    seq(vec![fly(1, 3.0)]),
                    None,
                ),
            ])),
        ]))]),
    );
    m.name = "Show<case> & \"more\"".into();
    eamos_petri::compile(&m, &profiles())
}

/// Stronger than [`assert_sliceable`]: the transitions that consume or read
/// a place all have the same owner, assigned or not, so the slicer never
/// has to pull an unassigned transition onto a drone because of a place.
pub fn assert_consumers_agree(net: &Net) {
    for (p, place) in net.places() {
        let mut owners: Vec<_> = net.consumers(p).map(|(t, _)| net.owner(t)).collect();
        owners.sort();
        owners.dedup();
        assert!(
            owners.len() <= 1,
            "place {:?} has consumers of {owners:?}",
            place.label
        );
        if let [o] = owners[..] {
            if p != net.initial_place {
                assert_eq!(place.owner, o, "place {:?}", place.label);
            }
        }
    }
}
