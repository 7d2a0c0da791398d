//! The report's model: everything the page draws, as plain data in mission
//! terms (drones by index, points as `[north, east, up]` metres in the
//! fleet frame, source places as 1-based lines), serialised into the page.

use eamos_geo::{Airspace, Vec3, Wgs84};
use serde::Serialize;

use crate::graph::{graph, Graph};
use crate::input::{line_of, Input};
use crate::timeline::{timeline, Timeline};

/// Version of the model's JSON: a monitor feeding the page checks it.
pub const SCHEMA: &str = "eamos-view/1";

/// One colour per drone, the same in every view (the plan view of
/// `eamos check --svg` uses the same order).
const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2",
];

#[derive(Debug, Clone, Serialize)]
pub struct Model {
    pub schema: &'static str,
    pub name: String,
    pub file: String,
    pub drones: Vec<Drone>,
    pub airspace: AirspaceModel,
    pub origin: Option<Wgs84>,
    pub legs: Vec<Leg>,
    /// Why there are no legs, when the mission was too large to follow.
    pub plan_error: Option<String>,
    pub findings: Vec<Finding>,
    pub timeline: Timeline,
    pub graph: Graph,
    /// The mission's text, line by line.
    pub source: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Drone {
    pub name: String,
    pub colour: &'static str,
    pub home: [f64; 3],
}

#[derive(Debug, Clone, Serialize)]
pub struct AirspaceModel {
    /// Corners `[north, east]`, in order.
    pub fence: Option<Vec<[f64; 2]>>,
    pub ceiling: Option<f64>,
    pub floor: f64,
    pub separation: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Leg {
    pub drone: usize,
    pub action: String,
    pub from: [f64; 3],
    pub to: [f64; 3],
    pub boxed: bool,
    pub line: u32,
    pub rounds: Vec<u32>,
}

/// A finding of `eamos check`; spatial ones carry what to draw.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    pub kind: &'static str,
    pub error: bool,
    pub message: String,
    pub line: Option<u32>,
    pub legs: Vec<Leg>,
    /// Points of closest approach (twice the same point where a leg
    /// leaves the airspace).
    pub closest: Option<[[f64; 3]; 2]>,
    pub distance: Option<f64>,
}

fn xyz(v: Vec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Builds the model of a checked mission.
pub fn model(input: &Input) -> Model {
    let net = input.net;
    let drones = net
        .drones
        .iter()
        .enumerate()
        .map(|(i, name)| Drone {
            name: name.clone(),
            colour: COLOURS[i % COLOURS.len()],
            home: xyz(input.space.homes.get(i).copied().unwrap_or_default()),
        })
        .collect();
    let index = |name: &str| net.drones.iter().position(|d| d == name).unwrap_or(0);
    let legs = match input.plan {
        Ok(plan) => plan
            .legs
            .iter()
            .map(|l| Leg {
                drone: l.drone,
                action: l.action.clone(),
                from: xyz(l.from),
                to: xyz(l.to),
                boxed: l.boxed,
                line: line_of(input.source, l.span),
                rounds: l.rounds.clone(),
            })
            .collect(),
        Err(_) => Vec::new(),
    };
    let findings = input
        .report
        .findings
        .iter()
        .map(|f| {
            let geometry = f.geometry.clone().unwrap_or_default();
            Finding {
                kind: f.kind.name(),
                error: f.kind.is_error(),
                message: f.message.clone(),
                line: f.labels.first().map(|l| line_of(input.source, l.span)),
                legs: geometry
                    .legs
                    .iter()
                    .map(|g| Leg {
                        drone: index(&g.drone),
                        action: String::new(),
                        from: xyz(g.from),
                        to: xyz(g.to),
                        boxed: g.boxed,
                        line: g.span.map_or(0, |s| line_of(input.source, s)),
                        rounds: Vec::new(),
                    })
                    .collect(),
                closest: geometry.closest.map(|(a, b)| [xyz(a), xyz(b)]),
                distance: geometry.distance,
            }
        })
        .collect();
    Model {
        schema: SCHEMA,
        name: net.name.clone(),
        file: input.source.name.clone(),
        drones,
        airspace: airspace(&input.space.airspace),
        origin: input.origin,
        legs,
        plan_error: input.plan.as_ref().err().cloned(),
        findings,
        timeline: timeline(input),
        graph: graph(net, input.source),
        source: input.source.text.lines().map(str::to_string).collect(),
    }
}

fn airspace(a: &Airspace) -> AirspaceModel {
    AirspaceModel {
        fence: a.fence.as_ref().map(|f| f.vertices().to_vec()),
        ceiling: a.ceiling,
        floor: a.floor,
        separation: a.separation,
    }
}
