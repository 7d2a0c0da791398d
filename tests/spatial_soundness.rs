//! Soundness of the spatial properties, with the simulator as an
//! independent witness: random generated missions, random fleets (homes,
//! airframes, how long the drone's other actions take) and random
//! airspaces are checked, then flown in the simulator, and no flight may
//! contradict what the checker proved. At each simulation step, two
//! drones' distance plus how far each was then off the leg the checker
//! models ([`ARRIVAL`], and how far it was off the leg's strip, see
//! [`STRAY`]) bounds how close two of the checker's legs came; so
//! - `separation` holds: that bound never falls below the separation;
//! - it falls below for two drones: the checker has a `TooClose` finding
//!   about those two (unless it left separation undecided), and, where it
//!   judged every pair, that finding's distance (the closest way the two
//!   can meet) is not above the bound: the checker's closest approach is
//!   never above one seen in flight. (Homes closer than the separation make
//!   it violated before any leg is looked at; past too many close pairs
//!   only the homes are judged, and the report says so in a note);
//! - `airspace` holds: no position is ever seen outside the fence, above
//!   the ceiling or below the floor by more than a drone strays off its
//!   leg in plan view and height.
//!
//! The witness of where the drones are *at the same time* is each
//! simulated drone's adapter log, a position at every simulation step
//! while armed, all drones on the one simulated clock. The executor's
//! telemetry events (every 5 cm a drone moves) are stamped when the
//! sampling task reads them, which at a high simulation speed is later
//! than the step that made them and not by the same amount for every
//! drone: they witness *where* a drone went (airspace), not *when*.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use proptest::prelude::*;
use serde_json::Value;

use eamos_exec::event::{Channel, Event, Kind};
use eamos_exec::runner::{run_fleet, RunOptions};
use eamos_fleet::Fleet;
use eamos_geo::{Airspace, Vec3};
use eamos_lang::SourceFile;
use eamos_verify::{check_net, FindingKind, Options, Property, Report, Space, Verdict};

/// How far a simulated drone strays from the leg it was told to fly, in
/// plan view and in height, metres: asserted on every leg of every case.
///
/// The horizontal controller steers one velocity vector straight at the
/// target under an acceleration limit, so a leg's plan view is the
/// straight line but for the residual velocity the last leg ended with
/// (at most the arrival speed, 0.2 m/s), and braking keeps a 10 % margin
/// of the acceleration limit, so it stops short rather than past the
/// target. Heights move on their own limits and never leave the band
/// between the leg's end heights. Measured over a few hundred legs in
/// some forty runs of this test (`SOUNDNESS_MEASURE=1` prints each
/// case's largest): at most 0.14 m, most cases under 0.05 m.
///
/// In 3D a leg is not the straight segment: the climb and the horizontal
/// run end at different times, so a diagonal leg bows off the straight
/// line (up to 2.3 m in these cases). The checker models a leg as the
/// upright strip above and below its plan-view line between its ends'
/// heights, which holds the bow; how far the drone was from that strip is
/// measured at every step ([`Strays::bow`], within [`STRAY`]) and added to
/// the distance seen at that step before it is held against the
/// separation. (With the straight segment as the model, a drone resting in
/// the bow of another's diagonal climb was a clean verdict that a flight
/// contradicted: `verify/tests/space/bow.go` keeps it found.)
const STRAY: f64 = 0.2;

/// A leg starts where the last one arrived: within the arrival tolerance
/// of the point the checker starts it from (the simulator's default,
/// which no case changes).
const ARRIVAL: f64 = 0.1;

/// The simulation step; the adapter log records a position at each.
const STEP: f64 = 0.02;

#[derive(Debug, Clone)]
enum Homes {
    /// The row `eamos run` uses: 3 m apart along Y.
    Default,
    /// A row with random gaps, each the separation plus this much: wide
    /// enough for the homes, not always for two lanes (a lane strays half
    /// a metre either side of its home), so that legs of two drones come
    /// near each other.
    Spaced(Vec<f64>),
    /// A row whose first gap is this share of the separation (the homes
    /// are too close), the others as [`Homes::Spaced`].
    TooClose(Vec<f64>),
    /// A row along X, the lanes' direction, with gaps of the separation
    /// plus 20 m times the cube of this (mostly a few metres, sometimes
    /// more than a lane's 20 m): the lanes of two drones overlap, so that
    /// drones meet in flight unless the mission's ordering or heights keep
    /// them apart.
    Along(Vec<f64>),
}

