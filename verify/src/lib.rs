//! Proves properties of a mission net before anything flies: deadlock
//! freedom, termination, 1-safety, dead actions, drone conflicts and
//! conditions that can never or always hold.
//!
//! The checker works on the P/T skeleton of the coloured net (guards may
//! hold or not, colours and time are ignored, see [`mission`]) and explores
//! its reachable markings breadth-first with stubborn sets ([`explore`]
//! states what the reduction preserves and why). [`check`] says which
//! property is decided how; asked only about deadlocks, it first shrinks
//! the net with structural rules (`reduce`) and maps what it finds back. Counterexamples are firing sequences from the
//! initial marking, named in mission terms and with the transitions' ids so
//! that the token game can replay them.
//!
//! It never runs an adapter or touches the network, and never reports a
//! property as holding when its exploration stopped short (the report
//! says the property is undecided).
//!
//! ```no_run
//! # fn demo(net: &eamos_petri::Net, profiles: &eamos_profile::ProfileTable, text: &str) {
//! let report = eamos_verify::check_net(net, profiles, Some(text), &eamos_verify::Options::default());
//! if report.found_something() { /* findings, with counterexamples */ }
//! # }
//! ```

pub mod check;
pub mod conditions;
mod explore;
mod fold;
mod invariants;
mod mission;
mod names;
pub mod plan;
pub mod pnml;
mod ptnet;
mod reduce;
mod relation;
pub mod report;
mod space;
mod structural;
#[cfg(test)]
mod testnet;

pub use check::{Goal, Options};
pub use plan::{plan, Plan, PlannedLeg};
pub use pnml::{PnmlError, PnmlNet};
pub use report::{
    Finding, FindingKind, GeoLeg, Geometry, InputKind, Label, Limit, Property, PropertyResult,
    Report, Stats, Step, Trace, Verdict,
};
pub use space::{default_home, Space};

use eamos_petri::Net;
use eamos_profile::ProfileTable;

/// Checks the net of a mission. `source` is the mission text the spans point
/// into: it names the structures in counterexamples (`If`, `RepeatWhile`).
pub fn check_net(
    net: &Net,
    profiles: &ProfileTable,
    source: Option<&str>,
    options: &Options,
) -> Report {
    let space = options.spatial.then(|| {
        options
            .space
            .clone()
            .unwrap_or_else(|| Space::default_for(net.drones.len()))
    });
    let relation = options.goal == Goal::All;
    let subject = |fold| mission::subject(net, profiles, source, space.as_ref(), fold, relation);
    let folded = subject(options.structural);
    let loops = folded.folded;
    let mut report = check::check(folded, options);
    if loops == 0 {
        return report;
    }
    if fold::proves(&report) {
        fold::note(&mut report, loops);
        return report;
    }
    // Something to show, or undecided: the counted net answers, and its
    // counterexamples replay as they are.
    check::check(subject(false), options)
}

/// Checks a plain P/T net read from PNML: deadlock, termination (when a
/// place marks the end) and safeness/boundedness.
pub fn check_pnml(net: &PnmlNet, options: &Options) -> Report {
    check::check(pnml::subject(net), options)
}

/// A progress bar on standard error for long explorations. Returns `None`
/// when standard error is not a terminal.
pub fn terminal_progress() -> Option<std::sync::Arc<dyn Fn(usize, usize) + Send + Sync>> {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    let started = std::time::Instant::now();
    Some(std::sync::Arc::new(
        move |states: usize, expanded: usize| {
            // Quiet for quick checks: only runs past half a second show a bar.
            if started.elapsed().as_millis() < 500 {
                return;
            }
            bar.set_message(format!("{states} states, {expanded} expanded"));
            bar.tick();
            if expanded >= states {
                bar.finish_and_clear();
            }
        },
    ))
}
