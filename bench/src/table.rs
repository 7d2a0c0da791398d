//! The table: criterion's results and the measured processes, each figure
//! beside the paper's, its baseline and its goal.

use std::path::PathBuf;
use std::time::Duration;

use serde_json::Value;

use crate::files::Facts;
use crate::process::Process;
use crate::workload::{SERIES, STRESS};

/// The paper's stress test (section VIII-E).
mod paper {
    pub const COMPILE_SMALL_MS: f64 = 50.0;
    pub const COMPILE_SMALL_KB: f64 = 4_368.78;
    pub const START_SMALL_MS: f64 = 916.63;
    pub const START_SMALL_KB: f64 = 3_749.50;
    pub const COMPILE_STRESS_MS: f64 = 2_340.0;
    pub const COMPILE_STRESS_KB: f64 = 23_979.0;
    pub const START_STRESS_MS: f64 = 733.64;
    pub const START_STRESS_KB: f64 = 4_257.45;
}

/// The goals of the stress test.
mod goal {
    pub const COMPILE_STRESS_MB: f64 = 16.0;
    /// Compile time grows as nodes^k with k at most this.
    pub const GROWTH_EXPONENT: f64 = 1.15;
    pub const START_STRESS_MS: f64 = 10.0;
    pub const CHECK_STRESS_MS: f64 = 1_000.0;
    /// The spatial properties may at most double the check.
    pub const SPATIAL_FACTOR: f64 = 2.0;
    pub const BRIDGE_RATIO: f64 = 1.5;
    /// From an edit to its diagnostics in the editor (issue 16).
    pub const LSP_EDIT_MS: f64 = 50.0;
    /// A fleet of 250 drones, one process each, starts within this (issue
    /// 23), and each process stays under `FLEET_PROCESS_MB`.
    pub const FLEET_START_S: f64 = 10.0;
    pub const FLEET_PROCESS_MB: f64 = 20.0;
    /// From a drone's event to the monitor's page, 99th percentile (issue
    /// 15).
    pub const MONITOR_P99_MS: f64 = 100.0;
}

/// How far a proof of the `check` probe went.
struct Proof {
    states: u64,
    full_expansions: u64,
    complete: bool,
    /// The state-space exploration alone: what proves deadlock freedom.
    seconds: f64,
    found_something: bool,
}

impl Proof {
    fn read(process: &Process) -> Option<Proof> {
        let v: Value = serde_json::from_str(process.said.first()?).ok()?;
        Some(Proof {
            states: v.get("states")?.as_u64()?,
            full_expansions: v.get("full_expansions")?.as_u64()?,
            complete: v.get("complete")?.as_bool()?,
            seconds: v.get("seconds")?.as_f64()?,
            found_something: v.get("found_something")?.as_bool()?,
        })
    }
}

/// Criterion's results.
pub struct Results {
    pub root: PathBuf,
}

impl Results {
    /// Time per iteration in nanoseconds of `group/function[/value]`.
    fn ns(&self, id: &str) -> Option<f64> {
        let v = self.json(id, "estimates.json")?;
        v.get("slope")
            .filter(|s| !s.is_null())
            .or_else(|| v.get("mean"))
            .and_then(|e| e.get("point_estimate"))
            .and_then(Value::as_f64)
    }

    /// Elements per iteration of a benchmark with a throughput.
    fn elements(&self, id: &str) -> Option<u64> {
        self.json(id, "benchmark.json")?
            .get("throughput")?
            .get("Elements")?
            .as_u64()
    }

    fn json(&self, id: &str, file: &str) -> Option<Value> {
        let path = self.root.join(id).join("new").join(file);
        let text = std::fs::read_to_string(path).ok()?;
        serde_json::from_str(&text).ok()
    }
}

pub struct Measured<'a> {
    pub results: &'a Results,
    pub facts: &'a Facts,
    pub idle: Process,
    pub compile_small: Process,
    pub compile_stress: Process,
    /// `gofmt` on the stress mission, where it is installed.
    pub gofmt_stress: Option<Process>,
    pub start_small: Process,
    pub start_stress: Process,
    pub check_stress: Process,
    pub check_without_choices: Process,
    /// `eamos lsp` on the stress mission.
    pub lsp: crate::lsp::Latency,
    /// The checker's corpus.
    pub corpus: Vec<(crate::corpus::Entry, crate::corpus::Checked)>,
    /// Fleets flown one process per drone.
    pub fleets: Vec<crate::fleet::FleetRun>,
    /// The live monitor under load: `None` not asked, `Some(None)` no
    /// browser here.
    pub monitor: Option<Option<crate::monitor::MonitorRun>>,
}

