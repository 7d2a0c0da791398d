//! Random nets of no mission's shape: places and arcs anywhere, read arcs,
//! the running places of several drones' actions, event places, and
//! condition guards (some pairs of them complementary) on any transition.
//! They reach markings the compiler never makes, which is the point: the
//! checker's shortcuts must hold on every net, not only on tidy ones.

use eamos_lang::hir::{BinaryOp, DroneId, Expr};
use eamos_lang::Span;
use eamos_petri::net::{
    ActionRef, ColourOp, Guard, Name, Net, NodeId, Owner, Place, PlaceKind, Transition,
    TransitionKind,
};
use proptest::prelude::*;

/// Actions of the running places: two motions (which exclude each other),
/// a photo and a hover (which do not).
const ACTIONS: [&str; 4] = ["FlyByX", "Land", "TakePhoto", "Hover"];

#[derive(Debug, Clone)]
pub struct RandomNet {
    pub drones: usize,
    /// Per place beyond `initial` (0) and `final` (1): what it is
    /// (0-1: control, 2: running, 3: an event) and whether it is marked.
    pub places: Vec<(u8, bool)>,
    /// Per transition: consumed, read and produced places (indices into all
    /// places) and an optional guard: the drone and threshold of
    /// `X() > threshold`, and whether it is negated.
    pub transitions: Vec<Arcs>,
}

#[derive(Debug, Clone)]
pub struct Arcs {
    pub pre: Vec<usize>,
    pub read: Vec<usize>,
    pub post: Vec<usize>,
    pub guard: Option<(usize, u8, bool)>,
}

pub fn random_net() -> impl Strategy<Value = RandomNet> {
    (1usize..4, 4usize..11).prop_flat_map(|(drones, extra)| {
        let n = extra + 2;
        let arcs = (
            proptest::collection::vec(0..n, 1..3),
            proptest::collection::vec(0..n, 0..2),
            proptest::collection::vec(0..n, 0..3),
            proptest::option::weighted(0.3, (0..drones, 0u8..2, any::<bool>())),
        )
            .prop_map(|(pre, read, post, guard)| Arcs {
                pre,
                read,
                post,
                guard,
            });
        (
            Just(drones),
            proptest::collection::vec((0u8..4, proptest::bool::weighted(0.2)), extra),
            proptest::collection::vec(arcs, 2..11),
        )
            .prop_map(|(drones, places, transitions)| RandomNet {
                drones,
                places,
                transitions,
            })
    })
}

/// The net and a source text its spans point into (a line per node, and
/// one per condition).
pub fn build(r: &RandomNet) -> (Net, String) {
    let mut src = String::new();
    let mut line = |s: &str| {
        let start = src.len();
        src.push_str(s);
        src.push('\n');
        Span::new(start, start + s.len())
    };
    let drones: Vec<String> = (1..=r.drones).map(|d| format!("D{d}")).collect();
    let mut net = Net::new(
        "Random",
        drones.clone(),
        vec!["Quadcopter".into(); r.drones],
    );
    let mut ids: Vec<NodeId> = vec![net.initial_place, net.final_place];
    for (i, &(kind, marked)) in r.places.iter().enumerate() {
        let span = Some(line(&format!("place {i}")));
        let drone = DroneId((i % r.drones) as u16);
        let kind = match kind {
            2 => PlaceKind::Running(
                ActionRef {
                    drone,
                    name: ACTIONS[i % ACTIONS.len()].into(),
                    args: vec![],
                    instance: i as u32,
                }
                .into(),
            ),
            3 if i % 2 == 0 => PlaceKind::Event(format!("e{i}")),
            3 => PlaceKind::EventPending(format!("e{i}")),
            _ => PlaceKind::Control,
        };
        let p = net.add_place(Place {
            id: Name::default(),
            label: format!("p{i}").into(),
            kind,
            owner: Owner::Unassigned,
            span,
            depth: 0,
        });
        if marked {
            net.initial_marking.push(p);
        }
        ids.push(p);
    }
    let conditions: Vec<Vec<Expr>> = (0..r.drones)
        .map(|d| {
            (0..2)
                .map(|k| {
                    let text = format!("{}.X() > {k}", drones[d]);
                    let span = line(&text);
                    Expr::Binary {
                        op: BinaryOp::Gt,
                        lhs: Box::new(Expr::Property {
                            drone: DroneId(d as u16),
                            name: "X".into(),
                            args: vec![],
                            span,
                        }),
                        rhs: Box::new(Expr::Number {
                            value: f64::from(k),
                            span,
                        }),
                        span,
                    }
                })
                .collect()
        })
        .collect();
    for (k, a) in r.transitions.iter().enumerate() {
        let span = line(&format!("transition {k}"));
        let set = |v: &[usize]| {
            let mut v = v.to_vec();
            v.sort_unstable();
            v.dedup();
            v
        };
        let (pre, post) = (set(&a.pre), set(&a.post));
        let mut read = set(&a.read);
        read.retain(|p| !pre.contains(p));
        // A transition producing into a running place starts its action.
        let kind = post
            .iter()
            .find_map(|&p| match &net.place(ids[p])?.kind {
                PlaceKind::Running(a) => Some(TransitionKind::ActionStart(a.clone())),
                _ => None,
            })
            .unwrap_or(TransitionKind::Silent);
        let guard = a.guard.map(|(d, k, negated)| {
            Box::new(Guard::cond(conditions[d][k as usize].clone(), negated))
        });
        let t = net.add_transition(Transition {
            id: Name::default(),
            label: format!("t{k}").into(),
            kind,
            owner: Owner::Unassigned,
            span,
            guard,
            delay: None,
        });
        for &p in &pre {
            net.arc(ids[p], t, ColourOp::Keep);
        }
        for &p in &read {
            net.read_arc(ids[p], t);
        }
        for &p in &post {
            net.arc(t, ids[p], ColourOp::Keep);
        }
    }
    (net, src)
}