#[derive(Debug, Clone)]
enum Fenced {
    None,
    /// A fence around the lanes, 2 m beside the outer ones and `margin`
    /// metres south of the first home and north of the last: generous above 10 m (lanes run
    /// from -10 to 10 m along X), tight below.
    Around {
        margin: f64,
    },
}

#[derive(Debug, Clone)]
struct Case {
    drones: usize,
    nodes: usize,
    seed: u64,
    homes: Homes,
    fence: Fenced,
    ceiling: Option<f64>,
    separation: f64,
    /// Per drone: horizontal speed, climb rate, descent rate, horizontal
    /// acceleration.
    airframes: Vec<(f64, f64, f64, f64)>,
    /// Seconds `TakePhoto`, `AdjustCamera`, `TurnOnCamera` take.
    delays: (f64, f64, f64),
    sim_speed: f64,
}

fn case() -> impl Strategy<Value = Case> {
    (2usize..=4).prop_flat_map(|drones| {
        let homes = prop_oneof![
            1 => Just(Homes::Default),
            1 => prop::collection::vec(0.05f64..0.7, drones - 1).prop_map(Homes::Spaced),
            1 => prop::collection::vec(0.05f64..0.7, drones - 1).prop_map(|mut g| {
                g[0] = 0.4 + g[0] / 3.0;
                Homes::TooClose(g)
            }),
            // Where drones meet in flight: the cases that show a checker
            // that misses a meeting.
            3 => prop::collection::vec(0.0f64..1.1, drones - 1).prop_map(Homes::Along),
        ];
        let fence = prop_oneof![
            Just(Fenced::None),
            (10.5f64..14.0).prop_map(|margin| Fenced::Around { margin }),
            (4.0f64..9.0).prop_map(|margin| Fenced::Around { margin }),
        ];
        let ceiling = prop_oneof![Just(None), (6.0f64..12.0).prop_map(Some)];
        (
            Just(drones),
            40usize..=120,
            any::<u64>(),
            homes,
            fence,
            ceiling,
            prop_oneof![Just(1.0), Just(1.5), Just(1.9)],
            prop::collection::vec((1.5f64..8.0, 1.0f64..4.0, 1.0f64..3.0, 1.5f64..5.0), drones),
            (0.0f64..2.0, 0.0f64..2.0, 0.0f64..2.0),
            50.0f64..200.0,
        )
            .prop_map(
                |(
                    drones,
                    nodes,
                    seed,
                    homes,
                    fence,
                    ceiling,
                    separation,
                    airframes,
                    delays,
                    sim_speed,
                )| {
                    Case {
                        drones,
                        nodes,
                        seed,
                        homes,
                        fence,
                        ceiling,
                        separation,
                        airframes,
                        delays,
                        sim_speed,
                    }
                },
            )
    })
}

impl Case {
    fn homes(&self) -> Vec<Vec3> {
        let sep = self.separation;
        let gaps: Vec<f64> = match &self.homes {
            Homes::Default => return (0..self.drones).map(eamos_geo::default_home).collect(),
            Homes::Spaced(g) | Homes::Along(g) => g.iter().map(|u| sep + u).collect(),
            Homes::TooClose(g) => g
                .iter()
                .enumerate()
                .map(|(i, u)| if i == 0 { sep * u } else { sep + u })
                .collect(),
        };
        let along = matches!(self.homes, Homes::Along(_));
        let gaps: Vec<f64> = if along {
            gaps.iter()
                .map(|g| sep + (g - sep).powi(3) * 20.0)
                .collect()
        } else {
            gaps
        };
        let mut y = 0.0;
        let mut out = vec![Vec3::ZERO];
        for g in gaps {
            y += g;
            out.push(if along {
                Vec3::new(y, 0.0, 0.0)
            } else {
                Vec3::new(0.0, y, 0.0)
            });
        }
        out
    }