/// One row of the table.
struct Row {
    what: String,
    eamos: String,
    paper: String,
    baseline: String,
    goal: String,
    met: String,
}

fn row(what: impl Into<String>, eamos: impl Into<String>) -> Row {
    Row {
        what: what.into(),
        eamos: eamos.into(),
        paper: "–".into(),
        baseline: "–".into(),
        goal: "–".into(),
        met: String::new(),
    }
}

impl Row {
    fn paper(mut self, p: impl Into<String>) -> Row {
        self.paper = p.into();
        self
    }
    fn baseline(mut self, b: impl Into<String>) -> Row {
        self.baseline = b.into();
        self
    }
    fn goal(mut self, g: impl Into<String>, met: Option<bool>) -> Row {
        self.goal = g.into();
        self.met = match met {
            Some(true) => "met".into(),
            Some(false) => "not met".into(),
            None => MISSING.into(),
        };
        self
    }
}

const MISSING: &str = "not measured";

fn time(ns: Option<f64>) -> String {
    match ns {
        None => MISSING.into(),
        Some(ns) if ns >= 1e9 => format!("{:.2} s", ns / 1e9),
        Some(ns) if ns >= 1e6 => format!("{:.2} ms", ns / 1e6),
        Some(ns) if ns >= 1e3 => format!("{:.1} µs", ns / 1e3),
        Some(ns) => format!("{ns:.0} ns"),
    }
}

fn ms(d: Duration) -> String {
    time(Some(d.as_nanos() as f64))
}

fn paper_ms(ms: f64) -> String {
    time(Some(ms * 1e6))
}

/// Megabytes (10^6 bytes) from KiB.
fn mb(kib: u64) -> f64 {
    kib as f64 * 1024.0 / 1e6
}

fn mem(kib: u64) -> String {
    if kib == 0 {
        MISSING.into()
    } else {
        format!("{:.1} MB", mb(kib))
    }
}

fn paper_kb(kb: f64) -> String {
    format!("{:.1} MB", kb * 1e3 / 1e6)
}

/// Least-squares slope of log(time) over log(nodes): 1 is linear.
fn growth_exponent(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let logs: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.ln(), y.ln())).collect();
    let n = logs.len() as f64;
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// How the check of the fleet series grows with the fleet: time and peak
/// memory fitted as powers of the number of drones (issue: close to
/// linear).
fn check_growth_row(corpus: &[(crate::corpus::Entry, crate::corpus::Checked)]) -> Row {
    let series: Vec<(usize, &crate::corpus::Checked)> = corpus
        .iter()
        .filter_map(|(e, c)| Some((e.fleet?, c)))
        .collect();
    let fit = |y: &dyn Fn(&crate::corpus::Checked) -> f64| {
        let points: Vec<(f64, f64)> = series.iter().map(|&(n, c)| (n as f64, y(c))).collect();
        growth_exponent(&points)
    };
    let time = fit(&|c| c.wall.as_secs_f64());
    let memory = fit(&|c| c.peak_kib as f64);
    let power = |k: Option<f64>| k.map_or(MISSING.to_string(), |k| format!("{k:.2}"));
    let fleets: Vec<String> = series.iter().map(|(n, _)| n.to_string()).collect();
    row(
        format!(
            "`eamos check` of the fleet series ({} drones): growth with the fleet",
            fleets.join(", ")
        ),
        format!(
            "time ∝ drones^{}, peak memory ∝ drones^{}",
            power(time),
            power(memory)
        ),
    )
    .goal(
        format!("close to linear (exponents ≤ {})", goal::GROWTH_EXPONENT),
        time.zip(memory)
            .map(|(t, m)| t <= goal::GROWTH_EXPONENT && m <= goal::GROWTH_EXPONENT),
    )
}

