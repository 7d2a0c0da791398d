//! Hand-built mission nets for the checker's tests: a tiny builder over the
//! `Net` API with spans that point into a mission text, so findings can be
//! checked against the lines they name.

#![allow(dead_code)]

use eamos_lang::hir::{BinaryOp, DroneId, Expr};
use eamos_lang::Span;
use eamos_petri::net::{
    ActionRef, ColourOp, Guard, Name, Net, NodeId, Owner, Place, PlaceKind, Transition,
    TransitionKind,
};

pub struct Builder {
    pub net: Net,
    pub src: String,
    instance: u32,
}

/// The span of the `nth` occurrence (0-based) of `needle` in `src`.
pub fn span_of(src: &str, needle: &str, nth: usize) -> Span {
    let start = src
        .match_indices(needle)
        .nth(nth)
        .unwrap_or_else(|| panic!("`{needle}` #{nth} is not in the source"))
        .0;
    Span::new(start, start + needle.len())
}

impl Builder {
    pub fn new(name: &str, drones: &[&str], src: &str) -> Self {
        Builder {
            net: Net::new(
                name,
                drones.iter().map(|d| d.to_string()).collect(),
                drones.iter().map(|_| "Quadcopter".to_string()).collect(),
            ),
            src: src.to_string(),
            instance: 0,
        }
    }

    pub fn span(&self, needle: &str, nth: usize) -> Span {
        span_of(&self.src, needle, nth)
    }

    pub fn place(&mut self, label: &str) -> NodeId {
        self.place_of(label, PlaceKind::Control, None)
    }

    pub fn place_of(&mut self, label: &str, kind: PlaceKind, span: Option<Span>) -> NodeId {
        self.net.add_place(Place {
            id: Name::default(),
            label: label.into(),
            kind,
            owner: Owner::Unassigned,
            span,
            depth: 0,
        })
    }

    /// A transition of `kind` consuming `pre`, producing `post`.
    pub fn trans(
        &mut self,
        kind: TransitionKind,
        span: Span,
        pre: &[NodeId],
        post: &[NodeId],
    ) -> NodeId {
        self.guarded(kind, span, None, pre, post)
    }

    pub fn guarded(
        &mut self,
        kind: TransitionKind,
        span: Span,
        guard: Option<Guard>,
        pre: &[NodeId],
        post: &[NodeId],
    ) -> NodeId {
        let t = self.net.add_transition(Transition {
            id: Name::default(),
            label: Name::default(),
            kind,
            owner: Owner::Unassigned,
            span,
            guard: guard.map(Box::new),
            delay: None,
        });
        for &p in pre {
            self.net.arc(p, t, ColourOp::Keep);
        }
        for &p in post {
            self.net.arc(t, p, ColourOp::Keep);
        }
        t
    }

    /// `Init`: the initial place to a fresh control place.
    pub fn init(&mut self) -> NodeId {
        let p = self.place("begin");
        let init = self.net.initial_place;
        self.trans(TransitionKind::Init, Span::default(), &[init], &[p]);
        p
    }

    /// `Finish`: from `p` to the final place.
    pub fn finish(&mut self, p: NodeId) {
        let f = self.net.final_place;
        self.trans(TransitionKind::Finish, Span::default(), &[p], &[f]);
    }

    /// A drone action between `from` and a new place, returned. `needle`
    /// locates the action's text (`D1.Arm()`), `nth` its occurrence.
    pub fn action(
        &mut self,
        from: NodeId,
        drone: u16,
        name: &str,
        args: &[f64],
        needle: &str,
        nth: usize,
    ) -> NodeId {
        let span = self.span(needle, nth);
        self.action_at(from, drone, name, args, span)
    }

