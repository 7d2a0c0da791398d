//! The one place where the compiler's types meet the slice file's: a
//! [`Slice`] to [`v3::Slice`] and back. Encoding cannot fail; decoding can,
//! only on a condition whose postfix nodes do not make one tree (the other
//! checks are [`Slice::validate`]'s, which decoding runs next).

use eamos_lang::hir::{BinaryOp, DroneId, Expr, UnaryOp};
use eamos_lang::Span;
use eamos_petri::net::{
    ActionRef, ColourOp, Guard, GuardKind, Owner, Place, PlaceKind, SharedAction, Transition,
    TransitionKind,
};

use super::v3;
use crate::error::DecodeError;
use crate::slice::{BridgeIn, BridgeOut, Produce, Slice, SliceTransition};

/// Conditions nest at most this deep. The front end never folds a condition
/// a person wrote anywhere near it; the bound keeps every reader that walks
/// the tree (validation, evaluation, dropping it) off the end of its stack
/// when the file is damaged.
pub const MAX_CONDITION_DEPTH: usize = 256;

impl From<&Slice> for v3::Slice {
    fn from(s: &Slice) -> Self {
        v3::Slice {
            mission: s.mission.clone(),
            mission_id: s.mission_id.clone(),
            drone: s.drone.clone(),
            profile: s.profile.clone(),
            drones: s.drones.to_vec(),
            places: s.places.iter().map(place_out).collect(),
            transitions: s.transitions.iter().map(transition_out).collect(),
            initial_marking: s.initial_marking.clone(),
            final_place: s.final_place,
            ends: s.ends.to_vec(),
            bridges_in: s
                .bridges_in
                .iter()
                .map(|b| v3::BridgeIn {
                    id: b.id,
                    from: b.from.clone(),
                    inbox: b.inbox,
                })
                .collect(),
            bridges_out: s
                .bridges_out
                .iter()
                .map(|b| v3::BridgeOut {
                    id: b.id,
                    transition: b.transition,
                    to: b.to.clone(),
                    colour: colour_out(b.colour),
                })
                .collect(),
            peers: s.peers.clone(),
            telemetry: s.telemetry.clone(),
        }
    }
}

impl TryFrom<v3::Slice> for Slice {
    type Error = DecodeError;

    fn try_from(s: v3::Slice) -> Result<Self, DecodeError> {
        Ok(Slice {
            mission: s.mission,
            mission_id: s.mission_id,
            drone: s.drone,
            profile: s.profile,
            drones: s.drones.into(),
            places: s.places.into_iter().map(place_in).collect(),
            transitions: s
                .transitions
                .into_iter()
                .map(transition_in)
                .collect::<Result<_, _>>()?,
            initial_marking: s.initial_marking,
            final_place: s.final_place,
            ends: s.ends.into(),
            bridges_in: s
                .bridges_in
                .into_iter()
                .map(|b| BridgeIn {
                    id: b.id,
                    from: b.from,
                    inbox: b.inbox,
                })
                .collect(),
            bridges_out: s
                .bridges_out
                .into_iter()
                .map(|b| BridgeOut {
                    id: b.id,
                    transition: b.transition,
                    to: b.to,
                    colour: colour_in(b.colour),
                })
                .collect(),
            peers: s.peers,
            telemetry: s.telemetry,
        })
    }
}

fn span_out(s: Span) -> v3::Span {
    v3::Span {
        start: s.start,
        end: s.end,
    }
}

fn span_in(s: v3::Span) -> Span {
    Span {
        start: s.start,
        end: s.end,
    }
}

fn owner_out(o: Owner) -> v3::Owner {
    match o {
        Owner::Gcs => v3::Owner::Gcs,
        Owner::Drone(d) => v3::Owner::Drone(d.0),
        Owner::Unassigned => v3::Owner::Unassigned,
    }
}

fn owner_in(o: v3::Owner) -> Owner {
    match o {
        v3::Owner::Gcs => Owner::Gcs,
        v3::Owner::Drone(d) => Owner::Drone(DroneId(d)),
        v3::Owner::Unassigned => Owner::Unassigned,
    }
}