pub fn table(m: &Measured) -> String {
    let r = m.results;
    let (small, stress) = (&m.facts.small, &m.facts.stress);
    let idle_mem = format!("{} (a process that does nothing)", mem(m.idle.peak_kib));
    let mut rows = Vec::new();

    for (f, paper_ms_v, paper_kb_v, process) in [
        (
            small,
            paper::COMPILE_SMALL_MS,
            paper::COMPILE_SMALL_KB,
            &m.compile_small,
        ),
        (
            stress,
            paper::COMPILE_STRESS_MS,
            paper::COMPILE_STRESS_KB,
            &m.compile_stress,
        ),
    ] {
        let n = f.spec.nodes;
        let total = r.ns(&format!("compile/total/{n}"));
        let parts = format!(
            "{} (front end {}, net {}, slices {})",
            time(total),
            time(r.ns(&format!("compile/parse/{n}"))),
            time(r.ns(&format!("compile/net/{n}"))),
            time(r.ns(&format!("compile/slices/{n}")))
        );
        let what = format!(
            "compile, {n}-node mission, {} drone{}",
            f.spec.drones,
            if f.spec.drones == 1 { "" } else { "s" }
        );
        let time_row = row(format!("{what}: time"), parts).paper(paper_ms(paper_ms_v));
        let mut mem_row = row(
            format!("{what}: peak memory of the process"),
            mem(process.peak_kib),
        )
        .paper(paper_kb(paper_kb_v))
        .baseline(idle_mem.clone());
        let mut process_row = None;
        if f.spec == STRESS {
            // Side by side with gofmt formatting the same file, both whole
            // processes measured in this run: the goal is gofmt's time.
            let gofmt = m.gofmt_stress.as_ref();
            let gofmt_said = gofmt.map_or(format!("gofmt: {MISSING} (not installed)"), |g| {
                format!(
                    "gofmt of the same file: {}, {}",
                    ms(g.to_ready),
                    mem(g.peak_kib)
                )
            });
            process_row = Some(
                row(
                    format!("{what}: new process, mission file to slices"),
                    ms(process.to_ready),
                )
                .baseline(gofmt_said.clone())
                .goal(
                    "≤ gofmt's time",
                    gofmt.map(|g| process.to_ready <= g.to_ready),
                ),
            );
            mem_row = mem_row.baseline(format!("{gofmt_said}; {idle_mem}")).goal(
                format!("≤ {} MB", goal::COMPILE_STRESS_MB),
                (process.peak_kib > 0).then(|| mb(process.peak_kib) <= goal::COMPILE_STRESS_MB),
            );
        }
        rows.push(time_row);
        rows.extend(process_row);
        rows.push(mem_row);
    }

    let series: Vec<(f64, f64)> = SERIES
        .iter()
        .filter_map(|&n| {
            r.ns(&format!("compile_series/total/{n}"))
                .map(|t| (n as f64, t))
        })
        .collect();
    let per_node: Vec<String> = series
        .iter()
        .map(|&(n, t)| format!("{}: {:.2} µs", n as u64, t / n / 1e3))
        .collect();
    let exponent = growth_exponent(&series);
    rows.push(
        row(
            "compile time per node, 20 drones, 1k to 100k nodes",
            format!(
                "{}; time ∝ nodes^{}",
                if per_node.is_empty() {
                    MISSING.to_string()
                } else {
                    per_node.join(", ")
                },
                exponent.map_or(MISSING.to_string(), |k| format!("{k:.2}"))
            ),
        )
        .goal(
            format!("linear (exponent ≤ {})", goal::GROWTH_EXPONENT),
            exponent.map(|k| k <= goal::GROWTH_EXPONENT),
        ),
    );

    for (f, paper_ms_v, paper_kb_v, process, paper_nodes) in [
        (
            small,
            paper::START_SMALL_MS,
            paper::START_SMALL_KB,
            &m.start_small,
            "22-node drone part",
        ),
        (
            stress,
            paper::START_STRESS_MS,
            paper::START_STRESS_KB,
            &m.start_stress,
            "634-node drone part",
        ),
    ] {
        let n = f.spec.nodes;
        let what = format!(
            "agent start, {n}-node mission, largest slice ({}: {} places, {} transitions, {} kB file)",
            f.drone,
            f.places,
            f.transitions,
            f.bytes.div_ceil(1000)
        );
        let ready = r.ns(&format!("start/ready/{n}"));
        rows.push(
            row(
                format!("{what}: slice file to agent ready (in process)"),
                format!(
                    "{} (decoding {})",
                    time(ready),
                    time(r.ns(&format!("start/decode/{n}")))
                ),
            )
            .paper(format!("{} ({paper_nodes})", paper_ms(paper_ms_v))),
        );
        // The goal is judged on what a drone's companion computer does: a
        // new process reading its slice and joining zenoh.
        let mut new_process = row(
            format!("{what}: new process to agent ready on zenoh"),
            ms(process.to_ready),
        )
        .paper(paper_ms(paper_ms_v))
        .baseline(format!(
            "{} (a process that does nothing)",
            ms(m.idle.to_ready)
        ));
        if f.spec == STRESS {
            new_process = new_process.goal(
                format!("≤ {} ms", goal::START_STRESS_MS),
                Some(process.to_ready.as_secs_f64() * 1e3 <= goal::START_STRESS_MS),
            );
        }
        rows.push(new_process);
        rows.push(
            row(
                format!("{what}: peak memory of the process"),
                mem(process.peak_kib),
            )
            .paper(paper_kb(paper_kb_v))
            .baseline(idle_mem.clone()),
        );
    }

    rows.push(
        row(
            format!(
                "`eamos check`, {}-node mission ({} MEG nodes): every property, from the mission text",
                small.spec.nodes, small.meg_nodes
            ),
            time(r.ns(&format!("check/check/{}", small.spec.nodes))),
        )
        .paper("– (no checker)"),
    );
    for (what, id, process) in [
        (
            "every structure of the language",
            format!("check/check/{}", STRESS.nodes),
            &m.check_stress,
        ),
        (
            "without `If`, condition loops and `Do`",
            format!("check/without_choices/{}", STRESS.nodes),
            &m.check_without_choices,
        ),
    ] {
        let t = r.ns(&id);
        let proof = Proof::read(process);
        let complete = proof.as_ref().map(|p| p.complete);
        let what = format!(
            "`eamos check`, {}-node mission, {} drones, {what}",
            STRESS.nodes, STRESS.drones
        );
        rows.push(
            row(
                format!("{what}: deadlock freedom (the state-space exploration, one run)"),
                proof.as_ref().map_or(MISSING.to_string(), |p| {
                    format!(
                        "{} ({}; {} states, {} fully expanded)",
                        time(Some(p.seconds * 1e9)),
                        if p.complete {
                            "proof complete"
                        } else {
                            "**proof incomplete**: stopped at the memory bound"
                        },
                        p.states,
                        p.full_expansions
                    )
                }),
            )
            .paper("– (no checker)")
            .goal(
                format!("≤ {} s", goal::CHECK_STRESS_MS / 1e3),
                proof
                    .as_ref()
                    .map(|p| p.complete && p.seconds * 1e3 <= goal::CHECK_STRESS_MS),
            ),
        );
        rows.push(
            row(
                format!(
                    "{what}: every property from the mission text, and peak memory of the process"
                ),
                format!(
                    "{}{}",
                    time(t),
                    proof.map_or(String::new(), |p| format!(
                        " ({}; peak memory {})",
                        if p.found_something {
                            "**findings**"
                        } else {
                            "nothing found"
                        },
                        mem(process.peak_kib)
                    ))
                ),
            )
            .paper("– (no checker)")
            .goal(
                format!("≤ {} s", goal::CHECK_STRESS_MS / 1e3),
                t.zip(complete)
                    .map(|(v, c)| c && v <= goal::CHECK_STRESS_MS * 1e6),
            ),
        );
    }

    // What the spatial properties cost: the whole check against the same
    // check with the logic alone, in the same run.
    let whole = r.ns(&format!("check/check/{}", STRESS.nodes));
    let logic = r.ns(&format!("check/logic_only/{}", STRESS.nodes));
    rows.push(
        row(
            format!(
                "`eamos check`, {}-node mission, {} drones: every property including separation, airspace and flight state, against the logic alone",
                STRESS.nodes, STRESS.drones
            ),
            format!(
                "{}{}",
                time(whole),
                whole
                    .zip(logic)
                    .map_or(String::new(), |(w, l)| format!(" ({:.2}x)", w / l))
            ),
        )
        .paper("– (no checker)")
        .baseline(format!("{} (logic alone)", time(logic)))
        .goal(
            format!(
                "≤ {}x the logic alone, ≤ {} s",
                goal::SPATIAL_FACTOR,
                goal::CHECK_STRESS_MS / 1e3
            ),
            whole.zip(logic).map(|(w, l)| {
                w <= goal::SPATIAL_FACTOR * l && w <= goal::CHECK_STRESS_MS * 1e6
            }),
        ),
    );

    let firings = r
        .ns("executor/firings/1000")
        .zip(r.elements("executor/firings/1000"));
    rows.push(row(
        "executor: local transition firings per second, instant actions",
        firings.map_or(MISSING.to_string(), |(ns, k)| {
            format!(
                "{:.0} k/s ({k} firings in {})",
                k as f64 / ns * 1e6,
                time(Some(ns))
            )
        }),
    ));

    let bare = r.ns("bridge/zenoh_bare");
    let bridge = r.ns("bridge/round_trip");
    let ratio = bare.zip(bridge).map(|(b, t)| t / b);
    rows.push(
        row(
            "bridge round trip, drone A to B and back, zenoh on loopback",
            format!(
                "{}{}",
                time(bridge),
                ratio.map_or(String::new(), |x| format!(" ({x:.2}× bare)"))
            ),
        )
        .baseline(format!("{} (bare zenoh ping-pong)", time(bare)))
        .goal(
            format!("≤ {}× bare", goal::BRIDGE_RATIO),
            ratio.map(|x| x <= goal::BRIDGE_RATIO),
        ),
    );

    rows.push(
        row(
            format!(
                "`eamos lsp`: from an edit to its diagnostics, {}-node mission, {} drones (median of {} keystrokes)",
                STRESS.nodes,
                STRESS.drones,
                crate::lsp::EDITS
            ),
            ms(m.lsp.edit),
        )
        .baseline(format!("{} (opening the file)", ms(m.lsp.open)))
        .goal(
            format!("≤ {} ms", goal::LSP_EDIT_MS),
            Some(m.lsp.edit.as_secs_f64() * 1e3 <= goal::LSP_EDIT_MS),
        ),
    );

    for (entry, c) in &m.corpus {
        let asked = if entry.deadlock_only {
            "deadlock only"
        } else if entry.spatial {
            "every property"
        } else {
            "every property but the spatial ones"
        };
        let median = match entry.runs {
            0 | 1 => String::new(),
            n => format!(" (median of {n} runs)"),
        };
        let what = format!(
            "`eamos check`, corpus: `{}`, {asked}{median}",
            entry.generator
        );
        let figure = format!(
            "{}: {} ({} states, peak memory {})",
            c.verdict,
            ms(c.wall),
            c.states,
            mem(c.peak_kib)
        );
        let mut r = row(what, figure);
        if let Some(goal_s) = entry.goal_s {
            r = r.goal(
                format!("decided in < {goal_s} s"),
                Some(c.decided && c.wall.as_secs_f64() < goal_s),
            );
        } else {
            r = r.goal(
                format!("decided within {} MB", crate::corpus::MAX_MEMORY_MB),
                Some(c.decided),
            );
        }
        rows.push(r);
    }

    rows.push(check_growth_row(&m.corpus));

    for f in &m.fleets {
        rows.extend(fleet_rows(f));
    }
    if let Some(monitor) = &m.monitor {
        rows.extend(monitor_rows(monitor.as_ref()));
    }

    let mut out = String::new();
    out.push_str("| measurement | eamos | paper | baseline | goal | met |\n");
    out.push_str("| --- | --- | --- | --- | --- | --- |\n");
    for r in rows {
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            r.what, r.eamos, r.paper, r.baseline, r.goal, r.met
        ));
    }
    out
}