    /// [`Builder::action`] with the span given.
    pub fn action_at(
        &mut self,
        from: NodeId,
        drone: u16,
        name: &str,
        args: &[f64],
        span: Span,
    ) -> NodeId {
        let needle = self
            .src
            .get(span.start as usize..span.end as usize)
            .unwrap_or(name)
            .to_string();
        let needle = needle.as_str();
        self.instance += 1;
        let a = ActionRef {
            drone: DroneId(drone),
            name: name.into(),
            args: args.to_vec(),
            instance: self.instance,
        };
        let running = self.place_of(
            &format!("running {needle}"),
            PlaceKind::Running(a.clone().into()),
            Some(span),
        );
        let after = self.place(&format!("after {needle}"));
        self.trans(
            TransitionKind::ActionStart(a.clone().into()),
            span,
            &[from],
            &[running],
        );
        self.trans(
            TransitionKind::ActionEnd(a.into()),
            span,
            &[running],
            &[after],
        );
        after
    }

    /// A fork into `n` branches.
    pub fn fork(&mut self, from: NodeId, n: usize, span: Span) -> Vec<NodeId> {
        let outs: Vec<NodeId> = (0..n).map(|i| self.place(&format!("branch {i}"))).collect();
        self.trans(TransitionKind::Fork, span, &[from], &outs);
        outs
    }

    pub fn join(&mut self, ins: &[NodeId], span: Span) -> NodeId {
        let out = self.place("joined");
        self.trans(TransitionKind::Join, span, ins, &[out]);
        out
    }

    /// An event's places: pending (marked at the start) and signalled.
    pub fn event(&mut self, name: &str) -> (NodeId, NodeId) {
        let pending = self.place_of(
            &format!("{name} pending"),
            PlaceKind::EventPending(name.into()),
            None,
        );
        let done = self.place_of(
            &format!("{name} signalled"),
            PlaceKind::Event(name.into()),
            None,
        );
        self.net.initial_marking.push(pending);
        (pending, done)
    }

    /// `Signal(name)` between `from` and a new place.
    pub fn signal(
        &mut self,
        from: NodeId,
        ev: (NodeId, NodeId),
        needle: &str,
        nth: usize,
    ) -> NodeId {
        let span = self.span(needle, nth);
        self.signal_at(from, ev, span)
    }

    pub fn signal_at(&mut self, from: NodeId, ev: (NodeId, NodeId), span: Span) -> NodeId {
        let after = self.place("after signal");
        self.trans(TransitionKind::Signal, span, &[from, ev.0], &[after, ev.1]);
        after
    }

    /// `Await(name)` between `from` and a new place: reads the event.
    pub fn await_(
        &mut self,
        from: NodeId,
        ev: (NodeId, NodeId),
        needle: &str,
        nth: usize,
    ) -> NodeId {
        let span = self.span(needle, nth);
        self.await_at(from, ev, span)
    }

    pub fn await_at(&mut self, from: NodeId, ev: (NodeId, NodeId), span: Span) -> NodeId {
        let after = self.place("after await");
        let t = self.trans(TransitionKind::Await, span, &[from], &[after]);
        self.net.read_arc(ev.1, t);
        after
    }

    /// A condition `drone.Prop() op value`, located by `needle` (the whole
    /// condition text) in the source.
    pub fn cond(&self, drone: u16, prop: &str, op: BinaryOp, value: f64, needle: &str) -> Expr {
        let span = self.span(needle, 0);
        Expr::Binary {
            op,
            lhs: Box::new(Expr::Property {
                drone: DroneId(drone),
                name: prop.into(),
                args: vec![],
                span,
            }),
            rhs: Box::new(Expr::Number { value, span }),
            span,
        }
    }

    /// An `If(cond, Then[, Else])`: returns (then entry, else entry).
    pub fn branch(&mut self, from: NodeId, cond: Expr, needle: &str) -> (NodeId, NodeId) {
        let span = self.span(needle, 0);
        let then = self.place("then");
        let other = self.place("else");
        self.guarded(
            TransitionKind::Branch,
            span,
            Some(Guard::cond(cond.clone(), false)),
            &[from],
            &[then],
        );
        self.guarded(
            TransitionKind::Branch,
            span,
            Some(Guard::cond(cond, true)),
            &[from],
            &[other],
        );
        (then, other)
    }

