//! From a checked mission to its coloured Petri net.
//!
//! Every statement is compiled from an entry place to an exit place, so
//! sequences simply chain: the exit place of one statement is the entry place
//! of the next. What each statement becomes:
//!
//! * **Action** `d.A(x)`: `entry -> start -> running -> end -> exit`, all owned
//!   by `d`. While the action runs its `running` place is marked, so a marking
//!   says which actions are in flight.
//! * **SEQ** chains its statements; **PAR** forks one token per statement and
//!   joins them (one statement: no fork; none: nothing at all). Every block
//!   call of the mission is already its own instance in the checked mission,
//!   so it becomes its own copy of places and transitions.
//! * **If(c, T[, E])**: the entry place is a *choice place*: two guarded
//!   `Branch` transitions, `c` and `!c`, consume it; each side ends in a
//!   `Merge` into the exit place.
//! * **WaitWhile / WaitUntil**: one guarded `Pause` transition (proceed when
//!   `!c` / `c`), then the body. **PauseWhile / PauseUntil** likewise, with
//!   no body; **PauseFor(s)** is a `Pause` transition with `delay = s`.
//! * **RepeatWhile(c, B[, X])** (RepeatUntil is RepeatWhile of `!c`): a silent
//!   step enters the loop and pushes an iteration counter onto the token's
//!   colour (`ColourOp::Enter`); the *loop head* place is consumed by the
//!   guarded `Branch` transitions "iterate" (`c`) and "leave" (`!c`, pops the
//!   counter with `ColourOp::Leave`, then `X`); the body's end goes back to
//!   the head through a `LoopBack` transition that adds one to the counter
//!   (`ColourOp::Next`). The counter therefore equals the number of finished
//!   iterations. **RepeatFor(n, B)** is the same loop with colour guards:
//!   iterate while the counter is below `n`, leave once it is at least `n`
//!   (so `n = 0` runs the body zero times). Colour guards are decided inside
//!   the net, so a `RepeatFor` head is owned by no drone in particular.
//! * **Signal / Await**: each `Await` instance `i` has its own event place
//!   `event_i` and its complement `pending_i` (initially marked); the `Await`
//!   transition reads `event_i`. Each `Signal` instance `j` of the same event
//!   produces a token into an inbox place `inbox_ij` beside every such
//!   `Await`; two absorbing transitions empty it: *first* (`inbox_ij +
//!   pending_i -> event_i`) and *again* (`inbox_ij`, reading `event_i` -> nothing).
//!   The front end guarantees that no `Signal` is inside a loop, so every
//!   inbox receives at most one token and the net stays 1-safe.
//! * **DoWhile / DoUntil**: see "Interruptible regions" below.
//!
//! # Ownership
//!
//! The slicer relies on one invariant: a place and every transition that
//! consumes or reads it can live on the same drone
//! ([`Net::ownership_violations`] is empty for every compiled net). So:
//! an action's start, running place and end belong to its drone; a choice
//! place (If, loop head, wait) is consumed only by transitions of the
//! *condition's owner* (the first drone the condition reads, by `DroneId`;
//! unassigned if it reads none); forks, joins, merges, loop entries and
//! loop-backs are unassigned (the slicer places them). The initial token is
//! in the place `initial`, owned by the ground station, whose `Init`
//! transition starts the mission. A place's owner is the common owner of the
//! transitions that consume or read it (a final pass sets it).
//!
//! Inside a `Do`, a transition that must observe the region (see below) but
//! has no drone of its own (a pause, a signal, an await, a condition that
//! reads no drone) is given the owner of the innermost enclosing `Do`
//! condition that has one: reading the region's state must be a local read.
//!
//! # Interruptible regions (`Do`)
//!
//! `DoWhile(c, B)` runs `B` and, the moment `c` stops holding, cancels the
//! running actions of `B` and skips the rest of it (`DoUntil`: the moment `c`
//! holds). The net must say this in a way that can be cut into one part per
//! drone with no shared memory, and stay 1-safe. Let `w` be the owner of the
//! condition and `D` the set of owners of the *observable* transitions of the
//! body (action starts, guarded branches and waits, pauses, awaits, signals;
//! nested `Do`s included). `R = D \ {w}` are the remote owners.
//!
//! * `do_start` (`Fork`) produces the body's entry, `watch` at `w`
//!   (`Region { interrupted: false }`) and, for each `d` in `R`, `live_d` at
//!   `d` (`Region { interrupted: false }`).
//! * `interrupt` (`Interrupt`, owner `w`, guarded by the stop side of `c`)
//!   consumes `watch` and produces `interrupted` at `w`
//!   (`Region { interrupted: true }`) and a message `kill_d` for each `d` in `R`.
//! * `flip_d` (owner `d`) consumes `live_d + kill_d` and produces
//!   `cancelled_d` (`Region { interrupted: true }`) and an acknowledgement
//!   `killed_d` back at `w`.
//! * Every observable body transition of owner `d` reads the "live" place of
//!   `d` of *every* enclosing `Do` (`watch` when `d = w`, else `live_d`), and
//!   has, per enclosing `Do`, a *skip twin* that reads that `Do`'s
//!   "cancelled" place (`interrupted` when `d = w`, else `cancelled_d`) and
//!   moves the token on without doing the thing: an action start's twin
//!   (`Skip`) goes straight past the action; a running action gets an
//!   `ActionCancel` transition (running -> after the action; the executor
//!   cancels the real action when it fires it); a choice place's twin goes to
//!   the merge; a loop head's twin leaves the loop and skips the exit block
//!   too; a wait's twin skips the waited-for body. Structural transitions
//!   (fork, join, merge, loop entry and loop-back, `RepeatFor` heads, inner
//!   `do_start`/ends, action ends) have no twin: once every observable step
//!   of the body is skipped, they carry the tokens to the body's exit in a
//!   bounded number of steps.
//! * `end_normal` (owner `w`) consumes the body's exit and `watch`;
//!   `end_cancelled` (owner `w`) consumes the body's exit, `interrupted` and
//!   every `killed_d`. When `R` is empty they produce the exit place of the
//!   `Do` directly. Otherwise both send `close_d` to each `d` in `R`; at `d`,
//!   one of two `close` transitions consumes `close_d` and `live_d` or
//!   `cancelled_d` and sends `done_d` back to `w`; `do_exit` (owner `w`)
//!   consumes every `done_d` and produces the exit place. After `do_exit`
//!   no place of the region is marked, so a `Do` inside a loop starts every
//!   iteration clean.
//!
//! Every read of the region's state is local (the live/cancelled places of
//! `d` are read only by transitions of `d`); only `do_start`, `interrupt`,
//! `flip_d`, `end_*`, `close` and `do_exit` send messages.
//!
//! **Change from the first design**, which kept a separate `live_w` beside
//! `watch` for observable transitions of `w` itself. `interrupt` then had to
//! consume `live_w` too (or go through a local kill message), and the two
//! places were always marked together: they are one place. So for `d = w`
//! the region uses `watch` / `interrupted` as the live / cancelled places,
//! and `flip`, `kill`, `killed`, `close` and `done` exist only for remote
//! owners. When `R` is empty (all observable steps at `w`, the common case of
//! a drone guarding its own actions) the region is `do_start`, `watch`,
//! `interrupt`, `interrupted`, `end_normal` and `end_cancelled`: no message
//! at all.
//!
//! Races that the distribution allows and the net keeps visible: an
//! observable step at `d` may still fire after `interrupt` until `kill_d` has
//! reached `d` (a remote action may start, and is then cancelled); an action
//! that ends as it is cancelled fires either `ActionEnd` or `ActionCancel`,
//! both lead to the same place. A `Signal` that the interrupt skips is never
//! sent: an `Await` outside the region then waits forever, which the
//! checker reports.
//!
//! # The final marking
//!
//! The root block's exit feeds a `Finish` transition into the place `final`.
//! The mission has ended properly when `final` is marked and every other
//! marked place is an event-state place: for each `Await` instance exactly
//! one of `event_i` (some matching `Signal` fired) or `pending_i` (none did).
//! Absorbing transitions may still fire after `Finish`; once nothing is
//! enabled, no inbox, region, control or running place is marked.