/// The rows of the live monitor under load.
fn monitor_rows(m: Option<&crate::monitor::MonitorRun>) -> Vec<Row> {
    let Some(m) = m else {
        return vec![row(
            "live monitor: from an event to the page",
            format!("{MISSING} (no chromium and chromedriver here)"),
        )
        .goal(format!("p99 ≤ {} ms", goal::MONITOR_P99_MS), None)];
    };
    let what = format!(
        "live monitor, {} simulated drones at 10 Hz in one `eamos run`, its page in headless Chromium, {:.0} s after a warm-up",
        m.drones,
        m.measured.as_secs_f64()
    );
    let said = |l: &crate::monitor::Latency| {
        format!(
            "p50 {:.1} ms, p99 {:.1} ms, max {:.0} ms ({} events)",
            l.p50, l.p99, l.max, l.count
        )
    };
    let size = |p: &crate::monitor::PageSize| {
        format!(
            "{:.1} MB of live heap, {} elements",
            p.heap_bytes as f64 / 1e6,
            p.elements
        )
    };
    vec![
        row(
            format!("{what}: from an event to the page's handler"),
            said(&m.handled),
        )
        .goal(
            format!("p99 ≤ {} ms", goal::MONITOR_P99_MS),
            Some(m.handled.count > 0 && m.handled.p99 <= goal::MONITOR_P99_MS),
        ),
        row(
            format!("{what}: from an event to the frame that shows it"),
            said(&m.painted),
        ),
        row(
            format!("{what}: the page's size, at the start and at the end"),
            format!(
                "{}; then {} (largest heap seen {:.1} MB)",
                size(&m.start),
                size(&m.end),
                m.largest_heap_bytes as f64 / 1e6
            ),
        ),
    ]
}

