//! `eamos bench-report`: run the benchmarks in criterion's quick mode and
//! print one markdown table, each figure beside the paper's (section VIII-E,
//! the stress test), beside its baseline and beside its goal.
//!
//! Run it from the workspace with a release build, so that it measures what
//! users run: `cargo run --release -- bench-report`. It runs
//! `cargo bench` (the `compile`, `start`, `check`, `executor` and `bridge`
//! benchmarks) with its results under `--dir`, then measures the peak
//! memory of whole processes: this program, started again on itself, once
//! compiling a mission and once starting an agent from a slice file (peak
//! resident set size from `wait4`), against a process that does nothing.
//! Progress goes to standard error, the table to standard output.
//! Exit status: 0 the table is printed, 2 a benchmark or a probe failed.

mod workload;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use eamos_lang::SourceFile;
use serde_json::Value;

use workload::{MissionSpec, SERIES, SMALL, STRESS, STRESS_WITHOUT_CHOICES};

/// Run the benchmarks in quick mode and print the table of results.
#[derive(clap::Args)]
pub struct Args {
    /// Where the benchmark results, missions and slices go.
    #[arg(long, value_name = "DIR", default_value = "target/bench-report")]
    pub dir: PathBuf,
    /// Do not run the benchmarks: report those of an earlier run in DIR.
    #[arg(long)]
    pub no_run: bool,
    /// How many times each process is measured (the median is reported).
    #[arg(long, value_name = "N", default_value_t = 5)]
    pub repeat: usize,
    /// Measure one process and exit: `idle`, `compile MISSION` or `start
    /// SLICE` (the report runs itself this way).
    #[arg(long, hide = true, num_args = 1..=2, value_names = ["WHAT", "FILE"])]
    pub probe: Option<Vec<String>>,
}

/// The benchmarks this report reads, as `cargo bench --bench` names them.
const BENCHES: [&str; 5] = ["compile", "start", "check", "executor", "bridge"];

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
    pub const COMPILE_STRESS_MS: f64 = 25.0;
    pub const COMPILE_STRESS_MB: f64 = 16.0;
    /// Compile time grows as nodes^k with k at most this.
    pub const GROWTH_EXPONENT: f64 = 1.15;
    pub const START_STRESS_MS: f64 = 10.0;
    pub const CHECK_STRESS_MS: f64 = 1_000.0;
    pub const BRIDGE_RATIO: f64 = 1.5;
}