use std::collections::BTreeMap;

use eamos_lang::hir::{self, Block, BlockKind, CondMode, Expr, Mission, Stmt};
use eamos_lang::Span;
use eamos_profile::ProfileTable;

use crate::net::{
    ActionRef, ColourOp, Guard, Name, Net, NodeId, Owner, Place, PlaceKind, SharedAction,
    Transition, TransitionKind,
};
use crate::pretty;

/// Compiles a checked mission into its net.
///
/// The profiles only add units to action labels (`Takeoff(1.5 m)`): the
/// mission has been checked against them already, and an action missing from
/// its profile is labelled without units rather than refused.
pub fn compile(mission: &Mission, profiles: &ProfileTable) -> Net {
    let drones: Vec<String> = mission.drones.iter().map(|d| d.name.clone()).collect();
    let profile_names = mission.drones.iter().map(|d| d.profile.clone()).collect();
    let mut c = Compiler {
        mission,
        profiles,
        net: Net::new(mission.name.clone(), drones.clone(), profile_names),
        drones,
        depth: 0,
        dos: Vec::new(),
        next_action: 0,
        next_region: 0,
        awaits: BTreeMap::new(),
        signals: BTreeMap::new(),
    };
    c.mission();
    // The node and arc vectors grew by doubling: up to half of them is
    // spare room, megabytes on a stress mission, held while it is sliced.
    c.net.graph.shrink_to_fit();
    c.net
}

