//! The report's model: legs per drone from the checker's plan, nominal
//! timelines from the profile, graph nodes with their source lines, and
//! a page that holds it all with nothing to fetch.

use eamos_lang::SourceFile;
use eamos_verify::{Options, Space};
use eamos_view::{model, page, Input, Model};

const MISSION: &str = r#"package Pair

var A Quadcopter
var B Quadcopter

func SEQ_Pair() {
	PAR_Up()
	A.FlyByX(10)
	Signal("there")
	B.Hover(3)
	PAR_Down()
}

func PAR_Up() {
	SEQ_AUp()
	SEQ_BUp()
}

func SEQ_AUp() {
	A.Arm()
	A.Takeoff(4)
}

func SEQ_BUp() {
	B.Arm()
	B.Takeoff(2)
}

func PAR_Down() {
	A.Land()
	B.Land()
}
"#;

fn build(text: &str) -> Model {
    let profiles = eamos_profile::builtin();
    let source = SourceFile::new("pair.go", text);
    let compiled = eamos_lang::compile(&source, &profiles).expect("compiles");
    let net = eamos_petri::compile(&compiled.mission, &profiles);
    let space = Space::default_for(net.drones.len());
    let options = Options {
        space: Some(space.clone()),
        ..Options::default()
    };
    let report = eamos_verify::check_net(&net, &profiles, Some(text), &options);
    let plan = eamos_verify::plan(&net, &profiles, &space);
    model(&Input {
        source: &source,
        net: &net,
        profiles: &profiles,
        report: &report,
        plan: &plan,
        space: &space,
        origin: None,
    })
}

#[test]
fn every_drone_has_its_legs_from_its_own_home_with_their_lines() {
    let m = build(MISSION);
    assert_eq!(m.drones.len(), 2);
    let a: Vec<_> = m.legs.iter().filter(|l| l.drone == 0).collect();
    let b: Vec<_> = m.legs.iter().filter(|l| l.drone == 1).collect();
    // A: take-off, 10 m north, land; B: take-off, land.
    assert_eq!(a.len(), 3, "{a:?}");
    assert_eq!(b.len(), 2, "{b:?}");
    let fly = a.iter().find(|l| l.action == "A.FlyByX(10)").unwrap();
    assert_eq!(fly.from, [0.0, 0.0, 4.0]);
    assert_eq!(fly.to, [10.0, 0.0, 4.0]);
    assert_eq!(fly.line, 8);
    // B takes off from its own home, east of A's.
    assert_eq!(b[0].from, m.drones[1].home);
    assert!(m.drones[1].home[1] > 0.0);
}

#[test]
fn the_timeline_times_each_action_at_the_profiles_speeds_and_shows_the_waits() {
    let m = build(MISSION);
    let t = &m.timeline;
    assert_eq!(t.lanes.len(), 2);
    let bar = |drone: usize, action: &str| {
        t.lanes[drone]
            .bars
            .iter()
            .find(|b| b.action == action)
            .unwrap_or_else(|| panic!("no {action} in {:?}", t.lanes[drone].bars))
            .clone()
    };
    // Climbs at 2 m/s, flies at 5 m/s; arming is instant.
    let up = bar(0, "A.Takeoff(4)");
    assert!((up.end - up.start - 2.0).abs() < 1e-9, "{up:?}");
    let fly = bar(0, "A.FlyByX(10)");
    assert!((fly.start - 2.0).abs() < 1e-9, "{fly:?}");
    assert!((fly.end - 4.0).abs() < 1e-9, "{fly:?}");
    // B hovers once A is there: after A's flight, for its 3 s.
    let hover = bar(1, "B.Hover(3)");
    assert!((hover.start - 4.0).abs() < 1e-9, "{hover:?}");
    assert!((hover.end - 7.0).abs() < 1e-9, "{hover:?}");
    assert_eq!(hover.line, 10);
    assert!(
        t.waits.iter().any(|w| w.from_drone == 0
            && w.to_drone == 1
            && (w.to_time - 4.0).abs() < 1e-9
            && w.label.contains("A.FlyByX(10)")),
        "{:?}",
        t.waits
    );
    // Landing at 1.5 m/s from 4 m is the last thing.
    assert!((t.length - (7.0 + 4.0 / 1.5)).abs() < 1e-9, "{}", t.length);
}

#[test]
fn every_place_and_transition_is_in_the_graph_with_its_line() {
    let m = build(MISSION);
    let g = &m.graph;
    let fly = g
        .nodes
        .iter()
        .find(|n| n.kind == "action-start" && n.label.contains("A.FlyByX"))
        .expect("the flight's start");
    assert_eq!(fly.line, Some(8));
    assert_eq!(fly.drone, Some(0));
    assert!(g.nodes.iter().any(|n| n.marked && n.shape == "place"));
    // Every arc joins two nodes of the graph.
    for e in &g.edges {
        assert!(g.nodes.iter().any(|n| n.id == e.from), "{e:?}");
        assert!(g.nodes.iter().any(|n| n.id == e.to), "{e:?}");
    }
    assert!(m.source[7].contains("A.FlyByX(10)"));
}

#[test]
fn the_page_embeds_everything_and_no_mission_text_can_close_its_script() {
    let tricky = MISSION.replace("package Pair", "// </script><script>alert(1)\npackage Pair");
    let html = page(&build(&tricky));
    assert!(html.starts_with("<!DOCTYPE html>"));
    // The model, the layout library, the page's script and its live part,
    // and the call that draws, all inline.
    assert!(html.contains(r#"<script type="application/json" id="eamos-model">"#));
    assert!(html.contains("dagre"));
    assert!(html.contains("EamosView.render("));
    assert!(html.contains("EamosLive.attach("));
    assert!(!html.contains("</script><script>alert"));
    assert_eq!(
        html.matches("</script>").count(),
        5,
        "one per script element"
    );
    // Nothing fetched: no source attribute, no link, no source map.
    for fetch in ["src=", "<link", "sourceMappingURL", "url(http", "https://"] {
        assert!(!html.contains(fetch), "{fetch}");
    }
}

#[test]
fn a_mission_too_large_to_follow_says_so_instead_of_drawing_legs() {
    let m = build(
        r#"package Long

var A Quadcopter

func SEQ_Long() {
	A.Arm()
	A.Takeoff(2)
	RepeatFor(5000, SEQ_Hop)
	A.Land()
}

func SEQ_Hop() {
	A.FlyByX(1)
	A.FlyByX(-1)
}
"#,
    );
    assert!(m.legs.is_empty());
    assert!(
        m.plan_error
            .as_deref()
            .is_some_and(|e| e.contains("too large")),
        "{:?}",
        m.plan_error
    );
    // The timeline and the graph do not need the legs.
    assert_eq!(m.timeline.lanes.len(), 1);
    assert!(!m.timeline.lanes[0].bars.is_empty());
    assert!(!m.graph.nodes.is_empty());
    assert!(page(&m).contains("too large"));
}
