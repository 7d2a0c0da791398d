//! The exports carry the whole net: a PNML reader finds the same places,
//! transitions and arcs (read arcs as pairs), the same initial marking and
//! the final place; DOT renders with Graphviz; GraphML is well-formed and
//! complete. Names that need escaping stay intact.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::process::{Command, Stdio};

use common::*;
use eamos_petri::export::dot::to_dot;
use eamos_petri::export::graphml::to_graphml;
use eamos_petri::export::pnml::{pt_counts, to_pnml, PnmlOptions, PTNET_TYPE};
use eamos_petri::export::{owner_colour, owner_label};
use eamos_petri::net::{ArcKind, Net};
use eamos_petri::stats::stats;

/// What a PNML document says, read back.
struct ReadBack {
    places: BTreeMap<String, (String, u32)>,
    transitions: BTreeMap<String, String>,
    arcs: Vec<(String, String, u32)>,
    guards: usize,
}

fn read_pnml(text: &str) -> ReadBack {
    let root = parse_xml(text);
    assert_eq!(root.name, "pnml");
    let nets: Vec<_> = root.children_named("net").collect();
    assert_eq!(nets.len(), 1);
    assert_eq!(nets[0].attr("type"), Some(PTNET_TYPE));
    let page = nets[0].child("page").expect("a page");
    let mut out = ReadBack {
        places: BTreeMap::new(),
        transitions: BTreeMap::new(),
        arcs: Vec::new(),
        guards: 0,
    };
    let mut ids = BTreeSet::new();
    for el in &page.children {
        let id = el
            .attr("id")
            .expect("every node and arc has an id")
            .to_string();
        assert!(ids.insert(id.clone()), "duplicate id {id}");
        let name = el
            .child("name")
            .and_then(|n| n.child("text"))
            .map(|t| t.text.clone())
            .unwrap_or_default();
        match el.name.as_str() {
            "place" => {
                let tokens = el
                    .child("initialMarking")
                    .map(|m| m.child("text").unwrap().text.trim().parse().unwrap())
                    .unwrap_or(0);
                out.places.insert(id, (name, tokens));
            }
            "transition" => {
                out.guards += el
                    .descendants()
                    .iter()
                    .filter(|e| e.name == "guard")
                    .count();
                out.transitions.insert(id, name);
            }
            "arc" => {
                let weight = el
                    .child("inscription")
                    .map(|i| i.child("text").unwrap().text.trim().parse().unwrap())
                    .unwrap_or(1);
                out.arcs.push((
                    el.attr("source").unwrap().to_string(),
                    el.attr("target").unwrap().to_string(),
                    weight,
                ));
            }
            other => panic!("unexpected element {other} in the page"),
        }
    }
    out
}

fn nets() -> Vec<(String, Net)> {
    let mut v: Vec<(String, Net)> = PAPER.iter().map(|s| (s.to_string(), paper(s).1)).collect();
    v.push(("showcase".into(), showcase()));
    v
}

#[test]
fn pnml_round_trips_places_transitions_arcs_and_the_initial_marking() {
    for (name, net) in nets() {
        for final_loop in [false, true] {
            let opts = PnmlOptions {
                final_loop,
                locate: None,
            };
            let back = read_pnml(&to_pnml(&net, &opts));
            let reads = net
                .arcs()
                .filter(|(_, _, a)| a.kind == ArcKind::Read)
                .count();
            let arcs = net.arcs().count() + reads + 2 * usize::from(final_loop);
            let transitions = net.transitions().count() + usize::from(final_loop);
            assert_eq!(back.places.len(), net.places().count(), "{name}");
            assert_eq!(back.transitions.len(), transitions, "{name}");
            assert_eq!(back.arcs.len(), arcs, "{name}");
            assert_eq!(
                pt_counts(&net, &opts),
                (back.places.len(), back.transitions.len(), back.arcs.len())
            );
            // Same labels, same initial marking.
            for (_, p) in net.places() {
                assert_eq!(back.places[p.id.as_str()].0, p.label, "{name}");
            }
            for (_, t) in net.transitions() {
                assert_eq!(back.transitions[t.id.as_str()], t.label, "{name}");
            }
            let marked: BTreeSet<&str> = back
                .places
                .iter()
                .filter(|(_, (_, n))| *n > 0)
                .map(|(id, _)| id.as_str())
                .collect();
            let expected: BTreeSet<&str> = net.initial_marking.iter().map(|&p| net.id(p)).collect();
            assert_eq!(marked, expected, "{name}");
            // Every arc joins a place and a transition, with weight one.
            for (s, t, w) in &back.arcs {
                let pt = back.places.contains_key(s) && back.transitions.contains_key(t);
                let tp = back.transitions.contains_key(s) && back.places.contains_key(t);
                assert!(pt || tp, "{name}: arc {s} -> {t}");
                assert_eq!(*w, 1);
            }
            assert!(back.places.contains_key("final"));
            let loops = back
                .arcs
                .iter()
                .filter(|(s, t, _)| {
                    (s == "final" && t == "final_loop") || (s == "final_loop" && t == "final")
                })
                .count();
            assert_eq!(loops, if final_loop { 2 } else { 0 }, "{name}");
            let guarded = net.transitions().filter(|(_, t)| t.guard.is_some()).count();
            assert_eq!(back.guards, guarded, "{name}");
        }
    }
}