struct Compiler<'a> {
    mission: &'a Mission,
    profiles: &'a ProfileTable,
    net: Net,
    drones: Vec<String>,
    /// Number of loops around the statement being compiled.
    depth: u8,
    /// Enclosing `Do` regions, outermost first.
    dos: Vec<Region>,
    next_action: u32,
    next_region: u32,
    /// `Await` instances by event name, in mission order.
    awaits: BTreeMap<String, Vec<AwaitSite>>,
    /// `Signal` transitions by event name, in mission order.
    signals: BTreeMap<String, Vec<NodeId>>,
}

/// The state of one `Do` while its body is compiled.
struct Region {
    id: u32,
    /// The owner of the condition.
    w: Owner,
    depth: u8,
    span: Span,
    do_start: NodeId,
    interrupt: NodeId,
    watch: NodeId,
    interrupted: NodeId,
    /// Per remote owner, created when the first observable step of that
    /// owner is compiled.
    remote: BTreeMap<Owner, Remote>,
}

/// What makes one loop different from another.
struct Loop<'b> {
    label: String,
    /// Owner of the head's guarded transitions.
    owner: Owner,
    iterate: Guard,
    leave: Guard,
    body: &'b Block,
    exit: Option<&'b Block>,
    span: Span,
}

struct Remote {
    live: NodeId,
    cancelled: NodeId,
    killed: NodeId,
}

struct AwaitSite {
    event: NodeId,
    pending: NodeId,
    owner: Owner,
    span: Span,
}