pub fn run(args: Args) -> ExitCode {
    if let Some(probe) = &args.probe {
        return run_probe(probe);
    }
    match report(&args) {
        Ok(table) => {
            print!("{table}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn report(args: &Args) -> Result<String, String> {
    std::fs::create_dir_all(&args.dir)
        .map_err(|e| format!("cannot create {}: {e}", args.dir.display()))?;
    // Absolute: the benchmarks run in the package's directory, which may
    // not be this one.
    let dir = std::path::absolute(&args.dir)
        .map_err(|e| format!("cannot resolve {}: {e}", args.dir.display()))?;
    let criterion = dir.join("criterion");
    if !args.no_run {
        run_benches(&criterion)?;
    }
    let results = Results { root: criterion };
    let facts = prepare(&dir)?;
    let exe = this_program()?;
    let n = args.repeat.max(1);
    eprintln!("measuring whole processes ({n} runs each)...");
    let idle = probe(&exe, &["idle"], n)?;
    let compile_small = probe(&exe, &["compile", path_str(&facts.small.mission)?], n)?;
    let compile_stress = probe(&exe, &["compile", path_str(&facts.stress.mission)?], n)?;
    let start_small = probe(&exe, &["start", path_str(&facts.small.slice)?], n)?;
    let start_stress = probe(&exe, &["start", path_str(&facts.stress.slice)?], n)?;
    eprintln!("checking the stress missions once more, to see how far the proofs go...");
    let check_stress = probe(&exe, &["check", path_str(&facts.stress.mission)?], 1)?;
    let check_without_choices = probe(&exe, &["check", path_str(&facts.without_choices)?], 1)?;
    Ok(table(&Measured {
        results: &results,
        facts: &facts,
        idle,
        compile_small,
        compile_stress,
        start_small,
        start_stress,
        check_stress,
        check_without_choices,
    }))
}

/// This program, to start again as a probe. On Linux through `/proc`, which
/// still reaches it when a rebuild has replaced the file meanwhile.
fn this_program() -> Result<PathBuf, String> {
    let proc_exe = Path::new("/proc/self/exe");
    if cfg!(target_os = "linux") && proc_exe.exists() {
        return Ok(proc_exe.to_path_buf());
    }
    std::env::current_exe().map_err(|e| format!("cannot find this program: {e}"))
}

/// `cargo bench` of every benchmark, quick mode, results in `criterion`.
fn run_benches(criterion: &Path) -> Result<(), String> {
    if criterion.exists() {
        std::fs::remove_dir_all(criterion)
            .map_err(|e| format!("cannot clear {}: {e}", criterion.display()))?;
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.arg("bench");
    for b in BENCHES {
        cmd.args(["--bench", b]);
    }
    cmd.args(["--", "--quick", "--noplot"])
        .env("CRITERION_HOME", criterion)
        .stdout(Stdio::piped());
    eprintln!("running the benchmarks (cargo bench, quick mode)...");
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot run cargo bench: {e}"))?;
    // Criterion's progress goes to standard error: standard output is the
    // table's.
    if let Some(out) = child.stdout.take() {
        let stderr = std::io::stderr();
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            let _ = writeln!(stderr.lock(), "{line}");
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("cargo bench did not finish: {e}"))?;
    if !status.success() {
        return Err(format!("cargo bench failed ({status})"));
    }
    Ok(())
}

/// The files the probes read, and what the table says about them.
struct Facts {
    small: MissionFacts,
    stress: MissionFacts,
    /// The stress mission without choices (only checked).
    without_choices: PathBuf,
}

struct MissionFacts {
    spec: MissionSpec,
    mission: PathBuf,
    slice: PathBuf,
    /// The largest drone slice: its drone, places, transitions, bytes.
    drone: String,
    places: usize,
    transitions: usize,
    bytes: usize,
    meg_nodes: usize,
}

/// Writes the two paper missions and their largest drone slices.
fn prepare(dir: &Path) -> Result<Facts, String> {
    let files = dir.join("files");
    std::fs::create_dir_all(&files)
        .map_err(|e| format!("cannot create {}: {e}", files.display()))?;
    let profiles = eamos_profile::builtin();
    let one = |spec: MissionSpec| -> Result<MissionFacts, String> {
        let text = spec.text();
        let mission = files.join(spec.file_name());
        std::fs::write(&mission, &text)
            .map_err(|e| format!("cannot write {}: {e}", mission.display()))?;
        let source = SourceFile::new(mission.display().to_string(), text);
        let compiled = workload::compile(&source, &profiles)?;
        let largest = workload::largest_drone_slice(&compiled.slices);
        let bytes = largest.to_bytes();
        let slice = files.join(format!(
            "{}-{}.slice",
            spec.file_name().trim_end_matches(".go"),
            largest.drone
        ));
        std::fs::write(&slice, &bytes)
            .map_err(|e| format!("cannot write {}: {e}", slice.display()))?;
        Ok(MissionFacts {
            spec,
            mission,
            slice,
            drone: largest.drone.clone(),
            places: largest.places.len(),
            transitions: largest.transitions.len(),
            bytes: bytes.len(),
            meg_nodes: eamos_gen::meg::nodes(&compiled.mission),
        })
    };
    let without_choices = files.join(STRESS_WITHOUT_CHOICES.file_name());
    std::fs::write(&without_choices, STRESS_WITHOUT_CHOICES.text())
        .map_err(|e| format!("cannot write {}: {e}", without_choices.display()))?;
    Ok(Facts {
        small: one(SMALL)?,
        stress: one(STRESS)?,
        without_choices,
    })
}

fn path_str(p: &Path) -> Result<&str, String> {
    p.to_str()
        .ok_or_else(|| format!("{} is not valid UTF-8", p.display()))
}

/// One process measured: from spawn to its "ready" line, and its peak
/// resident set size (medians over the runs), and what it said after
/// "ready" (the last run's).
#[derive(Debug, Clone)]
struct Process {
    to_ready: Duration,
    peak_kib: u64,
    said: Vec<String>,
}

fn probe(exe: &Path, what: &[&str], runs: usize) -> Result<Process, String> {
    let mut times = Vec::with_capacity(runs);
    let mut peaks = Vec::with_capacity(runs);
    let mut said = Vec::new();
    for _ in 0..runs {
        let p = probe_once(exe, what)?;
        times.push(p.to_ready);
        peaks.push(p.peak_kib);
        said = p.said;
    }
    times.sort();
    peaks.sort();
    Ok(Process {
        to_ready: times[runs / 2],
        peak_kib: peaks[runs / 2],
        said,
    })
}

fn probe_once(exe: &Path, what: &[&str]) -> Result<Process, String> {
    let started = Instant::now();
    let mut child = Command::new(exe)
        .arg("bench-report")
        .arg("--probe")
        .args(what)
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))?;
    let mut line = String::new();
    let mut said = Vec::new();
    let mut to_ready = Duration::ZERO;
    if let Some(out) = child.stdout.take() {
        let mut out = BufReader::new(out);
        let _ = out.read_line(&mut line);
        to_ready = started.elapsed();
        said = out.lines().map_while(Result::ok).collect();
    }
    let (ok, rusage_kib) = wait_with_peak(&mut child)?;
    let mut words = line.split_whitespace();
    if !ok || words.next() != Some("ready") {
        return Err(format!("the probe `{}` failed (see above)", what.join(" ")));
    }
    // The child's own figure where it has one: see `own_peak_kib`.
    let peak_kib = words
        .next()
        .and_then(|w| w.parse().ok())
        .unwrap_or(rusage_kib);
    Ok(Process {
        to_ready,
        peak_kib,
        said,
    })
}

/// Waits for the child and returns whether it succeeded and its peak
/// resident set size in KiB.
#[cfg(unix)]
fn wait_with_peak(child: &mut std::process::Child) -> Result<(bool, u64), String> {
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain data that `wait4` fills in; all zeroes is a
    // valid value of it.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not yet waited for (std never waits
    // on its own), and both pointers are to live locals.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    if r != pid {
        return Err(format!(
            "cannot wait for the probe: {}",
            std::io::Error::last_os_error()
        ));
    }
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    // Linux reports KiB, macOS bytes.
    let maxrss = usage.ru_maxrss as u64;
    let kib = if cfg!(target_os = "macos") {
        maxrss / 1024
    } else {
        maxrss
    };
    Ok((ok, kib))
}

#[cfg(not(unix))]
fn wait_with_peak(child: &mut std::process::Child) -> Result<(bool, u64), String> {
    let status = child
        .wait()
        .map_err(|e| format!("cannot wait for the probe: {e}"))?;
    Ok((status.success(), 0))
}

/// The peak resident set of this process so far, in KiB, from
/// `/proc/self/status` (Linux). `wait4`'s `ru_maxrss` cannot be trusted
/// for it: Linux counts into a child's maximum the pages it shared with its
/// parent between `fork` and `exec`, so every probe would weigh at least as
/// much as the report that started it.
fn own_peak_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// The child side: do one thing, say "ready" (with its peak memory where the
/// system tells it, and what it found), exit.
fn run_probe(probe: &[String]) -> ExitCode {
    let result = match probe {
        [what] if what == "idle" => Ok(String::new()),
        [what, file] if what == "compile" => probe_compile(Path::new(file)),
        [what, file] if what == "start" => probe_start(Path::new(file)),
        [what, file] if what == "check" => probe_check(Path::new(file)),
        _ => Err(format!(
            "unknown probe `{}`: idle, compile MISSION, start SLICE or check MISSION",
            probe.join(" ")
        )),
    };
    match result {
        Ok(said) => {
            let mut out = std::io::stdout().lock();
            let peak = own_peak_kib().map_or(String::new(), |kib| format!(" {kib}"));
            // A reader that went away is the report's business, not a panic.
            let written = (|| {
                writeln!(out, "ready{peak}")?;
                if !said.is_empty() {
                    writeln!(out, "{said}")?;
                }
                out.flush()
            })();
            // What happens after "ready" is not part of the measurement.
            std::process::exit(if written.is_ok() { 0 } else { 2 })
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn probe_compile(file: &Path) -> Result<String, String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let source = SourceFile::new(file.display().to_string(), text);
    let compiled = workload::compile(&source, &eamos_profile::builtin())?;
    std::hint::black_box(&compiled);
    Ok(String::new())
}

/// Checks a mission as the `check` benchmark does; says how far the proof
/// went (JSON).
fn probe_check(file: &Path) -> Result<String, String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let source = SourceFile::new(file.display().to_string(), text);
    let profiles = eamos_profile::builtin();
    let mission = workload::front_end(&source, &profiles)?;
    let net = eamos_petri::compile(&mission, &profiles);
    let options = eamos_verify::Options {
        max_memory_mb: workload::CHECK_MEMORY_MB,
        ..eamos_verify::Options::default()
    };
    let report = eamos_verify::check_net(&net, &profiles, Some(&source.text), &options);
    Ok(serde_json::json!({
        "states": report.stats.states,
        "full_expansions": report.stats.full_expansions,
        "complete": report.stats.complete,
        "seconds": report.stats.seconds,
        "found_something": report.found_something(),
    })
    .to_string())
}

fn probe_start(file: &Path) -> Result<String, String> {
    let bytes = std::fs::read(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let slice = eamos_slicer::Slice::from_bytes(&bytes).map_err(|e| e.to_string())?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the async runtime: {e}"))?;
    let profiles = eamos_profile::builtin();
    let ready = runtime.block_on(workload::ready_agent(
        slice,
        &profiles,
        workload::LinkKind::Zenoh,
    ))?;
    std::hint::black_box(&ready);
    Ok(String::new())
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
struct Results {
    root: PathBuf,
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

struct Measured<'a> {
    results: &'a Results,
    facts: &'a Facts,
    idle: Process,
    compile_small: Process,
    compile_stress: Process,
    start_small: Process,
    start_stress: Process,
    check_stress: Process,
    check_without_choices: Process,
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

fn table(m: &Measured) -> String {
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
        let mut time_row = row(format!("{what}: time"), parts).paper(paper_ms(paper_ms_v));
        let mut mem_row = row(
            format!("{what}: peak memory of the process"),
            mem(process.peak_kib),
        )
        .paper(paper_kb(paper_kb_v))
        .baseline(idle_mem.clone());
        if f.spec == STRESS {
            time_row = time_row.goal(
                format!("≤ {} ms", goal::COMPILE_STRESS_MS),
                total.map(|t| t <= goal::COMPILE_STRESS_MS * 1e6),
            );
            mem_row = mem_row.goal(
                format!("≤ {} MB", goal::COMPILE_STRESS_MB),
                (process.peak_kib > 0).then(|| mb(process.peak_kib) <= goal::COMPILE_STRESS_MB),
            );
        }
        rows.push(time_row);
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
        let mut t = row(
            format!("{what}: slice file to agent ready (in process)"),
            format!(
                "{} (decoding {})",
                time(ready),
                time(r.ns(&format!("start/decode/{n}")))
            ),
        )
        .paper(format!("{} ({paper_nodes})", paper_ms(paper_ms_v)));
        if f.spec == STRESS {
            t = t.goal(
                format!("≤ {} ms", goal::START_STRESS_MS),
                ready.map(|v| v <= goal::START_STRESS_MS * 1e6),
            );
        }
        rows.push(t);
        rows.push(
            row(
                format!("{what}: new process to agent ready on zenoh"),
                ms(process.to_ready),
            )
            .paper(paper_ms(paper_ms_v))
            .baseline(format!(
                "{} (a process that does nothing)",
                ms(m.idle.to_ready)
            )),
        );
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
                "`eamos check`, {}-node mission ({} MEG nodes): every property",
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
                format!("{what}: every property, and peak memory of the process"),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_series_has_growth_exponent_one_and_a_quadratic_two() {
        let linear: Vec<(f64, f64)> = [1e3, 1e4, 1e5].iter().map(|&n| (n, 3.0 * n)).collect();
        let quadratic: Vec<(f64, f64)> = [1e3, 1e4, 1e5].iter().map(|&n| (n, n * n)).collect();
        assert!((growth_exponent(&linear).unwrap() - 1.0).abs() < 1e-9);
        assert!((growth_exponent(&quadratic).unwrap() - 2.0).abs() < 1e-9);
        assert_eq!(growth_exponent(&linear[..1]), None);
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn a_probe_reads_its_own_peak_memory() {
        let kib = own_peak_kib().expect("Linux gives every process its VmHWM");
        assert!(kib > 0);
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
