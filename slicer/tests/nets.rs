//! Hand-built nets: how the slicer bundles crossings, and every way a net
//! or a set of slices can be refused.

use eamos_lang::hir::DroneId;
use eamos_lang::Span;
use eamos_petri::net::{
    ActionRef, ColourOp, Name, Net, NodeId, Owner, Place, PlaceKind, Transition, TransitionKind,
};
use eamos_slicer::compose::{compose, ComposeError};
use eamos_slicer::equivalence::{compare, Budget, Event, Step, Verdict};
use eamos_slicer::{slice, SliceError, Slices};

struct B {
    net: Net,
    instance: u32,
}

fn d(i: u16) -> Owner {
    Owner::Drone(DroneId(i))
}

impl B {
    fn new(drones: &[&str]) -> B {
        B {
            net: Net::new(
                "Hand",
                drones.iter().map(|s| s.to_string()).collect(),
                drones.iter().map(|_| "Quadcopter".to_string()).collect(),
            ),
            instance: 0,
        }
    }

    fn place(&mut self, label: &str) -> NodeId {
        self.net.add_place(Place {
            id: Name::default(),
            label: label.into(),
            kind: PlaceKind::Control,
            owner: Owner::Unassigned,
            span: None,
            depth: 0,
        })
    }

    fn trans(&mut self, label: &str, kind: TransitionKind, owner: Owner) -> NodeId {
        self.net.add_transition(Transition {
            id: Name::default(),
            label: label.into(),
            kind,
            owner,
            span: Span::default(),
            guard: None,
            delay: None,
        })
    }

    /// `from -> start -> running -> end -> (returned place)`, on drone `o`.
    fn action(&mut self, from: NodeId, o: u16) -> NodeId {
        let a = ActionRef {
            drone: DroneId(o),
            name: "Hover".into(),
            args: vec![1.0],
            instance: self.instance,
        };
        self.instance += 1;
        let start = self.trans("start", TransitionKind::ActionStart(a.clone().into()), d(o));
        let running = self.net.add_place(Place {
            id: Name::default(),
            label: "running".into(),
            kind: PlaceKind::Running(a.clone().into()),
            owner: d(o),
            span: None,
            depth: 0,
        });
        let end = self.trans("end", TransitionKind::ActionEnd(a.into()), d(o));
        let after = self.place("after");
        self.net.arc(from, start, ColourOp::Keep);
        self.net.arc(start, running, ColourOp::Keep);
        self.net.arc(running, end, ColourOp::Keep);
        self.net.arc(end, after, ColourOp::Keep);
        after
    }

    fn start(&mut self) -> NodeId {
        let init = self.trans("init", TransitionKind::Init, Owner::Gcs);
        let p = self.place("p0");
        let i = self.net.initial_place;
        self.net.arc(i, init, ColourOp::Keep);
        self.net.arc(init, p, ColourOp::Keep);
        p
    }

    fn finish(&mut self, from: NodeId) {
        let t = self.trans("finish", TransitionKind::Finish, Owner::Unassigned);
        let f = self.net.final_place;
        self.net.arc(from, t, ColourOp::Keep);
        self.net.arc(t, f, ColourOp::Keep);
    }

    fn fork(&mut self, from: NodeId, n: usize) -> Vec<NodeId> {
        let t = self.trans("fork", TransitionKind::Fork, Owner::Unassigned);
        self.net.arc(from, t, ColourOp::Keep);
        (0..n)
            .map(|_| {
                let p = self.place("branch");
                self.net.arc(t, p, ColourOp::Keep);
                p
            })
            .collect()
    }

    fn join(&mut self, from: &[NodeId]) -> NodeId {
        let t = self.trans("join", TransitionKind::Join, Owner::Unassigned);
        for &p in from {
            self.net.arc(p, t, ColourOp::Keep);
        }
        let p = self.place("joined");
        self.net.arc(t, p, ColourOp::Keep);
        p
    }
}

fn equivalent(net: &Net, s: &Slices) {
    let composed = compose(&s.slices).unwrap();
    let v = compare(net, &composed, Budget::default());
    assert!(matches!(v, Verdict::Equivalent { .. }), "{v:?}");
}

