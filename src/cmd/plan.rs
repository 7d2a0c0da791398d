//! `eamos check --svg`: the plan view of the spatial findings, seen from
//! above with north up: homes, the fence, the legs each finding is about,
//! and the points of closest approach (or where a leg leaves the fence).

use std::fmt::Write as _;

use eamos_petri::export::xml;
use eamos_verify::{Report, Space};

const SIZE: f64 = 800.0;
const MARGIN: f64 = 40.0;
const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2",
];

/// The SVG text.
pub fn svg(report: &Report, space: &Space, drones: &[String]) -> String {
    let findings: Vec<_> = report
        .findings
        .iter()
        .filter_map(|f| f.geometry.as_ref().map(|g| (f, g)))
        .collect();
    // What to fit in the picture: homes, fence, legs, closest points.
    let mut points: Vec<(f64, f64)> = space.homes.iter().map(|h| (h.x, h.y)).collect();
    if let Some(f) = &space.airspace.fence {
        points.extend(f.vertices().iter().map(|v| (v[0], v[1])));
    }
    for (_, g) in &findings {
        for l in &g.legs {
            points.push((l.from.x, l.from.y));
            points.push((l.to.x, l.to.y));
        }
    }
    let (mut lo_x, mut hi_x, mut lo_y, mut hi_y) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in &points {
        lo_x = lo_x.min(x);
        hi_x = hi_x.max(x);
        lo_y = lo_y.min(y);
        hi_y = hi_y.max(y);
    }
    if points.is_empty() {
        (lo_x, hi_x, lo_y, hi_y) = (-1.0, 1.0, -1.0, 1.0);
    }
    // At least 10 m across, the drawing centred on what it shows.
    let span = (hi_x - lo_x).max(hi_y - lo_y).max(10.0);
    let scale = (SIZE - 2.0 * MARGIN) / span;
    let (mid_x, mid_y) = ((lo_x + hi_x) / 2.0, (lo_y + hi_y) / 2.0);
    // North (x) up, east (y) right.
    let at = |x: f64, y: f64| {
        (
            SIZE / 2.0 + (y - mid_y) * scale,
            SIZE / 2.0 - (x - mid_x) * scale,
        )
    };
    // Labels on the right half are written leftwards, to stay in the page.
    let anchor = |a: f64| if a > SIZE / 2.0 { "end" } else { "start" };
    let colour = |name: &str| {
        let i = drones.iter().position(|d| d == name).unwrap_or(0);
        COLOURS[i % COLOURS.len()]
    };
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{SIZE}" height="{h}" viewBox="0 0 {SIZE} {h}" font-family="sans-serif" font-size="12">"#,
        h = SIZE + 20.0 * findings.len() as f64 + 30.0
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        "<title>{}: plan view of the spatial findings (north up, metres)</title>",
        xml(&report.name)
    );
    if let Some(f) = &space.airspace.fence {
        let pts: Vec<String> = f
            .vertices()
            .iter()
            .map(|v| {
                let (a, b) = at(v[0], v[1]);
                format!("{a:.1},{b:.1}")
            })
            .collect();
        let _ = writeln!(
            out,
            r##"<polygon class="fence" points="{}" fill="#f4fff4" stroke="#2a7a2a" stroke-width="2" stroke-dasharray="6 3"/>"##,
            pts.join(" ")
        );
    }
    for (i, h) in space.homes.iter().enumerate() {
        let (a, b) = at(h.x, h.y);
        let name = drones.get(i).map_or("", String::as_str);
        let _ = writeln!(
            out,
            r#"<g class="home"><rect x="{:.1}" y="{:.1}" width="8" height="8" fill="{c}"/><text x="{:.1}" y="{:.1}" text-anchor="{}">{} home</text></g>"#,
            a - 4.0,
            b - 4.0,
            if a > SIZE / 2.0 { a - 6.0 } else { a + 6.0 },
            b + 14.0,
            anchor(a),
            xml(name),
            c = colour(name)
        );
    }
    for (n, (f, g)) in findings.iter().enumerate() {
        for (k, l) in g.legs.iter().enumerate() {
            let (a, b) = at(l.from.x, l.from.y);
            let (c, d) = at(l.to.x, l.to.y);
            let col = colour(&l.drone);
            if l.boxed {
                let _ = writeln!(
                    out,
                    r#"<rect class="leg" x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{col}" fill-opacity="0.2" stroke="{col}"/>"#,
                    a.min(c),
                    b.min(d),
                    (c - a).abs(),
                    (d - b).abs()
                );
            } else {
                let _ = writeln!(
                    out,
                    r#"<line class="leg" x1="{a:.1}" y1="{b:.1}" x2="{c:.1}" y2="{d:.1}" stroke="{col}" stroke-width="{w}"{dash}><title>{}</title></line><circle cx="{c:.1}" cy="{d:.1}" r="3" fill="{col}"/>"#,
                    xml(&l.drone),
                    // The second leg of a pair thinner and dashed: two legs
                    // on one line stay visible.
                    w = if k == 0 { 5 } else { 2 },
                    dash = if k == 0 {
                        ""
                    } else {
                        r#" stroke-dasharray="8 4""#
                    },
                );
            }
        }
        if let Some((p, q)) = g.closest {
            let (a, b) = at(p.x, p.y);
            let (c, d) = at(q.x, q.y);
            let _ = writeln!(
                out,
                r##"<g class="closest"><line x1="{a:.1}" y1="{b:.1}" x2="{c:.1}" y2="{d:.1}" stroke="#000" stroke-dasharray="2 2"/><circle cx="{a:.1}" cy="{b:.1}" r="5" fill="none" stroke="#e00" stroke-width="2"/><circle cx="{c:.1}" cy="{d:.1}" r="5" fill="none" stroke="#e00" stroke-width="2"/><text x="{:.1}" y="{:.1}" fill="#e00">{}</text></g>"##,
                a + 8.0,
                b - 8.0,
                n + 1
            );
        }
        let _ = writeln!(
            out,
            r#"<text class="finding" x="10" y="{:.1}">{}. {}</text>"#,
            SIZE + 20.0 * (n as f64 + 1.0),
            n + 1,
            xml(&f.message)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="10" y="20">{}: {} spatial finding(s); north up, {:.1} m across</text>"#,
        xml(&report.name),
        findings.len(),
        span
    );
    out.push_str("</svg>\n");
    out
}
