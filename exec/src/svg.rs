//! `trajectories.svg`: every drone's path seen from above, one colour per
//! drone, with a legend, a metre grid and the start (circle) and end
//! (square) of each path. North (X) points up and east (Y) to the right, as
//! on a map.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::Mutex;

use eamos_geo::Vec3;
use eamos_petri::export::xml;

use crate::event::{Event, Kind, Sink};

/// The plot's paths: every drone's positions, in the order of its
/// telemetry samples (a sink of the run's events).
#[derive(Default)]
pub struct Paths(Mutex<BTreeMap<String, Vec<Vec3>>>);

impl Paths {
    /// The paths so far.
    pub fn paths(&self) -> BTreeMap<String, Vec<Vec3>> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

impl Sink for Paths {
    fn event(&self, e: &Event) {
        if let Kind::Telemetry { position, .. } = e.kind {
            self.0
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .entry(e.drone.clone())
                .or_default()
                .push(position);
        }
    }
}

const COLOURS: &[&str] = &[
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
    "#bcbd22", "#7f7f7f",
];

const W: f64 = 720.0;
const H: f64 = 560.0;
const MARGIN: f64 = 60.0;
const LEGEND: f64 = 150.0;

/// A tick step of 1, 2 or 5 times a power of ten giving 4 to 10 ticks.
fn tick_step(span: f64) -> f64 {
    let raw = (span / 6.0).max(1e-3);
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| span / s <= 10.0)
        .unwrap_or(10.0 * p)
}

/// The plot of `paths` (fleet frame, metres), titled `title`.
pub fn trajectories(title: &str, paths: &BTreeMap<String, Vec<Vec3>>) -> String {
    let points: Vec<Vec3> = paths.values().flatten().copied().collect();
    let (mut min_x, mut max_x, mut min_y, mut max_y) = (0.0f64, 1.0f64, 0.0f64, 1.0f64);
    if let Some(first) = points.first() {
        (min_x, max_x, min_y, max_y) = (first.x, first.x, first.y, first.y);
        for p in &points {
            min_x = min_x.min(p.x);
            max_x = max_x.max(p.x);
            min_y = min_y.min(p.y);
            max_y = max_y.max(p.y);
        }
    }
    // Equal scale on both axes, with a margin of 10 % (at least 1 m).
    let pad = ((max_x - min_x).max(max_y - min_y) * 0.1).max(1.0);
    min_x -= pad;
    max_x += pad;
    min_y -= pad;
    max_y += pad;
    let plot_w = W - 2.0 * MARGIN - LEGEND;
    let plot_h = H - 2.0 * MARGIN;
    let scale = (plot_w / (max_y - min_y)).min(plot_h / (max_x - min_x));
    // Centre the drawing in the plot area.
    let used_w = (max_y - min_y) * scale;
    let used_h = (max_x - min_x) * scale;
    let left = MARGIN + (plot_w - used_w) / 2.0;
    let top = MARGIN + (plot_h - used_h) / 2.0;
    let sx = |y: f64| left + (y - min_y) * scale;
    let sy = |x: f64| top + (max_x - x) * scale;

    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" font-size="16" text-anchor="middle">{} — paths seen from above</text>"#,
        (W - LEGEND) / 2.0,
        xml(title)
    );
    // Grid and ticks.
    let step = tick_step((max_x - min_x).max(max_y - min_y));
    let _ = writeln!(s, r##"<g stroke="#e0e0e0" stroke-width="1">"##);
    let mut y = (min_y / step).ceil() * step;
    while y <= max_y {
        let _ = writeln!(
            s,
            r#"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}"/>"#,
            sx(y),
            sy(max_x),
            sy(min_x)
        );
        y += step;
    }
    let mut x = (min_x / step).ceil() * step;
    while x <= max_x {
        let _ = writeln!(
            s,
            r#"<line x1="{1:.1}" y1="{0:.1}" x2="{2:.1}" y2="{0:.1}"/>"#,
            sy(x),
            sx(min_y),
            sx(max_y)
        );
        x += step;
    }
    let _ = writeln!(s, "</g>");
    let _ = writeln!(s, r##"<g fill="#444">"##);
    let mut y = (min_y / step).ceil() * step;
    while y <= max_y {
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            sx(y),
            sy(min_x) + 16.0,
            fmt_num(y)
        );
        y += step;
    }
    let mut x = (min_x / step).ceil() * step;
    while x <= max_x {
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#,
            sx(min_y) - 6.0,
            sy(x) + 4.0,
            fmt_num(x)
        );
        x += step;
    }
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">Y east (m)</text>"#,
        (sx(min_y) + sx(max_y)) / 2.0,
        sy(min_x) + 34.0
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate({:.1},{:.1}) rotate(-90)" text-anchor="middle">X north (m)</text>"#,
        sx(min_y) - 40.0,
        (sy(min_x) + sy(max_x)) / 2.0
    );
    let _ = writeln!(s, "</g>");
    // Paths.
    for (i, (name, path)) in paths.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let pts: Vec<String> = path
            .iter()
            .map(|p| format!("{:.1},{:.1}", sx(p.y), sy(p.x)))
            .collect();
        let _ = writeln!(
            s,
            r#"<g id="path-{}"><polyline fill="none" stroke="{colour}" stroke-width="2" stroke-linejoin="round" points="{}"/>"#,
            xml(name),
            pts.join(" ")
        );
        if let (Some(a), Some(b)) = (path.first(), path.last()) {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{colour}"/><rect x="{:.1}" y="{:.1}" width="8" height="8" fill="none" stroke="{colour}" stroke-width="2"/>"#,
                sx(a.y),
                sy(a.x),
                sx(b.y) - 4.0,
                sy(b.x) - 4.0
            );
        }
        let _ = writeln!(s, "</g>");
        // Legend.
        let ly = MARGIN + 20.0 * i as f64;
        let lx = W - LEGEND + 10.0;
        let _ = writeln!(
            s,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{colour}" stroke-width="3"/><text x="{}" y="{}">{}</text>"#,
            lx + 24.0,
            lx + 30.0,
            ly + 4.0,
            xml(name)
        );
    }
    let n = paths.len() as f64;
    let _ = writeln!(
        s,
        r##"<text x="{}" y="{}" fill="#444">● start  ■ end</text>"##,
        W - LEGEND + 10.0,
        MARGIN + 20.0 * n + 10.0
    );
    let _ = writeln!(s, "</svg>");
    s
}