fn colour_out(c: ColourOp) -> v3::Colour {
    match c {
        ColourOp::Keep => v3::Colour::Keep,
        ColourOp::Enter => v3::Colour::Enter,
        ColourOp::Next => v3::Colour::Next,
        ColourOp::Leave => v3::Colour::Leave,
        ColourOp::Plain => v3::Colour::Plain,
    }
}

fn colour_in(c: v3::Colour) -> ColourOp {
    match c {
        v3::Colour::Keep => ColourOp::Keep,
        v3::Colour::Enter => ColourOp::Enter,
        v3::Colour::Next => ColourOp::Next,
        v3::Colour::Leave => ColourOp::Leave,
        v3::Colour::Plain => ColourOp::Plain,
    }
}

fn action_out(a: &ActionRef) -> v3::Action {
    v3::Action {
        drone: a.drone.0,
        name: a.name.to_string(),
        args: a.args.clone(),
        instance: a.instance,
    }
}

fn action_in(a: v3::Action) -> SharedAction {
    SharedAction::new(ActionRef {
        drone: DroneId(a.drone),
        name: a.name.into(),
        args: a.args,
        instance: a.instance,
    })
}

fn place_out(p: &Place) -> v3::Place {
    v3::Place {
        id: p.id.to_string(),
        label: p.label.to_string(),
        kind: match &p.kind {
            PlaceKind::Initial => v3::PlaceKind::Initial,
            PlaceKind::Control => v3::PlaceKind::Control,
            PlaceKind::Running(a) => v3::PlaceKind::Running(action_out(a)),
            PlaceKind::Event(e) => v3::PlaceKind::Event(e.clone()),
            PlaceKind::EventPending(e) => v3::PlaceKind::EventPending(e.clone()),
            PlaceKind::Region {
                region,
                interrupted,
            } => v3::PlaceKind::Region {
                region: *region,
                interrupted: *interrupted,
            },
            PlaceKind::Final => v3::PlaceKind::Final,
        },
        owner: owner_out(p.owner),
        span: p.span.map(span_out),
        depth: p.depth,
    }
}

fn place_in(p: v3::Place) -> Place {
    Place {
        id: p.id.into(),
        label: p.label.into(),
        kind: match p.kind {
            v3::PlaceKind::Initial => PlaceKind::Initial,
            v3::PlaceKind::Control => PlaceKind::Control,
            v3::PlaceKind::Running(a) => PlaceKind::Running(action_in(a)),
            v3::PlaceKind::Event(e) => PlaceKind::Event(e),
            v3::PlaceKind::EventPending(e) => PlaceKind::EventPending(e),
            v3::PlaceKind::Region {
                region,
                interrupted,
            } => PlaceKind::Region {
                region,
                interrupted,
            },
            v3::PlaceKind::Final => PlaceKind::Final,
        },
        owner: owner_in(p.owner),
        span: p.span.map(span_in),
        depth: p.depth,
    }
}

fn kind_out(k: &TransitionKind) -> v3::TransitionKind {
    use v3::TransitionKind as W;
    match k {
        TransitionKind::Init => W::Init,
        TransitionKind::ActionStart(a) => W::ActionStart(action_out(a)),
        TransitionKind::ActionEnd(a) => W::ActionEnd(action_out(a)),
        TransitionKind::ActionCancel(a) => W::ActionCancel(action_out(a)),
        TransitionKind::Skip => W::Skip,
        TransitionKind::Fork => W::Fork,
        TransitionKind::Join => W::Join,
        TransitionKind::Branch => W::Branch,
        TransitionKind::Merge => W::Merge,
        TransitionKind::LoopBack => W::LoopBack,
        TransitionKind::Pause => W::Pause,
        TransitionKind::Signal => W::Signal,
        TransitionKind::Await => W::Await,
        TransitionKind::Interrupt => W::Interrupt,
        TransitionKind::Finish => W::Finish,
        TransitionKind::Silent => W::Silent,
    }
}

