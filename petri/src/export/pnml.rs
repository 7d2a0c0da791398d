//! PNML (ISO/IEC 15909-2) in its place/transition net grammar, which model
//! checkers and process-mining tools read.
//!
//! The P/T view drops what that grammar cannot say, and keeps it for readers
//! that know better in `toolspecific` elements (tool `eamos`):
//! * **Colours are dropped.** Every place is a P/T place and a token is a
//!   black token. This is sound for the control structure because the net
//!   is 1-safe and colours never decide which places get marked: they only
//!   count loop iterations. The colour guards of `RepeatFor` become free
//!   choice in the P/T view (the loop may iterate or leave at any time), an
//!   over-approximation: every behaviour of the coloured net is one of the
//!   P/T net, not the other way round. Place depths, arc colour functions
//!   and guards are kept as tool-specific data.
//! * **Read arcs** become a pair of arcs, place -> transition (id `aN`,
//!   marked `<read/>`) and transition -> place (id `aNr`, marked
//!   `<readReturn of="aN"/>`): in a P/T net a test arc is a self-loop. A
//!   reader that knows read arcs takes the arc marked `<read/>` as one read
//!   arc and drops its `readReturn` partner; a plain P/T reader gets the
//!   self-loop, which has the same reachable markings.
//! * **Guards**, owners, kinds, actions, delays and source spans are
//!   tool-specific data of each node.
//!
//! The final place keeps the id `final`. With [`PnmlOptions::final_loop`]
//! a transition `final_loop` consumes and reproduces its token, so that a
//! model checker looking for deadlocks tells proper termination (which then
//! is not a deadlock) from a stuck mission (which still is).

use std::fmt::Write as _;

use eamos_lang::Span;

use super::{colour_op_name, guard_text, owner_label, place_kind_name, transition_kind_name, xml};
use crate::net::{ActionRef, ArcKind, ColourOp, Net, PlaceKind};

/// The PNML grammar of place/transition nets.
pub const PTNET_TYPE: &str = "http://www.pnml.org/version-2009/grammar/ptnet";
/// The PNML namespace.
pub const PNML_NAMESPACE: &str = "http://www.pnml.org/version-2009/grammar/pnml";
/// The `tool` attribute of this crate's `toolspecific` elements.
pub const TOOL: &str = "eamos";
/// The id of the optional self-loop on the final place.
pub const FINAL_LOOP_ID: &str = "final_loop";

#[derive(Default, Clone, Copy)]
pub struct PnmlOptions<'a> {
    /// Add the transition `final_loop` on the place `final`.
    pub final_loop: bool,
    /// Turns a span into `file:line:col` (for example
    /// `|s| source.location(s)`); without it spans are written as byte
    /// offsets only.
    pub locate: Option<&'a dyn Fn(Span) -> String>,
}

/// How many places, transitions and arcs the P/T view of `net` has: read
/// arcs count twice, the final loop adds one transition and two arcs.
pub fn pt_counts(net: &Net, opts: &PnmlOptions<'_>) -> (usize, usize, usize) {
    let places = net.places().count();
    let transitions = net.transitions().count() + usize::from(opts.final_loop);
    let arcs = net
        .arcs()
        .map(|(_, _, a)| if a.kind == ArcKind::Read { 2 } else { 1 })
        .sum::<usize>()
        + 2 * usize::from(opts.final_loop);
    (places, transitions, arcs)
}