#[test]
fn pnml_keeps_owners_guards_and_source_locations_as_tool_specific_data() {
    let (file, net) = paper("experiment_d");
    let locate = |s: eamos_lang::Span| file.location(s);
    let text = to_pnml(
        &net,
        &PnmlOptions {
            final_loop: false,
            locate: Some(&locate),
        },
    );
    let root = parse_xml(&text);
    let all = root.descendants();
    let guard = all
        .iter()
        .find(|e| e.name == "guard")
        .expect("a guard")
        .text
        .clone();
    assert!(guard.contains("D3.X() > -30 && D3.X() < 30"), "{guard}");
    let tool = all
        .iter()
        .filter(|e| e.name == "toolspecific")
        .map(|e| e.attr("tool"))
        .collect::<BTreeSet<_>>();
    assert_eq!(tool, BTreeSet::from([Some("eamos")]));
    let locations: Vec<&str> = all
        .iter()
        .filter(|e| e.name == "span")
        .filter_map(|e| e.attr("location"))
        .collect();
    assert!(locations.iter().all(|l| l.starts_with("experiment_d.go:")));
    assert!(
        locations
            .iter()
            .any(|l| l.starts_with("experiment_d.go:13:")),
        "D1.Arm() on line 13"
    );
    let owners: BTreeSet<&str> = all
        .iter()
        .filter(|e| e.name == "owner")
        .map(|e| e.text.as_str())
        .collect();
    assert_eq!(
        owners,
        BTreeSet::from(["D1", "D2", "D3", "GCS", "unassigned"])
    );
}

#[test]
fn names_that_need_escaping_survive_every_export() {
    let net = showcase();
    let pnml = to_pnml(&net, &PnmlOptions::default());
    let root = parse_xml(&pnml);
    let net_el = root.child("net").unwrap();
    assert_eq!(
        net_el.child("name").unwrap().child("text").unwrap().text,
        "Show<case> & \"more\""
    );
    let events: BTreeSet<String> = root
        .descendants()
        .into_iter()
        .filter(|e| e.name == "event")
        .map(|e| e.text.clone())
        .collect();
    // The control character cannot be carried by XML 1.0 at all.
    assert_eq!(
        events,
        BTreeSet::from(["go \"now\" <&>\u{fffd}".to_string()])
    );
    let drones: Vec<&str> = root
        .descendants()
        .into_iter()
        .filter(|e| e.name == "drone")
        .filter_map(|e| e.attr("name"))
        .collect();
    assert_eq!(drones, ["D<1>", "D&2"]);
    let graphml = parse_xml(&to_graphml(&net));
    assert_eq!(graphml.name, "graphml");
}