fn fmt_num(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    if r == 0.0 {
        "0".into()
    } else {
        format!("{r}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plot_has_one_coloured_path_and_legend_entry_per_drone() {
        let mut paths = BTreeMap::new();
        paths.insert(
            "D1".to_string(),
            vec![
                Vec3::new(0.0, 0.0, 1.5),
                Vec3::new(1.0, 0.0, 1.5),
                Vec3::new(1.0, 1.0, 1.5),
            ],
        );
        paths.insert("D2".to_string(), vec![Vec3::new(0.0, 3.0, 0.0)]);
        let svg = trajectories("ExperimentB", &paths);
        assert!(svg.starts_with("<svg"));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains(r#"id="path-D1""#) && svg.contains(r#"id="path-D2""#));
        assert!(svg.contains(COLOURS[0]) && svg.contains(COLOURS[1]));
        assert!(svg.contains("X north (m)") && svg.contains("Y east (m)"));
    }

    #[test]
    fn names_are_escaped_and_an_empty_fleet_still_draws_axes() {
        let mut paths = BTreeMap::new();
        paths.insert("<D&1>".to_string(), vec![]);
        let svg = trajectories("M<1>", &paths);
        assert!(svg.contains("&lt;D&amp;1&gt;"));
        assert!(!svg.contains("<D&1>"));
        assert!(trajectories("M", &BTreeMap::new()).contains("Y east"));
    }

    #[test]
    fn north_is_up_and_east_is_right() {
        let mut paths = BTreeMap::new();
        paths.insert(
            "D".to_string(),
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(10.0, 0.0, 0.0),
                Vec3::new(10.0, 10.0, 0.0),
            ],
        );
        let svg = trajectories("M", &paths);
        let pts = svg
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        let p: Vec<(f64, f64)> = pts
            .split(' ')
            .map(|xy| {
                let (a, b) = xy.split_once(',').unwrap();
                (a.parse().unwrap(), b.parse().unwrap())
            })
            .collect();
        assert!(p[1].1 < p[0].1, "flying north goes up the page");
        assert!(p[2].0 > p[1].0, "flying east goes right");
    }
}