fn kind_in(k: v3::TransitionKind) -> TransitionKind {
    use v3::TransitionKind as W;
    match k {
        W::Init => TransitionKind::Init,
        W::ActionStart(a) => TransitionKind::ActionStart(action_in(a)),
        W::ActionEnd(a) => TransitionKind::ActionEnd(action_in(a)),
        W::ActionCancel(a) => TransitionKind::ActionCancel(action_in(a)),
        W::Skip => TransitionKind::Skip,
        W::Fork => TransitionKind::Fork,
        W::Join => TransitionKind::Join,
        W::Branch => TransitionKind::Branch,
        W::Merge => TransitionKind::Merge,
        W::LoopBack => TransitionKind::LoopBack,
        W::Pause => TransitionKind::Pause,
        W::Signal => TransitionKind::Signal,
        W::Await => TransitionKind::Await,
        W::Interrupt => TransitionKind::Interrupt,
        W::Finish => TransitionKind::Finish,
        W::Silent => TransitionKind::Silent,
    }
}

fn transition_out(st: &SliceTransition) -> v3::Transition {
    let t = &st.transition;
    v3::Transition {
        id: t.id.to_string(),
        label: t.label.to_string(),
        kind: kind_out(&t.kind),
        owner: owner_out(t.owner),
        span: span_out(t.span),
        guard: t.guard.as_ref().map(|g| match &g.kind {
            GuardKind::Cond { cond, negated } => v3::Guard::Cond {
                cond: condition_out(cond),
                negated: *negated,
            },
            GuardKind::IterationBelow(n) => v3::Guard::IterationBelow(*n),
            GuardKind::IterationAtLeast(n) => v3::Guard::IterationAtLeast(*n),
        }),
        delay: t.delay,
        consume: st.consume.clone(),
        read: st.read.clone(),
        produce: st
            .produce
            .iter()
            .map(|p| v3::Produce {
                place: p.place,
                colour: colour_out(p.colour),
            })
            .collect(),
    }
}

fn transition_in(t: v3::Transition) -> Result<SliceTransition, DecodeError> {
    let guard = match t.guard {
        None => None,
        Some(v3::Guard::Cond { cond, negated }) => {
            let cond = condition_in(cond).map_err(|why| {
                DecodeError::Inconsistent(format!("the condition of transition `{}` {why}", t.id))
            })?;
            Some(Guard::cond(cond, negated))
        }
        Some(v3::Guard::IterationBelow(n)) => Some(Guard::iteration_below(n)),
        Some(v3::Guard::IterationAtLeast(n)) => Some(Guard::iteration_at_least(n)),
    };
    Ok(SliceTransition {
        transition: Transition {
            id: t.id.into(),
            label: t.label.into(),
            kind: kind_in(t.kind),
            owner: owner_in(t.owner),
            span: span_in(t.span),
            guard: guard.map(Box::new),
            delay: t.delay,
        },
        consume: t.consume,
        read: t.read,
        produce: t
            .produce
            .into_iter()
            .map(|p| Produce {
                place: p.place,
                colour: colour_in(p.colour),
            })
            .collect(),
    })
}

/// The condition in postfix order.
fn condition_out(e: &Expr) -> v3::Condition {
    let mut nodes = Vec::new();
    postfix(e, &mut nodes);
    v3::Condition { nodes }
}

fn postfix(e: &Expr, out: &mut Vec<v3::Term>) {
    let term = match e {
        Expr::Number { value, span } => v3::Term::Number {
            value: *value,
            span: span_out(*span),
        },
        Expr::Bool { value, span } => v3::Term::Bool {
            value: *value,
            span: span_out(*span),
        },
        Expr::Property {
            drone,
            name,
            args,
            span,
        } => v3::Term::Property {
            drone: drone.0,
            name: name.clone(),
            args: args.iter().map(|d| d.0).collect(),
            span: span_out(*span),
        },
        Expr::Unary { op, operand, span } => {
            postfix(operand, out);
            v3::Term::Unary {
                op: match op {
                    UnaryOp::Not => v3::UnaryOp::Not,
                    UnaryOp::Neg => v3::UnaryOp::Neg,
                },
                span: span_out(*span),
            }
        }
        Expr::Binary { op, lhs, rhs, span } => {
            postfix(lhs, out);
            postfix(rhs, out);
            v3::Term::Binary {
                op: binary_out(*op),
                span: span_out(*span),
            }
        }
    };
    out.push(term);
}

