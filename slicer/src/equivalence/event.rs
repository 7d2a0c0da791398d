//! What a firing shows to the world. A drone team is judged by what it
//! does, so an event names who does it and what exactly: two slicings that
//! run the same action on different drones, decide a condition on another
//! drone or with the opposite outcome, or time a pause differently, differ.

use std::sync::Arc;

use eamos_petri::net::{GuardKind, Net, Owner, Transition, TransitionKind};
use eamos_petri::pretty;

/// The step of an action instance a firing takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Step {
    Start,
    End,
    Cancel,
}

/// A visible event. Colours are the loop counters of the firing (outermost
/// first), so each round of a loop is its own event.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Event {
    /// An action instance starts, ends or is cancelled. `action` is the
    /// action as the mission wrote it (`D1.FlyByX(2.5)`), `by` the owner
    /// whose slice runs the step: a drone can only fly itself.
    Action {
        step: Step,
        instance: u32,
        action: Arc<str>,
        by: Arc<str>,
        colour: Vec<u8>,
    },
    /// A condition over drone state was decided: `cond` as the mission
    /// wrote it, `holds` whether the firing needs it to hold (`false` for
    /// the complement of a branch), `by` the owner that evaluates it, where
    /// the condition reads a drone (the language evaluates a condition where
    /// the state it reads lives; a constant may be decided anywhere).
    Guard {
        cond: Arc<str>,
        holds: bool,
        by: Option<Arc<str>>,
        colour: Vec<u8>,
    },
    /// A timed step (`PauseFor`) waited `seconds`.
    Delay { seconds: Arc<str>, colour: Vec<u8> },
    /// The mission has ended.
    Final,
    /// Nothing can happen any more and the mission has not ended.
    Deadlock,
}

impl std::fmt::Display for Event {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Event::Action {
                step,
                instance,
                action,
                by,
                colour,
            } => write!(f, "{step:?} #{instance} {action} on {by} {colour:?}"),
            Event::Guard {
                cond,
                holds,
                by,
                colour,
            } => {
                let not = if *holds { "" } else { "not " };
                let by = by.as_deref().unwrap_or("anyone");
                write!(f, "{not}[{cond}] by {by} {colour:?}")
            }
            Event::Delay { seconds, colour } => write!(f, "wait {seconds} s {colour:?}"),
            Event::Final => write!(f, "final"),
            Event::Deadlock => write!(f, "deadlock"),
        }
    }
}

/// An event without its colour: what a transition shows whenever it fires.
#[derive(Debug, Clone)]
pub(super) enum Label {
    Action {
        step: Step,
        instance: u32,
        action: Arc<str>,
        by: Arc<str>,
    },
    Guard {
        cond: Arc<str>,
        holds: bool,
        by: Option<Arc<str>>,
    },
    Delay(Arc<str>),
}

impl Label {
    /// The label of transition `v`, `None` for a silent one. Colour guards
    /// (`RepeatFor`'s counters) stay silent: the net decides them itself and
    /// the explorer decides them exactly.
    pub fn of(net: &Net, t: &Transition) -> Option<Label> {
        let runner = || Arc::<str>::from(net.owner_name(t.owner));
        let step = match &t.kind {
            TransitionKind::ActionStart(_) => Some(Step::Start),
            TransitionKind::ActionEnd(_) => Some(Step::End),
            TransitionKind::ActionCancel(_) => Some(Step::Cancel),
            _ => None,
        };
        if let (Some(step), Some(a)) = (step, t.kind.action()) {
            let args: Vec<String> = a.args.iter().map(|&x| pretty::number(x)).collect();
            let drone = net.owner_name(Owner::Drone(a.drone));
            return Some(Label::Action {
                step,
                instance: a.instance,
                action: format!("{drone}.{}({})", a.name, args.join(", ")).into(),
                by: runner(),
            });
        }
        if let Some(GuardKind::Cond { cond, negated }) = t.guard.as_ref().map(|g| &g.kind) {
            return Some(Label::Guard {
                cond: pretty::expr(cond, &net.drones).into(),
                holds: !negated,
                by: (!cond.drones().is_empty()).then(runner),
            });
        }
        t.delay.map(|s| Label::Delay(pretty::number(s).into()))
    }

    pub fn event(&self, colour: Vec<u8>) -> Event {
        match self {
            Label::Action {
                step,
                instance,
                action,
                by,
            } => Event::Action {
                step: *step,
                instance: *instance,
                action: action.clone(),
                by: by.clone(),
                colour,
            },
            Label::Guard { cond, holds, by } => Event::Guard {
                cond: cond.clone(),
                holds: *holds,
                by: by.clone(),
                colour,
            },
            Label::Delay(seconds) => Event::Delay {
                seconds: seconds.clone(),
                colour,
            },
        }
    }
}
