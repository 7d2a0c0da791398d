//! Writing a net for other tools: PNML for model checkers and process-mining
//! tools, DOT and GraphML for people.
//!
//! The drawings colour every node by its owner the way the paper draws its
//! mission graphs: one colour per drone (yellow for the first, green for the
//! second, orange for the third, then a palette), grey for the ground
//! station, white for what the slicer has yet to place.

pub mod dot;
pub mod graphml;
pub mod pnml;

use crate::net::{ColourOp, GuardKind, Net, Owner, PlaceKind, Transition, TransitionKind};
use crate::pretty;

/// Fill colours of drones 1, 2, 3, ...: the first three as in the paper,
/// then colours that stay apart from them and from grey and white.
pub const DRONE_PALETTE: &[&str] = &[
    "#ffe066", "#8cd47e", "#ff8c5a", "#7ec8e3", "#c3a6e8", "#f7a8c4", "#6fd6c0", "#d9b38c",
];
/// Fill colour of the ground station's nodes.
pub const GCS_COLOUR: &str = "#bdbdbd";
/// Fill colour of nodes the slicer places.
pub const UNASSIGNED_COLOUR: &str = "#ffffff";

/// The fill colour of an owner (the palette repeats after eight drones).
pub fn owner_colour(owner: Owner) -> &'static str {
    match owner {
        Owner::Gcs => GCS_COLOUR,
        Owner::Unassigned => UNASSIGNED_COLOUR,
        Owner::Drone(d) => DRONE_PALETTE[d.0 as usize % DRONE_PALETTE.len()],
    }
}

/// The owner as a person names it; unlike [`Net::owner_name`] this never
/// fails on a drone id the net does not know.
pub fn owner_label(net: &Net, owner: Owner) -> String {
    match owner {
        Owner::Gcs => "GCS".into(),
        Owner::Unassigned => "unassigned".into(),
        Owner::Drone(d) => pretty::drone_name(&net.drones, d),
    }
}

/// A short, stable name of a transition kind for exports.
pub fn transition_kind_name(kind: &TransitionKind) -> &'static str {
    match kind {
        TransitionKind::Init => "init",
        TransitionKind::ActionStart(_) => "action-start",
        TransitionKind::ActionEnd(_) => "action-end",
        TransitionKind::ActionCancel(_) => "action-cancel",
        TransitionKind::Skip => "skip",
        TransitionKind::Fork => "fork",
        TransitionKind::Join => "join",
        TransitionKind::Branch => "branch",
        TransitionKind::Merge => "merge",
        TransitionKind::LoopBack => "loop-back",
        TransitionKind::Pause => "pause",
        TransitionKind::Signal => "signal",
        TransitionKind::Await => "await",
        TransitionKind::Interrupt => "interrupt",
        TransitionKind::Finish => "finish",
        TransitionKind::Silent => "silent",
    }
}

/// A short, stable name of a place kind for exports.
pub fn place_kind_name(kind: &PlaceKind) -> &'static str {
    match kind {
        PlaceKind::Initial => "initial",
        PlaceKind::Control => "control",
        PlaceKind::Running(_) => "running",
        PlaceKind::Event(_) => "event",
        PlaceKind::EventPending(_) => "event-pending",
        PlaceKind::Region { .. } => "region",
        PlaceKind::Final => "final",
    }
}

pub fn colour_op_name(op: ColourOp) -> &'static str {
    match op {
        ColourOp::Keep => "keep",
        ColourOp::Enter => "enter",
        ColourOp::Next => "next",
        ColourOp::Leave => "leave",
        ColourOp::Plain => "plain",
    }
}

/// The guard as mission text: `D3.X() > 5`, `!(D3.X() > 5)`,
/// `iteration < 3`, `iteration >= 3`.
pub fn guard_text(net: &Net, t: &Transition) -> Option<String> {
    let g = t.guard.as_ref()?;
    Some(match &g.kind {
        GuardKind::Cond { cond, negated } => {
            let c = pretty::expr(cond, &net.drones);
            if *negated {
                format!("!({c})")
            } else {
                c
            }
        }
        GuardKind::IterationBelow(n) => format!("iteration < {n}"),
        GuardKind::IterationAtLeast(n) => format!("iteration >= {n}"),
    })
}

/// Text safe inside XML 1.0 elements and attributes: markup characters are
/// escaped and characters XML 1.0 cannot carry at all (most control
/// characters) become U+FFFD, so any event name or label yields a
/// well-formed document.
pub fn xml(s: &str) -> String {
    let clean: String = s
        .chars()
        .map(|c| match c {
            '\t' | '\n' | '\r' => c,
            c if (c as u32) < 0x20 || c == '\u{fffe}' || c == '\u{ffff}' => '\u{fffd}',
            c => c,
        })
        .collect();
    quick_xml::escape::escape(clean.as_str()).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xml_text_escapes_markup_and_replaces_what_xml_cannot_carry() {
        assert_eq!(
            xml("a<b & \"c\" 'd'>"),
            "a&lt;b &amp; &quot;c&quot; &apos;d&apos;&gt;"
        );
        assert_eq!(xml("x\u{1}y\tz"), "x\u{fffd}y\tz");
    }

    #[test]
    fn the_first_three_drones_have_the_paper_colours_and_the_palette_repeats() {
        use eamos_lang::hir::DroneId;
        assert_eq!(owner_colour(Owner::Drone(DroneId(0))), "#ffe066");
        assert_eq!(
            owner_colour(Owner::Drone(DroneId(8))),
            owner_colour(Owner::Drone(DroneId(0)))
        );
        assert_eq!(owner_colour(Owner::Gcs), GCS_COLOUR);
        assert_eq!(owner_colour(Owner::Unassigned), UNASSIGNED_COLOUR);
    }
}