    /// The fleet file of the case: homes, airframes, airspace, and a
    /// position in the adapter log at every simulation step.
    fn fleet_text(&self) -> String {
        let homes = self.homes();
        let (photo, adjust, camera) = self.delays;
        let mut t = format!(
            "[sim]\nstep = {STEP}\nposition_log_period = {STEP}\n\
             [sim.durations]\nTakePhoto = {photo}\nAdjustCamera = {adjust}\nTurnOnCamera = {camera}\n\
             [airspace]\nseparation = {}\n",
            self.separation
        );
        if let Some(c) = self.ceiling {
            t += &format!("ceiling = {c}\n");
        }
        if let Fenced::Around { margin } = self.fence {
            let (y0, y1) = (homes[0].y - 2.0, homes.last().unwrap().y + 2.0);
            let (x0, x1) = (homes[0].x - margin, homes.last().unwrap().x + margin);
            t += &format!("fence = [[{x0}, {y0}], [{x1}, {y0}], [{x1}, {y1}], [{x0}, {y1}]]\n");
        }
        for (i, (h, (speed, climb, descent, accel))) in
            homes.iter().zip(&self.airframes).enumerate()
        {
            t += &format!(
                "[drones.D{}]\nhome = {{ x = {}, y = {}, z = 0.0 }}\n\
                 vehicle = {{ max_horizontal_speed = {speed}, climb_rate = {climb}, descent_rate = {descent}, max_horizontal_accel = {accel} }}\n",
                i + 1,
                h.x,
                h.y
            );
        }
        t
    }
}

/// Where each drone was at every simulation step, in the fleet frame.
struct Flight {
    drones: Vec<String>,
    homes: Vec<Vec3>,
    /// Per drone: step number -> position (only while armed).
    steps: Vec<BTreeMap<i64, Vec3>>,
    telemetry: Vec<(String, Vec3, f64)>,
    events: Vec<Event>,
}

fn adapter_positions(dir: &Path, drone: &str, home: Vec3) -> BTreeMap<i64, Vec3> {
    let text =
        std::fs::read_to_string(dir.join(format!("{drone}.adapter.jsonl"))).unwrap_or_default();
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let r: Value = serde_json::from_str(line).expect("a log record");
        if r["event"] != "position" {
            continue;
        }
        let p = &r["position"];
        let local = Vec3::new(
            p["x"].as_f64().unwrap(),
            p["y"].as_f64().unwrap(),
            p["z"].as_f64().unwrap(),
        );
        let step = (r["time"].as_f64().unwrap() / STEP).round() as i64;
        out.insert(step, home + local);
    }
    out
}

impl Flight {
    /// For each two drones, the least over the simulation steps of their
    /// distance plus how far each was off the strip of its leg
    /// ([`Strays::bow`]) at that step: an upper bound, at each step, of
    /// the distance between the points of the two legs the checker models
    /// (each leg starting within [`ARRIVAL`] of where the drone began it,
    /// not counted here). Beside it, the least plain distance. A drone not
    /// yet armed is at home, one disarmed again where it was last logged.
    fn least_distances(&self, bow: &[BTreeMap<i64, f64>]) -> BTreeMap<(usize, usize), (f64, f64)> {
        let mut all: Vec<i64> = self.steps.iter().flat_map(|s| s.keys().copied()).collect();
        all.sort_unstable();
        all.dedup();
        let mut at: Vec<Vec3> = self.homes.clone();
        let mut least = BTreeMap::new();
        let n = self.drones.len();
        let note = |k: i64, at: &[Vec3], least: &mut BTreeMap<(usize, usize), (f64, f64)>| {
            let off = |d: usize| bow[d].get(&k).copied().unwrap_or(0.0);
            for a in 0..n {
                for b in a + 1..n {
                    let d = at[a].distance(at[b]);
                    let e = least.entry((a, b)).or_insert((f64::MAX, f64::MAX));
                    e.0 = e.0.min(d + off(a) + off(b));
                    e.1 = e.1.min(d);
                }
            }
        };
        note(i64::MIN, &at, &mut least);
        for k in all {
            for (d, s) in self.steps.iter().enumerate() {
                if let Some(p) = s.get(&k) {
                    at[d] = *p;
                }
            }
            note(k, &at, &mut least);
        }
        least
    }