impl Compiler<'_> {
    fn mission(&mut self) {
        let root = &self.mission.root;
        let init = self.transition(
            format!("init {}", self.mission.name),
            TransitionKind::Init,
            Owner::Gcs,
            root.span,
            None,
        );
        let initial = self.net.initial_place;
        self.net.arc(initial, init, ColourOp::Keep);
        let first = self.control(format!("begin {}", root.name), root.span);
        self.net.arc(init, first, ColourOp::Keep);
        let last = self.block(root, first);
        let finish = self.transition(
            format!("finish {}", self.mission.name),
            TransitionKind::Finish,
            Owner::Unassigned,
            root.span,
            None,
        );
        self.net.arc(last, finish, ColourOp::Keep);
        let fin = self.net.final_place;
        self.net.arc(finish, fin, ColourOp::Keep);
        self.events();
        self.assign_place_owners();
    }

    // ---- building blocks -------------------------------------------------

    fn place_at(
        &mut self,
        label: impl Into<Name>,
        kind: PlaceKind,
        span: Span,
        depth: u8,
    ) -> NodeId {
        self.net.add_place(Place {
            id: self.net.next_id('p'),
            label: label.into(),
            kind,
            owner: Owner::Unassigned,
            span: Some(span),
            depth,
        })
    }

    fn control(&mut self, label: impl Into<Name>, span: Span) -> NodeId {
        self.place_at(label, PlaceKind::Control, span, self.depth)
    }

    fn transition(
        &mut self,
        label: impl Into<Name>,
        kind: TransitionKind,
        owner: Owner,
        span: Span,
        guard: Option<Guard>,
    ) -> NodeId {
        self.net.add_transition(Transition {
            id: self.net.next_id('t'),
            label: label.into(),
            kind,
            owner,
            span,
            guard: guard.map(Box::new),
            delay: None,
        })
    }

    fn name(&self, d: hir::DroneId) -> String {
        pretty::drone_name(&self.drones, d)
    }

    fn cond_text(&self, c: &Expr) -> String {
        pretty::expr(c, &self.drones)
    }

    /// The owner of a condition: the first drone it reads, by id.
    fn cond_owner(&self, c: &Expr) -> Owner {
        c.drones()
            .first()
            .map_or(Owner::Unassigned, |d| Owner::Drone(*d))
    }

    /// Inside a `Do`, an observable step with no owner of its own takes the
    /// owner of the innermost enclosing condition that has one, so that its
    /// read of the region's state is local.
    fn observable_owner(&self, natural: Owner) -> Owner {
        if natural != Owner::Unassigned {
            return natural;
        }
        self.dos
            .iter()
            .rev()
            .map(|r| r.w)
            .find(|w| *w != Owner::Unassigned)
            .unwrap_or(Owner::Unassigned)
    }

    // ---- statements ------------------------------------------------------

    fn block(&mut self, b: &Block, entry: NodeId) -> NodeId {
        match (b.kind, b.stmts.len()) {
            (_, 0) => entry,
            (BlockKind::Seq, _) | (BlockKind::Par, 1) => {
                b.stmts.iter().fold(entry, |at, s| self.stmt(s, at))
            }
            (BlockKind::Par, n) => {
                let fork = self.transition(
                    format!("fork {}", b.name),
                    TransitionKind::Fork,
                    Owner::Unassigned,
                    b.span,
                    None,
                );
                self.net.arc(entry, fork, ColourOp::Keep);
                let mut exits = Vec::with_capacity(n);
                for (i, s) in b.stmts.iter().enumerate() {
                    let p = self.control(format!("{} branch {}", b.name, i + 1), s.span());
                    self.net.arc(fork, p, ColourOp::Keep);
                    exits.push(self.stmt(s, p));
                }
                let join = self.transition(
                    format!("join {}", b.name),
                    TransitionKind::Join,
                    Owner::Unassigned,
                    b.span,
                    None,
                );
                for x in exits {
                    self.net.arc(x, join, ColourOp::Keep);
                }
                let exit = self.control(format!("after {}", b.name), b.span);
                self.net.arc(join, exit, ColourOp::Keep);
                exit
            }
        }
    }

    fn stmt(&mut self, s: &Stmt, entry: NodeId) -> NodeId {
        match s {
            Stmt::Action(a) => self.action(a, entry),
            Stmt::Block(b) => self.block(b, entry),
            Stmt::If {
                cond,
                then,
                otherwise,
                span,
            } => self.if_(cond, then, otherwise.as_ref(), *span, entry),
            Stmt::Wait {
                mode,
                cond,
                body,
                span,
            } => self.wait(*mode, cond, Some(body), *span, entry),
            Stmt::Pause { mode, cond, span } => self.wait(*mode, cond, None, *span, entry),
            Stmt::PauseFor { seconds, span } => self.pause_for(*seconds, *span, entry),
            Stmt::Repeat {
                mode,
                cond,
                body,
                exit,
                span,
            } => self.repeat(*mode, cond, body, exit.as_ref(), *span, entry),
            Stmt::RepeatFor { count, body, span } => self.repeat_for(*count, body, *span, entry),
            Stmt::Do {
                mode,
                cond,
                body,
                span,
            } => self.do_(*mode, cond, body, *span, entry),
            Stmt::Signal { event, span } => self.signal(event, *span, entry),
            Stmt::Await { event, span } => self.await_(event, *span, entry),
        }
    }

    fn action_label(&self, a: &hir::Action) -> String {
        let profile = self
            .mission
            .drones
            .get(a.drone.0 as usize)
            .and_then(|d| self.profiles.get(&d.profile));
        let params = profile
            .and_then(|p| p.actions.get(&a.name))
            .map(|s| &s.params);
        let args: Vec<String> = a
            .args
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let unit = params
                    .and_then(|ps| ps.get(i))
                    .map_or("", |p| unit_suffix(p.kind));
                format!("{}{unit}", pretty::number(*v))
            })
            .collect();
        format!("{}.{}({})", self.name(a.drone), a.name, args.join(", "))
    }

    fn action(&mut self, a: &hir::Action, entry: NodeId) -> NodeId {
        let owner = Owner::Drone(a.drone);
        let action = SharedAction::new(ActionRef {
            drone: a.drone,
            name: Name::from(&a.name),
            args: a.args.clone(),
            instance: self.next_action,
        });
        self.next_action += 1;
        let label = Name::from(self.action_label(a));
        let start = self.transition(
            label.clone(),
            TransitionKind::ActionStart(action.clone()),
            owner,
            a.span,
            None,
        );
        self.net.arc(entry, start, ColourOp::Keep);
        let running = self.place_at(
            format!("{label} running"),
            PlaceKind::Running(action.clone()),
            a.span,
            self.depth,
        );
        self.net.arc(start, running, ColourOp::Keep);
        let end = self.transition(
            format!("end {label}"),
            TransitionKind::ActionEnd(action.clone()),
            owner,
            a.span,
            None,
        );
        self.net.arc(running, end, ColourOp::Keep);
        let exit = self.control(format!("after {label}"), a.span);
        self.net.arc(end, exit, ColourOp::Keep);

        self.read_live(start, owner);
        self.skip_twins(entry, owner, exit, ColourOp::Keep, &label, a.span);
        for i in 0..self.dos.len() {
            let (_, cancelled) = self.region_state(i, owner);
            let cancel = self.transition(
                format!("cancel {label}"),
                TransitionKind::ActionCancel(action.clone()),
                owner,
                a.span,
                None,
            );
            self.net.arc(running, cancel, ColourOp::Keep);
            self.net.read_arc(cancelled, cancel);
            self.net.arc(cancel, exit, ColourOp::Keep);
        }
        exit
    }

    fn if_(
        &mut self,
        cond: &Expr,
        then: &Block,
        otherwise: Option<&Block>,
        span: Span,
        entry: NodeId,
    ) -> NodeId {
        let owner = self.observable_owner(self.cond_owner(cond));
        let text = self.cond_text(cond);
        let yes = self.transition(
            format!("if {text}"),
            TransitionKind::Branch,
            owner,
            span,
            Some(Guard::cond(cond.clone(), false)),
        );
        let no = self.transition(
            format!("if not ({text})"),
            TransitionKind::Branch,
            owner,
            span,
            Some(Guard::cond(cond.clone(), true)),
        );
        self.net.arc(entry, yes, ColourOp::Keep);
        self.net.arc(entry, no, ColourOp::Keep);
        let then_entry = self.control(format!("then {}", then.name), then.span);
        self.net.arc(yes, then_entry, ColourOp::Keep);
        let then_exit = self.block(then, then_entry);
        let else_entry = match otherwise {
            Some(b) => self.control(format!("else {}", b.name), b.span),
            None => self.control(format!("no else of if {text}"), span),
        };
        self.net.arc(no, else_entry, ColourOp::Keep);
        let else_exit = match otherwise {
            Some(b) => self.block(b, else_entry),
            None => else_entry,
        };
        let exit = self.control(format!("after if {text}"), span);
        for from in [then_exit, else_exit] {
            let merge = self.transition(
                format!("merge if {text}"),
                TransitionKind::Merge,
                Owner::Unassigned,
                span,
                None,
            );
            self.net.arc(from, merge, ColourOp::Keep);
            self.net.arc(merge, exit, ColourOp::Keep);
        }
        self.read_live(yes, owner);
        self.read_live(no, owner);
        self.skip_twins(
            entry,
            owner,
            exit,
            ColourOp::Keep,
            &format!("if {text}"),
            span,
        );
        exit
    }

    /// `WaitWhile`/`WaitUntil` (with a body) and `PauseWhile`/`PauseUntil`
    /// (without): proceed once the condition lets the branch go on.
    fn wait(
        &mut self,
        mode: CondMode,
        cond: &Expr,
        body: Option<&Block>,
        span: Span,
        entry: NodeId,
    ) -> NodeId {
        let owner = self.observable_owner(self.cond_owner(cond));
        let text = self.cond_text(cond);
        let (what, negated) = match (mode, body.is_some()) {
            (CondMode::While, true) => ("WaitWhile", true),
            (CondMode::Until, true) => ("WaitUntil", false),
            (CondMode::While, false) => ("PauseWhile", true),
            (CondMode::Until, false) => ("PauseUntil", false),
        };
        let label = format!("{what} {text}");
        let proceed = self.transition(
            label.clone(),
            TransitionKind::Pause,
            owner,
            span,
            Some(Guard::cond(cond.clone(), negated)),
        );
        self.net.arc(entry, proceed, ColourOp::Keep);
        let after = self.control(format!("after {label}"), span);
        self.net.arc(proceed, after, ColourOp::Keep);
        let exit = match body {
            Some(b) => self.block(b, after),
            None => after,
        };
        self.read_live(proceed, owner);
        self.skip_twins(entry, owner, exit, ColourOp::Keep, &label, span);
        exit
    }

    fn pause_for(&mut self, seconds: f64, span: Span, entry: NodeId) -> NodeId {
        let owner = self.observable_owner(Owner::Unassigned);
        let label = format!("PauseFor {} s", pretty::number(seconds));
        let pause = self.transition(label.clone(), TransitionKind::Pause, owner, span, None);
        if let Some(crate::Node::Transition(t)) = self.net.graph.node_weight_mut(pause) {
            t.delay = Some(seconds);
        }
        self.net.arc(entry, pause, ColourOp::Keep);
        let exit = self.control(format!("after {label}"), span);
        self.net.arc(pause, exit, ColourOp::Keep);
        self.read_live(pause, owner);
        self.skip_twins(entry, owner, exit, ColourOp::Keep, &label, span);
        exit
    }

    /// The common shape of both loops; see the module documentation.
    /// Returns the loop head, the exit place (after the exit block) and the
    /// iterate and leave transitions.
    fn loop_(&mut self, l: Loop<'_>, entry: NodeId) -> (NodeId, NodeId, [NodeId; 2]) {
        let Loop {
            label,
            owner,
            iterate,
            leave,
            body,
            exit,
            span,
        } = l;
        let enter = self.transition(
            format!("enter {label}"),
            TransitionKind::Silent,
            Owner::Unassigned,
            span,
            None,
        );
        self.net.arc(entry, enter, ColourOp::Keep);
        self.depth += 1;
        let head = self.control(format!("head of {label}"), span);
        self.net.arc(enter, head, ColourOp::Enter);
        let it = self.transition(
            format!("iterate {label}"),
            TransitionKind::Branch,
            owner,
            span,
            Some(iterate),
        );
        self.net.arc(head, it, ColourOp::Keep);
        let body_entry = self.control(format!("body {}", body.name), body.span);
        self.net.arc(it, body_entry, ColourOp::Keep);
        let body_exit = self.block(body, body_entry);
        let back = self.transition(
            format!("loop back {label}"),
            TransitionKind::LoopBack,
            Owner::Unassigned,
            span,
            None,
        );
        self.net.arc(body_exit, back, ColourOp::Keep);
        self.net.arc(back, head, ColourOp::Next);
        let out = self.transition(
            format!("leave {label}"),
            TransitionKind::Branch,
            owner,
            span,
            Some(leave),
        );
        self.net.arc(head, out, ColourOp::Keep);
        self.depth -= 1;
        let after = self.control(format!("after {label}"), span);
        self.net.arc(out, after, ColourOp::Leave);
        let exit = match exit {
            Some(b) => self.block(b, after),
            None => after,
        };
        (head, exit, [it, out])
    }

    fn repeat(
        &mut self,
        mode: CondMode,
        cond: &Expr,
        body: &Block,
        exit: Option<&Block>,
        span: Span,
        entry: NodeId,
    ) -> NodeId {
        let owner = self.observable_owner(self.cond_owner(cond));
        let text = self.cond_text(cond);
        let (label, iterate_negated) = match mode {
            CondMode::While => (format!("RepeatWhile {text}"), false),
            CondMode::Until => (format!("RepeatUntil {text}"), true),
        };
        let (head, exit, branches) = self.loop_(
            Loop {
                label: label.clone(),
                owner,
                iterate: Guard::cond(cond.clone(), iterate_negated),
                leave: Guard::cond(cond.clone(), !iterate_negated),
                body,
                exit,
                span,
            },
            entry,
        );
        for t in branches {
            self.read_live(t, owner);
        }
        self.skip_twins(head, owner, exit, ColourOp::Leave, &label, span);
        exit
    }

    fn repeat_for(&mut self, count: u32, body: &Block, span: Span, entry: NodeId) -> NodeId {
        let (_, exit, _) = self.loop_(
            Loop {
                label: format!("RepeatFor {count}"),
                owner: Owner::Unassigned,
                iterate: Guard::iteration_below(count),
                leave: Guard::iteration_at_least(count),
                body,
                exit: None,
                span,
            },
            entry,
        );
        exit
    }

    fn do_(
        &mut self,
        mode: CondMode,
        cond: &Expr,
        body: &Block,
        span: Span,
        entry: NodeId,
    ) -> NodeId {
        let w = self.observable_owner(self.cond_owner(cond));
        let text = self.cond_text(cond);
        let id = self.next_region;
        self.next_region += 1;
        let (label, stop_negated) = match mode {
            CondMode::While => (format!("DoWhile {text}"), true),
            CondMode::Until => (format!("DoUntil {text}"), false),
        };
        let do_start = self.transition(
            format!("start {label}"),
            TransitionKind::Fork,
            Owner::Unassigned,
            span,
            None,
        );
        self.net.arc(entry, do_start, ColourOp::Keep);
        let body_entry = self.control(format!("body {}", body.name), body.span);
        self.net.arc(do_start, body_entry, ColourOp::Keep);
        let depth = self.depth;
        let watch = self.place_at(
            format!("watch {label}"),
            PlaceKind::Region {
                region: id,
                interrupted: false,
            },
            span,
            depth,
        );
        self.net.arc(do_start, watch, ColourOp::Keep);
        let interrupt = self.transition(
            format!("interrupt {label}"),
            TransitionKind::Interrupt,
            w,
            span,
            Some(Guard::cond(cond.clone(), stop_negated)),
        );
        self.net.arc(watch, interrupt, ColourOp::Keep);
        let interrupted = self.place_at(
            format!("interrupted {label}"),
            PlaceKind::Region {
                region: id,
                interrupted: true,
            },
            span,
            depth,
        );
        self.net.arc(interrupt, interrupted, ColourOp::Keep);

        self.dos.push(Region {
            id,
            w,
            depth,
            span,
            do_start,
            interrupt,
            watch,
            interrupted,
            remote: BTreeMap::new(),
        });
        let body_exit = self.block(body, body_entry);
        let region = self.dos.pop().expect("the region pushed above");

        let end_normal =
            self.transition(format!("end {label}"), TransitionKind::Join, w, span, None);
        self.net.arc(body_exit, end_normal, ColourOp::Keep);
        self.net.arc(watch, end_normal, ColourOp::Keep);
        let end_cancelled = self.transition(
            format!("end interrupted {label}"),
            TransitionKind::Join,
            w,
            span,
            None,
        );
        self.net.arc(body_exit, end_cancelled, ColourOp::Keep);
        self.net.arc(interrupted, end_cancelled, ColourOp::Keep);
        for r in region.remote.values() {
            self.net.arc(r.killed, end_cancelled, ColourOp::Keep);
        }
        let exit = self.control(format!("after {label}"), span);
        if region.remote.is_empty() {
            self.net.arc(end_normal, exit, ColourOp::Keep);
            self.net.arc(end_cancelled, exit, ColourOp::Keep);
            return exit;
        }
        let do_exit = self.transition(format!("exit {label}"), TransitionKind::Join, w, span, None);
        for (d, r) in &region.remote {
            let at = crate::export::owner_label(&self.net, *d);
            let close = self.place_at(
                format!("close {label} at {at}"),
                PlaceKind::Control,
                span,
                depth,
            );
            self.net.arc(end_normal, close, ColourOp::Keep);
            self.net.arc(end_cancelled, close, ColourOp::Keep);
            let done = self.place_at(
                format!("done {label} at {at}"),
                PlaceKind::Control,
                span,
                depth,
            );
            for state in [r.live, r.cancelled] {
                let t = self.transition(
                    format!("close {label} at {at}"),
                    TransitionKind::Silent,
                    *d,
                    span,
                    None,
                );
                self.net.arc(close, t, ColourOp::Keep);
                self.net.arc(state, t, ColourOp::Keep);
                self.net.arc(t, done, ColourOp::Keep);
            }
            self.net.arc(done, do_exit, ColourOp::Keep);
        }
        self.net.arc(do_exit, exit, ColourOp::Keep);
        exit
    }

    fn signal(&mut self, event: &str, span: Span, entry: NodeId) -> NodeId {
        let owner = self.observable_owner(Owner::Unassigned);
        let label = format!("Signal({event:?})");
        let t = self.transition(label.clone(), TransitionKind::Signal, owner, span, None);
        self.net.arc(entry, t, ColourOp::Keep);
        let exit = self.control(format!("after {label}"), span);
        self.net.arc(t, exit, ColourOp::Keep);
        self.read_live(t, owner);
        self.skip_twins(entry, owner, exit, ColourOp::Keep, &label, span);
        self.signals.entry(event.to_string()).or_default().push(t);
        exit
    }

    fn await_(&mut self, event: &str, span: Span, entry: NodeId) -> NodeId {
        let owner = self.observable_owner(Owner::Unassigned);
        let label = format!("Await({event:?})");
        let happened = self.place_at(
            format!("event {event:?}"),
            PlaceKind::Event(event.to_string()),
            span,
            0,
        );
        let pending = self.place_at(
            format!("pending {event:?}"),
            PlaceKind::EventPending(event.to_string()),
            span,
            0,
        );
        self.net.initial_marking.push(pending);
        let t = self.transition(label.clone(), TransitionKind::Await, owner, span, None);
        self.net.arc(entry, t, ColourOp::Keep);
        self.net.read_arc(happened, t);
        let exit = self.control(format!("after {label}"), span);
        self.net.arc(t, exit, ColourOp::Keep);
        self.read_live(t, owner);
        self.skip_twins(entry, owner, exit, ColourOp::Keep, &label, span);
        self.awaits
            .entry(event.to_string())
            .or_default()
            .push(AwaitSite {
                event: happened,
                pending,
                owner,
                span,
            });
        exit
    }

    // ---- interruptible regions -------------------------------------------

    /// The "live" and "cancelled" places of `owner` in the `i`-th enclosing
    /// region, created with their protocol on first use.
    fn region_state(&mut self, i: usize, owner: Owner) -> (NodeId, NodeId) {
        let r = &self.dos[i];
        if owner == r.w {
            return (r.watch, r.interrupted);
        }
        if let Some(x) = r.remote.get(&owner) {
            return (x.live, x.cancelled);
        }
        let (id, depth, span, do_start, interrupt) =
            (r.id, r.depth, r.span, r.do_start, r.interrupt);
        let at = crate::export::owner_label(&self.net, owner);
        let region = format!("Do#{id} at {at}");
        let live = self.place_at(
            format!("live {region}"),
            PlaceKind::Region {
                region: id,
                interrupted: false,
            },
            span,
            depth,
        );
        self.net.arc(do_start, live, ColourOp::Keep);
        let kill = self.place_at(format!("kill {region}"), PlaceKind::Control, span, depth);
        self.net.arc(interrupt, kill, ColourOp::Keep);
        let flip = self.transition(
            format!("cancel {region}"),
            TransitionKind::Silent,
            owner,
            span,
            None,
        );
        self.net.arc(live, flip, ColourOp::Keep);
        self.net.arc(kill, flip, ColourOp::Keep);
        let cancelled = self.place_at(
            format!("cancelled {region}"),
            PlaceKind::Region {
                region: id,
                interrupted: true,
            },
            span,
            depth,
        );
        self.net.arc(flip, cancelled, ColourOp::Keep);
        let killed = self.place_at(format!("killed {region}"), PlaceKind::Control, span, depth);
        self.net.arc(flip, killed, ColourOp::Keep);
        self.dos[i].remote.insert(
            owner,
            Remote {
                live,
                cancelled,
                killed,
            },
        );
        (live, cancelled)
    }

    /// An observable step may fire only while no enclosing region has been
    /// cancelled at its owner.
    fn read_live(&mut self, t: NodeId, owner: Owner) {
        for i in 0..self.dos.len() {
            let (live, _) = self.region_state(i, owner);
            self.net.read_arc(live, t);
        }
    }

    /// Per enclosing region, a transition that moves the token from `input`
    /// to `skip_to` once that region is cancelled at `owner`.
    fn skip_twins(
        &mut self,
        input: NodeId,
        owner: Owner,
        skip_to: NodeId,
        colour: ColourOp,
        what: &str,
        span: Span,
    ) {
        for i in 0..self.dos.len() {
            let (_, cancelled) = self.region_state(i, owner);
            let twin = self.transition(
                format!("skip {what}"),
                TransitionKind::Skip,
                owner,
                span,
                None,
            );
            self.net.arc(input, twin, ColourOp::Keep);
            self.net.read_arc(cancelled, twin);
            self.net.arc(twin, skip_to, colour);
        }
    }

    // ---- events and owners -----------------------------------------------

    fn events(&mut self) {
        let awaits = std::mem::take(&mut self.awaits);
        for (event, sites) in &awaits {
            let signals = self.signals.get(event).cloned().unwrap_or_default();
            for site in sites {
                for &signal in &signals {
                    let inbox =
                        self.place_at(format!("inbox {event:?}"), PlaceKind::Control, site.span, 0);
                    self.net.arc(signal, inbox, ColourOp::Plain);
                    let first = self.transition(
                        format!("absorb {event:?}"),
                        TransitionKind::Silent,
                        site.owner,
                        site.span,
                        None,
                    );
                    self.net.arc(inbox, first, ColourOp::Plain);
                    self.net.arc(site.pending, first, ColourOp::Plain);
                    self.net.arc(first, site.event, ColourOp::Plain);
                    let again = self.transition(
                        format!("absorb {event:?} again"),
                        TransitionKind::Silent,
                        site.owner,
                        site.span,
                        None,
                    );
                    self.net.arc(inbox, again, ColourOp::Plain);
                    self.net.read_arc(site.event, again);
                }
            }
        }
    }

    /// A place lives where the transitions that consume or read it live.
    fn assign_place_owners(&mut self) {
        let places: Vec<NodeId> = self.net.places().map(|(n, _)| n).collect();
        for p in places {
            if p == self.net.initial_place {
                continue;
            }
            let mut owners: Vec<Owner> = self
                .net
                .consumers(p)
                .map(|(t, _)| self.net.owner(t))
                .filter(|o| *o != Owner::Unassigned)
                .collect();
            owners.sort();
            owners.dedup();
            if let [only] = owners[..] {
                if let Some(crate::Node::Place(place)) = self.net.graph.node_weight_mut(p) {
                    place.owner = only;
                }
            }
        }
    }
}

fn unit_suffix(kind: eamos_profile::ParamKind) -> &'static str {
    use eamos_profile::ParamKind;
    match kind {
        ParamKind::Metres => " m",
        ParamKind::Seconds => " s",
        ParamKind::Degrees => "°",
        ParamKind::Percent => " %",
        ParamKind::Number | ParamKind::Drone => "",
    }
}
