//! The benchmark harness behind `eamos bench-report`: runs the criterion
//! benchmarks of the workspace in quick mode, measures whole processes (this
//! program started again on itself as a probe, and `gofmt` on the same
//! mission as a baseline), and prints one markdown table, each figure beside
//! the paper's (section VIII-E, the stress test), its baseline and its goal.
//!
//! It owns the workloads the benchmarks time (`workload`, which
//! `benches/*.rs` import), so that a benchmark and a probe measure one
//! thing. It must never judge speed in a test: figures are only reported,
//! and goals are met or not in the table.
//!
//! Run it from the workspace with a release build, so that it measures what
//! users run: `cargo run --release -- bench-report`. It runs `cargo bench`
//! (the `compile`, `start`, `check`, `executor` and `bridge` benchmarks)
//! with its results under `dir`, and flies fleets of simulated drones one
//! process per drone (`fleet`). Progress goes to standard error, the table
//! to standard output.

mod corpus;
mod files;
mod fleet;
mod lsp;
mod monitor;
mod probe;
mod process;
mod table;
pub mod workload;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

pub use probe::run_probe;

/// What `eamos bench-report` was asked.
#[derive(Debug, Clone)]
pub struct Options {
    /// Where the benchmark results, missions and slices go.
    pub dir: PathBuf,
    /// Report the results of an earlier run in `dir` without running the
    /// benchmarks.
    pub no_run: bool,
    /// How many times each process is measured (the median is reported).
    pub repeat: usize,
    /// The fleets flown one process per drone, by their numbers of drones
    /// (once each: a fleet is a hundred processes, not one).
    pub fleets: Vec<usize>,
    /// The live monitor: how many simulated drones, and for how long it is
    /// measured after its warm-up (`None`: not measured).
    pub monitor: Option<(usize, std::time::Duration)>,
    /// Fly the fleets and report them alone, without the benchmarks and
    /// the other probes.
    pub fleets_only: bool,
    /// Measure the live monitor and report it alone.
    pub monitor_only: bool,
}

/// The benchmarks this report reads, as `cargo bench --bench` names them.
const BENCHES: [&str; 5] = ["compile", "start", "check", "executor", "bridge"];

/// Runs the benchmarks and the probes; returns the table.
pub fn report(options: &Options) -> Result<String, String> {
    std::fs::create_dir_all(&options.dir)
        .map_err(|e| format!("cannot create {}: {e}", options.dir.display()))?;
    // Absolute: the benchmarks run in the package's directory, which may
    // not be this one.
    let dir = std::path::absolute(&options.dir)
        .map_err(|e| format!("cannot resolve {}: {e}", options.dir.display()))?;
    if options.monitor_only {
        let (drones, span) = options
            .monitor
            .ok_or("--monitor-only with --monitor-drones 0 measures nothing")?;
        let measured = monitor::measure(&this_program()?, &dir, drones, span)?;
        return Ok(table::monitor_table(measured.as_ref()));
    }
    if options.fleets_only {
        let exe = this_program()?;
        let mut fleets = Vec::new();
        for &drones in &options.fleets {
            eprintln!("flying {drones} drones, one process each, through a zenoh router...");
            fleets.push(fleet::measure(&exe, &dir, drones)?);
        }
        return Ok(table::fleet_table(&fleets));
    }
    let criterion = dir.join("criterion");
    if !options.no_run {
        run_benches(&criterion)?;
    }
    let results = table::Results { root: criterion };
    let facts = files::prepare(&dir)?;
    let exe = this_program()?;
    let n = options.repeat.max(1);
    let path = files::path_str;
    eprintln!("measuring whole processes ({n} runs each)...");
    let idle = process::probe(&exe, &["idle"], n)?;
    let compile_small = process::probe(&exe, &["compile", path(&facts.small.mission)?], n)?;
    let compile_stress = process::probe(&exe, &["compile", path(&facts.stress.mission)?], n)?;
    let gofmt_stress = process::gofmt(&facts.stress.mission, n);
    let start_small = process::probe(&exe, &["start", path(&facts.small.slice)?], n)?;
    let start_stress = process::probe(&exe, &["start", path(&facts.stress.slice)?], n)?;
    eprintln!("checking the stress missions once more, to see how far the proofs go...");
    let check_stress = process::probe(&exe, &["check", path(&facts.stress.mission)?], 1)?;
    let check_without_choices = process::probe(&exe, &["check", path(&facts.without_choices)?], 1)?;
    eprintln!("checking the benchmark corpus...");
    let corpus_dir = dir.join("corpus");
    std::fs::create_dir_all(&corpus_dir)
        .map_err(|e| format!("cannot create {}: {e}", corpus_dir.display()))?;
    let corpus = corpus::check_all(&exe, corpus::prepare(&corpus_dir)?, |entry| {
        eprintln!("  {}", entry.generator)
    })?;
    eprintln!("timing the language server's diagnostics after an edit...");
    let lsp = lsp::measure(&exe, &facts.stress.mission)?;
    let mut fleets = Vec::new();
    for &drones in &options.fleets {
        eprintln!("flying {drones} drones, one process each, through a zenoh router...");
        fleets.push(fleet::measure(&exe, &dir, drones)?);
    }
    let monitor = match options.monitor {
        Some((drones, span)) => {
            eprintln!(
                "watching {drones} drones on the live monitor in Chromium for {} s...",
                span.as_secs()
            );
            Some(monitor::measure(&exe, &dir, drones, span)?)
        }
        None => None,
    };
    Ok(table::table(&table::Measured {
        results: &results,
        facts: &facts,
        idle,
        compile_small,
        compile_stress,
        gofmt_stress,
        start_small,
        start_stress,
        check_stress,
        check_without_choices,
        lsp,
        corpus,
        fleets,
        monitor,
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
