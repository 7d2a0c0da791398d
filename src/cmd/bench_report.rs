//! `eamos bench-report`: the benchmark report of `eamos-bench`, run from
//! the workspace with a release build (`cargo run --release --
//! bench-report`). Exit status: 0 the table is printed, 2 a benchmark or a
//! probe failed.

use std::path::PathBuf;
use std::process::ExitCode;

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
    /// Fly fleets of these sizes, one process per drone plus the ground
    /// station, through a zenoh router: from the launch to the mission's
    /// start, to its end, and each process's peak memory. The default
    /// keeps a CI run short; a full run says `--fleets 50,100,250`.
    #[arg(
        long,
        value_name = "N,...",
        value_delimiter = ',',
        default_value = "50"
    )]
    pub fleets: Vec<usize>,
    /// How many simulated drones fly under the live monitor while its page,
    /// in headless Chromium, measures how long events take to reach it (0:
    /// not measured).
    #[arg(long, value_name = "N", default_value_t = 100)]
    pub monitor_drones: usize,
    /// How long the monitor's page is measured, after a warm-up, in
    /// seconds. The default keeps a CI run short; the figure of a long
    /// flight is `--monitor-seconds 600`.
    #[arg(long, value_name = "S", default_value_t = 30)]
    pub monitor_seconds: u64,
    /// Fly the fleets (`--fleets`) and report them alone: no benchmarks,
    /// no other probes.
    #[arg(long)]
    pub fleets_only: bool,
    /// Measure the live monitor (`--monitor-drones`, `--monitor-seconds`)
    /// and report it alone.
    #[arg(long, conflicts_with = "fleets_only")]
    pub monitor_only: bool,
    /// Measure one process and exit: `idle`, `compile MISSION` or `start
    /// SLICE` (the report runs itself this way).
    #[arg(long, hide = true, num_args = 1..=2, value_names = ["WHAT", "FILE"])]
    pub probe: Option<Vec<String>>,
}

pub fn run(args: Args) -> ExitCode {
    if let Some(probe) = &args.probe {
        return eamos_bench::run_probe(probe);
    }
    let options = eamos_bench::Options {
        dir: args.dir,
        no_run: args.no_run,
        repeat: args.repeat,
        fleets: args.fleets,
        monitor: (args.monitor_drones > 0).then(|| {
            (
                args.monitor_drones,
                std::time::Duration::from_secs(args.monitor_seconds),
            )
        }),
        fleets_only: args.fleets_only,
        monitor_only: args.monitor_only,
    };
    match eamos_bench::report(&options) {
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
