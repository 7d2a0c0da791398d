//! `eamos abort MISSION`: abort a running mission from any machine on its
//! network. Every drone cancels what it is doing and goes to its abort
//! failsafe (the fleet file's `on_abort`, landing by default), each exactly
//! once; drones this command cannot reach hear it from the peers that can.
//!
//! The command joins the mission's zenoh network (the endpoints the fleet
//! file gives, or the loopback ports derived from the mission) without
//! becoming a peer of the mission. The command is signed with the ground
//! station's key when the fleet names one, and carries the time it was
//! issued: a drone refuses an abort issued before its flight began (a
//! recording of an earlier flight's). Exit status: 0 every peer acknowledged,
//! 1 some did not (down, or cut off), 2 bad input or no network.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use eamos_exec::abort::{self, AbortCommand};
use eamos_rollout as rollout;

use super::mission::{self, bad_input, Mission};
use eamos_exec::runner;
use eamos_exec::transport::GCS;

/// Abort a running mission: every drone goes to its failsafe.
#[derive(clap::Args)]
pub struct Args {
    /// The mission file (Go syntax), as the mission was started with.
    pub mission: PathBuf,
    /// The fleet file the mission was started with (endpoints, keys).
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: Option<PathBuf>,
    /// The ground station's secret key, to seal the command [default: the
    /// fleet's `[keys] gcs` public key with the extension `.key`]. When the
    /// fleet file names the ground station's public key the drones refuse
    /// unsealed commands, so a missing or wrong key is an error here.
    #[arg(long, value_name = "GCS.key")]
    pub key: Option<PathBuf>,
    /// How long to wait for every peer's acknowledgement.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub timeout: f64,
}

pub fn run(args: Args) -> ExitCode {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        return bad_input("--timeout must be a number of seconds above zero");
    }
    let Mission { slices, fleet, .. } =
        match mission::load(&args.mission, args.fleet.as_deref(), false) {
            Ok(m) => m,
            Err(status) => return status,
        };
    let sealer = match rollout::ground_key(&fleet, args.key.as_deref()) {
        Ok(k) => k.map(|k| abort::sealer(Arc::new(k))),
        Err(e) => return bad_input(&format!("cannot sign the abort: {e}")),
    };
    let peers = runner::peers(&slices);
    // This command is nobody's peer: it must not take the ground
    // station's port, and joins through the fleet's routers when it has
    // them. Over TLS it presents the ground station's certificate.
    let mut options = fleet.outsider_options(&slices.mission_id, &peers);
    options.tls = fleet.tls_files(GCS);
    let me = format!("abort-{}", std::process::id());
    let issued_by = std::env::var("USER").unwrap_or_else(|_| "eamos abort".to_string());
    let command = AbortCommand::new(&slices.mission_id, &format!("{issued_by} ({me})"));
    let runtime = match super::Runtime::new() {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the async runtime: {e}")),
    };
    let timeout = Duration::from_secs_f64(args.timeout);
    let sent = runtime.block_on(abort::broadcast(
        &command,
        &me,
        &peers,
        &options,
        sealer.as_ref(),
        timeout,
    ));
    match sent {
        Err(e) => bad_input(&format!("cannot join the mission's network: {e}")),
        Ok(sent) => {
            let missing: Vec<&String> = sent
                .sent_to
                .iter()
                .filter(|p| !sent.reached.contains(p))
                .collect();
            println!(
                "{}: abort sent to {} peers ({} up), {} not acknowledged",
                slices.mission,
                sent.sent_to.len(),
                sent.reached.len(),
                sent.unacknowledged
            );
            if !missing.is_empty() {
                let names: Vec<&str> = missing.iter().map(|s| s.as_str()).collect();
                println!(
                    "not seen up: {} (the peers that are pass the abort on)",
                    names.join(", ")
                );
            }
            if sent.unacknowledged == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
    }
}