    /// Every position seen: telemetry events and the adapter logs.
    fn positions(&self) -> impl Iterator<Item = (usize, Vec3)> + '_ {
        let logged = self
            .steps
            .iter()
            .enumerate()
            .flat_map(|(d, s)| s.values().map(move |p| (d, *p)));
        let seen = self
            .telemetry
            .iter()
            .filter_map(|(name, p, _)| self.drones.iter().position(|d| d == name).map(|d| (d, *p)));
        logged.chain(seen)
    }

    /// How far each drone strayed from the straight leg it flew (from
    /// where it was when a flight to a target began to that target), at
    /// every step logged until the flight ended.
    fn strays(&self) -> Strays {
        let mut out = Strays {
            plan: 0.0,
            bow: vec![BTreeMap::new(); self.drones.len()],
        };
        for (d, name) in self.drones.iter().enumerate() {
            let mut open: Option<(i64, Vec3, u32)> = None;
            for e in self.events.iter().filter(|e| &e.drone == name) {
                match &e.kind {
                    Kind::ActionStarted {
                        target: Some(t),
                        instance,
                        ..
                    } => {
                        let step = (e.time / STEP).round() as i64;
                        open = Some((step, self.homes[d] + *t, *instance));
                    }
                    Kind::ActionFinished { instance, .. }
                    | Kind::ActionCancelled { instance, .. } => {
                        let Some((from, target, i)) = open else {
                            continue;
                        };
                        if i != *instance {
                            continue;
                        }
                        open = None;
                        let to = (e.time / STEP).round() as i64;
                        let s = &self.steps[d];
                        let Some(start) = s.range(..=from).next_back().map(|(_, p)| *p) else {
                            continue;
                        };
                        let flat = |v: Vec3| Vec3::new(v.x, v.y, 0.0);
                        let (low, high) = (start.z.min(target.z), start.z.max(target.z));
                        for (k, p) in s.range(from..=to) {
                            let plan =
                                eamos_geo::point_segment(flat(*p), flat(start), flat(target));
                            let height = (low - p.z).max(p.z - high).max(0.0);
                            out.plan = out.plan.max(plan.distance).max(height);
                            // Off the strip the checker models the leg as.
                            let bow = plan.distance.hypot(height);
                            out.bow[d].insert(*k, bow);
                        }
                    }
                    _ => {}
                }
            }
        }
        out
    }
}

/// How far the drones of a flight strayed from their legs.
struct Strays {
    /// The largest distance off a leg in plan view, or out of the band
    /// between its end heights, of any drone.
    plan: f64,
    /// Per drone, per simulation step while it flew to a target: its
    /// distance from the leg's strip (plan-view line times height band).
    bow: Vec<BTreeMap<i64, f64>>,
}

fn compile(text: &str) -> (eamos_petri::net::Net, SourceFile) {
    let file = SourceFile::new("generated.go", text.to_string());
    let profiles = eamos_profile::builtin();
    let compiled = eamos_lang::compile(&file, &profiles).unwrap_or_else(|d| {
        panic!(
            "{}",
            eamos_lang::render_all(&d, &file, eamos_lang::Style::PLAIN)
        )
    });
    (eamos_petri::compile(&compiled.mission, &profiles), file)
}

