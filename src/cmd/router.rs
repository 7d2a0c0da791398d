//! `eamos router --fleet FLEET --router N`: one of the fleet's zenoh
//! routers (`[zenoh] routers` in the fleet file). A fleet that names
//! routers does not form a full mesh: every drone's agent and the ground
//! station join through a router as clients, and the routers pass on to
//! each other what their clients send. Run two or more on different
//! machines: a client whose router is lost joins through the next one.
//!
//! A router knows no mission and flies nothing; it carries the traffic of
//! every mission on its network. Exit status: 0 stopped (Ctrl-C), 2 bad
//! input or a router that cannot start.

use std::path::PathBuf;
use std::process::ExitCode;

use eamos_exec::transport::{zenoh, TransportError};
use eamos_fleet::Fleet;
use eamos_rollout::CancellationToken;

/// Route the fleet's zenoh traffic, as one of its routers.
#[derive(clap::Args)]
pub struct Args {
    /// The fleet file naming the routers (`[zenoh] routers = [...]`).
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: PathBuf,
    /// Which of the fleet's routers this is, from 1 in the file's order:
    /// it listens on that endpoint and connects to the others.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub router: usize,
}

fn bad_input(message: &str) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(2)
}

pub fn run(args: Args) -> ExitCode {
    let name = args.fleet.display().to_string();
    let fleet = match Fleet::load_unbound(&args.fleet) {
        Ok(f) => f,
        Err(e) => return bad_input(&e.to_string()),
    };
    let options = match fleet.router_options(args.router) {
        Ok(o) => o,
        Err(e) => return bad_input(&format!("{name}: {e}")),
    };
    let runtime = match super::Runtime::new() {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the async runtime: {e}")),
    };
    let result = runtime.block_on(async {
        let stop = CancellationToken::new();
        let on_signal = stop.clone();
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                on_signal.cancel();
            }
        });
        let routing = zenoh::route(&options, stop.clone());
        println!(
            "router {}: listening on {}{}",
            args.router,
            options.listen.join(", "),
            if options.connect.is_empty() {
                String::new()
            } else {
                format!(", joined to {}", options.connect.join(", "))
            }
        );
        routing.await
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(TransportError::PortTaken { endpoints, .. }) => bad_input(&format!(
            "router {} cannot listen on {}: the port is taken by another program; give it another endpoint in {name}'s `[zenoh] routers`",
            args.router,
            endpoints.join(", ")
        )),
        Err(e) => bad_input(&format!("router {}: {e}", args.router)),
    }
}