fn between(s: &Slices, from: &str, to: &str) -> usize {
    s.get(from)
        .unwrap()
        .bridges_out
        .iter()
        .filter(|b| b.to == to)
        .count()
}

#[test]
fn a_fork_into_several_places_of_one_remote_drone_sends_one_token_and_fans_out_there() {
    let mut b = B::new(&["D1", "D2"]);
    let p = b.start();
    let after = b.action(p, 0);
    let branches = b.fork(after, 4);
    let ends: Vec<NodeId> = branches
        .iter()
        .enumerate()
        .map(|(i, &q)| b.action(q, if i == 0 { 0 } else { 1 }))
        .collect();
    let j = b.join(&ends);
    let last = b.action(j, 0);
    b.finish(last);
    let s = slice(&b.net).unwrap();
    assert_eq!(between(&s, "D1", "D2"), 1, "one token for three branches");
    let d2 = s.get("D2").unwrap();
    assert!(d2
        .transitions
        .iter()
        .any(|t| t.transition.id.contains(".out.D2")));
    assert_eq!(
        between(&s, "D2", "D1"),
        1,
        "the three branches join on D2 first"
    );
    equivalent(&b.net, &s);
}

#[test]
fn branches_that_end_on_one_remote_drone_are_joined_there_before_one_token_crosses() {
    let mut b = B::new(&["D1", "D2"]);
    let p = b.start();
    let first = b.action(p, 1);
    let branches = b.fork(first, 2);
    let a = b.action(branches[0], 1);
    let c = b.action(branches[1], 1);
    let j = b.join(&[a, c]);
    let last = b.action(j, 0);
    b.finish(last);
    let s = slice(&b.net).unwrap();
    assert_eq!(between(&s, "D2", "D1"), 1);
    equivalent(&b.net, &s);
}

#[test]
fn two_producers_on_one_remote_drone_feeding_one_place_forward_one_token() {
    // A choice on D1 between two actions of D2, then an action of D1: both
    // branch ends feed the merge place, which D1 consumes.
    let mut b = B::new(&["D1", "D2"]);
    let p = b.start();
    let choice = b.action(p, 0);
    let then = b.trans("then", TransitionKind::Branch, d(0));
    let other = b.trans("else", TransitionKind::Branch, d(0));
    let (pt, pe) = (b.place("then"), b.place("else"));
    b.net.arc(choice, then, ColourOp::Keep);
    b.net.arc(choice, other, ColourOp::Keep);
    b.net.arc(then, pt, ColourOp::Keep);
    b.net.arc(other, pe, ColourOp::Keep);
    let e1 = b.action(pt, 1);
    let e2 = b.action(pe, 1);
    let merge = b.place("merge");
    for e in [e1, e2] {
        let m = b.trans("merge", TransitionKind::Merge, Owner::Unassigned);
        b.net.arc(e, m, ColourOp::Keep);
        b.net.arc(m, merge, ColourOp::Keep);
    }
    let last = b.action(merge, 0);
    b.finish(last);
    let s = slice(&b.net).unwrap();
    assert_eq!(
        between(&s, "D2", "D1"),
        1,
        "{:?}",
        s.get("D2").unwrap().bridges_out
    );
    assert_eq!(between(&s, "D1", "D2"), 2, "one per branch taken");
    equivalent(&b.net, &s);
}

#[test]
fn a_place_read_by_one_drone_and_consumed_by_another_cannot_be_sliced() {
    let mut b = B::new(&["D1", "D2"]);
    let p = b.start();
    let shared = b.place("shared");
    let t1 = b.trans("t1", TransitionKind::Silent, d(0));
    let t2 = b.trans("t2", TransitionKind::Silent, d(1));
    b.net.arc(p, t1, ColourOp::Keep);
    b.net.arc(t1, shared, ColourOp::Keep);
    b.net.read_arc(shared, t1);
    b.net.arc(shared, t2, ColourOp::Keep);
    let err = slice(&b.net).unwrap_err();
    match err {
        SliceError::OwnerConflict { place, owners, .. } => {
            assert_eq!(place, b.net.place(shared).unwrap().id);
            assert_eq!(owners, ["D1", "D2"]);
        }
        other => panic!("{other}"),
    }
}