/// The rows of one fleet flown one process per drone.
fn fleet_rows(f: &crate::fleet::FleetRun) -> Vec<Row> {
    let what = format!(
        "{} drones, one process each plus the ground station, through one zenoh router ({}-node mission, release build)",
        f.drones,
        f.drones * 10
    );
    let start = f.to_start.map(|d| d.as_secs_f64());
    let start_met = Some(start.is_some_and(|s| s <= goal::FLEET_START_S));
    // Only a fleet that flew its mission says what a process weighs.
    let peak_met = (f.completed && f.drone_max_kib > 0 && f.gcs_kib > 0)
        .then(|| mb(f.drone_max_kib.max(f.gcs_kib)) <= goal::FLEET_PROCESS_MB);
    let private_met = (f.completed && f.drone_private_max_kib > 0 && f.gcs_private_kib > 0)
        .then(|| mb(f.drone_private_max_kib.max(f.gcs_private_kib)) <= goal::FLEET_PROCESS_MB);
    let flown = f.to_end.as_secs_f64().max(1e-3);
    let through = f.loopback.map_or("not measured".to_string(), |t| {
        format!(
            "{:.0} packets a second, {:.2} MB/s",
            t.packets as f64 / flown,
            t.bytes as f64 / flown / 1e6
        )
    });
    vec![
        row(
            format!("{what}: compiling and cutting the slices once, before the launch"),
            format!("{:.2} s", f.cut.as_secs_f64()),
        ),
        row(
            format!("{what}: from the launch to the mission's start"),
            start.map_or("did not start".to_string(), |s| format!("{s:.1} s")),
        )
        .goal(format!("≤ {} s", goal::FLEET_START_S), start_met),
        row(
            format!("{what}: from the launch to the last process's exit"),
            format!(
                "{:.1} s ({})",
                f.to_end.as_secs_f64(),
                if f.completed {
                    "completed"
                } else {
                    "did not complete"
                }
            ),
        ),
        row(
            format!("{what}: peak memory per process"),
            format!(
                "drones: largest {}, median {}; ground station {}",
                mem(f.drone_max_kib),
                mem(f.drone_median_kib),
                mem(f.gcs_kib)
            ),
        )
        .goal(format!("≤ {} MB", goal::FLEET_PROCESS_MB), peak_met),
        row(
            format!("{what}: peak private memory per process (sampled; the rest of the resident set is code shared by every process)"),
            format!(
                "drones: largest {}, median {}; ground station {}",
                mem(f.drone_private_max_kib),
                mem(f.drone_private_median_kib),
                mem(f.gcs_private_kib)
            ),
        )
        .goal(format!("≤ {} MB", goal::FLEET_PROCESS_MB), private_met),
        row(
            format!("{what}: the ground station's resident set while the fleet flies (sampled from the mission's start, once the compile and the check are over)"),
            mem(f.gcs_flying_kib),
        ),
        row(
            format!("{what}: peak memory of the zenoh router (`eamos router`, on the ground: every frame of the fleet goes through it; not one of the fleet's processes)"),
            mem(f.router_kib),
        ),
        row(
            format!("{what}: peak proportional memory per drone (sampled; shared pages divided among the processes that map them)"),
            format!(
                "largest {}, median {}",
                mem(f.drone_pss_max_kib),
                mem(f.drone_pss_median_kib)
            ),
        ),
        row(
            format!("{what}: on the loopback interface, from the launch to the end (every frame goes through the router, once in, once out; TCP's acknowledgements included)"),
            through,
        ),
    ]
}

