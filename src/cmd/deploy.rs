//! `eamos deploy MISSION --fleet FLEET`: the ground station's roll-out.
//! Compiles and slices the mission, signs each drone's slice with the
//! ground station key, sends it to the drone's agent (`eamos agent`) and
//! waits for the agent to say it verified and kept it, or why it refused.
//! A drone whose agent already holds the very same slice is not sent it
//! again: after an edit only the drones whose part changed get a new one.
//! Then it sends the signed start and flies the ground station's part,
//! as `eamos run --gcs` does (stopped with Ctrl-C, it sends every drone
//! an abort signed with the same key).
//!
//! Every deploy is a session of its own (a fresh random id in each signed
//! offer and in the start): an agent never starts one session twice, so a
//! recorded deploy played back is refused (see `eamos_rollout`).
//!
//! Prints one line per drone: `sent`, `unchanged` or `refused: <reason>`.
//! Exit status: 0 the mission completed (or, with `--no-start`, every drone
//! holds its slice), 1 a drone refused or the mission did not complete,
//! 2 bad input.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use eamos_rollout::{self as rollout, Answer, Delivery, RollOut};

use super::mission::{self, bad_input, Mission};
use eamos_exec::runner::RunOptions;
use eamos_exec::Outcome;

/// Send each drone's agent its signed slice, then start the mission.
#[derive(clap::Args)]
pub struct Args {
    /// The mission file (Go syntax).
    pub mission: PathBuf,
    /// The fleet file, the same as the agents'.
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: Option<PathBuf>,
    /// The ground station's secret key [default: the fleet's `[keys] gcs`
    /// public key with the extension `.key`].
    #[arg(long, value_name = "KEY")]
    pub key: Option<PathBuf>,
    /// How long to wait for every drone's agent to show up.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub wait: f64,
    /// Only deliver the slices; do not start the mission.
    #[arg(long)]
    pub no_start: bool,
    /// Simulated seconds per real second, on every drone.
    #[arg(long, value_name = "N", default_value_t = 20.0)]
    pub speed: f64,
    /// Mission time limit in seconds.
    #[arg(long, value_name = "SECONDS")]
    pub max_duration: Option<f64>,
    /// Seed of the simulators' random processes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Where the ground station's logs go [default: eamos-run/<mission>].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// How long the ground station waits for the started drones.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub startup_timeout: f64,
    /// Fly even when `eamos check` finds errors in the mission (two drones
    /// that can meet, a leg out of the airspace...): the findings are
    /// printed either way.
    #[arg(long)]
    pub allow_findings: bool,
    /// Serve the live monitor on ADDR (`HOST:PORT`, or a port alone for
    /// 127.0.0.1): the ground station's events, and each drone's position
    /// and liveness heard on the mission's network. The drones never wait
    /// for it, and it serves nothing that commands them.
    #[arg(long, value_name = "ADDR", value_parser = super::live::parse_addr)]
    pub monitor: Option<std::net::SocketAddr>,
}