fn fly(net: &eamos_petri::net::Net, fleet: &Fleet, speed: f64, dir: &Path) -> Flight {
    let slices = eamos_fleet::identity::slice(net, fleet).expect("slices");
    let (sink, mut rx) = Channel::new();
    let options = RunOptions {
        speed,
        // Generated waits and loops end in flight; this only bounds a run
        // that would not.
        max_duration: Some(1800.0),
        out: dir.to_path_buf(),
        linger: std::time::Duration::ZERO,
        events: Some(Arc::new(sink)),
        ..RunOptions::default()
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let report = runtime
        .block_on(run_fleet(
            &slices,
            fleet,
            &eamos_profile::builtin(),
            &options,
        ))
        .expect("the run");
    drop(runtime);
    for r in &report.reports {
        assert_eq!(
            r.outcome,
            eamos_exec::Outcome::Completed,
            "{}: {:?}",
            r.drone,
            r.outcome
        );
    }
    let events: Vec<Event> = std::iter::from_fn(|| rx.try_recv().ok()).collect();
    let telemetry = events
        .iter()
        .filter_map(|e| match &e.kind {
            Kind::Telemetry { position, .. } => Some((e.drone.clone(), *position, e.time)),
            _ => None,
        })
        .collect();
    let drones = net.drones.clone();
    let homes = fleet.homes(&drones);
    let steps = drones
        .iter()
        .zip(&homes)
        .map(|(d, h)| adapter_positions(dir, d, *h))
        .collect();
    Flight {
        drones,
        homes,
        steps,
        telemetry,
        events,
    }
}

/// How far `p` is outside `airspace` (0 inside), metres.
fn outside(airspace: &Airspace, home: Vec3, p: Vec3) -> f64 {
    let mut out: f64 = 0.0;
    if let Some(f) = &airspace.fence {
        if !f.contains(p) {
            let flat = Vec3::new(p.x, p.y, 0.0);
            let edge = f
                .edges()
                .map(|(a, b)| {
                    eamos_geo::point_segment(
                        flat,
                        Vec3::new(a[0], a[1], 0.0),
                        Vec3::new(b[0], b[1], 0.0),
                    )
                    .distance
                })
                .fold(f64::MAX, f64::min);
            out = out.max(edge);
        }
    }
    let z = p.z - home.z;
    if let Some(c) = airspace.ceiling {
        out = out.max(z - c);
    }
    out.max(airspace.floor - z)
}

/// Whether the checker looked at every way two drones can meet (not so
/// past too many close pairs, where the homes alone are judged).
fn every_pair_judged(report: &Report) -> bool {
    report
        .properties
        .iter()
        .find(|r| r.property == Property::Separation)
        .is_some_and(|r| !r.notes.iter().any(|n| n.starts_with("not every pair")))
}

/// The checker's closest possible approach of drones `a` and `b`: the
/// distance of its finding about the two (one per pair, the closest way
/// they can meet), if it has one.
fn pair_found(report: &Report, a: &str, b: &str) -> Option<f64> {
    report
        .findings_of(FindingKind::TooClose)
        .filter_map(|f| {
            let g = f.geometry.as_ref()?;
            let names: Vec<&str> = g.legs.iter().map(|l| l.drone.as_str()).collect();
            let homes = g.legs.is_empty() && f.message.starts_with(&format!("{a} and {b} start"));
            (homes || (names.contains(&a) && names.contains(&b))).then_some(g.distance?)
        })
        .reduce(f64::min)
}

fn verdict(r: &Report, p: Property) -> Verdict {
    r.verdict(p).cloned().expect("every property has a verdict")
}

fn run_case(c: &Case) -> Result<(), TestCaseError> {
    let generated = eamos_gen::generate(&eamos_gen::Options::new(
        c.drones,
        eamos_gen::Size::Nodes(c.nodes),
        c.seed,
    ))
    .expect("a generated mission");
    let (net, file) = compile(&generated.text);
    let fleet_text = c.fleet_text();
    let fleet = Fleet::parse(&fleet_text, "fleet.toml", &net.name, &net.drones)
        .unwrap_or_else(|e| panic!("{e}\n{fleet_text}"));
    let space = Space {
        homes: fleet.homes(&net.drones),
        airspace: fleet.airspace().clone(),
    };
    let airspace = space.airspace.clone();
    let options = Options {
        space: Some(space),
        ..Options::default()
    };
    let report = check_net(&net, &eamos_profile::builtin(), Some(&file.text), &options);
    let dir = tempfile::tempdir().unwrap();
    let flight = fly(&net, &fleet, c.sim_speed, dir.path());
    let separation = verdict(&report, Property::Separation);
    let inside = verdict(&report, Property::Airspace);
    let context = || {
        format!(
            "{c:?}\nseparation: {separation:?}, airspace: {inside:?}\nfindings: {:#?}\n{}\n{}",
            report
                .findings
                .iter()
                .map(|f| &f.message)
                .collect::<Vec<_>>(),
            fleet_text,
            generated.text
        )
    };

    let strays = flight.strays();
    let least = flight.least_distances(&strays.bow);
    if std::env::var_os("SOUNDNESS_MEASURE").is_some() {
        let plain = least.values().fold(f64::MAX, |a, b| a.min(b.1));
        let bow = strays
            .bow
            .iter()
            .flat_map(|b| b.values())
            .fold(0.0f64, |a, b| a.max(*b));
        eprintln!(
            "separation {separation:?}, airspace {inside:?}, closest seen {plain:.3} m, \
             off the leg in plan view {:.3} m, in 3D {bow:.3} m",
            strays.plan
        );
    }
    prop_assert!(
        strays.plan <= STRAY,
        "a drone strayed {:.3} m from the leg it flew, more than {STRAY} m\n{}",
        strays.plan,
        context()
    );

    let sep = airspace.separation;
    // Undecided (too many pairs to watch, a drone that drifts), the
    // checker claims nothing about separation.
    let decided = matches!(separation, Verdict::Holds | Verdict::Violated);
    for ((a, b), (modelled, seen)) in least {
        let (da, db) = (&flight.drones[a], &flight.drones[b]);
        // Two points of the checker's legs were at most this far apart
        // at one moment of the flight.
        let apart = modelled + 2.0 * ARRIVAL;
        if separation == Verdict::Holds {
            prop_assert!(
                apart >= sep,
                "separation holds, yet {da} and {db} flew {seen:.3} m apart \
                 ({apart:.3} m with what they strayed off their legs)\n{}",
                context()
            );
        }
        if decided && apart < sep {
            let found = pair_found(&report, da, db);
            prop_assert!(
                found.is_some(),
                "{da} and {db} flew {seen:.3} m apart ({apart:.3} m with what they strayed \
                 off their legs) and the checker says nothing of them\n{}",
                context()
            );
            // Where the checker judged every pair, its closest possible
            // approach of the two is never above one seen in flight.
            let closest = found.unwrap_or_default();
            prop_assert!(
                !every_pair_judged(&report) || closest <= apart,
                "{da} and {db} flew {seen:.3} m apart ({apart:.3} m with what they strayed \
                 off their legs), closer than the checker's closest approach of {closest:.3} m\n{}",
                context()
            );
        }
    }

    if inside == Verdict::Holds {
        for (d, p) in flight.positions() {
            let out = outside(&airspace, flight.homes[d], p);
            prop_assert!(
                out <= ARRIVAL + strays.plan,
                "airspace holds, yet {} was seen at {p:?}, {out:.3} m outside\n{}",
                flight.drones[d],
                context()
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 10,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn no_flight_contradicts_what_the_checker_proved(c in case()) {
        run_case(&c)?;
    }
}

/// D1 and D2 start 0.77 m apart, closer than the separation, and their
/// lanes overlap. The closest-approach claim once failed here: seen
/// 0.30 m (0.50 m with the strays) against 0.77 m, the distance of the
/// homes finding, taken for the pair's closest although the findings
/// about their legs say less. The pair's closest approach is the least over
/// every finding about the two (and each pair's finding is now its closest
/// way to meet). The simulated flight is not exactly the same from run to
/// run (the sim clock runs against the wall clock's scheduling), so this
/// replays the case, not necessarily the same flight.
#[test]
fn the_closest_approach_of_two_drones_is_the_least_of_their_findings() {
    let c = Case {
        drones: 4,
        nodes: 84,
        seed: 16472201400580244105,
        homes: Homes::TooClose(vec![
            0.5119308721818162,
            0.5066445562705426,
            0.4671165081131151,
        ]),
        fence: Fenced::Around {
            margin: 5.742806085356862,
        },
        ceiling: None,
        separation: 1.5,
        airframes: vec![
            (
                4.144001555304098,
                3.7363397010793307,
                1.6074689410642593,
                3.2907246810067536,
            ),
            (
                4.63769822907094,
                3.2071315830517464,
                2.861642740510586,
                3.981705774415864,
            ),
            (
                6.5242156366705455,
                3.8797391751050676,
                2.087145776510279,
                2.6609397666208943,
            ),
            (
                7.96400778222014,
                1.2129525325799848,
                1.693018582159733,
                3.6514351885695397,
            ),
        ],
        delays: (0.43399701044975764, 0.302706962019025, 1.2262188839502115),
        sim_speed: 59.70590203423465,
    };
    run_case(&c).unwrap();
}