/// The net as a PNML document.
pub fn to_pnml(net: &Net, opts: &PnmlOptions<'_>) -> String {
    let version = env!("CARGO_PKG_VERSION");
    let tool = format!("<toolspecific tool=\"{TOOL}\" version=\"{version}\">");
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>");
    let _ = writeln!(w, "<pnml xmlns=\"{PNML_NAMESPACE}\">");
    let _ = writeln!(w, "  <net id=\"net\" type=\"{PTNET_TYPE}\">");
    let _ = writeln!(w, "    <name><text>{}</text></name>", xml(&net.name));
    let _ = writeln!(w, "    {tool}");
    for (i, (name, profile)) in net.drones.iter().zip(&net.profiles).enumerate() {
        let _ = writeln!(
            w,
            "      <drone id=\"{i}\" name=\"{}\" profile=\"{}\"/>",
            xml(name),
            xml(profile)
        );
    }
    let _ = writeln!(w, "      <colours dropped=\"true\"/>");
    let _ = writeln!(w, "    </toolspecific>");
    let _ = writeln!(w, "    <page id=\"page\">");

    let initially: std::collections::BTreeSet<_> = net.initial_marking.iter().collect();
    for (n, p) in net.places() {
        let _ = writeln!(w, "      <place id=\"{}\">", xml(&p.id));
        let _ = writeln!(w, "        <name><text>{}</text></name>", xml(&p.label));
        if initially.contains(&n) {
            let _ = writeln!(w, "        <initialMarking><text>1</text></initialMarking>");
        }
        let _ = writeln!(w, "        {tool}");
        let _ = writeln!(
            w,
            "          <owner>{}</owner>",
            xml(&owner_label(net, p.owner))
        );
        let _ = writeln!(w, "          <kind>{}</kind>", place_kind_name(&p.kind));
        let _ = writeln!(w, "          <depth>{}</depth>", p.depth);
        if n == net.final_place {
            let _ = writeln!(w, "          <final/>");
        }
        match &p.kind {
            PlaceKind::Running(a) => write_action(w, net, a),
            PlaceKind::Event(e) | PlaceKind::EventPending(e) => {
                let _ = writeln!(w, "          <event>{}</event>", xml(e));
            }
            PlaceKind::Region {
                region,
                interrupted,
            } => {
                let _ = writeln!(
                    w,
                    "          <region id=\"{region}\" interrupted=\"{interrupted}\"/>"
                );
            }
            _ => {}
        }
        if let Some(s) = p.span {
            write_span(w, s, opts);
        }
        let _ = writeln!(w, "        </toolspecific>");
        let _ = writeln!(w, "      </place>");
    }

    for (_, t) in net.transitions() {
        let _ = writeln!(w, "      <transition id=\"{}\">", xml(&t.id));
        let _ = writeln!(w, "        <name><text>{}</text></name>", xml(&t.label));
        let _ = writeln!(w, "        {tool}");
        let _ = writeln!(
            w,
            "          <owner>{}</owner>",
            xml(&owner_label(net, t.owner))
        );
        let _ = writeln!(
            w,
            "          <kind>{}</kind>",
            transition_kind_name(&t.kind)
        );
        if let Some(a) = t.kind.action() {
            write_action(w, net, a);
        }
        if let Some(g) = guard_text(net, t) {
            let _ = writeln!(w, "          <guard>{}</guard>", xml(&g));
        }
        if let Some(d) = t.delay {
            let _ = writeln!(w, "          <delay unit=\"s\">{d}</delay>");
        }
        write_span(w, t.span, opts);
        let _ = writeln!(w, "        </toolspecific>");
        let _ = writeln!(w, "      </transition>");
    }
    let final_id = net.id(net.final_place).to_string();
    if opts.final_loop {
        let _ = writeln!(w, "      <transition id=\"{FINAL_LOOP_ID}\">");
        let _ = writeln!(w, "        <name><text>mission ended</text></name>");
        let _ = writeln!(w, "        {tool}<kind>final-loop</kind></toolspecific>");
        let _ = writeln!(w, "      </transition>");
    }

    for e in net.graph.edge_indices() {
        let Some((from, to)) = net.graph.edge_endpoints(e) else {
            continue;
        };
        let arc = net.graph[e];
        let (src, dst) = (xml(net.id(from)), xml(net.id(to)));
        let id = format!("a{}", e.index());
        match arc.kind {
            ArcKind::Read => {
                write_arc(w, &id, &src, &dst, 1, &tool, Some("<read/>"));
                let back = format!("{id}r");
                let mark = format!("<readReturn of=\"{id}\"/>");
                write_arc(w, &back, &dst, &src, 1, &tool, Some(&mark));
            }
            ArcKind::Consume | ArcKind::Produce => {
                let colour = (arc.colour != ColourOp::Keep)
                    .then(|| format!("<colour>{}</colour>", colour_op_name(arc.colour)));
                write_arc(w, &id, &src, &dst, arc.weight, &tool, colour.as_deref());
            }
        }
    }
    if opts.final_loop {
        let fin = xml(&final_id);
        write_arc(w, "final_loop_in", &fin, FINAL_LOOP_ID, 1, &tool, None);
        write_arc(w, "final_loop_out", FINAL_LOOP_ID, &fin, 1, &tool, None);
    }
    let _ = writeln!(w, "    </page>");
    let _ = writeln!(w, "  </net>");
    let _ = writeln!(w, "</pnml>");
    out
}

fn write_arc(
    w: &mut String,
    id: &str,
    src: &str,
    dst: &str,
    weight: u32,
    tool: &str,
    extra: Option<&str>,
) {
    let _ = write!(
        w,
        "      <arc id=\"{id}\" source=\"{src}\" target=\"{dst}\">"
    );
    if weight > 1 {
        let _ = write!(w, "<inscription><text>{weight}</text></inscription>");
    }
    if let Some(x) = extra {
        let _ = write!(w, "{tool}{x}</toolspecific>");
    }
    let _ = writeln!(w, "</arc>");
}

fn write_action(w: &mut String, net: &Net, a: &ActionRef) {
    let _ = write!(
        w,
        "          <action drone=\"{}\" name=\"{}\" instance=\"{}\">",
        xml(&owner_label(net, crate::Owner::Drone(a.drone))),
        xml(&a.name),
        a.instance
    );
    for v in &a.args {
        let _ = write!(w, "<arg>{v}</arg>");
    }
    let _ = writeln!(w, "</action>");
}

fn write_span(w: &mut String, s: Span, opts: &PnmlOptions<'_>) {
    let _ = write!(w, "          <span start=\"{}\" end=\"{}\"", s.start, s.end);
    if let Some(locate) = opts.locate {
        let _ = write!(w, " location=\"{}\"", xml(&locate(s)));
    }
    let _ = writeln!(w, "/>");
}
