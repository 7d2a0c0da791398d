//! `eamos monitor MISSION --fleet FLEET`: the live monitor of a mission
//! flown by separate processes (`eamos run --drone`, `eamos agent`),
//! joining its zenoh network as a read-only observer: it hears each
//! drone's telemetry and which peers are up, and shows them on the
//! mission's page. It declares nothing the peers wait for, publishes
//! nothing, and the mission flies the same without it. Exit status: 0
//! stopped (Ctrl-C), 2 bad input.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;

use super::mission::{self, bad_input};

/// Watch a running mission live: its page, fed from its zenoh network.
#[derive(clap::Args)]
pub struct Args {
    /// The mission (`.go`), as its peers fly it.
    pub mission: PathBuf,
    /// The fleet file its peers fly with (the mission's identity and the
    /// peers' endpoints come from both).
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: Option<PathBuf>,
    /// Where to serve the page (`HOST:PORT`, or a port alone for
    /// 127.0.0.1).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8080",
          value_parser = super::live::parse_addr)]
    pub listen: SocketAddr,
    /// The ground station's secret key: with it (and only with it) the
    /// page has an abort button, behind a confirmation, that aborts the
    /// mission as `eamos abort --key` does.
    #[arg(long, value_name = "GCS.key")]
    pub key: Option<PathBuf>,
}

pub fn run(args: Args) -> ExitCode {
    let colour = false;
    let loaded = match mission::load(&args.mission, args.fleet.as_deref(), colour) {
        Ok(m) => m,
        Err(status) => return status,
    };
    let abort = match &args.key {
        Some(path) => match eamos_rollout::ground_key(&loaded.fleet, Some(path)) {
            Ok(Some(key)) => Some(super::live::abort_with(&loaded, key)),
            Ok(None) => None,
            Err(e) => return bad_input(&format!("cannot sign an abort: {e}")),
        },
        None => None,
    };
    let runtime = match super::Runtime::new() {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the async runtime: {e}")),
    };
    runtime.block_on(async {
        let monitor = match super::live::start(args.listen, &loaded, abort).await {
            Ok(m) => m,
            Err(e) => return bad_input(&e),
        };
        let observer = match super::live::observe(&loaded, &monitor.feed).await {
            Ok(o) => o,
            Err(e) => return bad_input(&e),
        };
        eprintln!(
            "watching {} ({}) read-only; Ctrl-C stops",
            loaded.slices.mission, loaded.slices.mission_id
        );
        let _ = tokio::signal::ctrl_c().await;
        observer.close().await;
        monitor.stop.cancel();
        let _ = monitor.task.await;
        ExitCode::SUCCESS
    })
}