#[test]
fn a_drone_named_like_the_ground_station_is_refused() {
    let b = B::new(&["GCS"]);
    assert_eq!(
        slice(&b.net).unwrap_err(),
        SliceError::ReservedName("GCS".into())
    );
}

#[test]
fn an_arc_of_weight_two_is_refused() {
    let mut b = B::new(&["D1"]);
    let p = b.start();
    let t = b.trans("t", TransitionKind::Silent, Owner::Unassigned);
    let e = b.net.arc(p, t, ColourOp::Keep);
    b.net.graph[e].weight = 2;
    assert!(matches!(
        slice(&b.net),
        Err(SliceError::ArcWeight { weight: 2, .. })
    ));
}

#[test]
fn a_node_owned_by_a_drone_the_net_does_not_declare_is_refused() {
    let mut b = B::new(&["D1"]);
    b.trans("t", TransitionKind::Silent, d(3));
    assert!(matches!(
        slice(&b.net),
        Err(SliceError::UnknownDrone { index: 3, .. })
    ));
}

#[test]
fn a_net_with_more_profiles_than_drones_is_refused() {
    let mut b = B::new(&["D1"]);
    b.net.profiles.push("Quadcopter".into());
    assert!(matches!(
        slice(&b.net),
        Err(SliceError::Profiles {
            drones: 1,
            profiles: 2
        })
    ));
}

fn two_drone_slices() -> Slices {
    let mut b = B::new(&["D1", "D2"]);
    let p = b.start();
    let a = b.action(p, 0);
    let c = b.action(a, 1);
    b.finish(c);
    slice(&b.net).unwrap()
}

#[test]
fn slices_whose_bridges_do_not_match_do_not_compose() {
    let s = two_drone_slices();
    let mut slices = s.slices.clone();
    let d2 = slices.iter_mut().find(|s| s.drone == "D2").unwrap();
    let id = d2.bridges_in[0].id;
    d2.bridges_in.clear();
    assert!(matches!(
        compose(&slices),
        Err(ComposeError::Unmatched { id: i, .. }) if i == id
    ));
    let mut slices = s.slices.clone();
    slices.push(slices[1].clone());
    assert!(matches!(compose(&slices), Err(ComposeError::Duplicate(_))));
    let mut slices = s.slices.clone();
    slices.retain(|s| s.drone != "GCS");
    assert!(compose(&slices).is_err());
}

#[test]
fn the_equivalence_check_finds_a_missing_synchronisation() {
    // The same mission with the bridge from D1 to D2 delivered before D1's
    // action ends: D2 may start first, which the mission forbids.
    let s = two_drone_slices();
    let mut b = B::new(&["D1", "D2"]);
    let p = b.start();
    let fork = b.fork(p, 2);
    let a = b.action(fork[0], 0);
    let c = b.action(fork[1], 1);
    let j = b.join(&[a, c]);
    b.finish(j);
    let composed = compose(&s.slices).unwrap();
    match compare(&b.net, &composed, Budget::default()) {
        Verdict::Different {
            trace, only_left, ..
        } => {
            assert!(trace.is_empty(), "{trace:?}");
            assert!(
                only_left.iter().any(|e| matches!(
                    e,
                    Event::Action {
                        step: Step::Start,
                        instance: 1,
                        ..
                    }
                )),
                "{only_left:?}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_equivalence_check_reports_a_place_that_receives_a_second_token() {
    let mut b = B::new(&["D1"]);
    let p = b.start();
    let t = b.trans("twice", TransitionKind::Silent, Owner::Unassigned);
    let q = b.place("q");
    b.net.arc(p, t, ColourOp::Keep);
    b.net.arc(t, q, ColourOp::Keep);
    let u = b.trans("again", TransitionKind::Silent, Owner::Unassigned);
    b.net.read_arc(q, u);
    b.net.arc(u, q, ColourOp::Keep);
    let v = compare(&b.net, &b.net, Budget::default());
    assert!(matches!(v, Verdict::Unsafe { left: true, .. }), "{v:?}");
}