fn binary_out(op: BinaryOp) -> v3::BinaryOp {
    use v3::BinaryOp as W;
    match op {
        BinaryOp::Or => W::Or,
        BinaryOp::And => W::And,
        BinaryOp::Eq => W::Eq,
        BinaryOp::Ne => W::Ne,
        BinaryOp::Lt => W::Lt,
        BinaryOp::Le => W::Le,
        BinaryOp::Gt => W::Gt,
        BinaryOp::Ge => W::Ge,
        BinaryOp::Add => W::Add,
        BinaryOp::Sub => W::Sub,
        BinaryOp::Mul => W::Mul,
        BinaryOp::Div => W::Div,
    }
}

fn binary_in(op: v3::BinaryOp) -> BinaryOp {
    use v3::BinaryOp as W;
    match op {
        W::Or => BinaryOp::Or,
        W::And => BinaryOp::And,
        W::Eq => BinaryOp::Eq,
        W::Ne => BinaryOp::Ne,
        W::Lt => BinaryOp::Lt,
        W::Le => BinaryOp::Le,
        W::Gt => BinaryOp::Gt,
        W::Ge => BinaryOp::Ge,
        W::Add => BinaryOp::Add,
        W::Sub => BinaryOp::Sub,
        W::Mul => BinaryOp::Mul,
        W::Div => BinaryOp::Div,
    }
}

/// Rebuilds the tree from postfix nodes without recursion; the error
/// completes "the condition of transition `t` ...".
fn condition_in(c: v3::Condition) -> Result<Expr, String> {
    // Each entry is a finished subtree and its depth.
    let mut stack: Vec<(Expr, usize)> = Vec::new();
    for (i, term) in c.nodes.into_iter().enumerate() {
        let (e, depth) = match term {
            v3::Term::Number { value, span } => (
                Expr::Number {
                    value,
                    span: span_in(span),
                },
                1,
            ),
            v3::Term::Bool { value, span } => (
                Expr::Bool {
                    value,
                    span: span_in(span),
                },
                1,
            ),
            v3::Term::Property {
                drone,
                name,
                args,
                span,
            } => (
                Expr::Property {
                    drone: DroneId(drone),
                    name,
                    args: args.into_iter().map(DroneId).collect(),
                    span: span_in(span),
                },
                1,
            ),
            v3::Term::Unary { op, span } => {
                let Some((operand, d)) = stack.pop() else {
                    return Err(format!("applies an operator to nothing at node {i}"));
                };
                let op = match op {
                    v3::UnaryOp::Not => UnaryOp::Not,
                    v3::UnaryOp::Neg => UnaryOp::Neg,
                };
                let e = Expr::Unary {
                    op,
                    operand: Box::new(operand),
                    span: span_in(span),
                };
                (e, d + 1)
            }
            v3::Term::Binary { op, span } => {
                let (Some((rhs, dr)), Some((lhs, dl))) = (stack.pop(), stack.pop()) else {
                    return Err(format!(
                        "applies a two-operand operator to fewer at node {i}"
                    ));
                };
                let e = Expr::Binary {
                    op: binary_in(op),
                    lhs: Box::new(lhs),
                    rhs: Box::new(rhs),
                    span: span_in(span),
                };
                (e, dl.max(dr) + 1)
            }
        };
        if depth > MAX_CONDITION_DEPTH {
            return Err(format!(
                "nests deeper than {MAX_CONDITION_DEPTH} levels at node {i}"
            ));
        }
        stack.push((e, depth));
    }
    match stack.len() {
        1 => Ok(stack.pop().expect("one entry").0),
        0 => Err("is empty".to_string()),
        n => Err(format!("leaves {n} values where one was expected")),
    }
}