/// The table of the fleets alone (`eamos bench-report --fleets-only`).
pub fn fleet_table(fleets: &[crate::fleet::FleetRun]) -> String {
    short_table(fleets.iter().flat_map(fleet_rows))
}

/// The table of `eamos bench-report --monitor-only`.
pub fn monitor_table(monitor: Option<&crate::monitor::MonitorRun>) -> String {
    short_table(monitor_rows(monitor))
}

/// A table of live measurements alone: nothing of the paper's.
fn short_table(rows: impl IntoIterator<Item = Row>) -> String {
    let mut out = String::new();
    out.push_str("| measurement | eamos | goal | met |\n");
    out.push_str("| --- | --- | --- | --- |\n");
    for r in rows {
        out.push_str(&format!(
            "| {} | {} | {} | {} |\n",
            r.what, r.eamos, r.goal, r.met
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_monitor_not_measured_says_why_and_meets_no_goal() {
        let rows = monitor_rows(None);
        assert_eq!(rows.len(), 1);
        assert!(rows[0].eamos.contains("no chromium"), "{}", rows[0].eamos);
        assert_eq!(rows[0].met, MISSING);
    }

    #[test]
    fn a_monitor_meets_its_goal_only_with_a_p99_within_it() {
        let latency = |p99: f64| crate::monitor::Latency {
            count: 1000,
            p50: 5.0,
            p99,
            max: p99 + 1.0,
        };
        let size = crate::monitor::PageSize {
            heap_bytes: 3_000_000,
            elements: 100,
        };
        let run = |p99: f64| crate::monitor::MonitorRun {
            drones: 100,
            measured: Duration::from_secs(600),
            handled: latency(p99),
            painted: latency(p99),
            start: size,
            end: size,
            largest_heap_bytes: 3_000_000,
        };
        assert_eq!(monitor_rows(Some(&run(99.0)))[0].met, "met");
        assert_eq!(monitor_rows(Some(&run(101.0)))[0].met, "not met");
        assert!(monitor_rows(Some(&run(99.0)))[2]
            .eamos
            .contains("3.0 MB of live heap"));
    }

    #[test]
    fn the_fleet_series_is_judged_by_how_its_check_grows() {
        let entry = |n| crate::corpus::Entry {
            generator: format!("eamos gen --drones {n}"),
            file: std::path::PathBuf::new(),
            deadlock_only: false,
            spatial: true,
            fleet: Some(n),
            goal_s: None,
            runs: 1,
        };
        let checked = |seconds: f64, peak_kib: u64| crate::corpus::Checked {
            verdict: "every property decided".into(),
            decided: true,
            states: 1,
            wall: std::time::Duration::from_secs_f64(seconds),
            peak_kib,
        };
        let series = |time: &dyn Fn(f64) -> f64, memory: &dyn Fn(f64) -> f64| {
            [50, 100, 250, 500]
                .into_iter()
                .map(|n| (entry(n), checked(time(n as f64), memory(n as f64) as u64)))
                .collect::<Vec<_>>()
        };
        let linear = check_growth_row(&series(&|n| n / 100.0, &|n| 1000.0 * n));
        assert_eq!(linear.met, "met");
        assert!(linear.eamos.contains("drones^1.00"), "{}", linear.eamos);
        let quadratic_time = check_growth_row(&series(&|n| n * n / 1e4, &|n| 1000.0 * n));
        assert_eq!(quadratic_time.met, "not met");
        let quadratic_memory = check_growth_row(&series(&|n| n / 100.0, &|n| n * n));
        assert_eq!(quadratic_memory.met, "not met");
        assert_eq!(check_growth_row(&[]).met, MISSING);
    }

    #[test]
    fn a_linear_series_has_growth_exponent_one_and_a_quadratic_two() {
        let linear: Vec<(f64, f64)> = [1e3, 1e4, 1e5].iter().map(|&n| (n, 3.0 * n)).collect();
        let quadratic: Vec<(f64, f64)> = [1e3, 1e4, 1e5].iter().map(|&n| (n, n * n)).collect();
        assert!((growth_exponent(&linear).unwrap() - 1.0).abs() < 1e-9);
        assert!((growth_exponent(&quadratic).unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(growth_exponent(&linear[..1]), None);
    }

    #[test]
    fn times_and_sizes_print_in_readable_units() {
        assert_eq!(time(Some(2.34e9)), "2.34 s");
        assert_eq!(time(Some(12.345e6)), "12.35 ms");
        assert_eq!(time(Some(45_600.0)), "45.6 µs");
        assert_eq!(time(Some(80.0)), "80 ns");
        assert_eq!(time(None), MISSING);
        assert_eq!(mem(15_625), "16.0 MB");
        assert_eq!(paper_kb(23_979.0), "24.0 MB");
    }
}