    pub fn merge(&mut self, ins: &[NodeId], span: Span) -> NodeId {
        let out = self.place("merged");
        for &i in ins {
            self.trans(TransitionKind::Merge, span, &[i], &[out]);
        }
        out
    }
}

/// Replays a counterexample on the net with plain P/T semantics (every
/// guard answered as the step says, which the P/T view does not need) and
/// returns the place ids marked at the end, each with its count. Panics if
/// a step is not enabled: the checker then reported an impossible run.
pub fn replay(net: &Net, steps: &[eamos_verify::Step]) -> Vec<(String, u32)> {
    use eamos_petri::net::{ArcKind, Node};
    use petgraph::visit::EdgeRef;
    let mut m = vec![0u32; net.graph.node_count()];
    for &p in &net.initial_marking {
        m[p.index()] += 1;
    }
    for (i, s) in steps.iter().enumerate() {
        let t = net
            .find(&s.transition)
            .unwrap_or_else(|| panic!("step {i}: no transition {}", s.transition));
        for e in net.graph.edges_directed(t, petgraph::Direction::Incoming) {
            let have = m[e.source().index()];
            assert!(
                have >= e.weight().weight,
                "step {i} ({}) is not enabled: place {:?} is empty",
                s.text,
                net.place(e.source()).map(|p| &p.id)
            );
            if e.weight().kind == ArcKind::Consume {
                m[e.source().index()] -= e.weight().weight;
            }
        }
        for e in net.graph.edges_directed(t, petgraph::Direction::Outgoing) {
            m[e.target().index()] += e.weight().weight;
        }
    }
    let mut out: Vec<(String, u32)> = net
        .graph
        .node_indices()
        .filter_map(|n| match &net.graph[n] {
            Node::Place(p) if m[n.index()] > 0 => Some((p.id.to_string(), m[n.index()])),
            _ => None,
        })
        .collect();
    out.sort();
    out
}

/// The marking a trace claims, sorted like [`replay`]'s.
pub fn claimed(trace: &eamos_verify::Trace) -> Vec<(String, u32)> {
    let mut v = trace.marking.clone();
    v.sort();
    v
}

/// Whether nothing can fire in `marking` (as [`replay`] returns it) on the
/// net's P/T skeleton, every guard taken as possibly holding: what a
/// deadlock's marking must be, besides not final.
pub fn is_dead(net: &Net, marking: &[(String, u32)]) -> bool {
    use eamos_petri::net::Node;
    use petgraph::visit::EdgeRef;
    let tokens = |p: petgraph::graph::NodeIndex| {
        let Node::Place(place) = &net.graph[p] else {
            return 0;
        };
        marking
            .iter()
            .find(|(id, _)| *id == place.id)
            .map_or(0, |(_, n)| *n)
    };
    net.graph.node_indices().all(|t| {
        !matches!(net.graph[t], Node::Transition(_))
            || net
                .graph
                .edges_directed(t, petgraph::Direction::Incoming)
                .any(|e| tokens(e.source()) < e.weight().weight)
    })
}

/// A mission file compiled by the real front end and net compiler with the
/// built-in profiles; a mission that does not compile fails the test with
/// its diagnostics.
pub fn compile_file(path: &std::path::Path) -> (Net, eamos_lang::SourceFile) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let file = eamos_lang::SourceFile::new(name, text);
    let profiles = eamos_profile::builtin();
    let compiled = eamos_lang::compile(&file, &profiles).unwrap_or_else(|d| {
        panic!(
            "{}",
            eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN)
        )
    });
    (eamos_petri::compile(&compiled.mission, &profiles), file)
}
