//! `eamos agent --drone D2`: the agent on a drone's companion computer. It
//! joins the fleet's roll-out endpoints, waits for its slice from `eamos
//! deploy`, checks it (signed by the ground station key the fleet file
//! names, built with this very fleet file, meant for this drone), keeps it,
//! and flies it when the signed start command comes, as `eamos run --drone`
//! would. While it flies, it obeys only abort commands signed by that key
//! and issued since the start; it logs any other and flies on. It starts
//! each deploy session once (remembered in `OUT/<drone>.sessions`), so a
//! recorded start played back is refused. While it flies it journals
//! what it does (`OUT/<mission>/journal/<session>`) and keeps the started
//! flight in `OUT/<drone>.flight`: killed mid-flight and started again, it
//! flies on from the journal at once, every action run exactly once. Then
//! it waits for the next version of the mission, unless `--once`. Exit status: 0 stopped (or, with `--once`, the mission
//! completed), 1 the mission did not complete, 2 bad input.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use eamos_exec::event::{Channel, Kind};
use eamos_fleet::Fleet;
use eamos_rollout::{self as rollout, AgentConfig, CancellationToken};

/// Wait on a drone's companion computer for its slice, then fly it.
#[derive(clap::Args)]
pub struct Args {
    /// The drone this computer flies.
    #[arg(long, value_name = "DRONE")]
    pub drone: String,
    /// The fleet file: the same file the ground station deploys with.
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: Option<PathBuf>,
    /// Where each mission's logs go (`DIR/<mission>`).
    #[arg(long, value_name = "DIR", default_value = "eamos-agent")]
    pub out: PathBuf,
    /// Exit after one mission.
    #[arg(long)]
    pub once: bool,
}

fn bad_input(message: &str) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    let (fleet, name) = match &args.fleet {
        Some(p) => match Fleet::load_unbound(p) {
            Ok(f) => (f, p.display().to_string()),
            Err(e) => return bad_input(&e.to_string()),
        },
        None => (Fleet::default(), "(no fleet file)".to_string()),
    };
    let trusted = match rollout::trusted_key(&fleet) {
        Ok(k) => k,
        Err(e) => return bad_input(&format!("{name}: {e}")),
    };
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("error")),
        )
        .try_init();
    let runtime = match super::Runtime::new() {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the async runtime: {e}")),
    };
    let drone = args.drone.clone();
    match &trusted {
        Some(k) => println!(
            "{drone}: trusts the ground station key {} (slices, start and abort commands)",
            k.fingerprint()
        ),
        None => println!(
            "{drone}: no ground station key in the fleet file: accepting unsigned slices and commands"
        ),
    }
    let config = AgentConfig {
        drone: drone.clone(),
        fleet_name: name,
        fleet,
        trusted,
        profiles: eamos_profile::builtin(),
        out: args.out.clone(),
        once: args.once,
    };
    let result = runtime.block_on(async {
        let stop = CancellationToken::new();
        let on_signal = stop.clone();
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                on_signal.cancel();
            }
        });
        // One stream: the roll-out's events and each flight's. The flights'
        // go to their mission logs; this prints the roll-out's.
        let (events, mut rx) = Channel::new();
        let printer = tokio::spawn(async move {
            let mut completed = false;
            while let Some(e) = rx.recv().await {
                if let Kind::RolloutEnded { outcome, .. } = &e.kind {
                    completed = outcome == "completed";
                }
                if let Some(line) = rollout::describe(&e.kind) {
                    println!("{drone}: {line}");
                }
            }
            completed
        });
        // Each flight (one executor) lets go of the start-up's code once
        // it is under way, as `eamos run` does.
        let events = crate::phases::releasing_once_started(1, vec![Arc::new(events)]);
        let r = rollout::run_agent(config, events, stop).await;
        let completed = printer.await.unwrap_or(false);
        r.map(|()| completed)
    });
    match result {
        Err(e) => bad_input(&e.to_string()),
        Ok(completed) if args.once && !completed => ExitCode::from(1),
        Ok(_) => ExitCode::SUCCESS,
    }
}
