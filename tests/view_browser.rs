//! `eamos view`'s report in a real browser: the page is opened from the
//! disk (`file://`, no server) in headless Chromium, and what it drew is
//! read back from the DOM: the legs of each drone in the plan and side
//! views, one timeline lane per drone, the mission graph's nodes linking
//! to their source lines, and the findings of a planted collision.
//!
//! Screenshots of each report are written beside the test's output
//! (`<target>/tmp/view_browser/`), and to `docs/img/` for the README when
//! `EAMOS_UPDATE_SCREENSHOTS` is set. Without Chromium and chromedriver
//! these tests fail, saying what to install (scripts/test installs both).

#[allow(dead_code)] // Each test uses its own few of the client's commands.
mod browser;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use browser::Browser;

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn out_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("view_browser")
}

/// Writes the report of `mission` (with `fleet`) to `page`.
fn report(mission: &Path, fleet: Option<&Path>, page: &Path) {
    let mut c = Command::cargo_bin("eamos").unwrap();
    c.arg("view").arg(mission).arg("-o").arg(page);
    if let Some(f) = fleet {
        c.arg("--fleet").arg(f);
    }
    c.assert().success();
}

/// The screenshot `name`, beside the test's output and, when asked, in
/// `docs/img/` for the README.
fn screenshot(b: &Browser, selector: Option<&str>, name: &str) {
    let to = out_dir().join(name);
    b.screenshot(selector, &to);
    if std::env::var_os("EAMOS_UPDATE_SCREENSHOTS").is_some() {
        std::fs::copy(&to, repo("docs/img").join(name)).unwrap();
    }
}

/// The page drew without a script error: `render` returned its view.
fn assert_rendered(b: &Browser) {
    assert_eq!(
        b.eval("return typeof window.eamosView;"),
        "object",
        "the page's script did not finish drawing"
    );
}

#[test]
fn experiment_c_shows_three_drones_legs_three_lanes_and_the_graph() {
    std::fs::create_dir_all(out_dir()).unwrap();
    let page = out_dir().join("experiment_c.html");
    report(
        &repo("../shared/missions/paper/experiment_c.go"),
        None,
        &page,
    );
    let b = Browser::start(1300, 1000);
    b.open(&page);
    assert_rendered(&b);

    // Every drone's six legs (take-off, the square's four sides, landing),
    // from above and from the side, and its home.
    for d in 0..3 {
        for view in ["plan", "side"] {
            let legs = b.count(&format!("#{view} .legs .leg[data-drone=\"{d}\"]"));
            assert_eq!(legs, 6, "{view} view, drone {d}");
        }
        assert_eq!(b.count(&format!("#plan .home[data-drone=\"{d}\"]")), 1);
    }
    assert_eq!(b.count("#plan .findings > *"), 0, "no findings to draw");

    // One lane per drone, each with its actions as bars, and the waits
    // between drones as arrows.
    assert_eq!(b.count("#timeline .lane"), 3);
    for d in 0..3 {
        let bars = b.count(&format!("#timeline .lane[data-drone=\"{d}\"] .bar"));
        assert!(bars >= 7, "drone {d}: {bars} bars");
    }
    assert!(b.count("#timeline .wait") >= 3);

    screenshot(&b, None, "view-experiment-c.png");
    screenshot(&b, Some("#timeline-view"), "view-experiment-c-timeline.png");

    // The graph: every node of the net laid out, each with a line linking
    // into the source beside it.
    let nodes = b.count("#graph .node");
    let in_model = b.eval("return window.eamosView.model.graph.nodes.length;");
    assert_eq!(Some(nodes), in_model.as_u64());
    assert!(nodes > 50, "{nodes} nodes");
    assert_eq!(b.count("#graph .node.transition"), b.count("#graph rect"));
    let lines = b.count("#source .src-line");
    assert_eq!(lines, 66);
    // Following a node's link marks its line in the source.
    let selector = "#graph .node.transition[data-line=\"11\"]";
    assert!(b.count(selector) >= 1);
    b.click(selector);
    b.wait_for("return document.querySelector('#source .src-line.here') !== null;");
    assert_eq!(b.eval("return location.hash;"), "#L11");
    assert_eq!(
        b.eval("return document.querySelector('#source .src-line.here').id;"),
        "L11"
    );
    // ... and what line 11 made: Drone3's take-off, its leg and its bar.
    assert!(b.count("#graph .node.here") >= 2);
    assert_eq!(b.count("#plan .legs .leg.here"), 1);
    assert_eq!(b.count("#timeline .bar.here"), 1);
    b.eval("document.getElementById('source').parentNode.scrollTop = 0;");
    screenshot(&b, Some("#graph-view"), "view-experiment-c-graph.png");
    // A line's number leads the other way, to what it made.
    b.click("#L13 .line-no");
    b.wait_for("return document.querySelector('#L13.here') !== null;");
    assert_eq!(b.count("#plan .legs .leg.here[data-drone=\"2\"]"), 1);

    // The executor's events, as its log writes them, move a drone's marker
    // and mark the places its peer holds, without drawing again.
    b.eval(
        r#"var v = window.eamosView;
        v.update({time: 1, drone: "Drone2", event: "telemetry",
                  position: {x: 1, y: 1, z: 1.5}, altitude: 1.5, battery: 90});
        v.update({time: 1, drone: "Drone2", event: "marking",
                  marked: v.model.graph.nodes.filter(n => n.shape === "place" && n.drone === 1)
                          .slice(0, 2).map(n => n.id)});"#,
    );
    assert_eq!(b.count("#plan .live-drone[data-drone=\"1\"]"), 1);
    assert_eq!(b.count("#side .live-drone[data-drone=\"1\"]"), 1);
    assert_eq!(b.count("#graph .node.place.marked[data-drone=\"1\"]"), 2);
    assert_eq!(b.count("#plan .legs .leg"), 18);
}

#[test]
fn a_planted_collision_is_drawn_where_the_legs_meet_and_leave_the_fence() {
    std::fs::create_dir_all(out_dir()).unwrap();
    let page = out_dir().join("crossing.html");
    report(
        &repo("tests/view/crossing.go"),
        Some(&repo("tests/view/crossing_fleet.toml")),
        &page,
    );
    let b = Browser::start(1300, 1000);
    b.open(&page);
    assert_rendered(&b);

    assert_eq!(b.count("#findings li.error"), 2);
    assert_eq!(b.count("#plan .fence"), 1);
    assert_eq!(b.count("#side .ceiling"), 1);
    // The two legs that can meet, marked over the plan, and their points
    // of closest approach.
    assert_eq!(b.count("#plan .finding-closest"), 1);
    assert_eq!(b.count("#plan .finding-closest circle"), 2);
    for d in 0..2 {
        let legs = b.count(&format!("#plan .findings .finding-leg[data-drone=\"{d}\"]"));
        assert!(legs >= 1, "drone {d} has no leg in a finding");
    }
    // The leg that leaves the fence, and where.
    assert_eq!(b.count("#plan .finding-breach"), 1);
    assert_eq!(b.count("#plan .findings .finding-leg"), 3);
    assert_eq!(b.count("#side .finding-closest"), 1);
    // Both drones' own legs are drawn too.
    assert_eq!(b.count("#plan .legs .leg[data-drone=\"0\"]"), 4);
    assert_eq!(b.count("#plan .legs .leg[data-drone=\"1\"]"), 3);
    assert_eq!(b.count("#timeline .lane"), 2);

    screenshot(&b, None, "view-crossing.png");
}