#[test]
fn graphml_has_every_node_and_arc_coloured_by_its_owner() {
    for (name, net) in nets() {
        let root = parse_xml(&to_graphml(&net));
        let graph = root.child("graph").unwrap();
        let nodes: Vec<_> = graph.children_named("node").collect();
        let edges: Vec<_> = graph.children_named("edge").collect();
        assert_eq!(nodes.len(), net.graph.node_count(), "{name}");
        assert_eq!(edges.len(), net.graph.edge_count(), "{name}");
        let data = |el: &common::Element, key: &str| {
            el.children_named("data")
                .find(|d| d.attr("key") == Some(key))
                .map(|d| d.text.clone())
        };
        for n in &nodes {
            let id = n.attr("id").unwrap();
            let node = net.find(id).unwrap();
            let owner = net.owner(node);
            assert_eq!(data(n, "fill").as_deref(), Some(owner_colour(owner)));
            assert_eq!(data(n, "owner"), Some(owner_label(&net, owner)));
            let shape = if net.is_place(node) {
                "ellipse"
            } else {
                "rectangle"
            };
            assert_eq!(data(n, "shape").as_deref(), Some(shape));
        }
        let dashed = edges
            .iter()
            .filter(|e| data(e, "style").as_deref() == Some("dashed"))
            .count();
        let reads = net
            .arcs()
            .filter(|(_, _, a)| a.kind == ArcKind::Read)
            .count();
        assert_eq!(dashed, reads, "{name}");
    }
}

fn render_svg(dot: &str) -> String {
    let mut child = Command::new("dot")
        .arg("-Tsvg")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("Graphviz `dot` must be installed to render nets (scripts/test installs it)");
    use std::io::Write;
    child
        .stdin
        .take()
        .unwrap()
        .write_all(dot.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "dot failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_dot_drawing_of_experiment_b_renders_with_graphviz() {
    let (_, net) = paper("experiment_b");
    let svg = render_svg(&to_dot(&net));
    assert!(svg.contains("<svg"));
    // Drone1 yellow, Drone2 green, the ground station grey.
    for colour in ["#ffe066", "#8cd47e", "#bdbdbd"] {
        assert!(svg.contains(colour), "missing {colour}");
    }
    assert!(svg.contains("Drone1.Takeoff(1.5 m)"));
}

#[test]
fn the_dot_drawing_dashes_read_arcs_and_escapes_names() {
    let net = showcase();
    let dot = to_dot(&net);
    let reads = net
        .arcs()
        .filter(|(_, _, a)| a.kind == ArcKind::Read)
        .count();
    assert_eq!(dot.matches("style=dashed").count(), reads);
    let svg = render_svg(&dot);
    assert!(svg.contains("D&amp;2") || svg.contains("D&#38;2"));
}

#[test]
fn statistics_add_up_and_serialise_to_json() {
    for (name, net) in nets() {
        let s = stats(&net);
        let sum =
            |f: fn(&eamos_petri::stats::Counts) -> usize| s.owners.iter().map(f).sum::<usize>();
        assert_eq!(sum(|c| c.places), s.total.places, "{name}");
        assert_eq!(sum(|c| c.transitions), s.total.transitions, "{name}");
        assert_eq!(sum(|c| c.arcs), s.total.arcs, "{name}");
        assert_eq!(s.total.places, net.places().count());
        assert_eq!(s.total.transitions, net.transitions().count());
        assert_eq!(s.total.arcs, net.graph.edge_count());
        let json = serde_json::to_string(&s).unwrap();
        let back: eamos_petri::stats::NetStats = serde_json::from_str(&json).unwrap();
        assert_eq!(back, s);
        let table = s.to_string();
        assert!(table.lines().any(|l| l.starts_with("total")));
    }
    let (_, b) = paper("experiment_b");
    let s = stats(&b);
    let owners: Vec<&str> = s.owners.iter().map(|c| c.owner.as_str()).collect();
    assert_eq!(owners, ["Drone1", "Drone2", "GCS", "unassigned"]);
}

#[test]
fn a_malformed_mission_naming_an_unknown_drone_compiles_and_exports_without_panicking() {
    use eamos_lang::hir::CondMode;
    // Drone 9 does not exist: the front end never produces this, but no
    // stage may panic on malformed input.
    let net = compile(
        &["D1"],
        seq(vec![do_(
            CondMode::Until,
            x_above(9, 1.0),
            seq(vec![fly(0, 1.0), fly(9, 2.0)]),
        )]),
    );
    let pnml = to_pnml(&net, &PnmlOptions::default());
    assert!(pnml.contains("drone#9"));
    parse_xml(&pnml);
    parse_xml(&to_graphml(&net));
    render_svg(&to_dot(&net));
    assert!(stats(&net).owners.iter().any(|c| c.owner == "drone#9"));
    run_to_final(&net, 0);
}