pub fn run(args: Args) -> ExitCode {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        return bad_input(&format!("--speed must be above zero, not {}", args.speed));
    }
    if !(args.wait.is_finite() && args.wait >= 0.0) {
        return bad_input("--wait must be zero or more seconds");
    }
    if !(args.startup_timeout.is_finite() && args.startup_timeout >= 0.0) {
        return bad_input("--startup-timeout must be zero or more seconds");
    }
    if let Some(d) = args.max_duration {
        if !(d.is_finite() && d > 0.0) {
            return bad_input(&format!("--max-duration must be above zero, not {d}"));
        }
    }
    let loaded = match mission::load_to_fly(
        &args.mission,
        args.fleet.as_deref(),
        std::io::stderr().is_terminal(),
        args.allow_findings,
    ) {
        Ok(m) => m,
        Err(status) => return status,
    };
    let runtime = match super::Runtime::new() {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the async runtime: {e}")),
    };
    // Bound before anything is sent: a taken port stops the deploy here.
    let monitor = match args.monitor {
        Some(addr) => match runtime.block_on(async {
            let m = super::live::start(addr, &loaded, None).await?;
            let observer = super::live::observe(&loaded, &m.feed).await?;
            Ok::<_, String>((m, observer))
        }) {
            Ok(m) => Some(m),
            Err(e) => return bad_input(&e),
        },
        None => None,
    };
    let Mission {
        source,
        profiles,
        slices,
        fleet,
        ..
    } = loaded;
    eamos_trim::after_phase();
    let key = match rollout::ground_key(&fleet, args.key.as_deref()) {
        Ok(k) => k,
        Err(e) => return bad_input(&e),
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("eamos-run").join(&slices.mission));
    let run = RunOptions {
        speed: args.speed,
        max_duration: args.max_duration,
        seed: args.seed,
        out,
        source: Some(Arc::new(source)),
        startup_timeout: Duration::from_secs_f64(args.startup_timeout),
        // Its one executor: the ground station's.
        events: Some(crate::phases::releasing_once_started(
            1,
            monitor
                .iter()
                .map(|(m, _)| Arc::new(m.feed.clone()) as Arc<dyn eamos_exec::event::Sink>)
                .collect(),
        )),
        ..RunOptions::default()
    };
    println!(
        "deploying {} ({})",
        slices.mission_id,
        match &key {
            Some(k) => format!("signed by {}", k.public().fingerprint()),
            None => "unsigned: no ground station key".to_string(),
        }
    );
    let status = runtime.block_on(deploy(&args, &slices, &fleet, &profiles, key, run));
    if let Some((m, observer)) = monitor {
        runtime.block_on(async {
            observer.close().await;
            m.stop.cancel();
            let _ = m.task.await;
        });
    }
    status
}

/// Delivers the slices, starts the mission and flies the ground station's
/// part.
async fn deploy(
    args: &Args,
    slices: &eamos_slicer::Slices,
    fleet: &eamos_fleet::Fleet,
    profiles: &eamos_profile::ProfileTable,
    key: Option<eamos_seal::GroundKey>,
    mut run: RunOptions,
) -> ExitCode {
    let rollout = match RollOut::open(fleet, key).await {
        Ok(r) => r,
        Err(e) => return bad_input(&e.to_string()),
    };
    let drones = slices.drones.clone();
    let missing = rollout
        .wait_for_agents(&drones, Duration::from_secs_f64(args.wait))
        .await;
    if !missing.is_empty() {
        for d in &missing {
            println!("{d}: refused: no agent showed up within {} s", args.wait);
        }
        eprintln!(
            "error: mission not started: no agent for {}",
            missing.join(", ")
        );
        return ExitCode::from(1);
    }
    let delivered = rollout.deliver(slices).await;
    for (d, what) in &delivered {
        println!("{d}: {what}");
    }
    let refused = delivered
        .values()
        .filter(|d| matches!(d, Delivery::Refused { .. }))
        .count();
    if refused > 0 {
        eprintln!("error: mission not started: {refused} drone(s) refused their slice");
        return ExitCode::from(1);
    }
    if args.no_start {
        return ExitCode::SUCCESS;
    }
    let answers = rollout.start(slices, &run).await;
    // Stopped (Ctrl-C), the ground station tells every drone to abort
    // with a command signed like `eamos abort`'s.
    run.abort_sealer = rollout.abort_sealer();
    let mut refused = 0;
    for (d, a) in &answers {
        if let Answer::Refused { reason } = a {
            println!("{d}: refused the start: {reason}");
            refused += 1;
        }
    }
    rollout.close().await;
    if refused > 0 {
        eprintln!("error: {refused} drone(s) refused to start");
        return ExitCode::from(1);
    }
    println!("started {}", slices.mission_id);
    // From here on Ctrl-C stops the ground station's part, which tells
    // every drone to abort; before, nothing flies and it just exits.
    let stop = run.stop.clone();
    tokio::spawn(async move {
        if tokio::signal::ctrl_c().await.is_ok() {
            eprintln!("stopping: every drone goes to its failsafe");
            stop.cancel();
        }
    });
    match rollout::fly_ground_station(slices, fleet, profiles, &run).await {
        Err(e) => bad_input(&e.to_string()),
        Ok(report) => {
            let outcome = report.reports.first().map(|r| r.outcome.clone());
            println!("mission {}: {:?}", slices.mission, outcome);
            if matches!(outcome, Some(Outcome::Completed)) {
                println!("mission {} completed", slices.mission);
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
    }
}
