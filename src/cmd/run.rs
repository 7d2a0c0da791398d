//! `eamos run MISSION`: fly a mission, simulated unless a fleet file binds
//! drones to autopilots.
//!
//! Without `--drone` or `--gcs` the whole fleet runs in this process (one
//! executor per drone plus the ground station); `--drone D2` runs only
//! D2's agent, as on D2's companion computer, and `--gcs` the ground
//! station, which starts the mission and follows it to its end; those talk
//! zenoh to each other. Exit status: 0 the mission completed, 1 it did not
//! (time limit, a failed action, stopped), 2 bad input.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use tokio::sync::mpsc;

use eamos_exec::event::{Channel, Event, Kind};
use eamos_mid::ActionCall;

use super::mission::{self, bad_input, Mission};
use eamos_exec::runner::{self, RunOptions, RunReport, TransportKind};
use eamos_exec::transport::GCS;
use eamos_exec::Outcome;
use eamos_petri::net::TransitionKind;
use eamos_slicer::{Slice, Slices};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Transport {
    /// Channels inside this process (the whole fleet only).
    InProcess,
    /// zenoh peers (on loopback unless the fleet file says otherwise).
    Zenoh,
}

/// Fly a mission: the whole fleet here, or one drone's agent (`--drone`),
/// or the ground station (`--gcs`).
#[derive(clap::Args)]
pub struct Args {
    /// The mission file (Go syntax).
    #[arg(required_unless_present = "slices")]
    pub mission: Option<PathBuf>,
    /// Run only this drone's agent, talking zenoh to its peers.
    #[arg(long, value_name = "DRONE", conflicts_with = "gcs")]
    pub drone: Option<String>,
    /// With `--drone`: fly the drone's slice from DIR, written by `eamos
    /// build MISSION --fleet FLEET.toml --out DIR`, instead of compiling
    /// the whole mission to cut it out (what a fleet of hundreds of
    /// processes on one computer would otherwise do hundreds of times).
    /// The slices must have been built for the same fleet file.
    #[arg(
        long,
        value_name = "DIR",
        requires = "drone",
        conflicts_with_all = ["mission", "monitor", "allow_findings"]
    )]
    pub slices: Option<PathBuf>,
    /// Run only the ground station: start the mission and follow it.
    #[arg(long)]
    pub gcs: bool,
    /// Binds drones to adapters (sim, MAVLink), homes and zenoh endpoints.
    /// Without it every drone is simulated and peers use loopback ports
    /// derived from the mission.
    #[arg(long, value_name = "FLEET.toml")]
    pub fleet: Option<PathBuf>,
    /// Simulated seconds per real second.
    #[arg(long, value_name = "N", default_value_t = 20.0)]
    pub speed: f64,
    /// Mission time limit in seconds: then every drone lands and the run
    /// reports what was still waiting, and on what.
    #[arg(long, value_name = "SECONDS")]
    pub max_duration: Option<f64>,
    /// Where the logs and trajectories.svg go [default: eamos-run/<mission>].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Seed of the simulator's random processes (wind gusts).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// How the peers of a whole-fleet run talk.
    #[arg(long, value_enum, default_value_t = Transport::InProcess)]
    pub transport: Transport,
    /// How long the ground station waits for its peers to come up.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    pub startup_timeout: f64,
    /// Journal what each peer does in DIR (`<peer>.journal`, and each
    /// simulated drone's airframe), flushed to the disk before a message
    /// is acknowledged or an action started. Run again with the same DIR
    /// after a crash: the peer resumes where it was, every action run
    /// exactly once, and appends to its logs.
    #[arg(long, value_name = "DIR")]
    pub journal: Option<PathBuf>,
    /// Fly even when `eamos check` finds errors in the mission (two drones
    /// that can meet, a leg out of the airspace...): the findings are
    /// printed either way. The check is the ground station's: a drone's
    /// agent (`--drone`) does not check, and flies only once the ground
    /// station (`--gcs`), which does, starts the mission.
    #[arg(long)]
    pub allow_findings: bool,
    /// Serve the live monitor on ADDR (`HOST:PORT`, or a port alone for
    /// 127.0.0.1): the mission's report page, its drones moving, their
    /// actions, markings and lost peers as they happen. The drones never
    /// wait for it, and it serves nothing that commands them.
    #[arg(long, value_name = "ADDR", value_parser = super::live::parse_addr)]
    pub monitor: Option<std::net::SocketAddr>,
}

pub fn run(args: Args) -> ExitCode {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        return bad_input(&format!(
            "--speed must be a number above zero, not {}",
            args.speed
        ));
    }
    if let Some(d) = args.max_duration {
        if !(d.is_finite() && d > 0.0) {
            return bad_input(&format!(
                "--max-duration must be a number of seconds above zero, not {d}"
            ));
        }
    }
    if !(args.startup_timeout.is_finite() && args.startup_timeout >= 0.0) {
        return bad_input("--startup-timeout must be zero or more seconds");
    }
    let colour = std::io::stderr().is_terminal();
    let loaded = match load(&args, colour) {
        Ok(l) => l,
        Err(status) => return status,
    };
    let runtime = match super::Runtime::new() {
        Ok(r) => r,
        Err(e) => return bad_input(&format!("cannot start the async runtime: {e}")),
    };
    // Bound before anything flies: a taken port stops the run here.
    let monitor = match (args.monitor, &loaded) {
        (Some(addr), Loaded::Mission(m)) => {
            match runtime.block_on(super::live::start(addr, m, None)) {
                Ok(m) => Some(m),
                Err(e) => return bad_input(&e),
            }
        }
        _ => None,
    };
    let Flight {
        name,
        source,
        part,
        fleet,
        profiles,
    } = match flight_of(loaded, &args) {
        Ok(f) => f,
        Err(message) => return bad_input(&message),
    };
    eamos_trim::after_phase();
    // With the ground station's public key, abort commands must be sealed
    // by its secret key (`eamos abort --key`).
    let abort_opener = match eamos_rollout::trusted_key(&fleet) {
        Ok(key) => key.map(eamos_exec::abort::opener),
        Err(e) => return bad_input(&e),
    };
    let flown: Vec<&Slice> = match &part {
        Part::Whole(all) => all.slices.iter().collect(),
        Part::One(s) => vec![s],
    };
    let shown: Vec<String> = flown.iter().map(|s| s.drone.clone()).collect();
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("eamos-run").join(&name));

    // Diagnostics (who is up, who sees whom, retransmissions) only when
    // asked for with RUST_LOG (`RUST_LOG=eamos_exec=debug`): the progress
    // lines are what a crew reads.
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("off")),
        )
        .try_init();
    let (events, events_rx) = Channel::new();
    let mut sinks: Vec<Arc<dyn eamos_exec::event::Sink>> = vec![Arc::new(events)];
    if let Some(m) = &monitor {
        sinks.push(Arc::new(m.feed.clone()));
    }
    let events = crate::phases::releasing_once_started(flown.len(), sinks);
    let options = RunOptions {
        speed: args.speed,
        max_duration: args.max_duration,
        out: out.clone(),
        transport: match args.transport {
            Transport::InProcess => TransportKind::InProcess,
            Transport::Zenoh => TransportKind::Zenoh,
        },
        source: source.map(Arc::new),
        events: Some(events),
        startup_timeout: Duration::from_secs_f64(args.startup_timeout),
        seed: args.seed,
        journal: args.journal.clone(),
        abort_opener,
        ..RunOptions::default()
    };
    let counts = action_counts(&flown);
    let result = runtime.block_on(async {
        let stop = options.stop.clone();
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                eprintln!("stopping: every drone goes to its failsafe");
                stop.cancel();
            }
        });
        let display = tokio::spawn(show_progress(events_rx, counts));
        let result = match &part {
            Part::One(slice) => runner::run_peer(slice, &fleet, &profiles, &options).await,
            Part::Whole(all) => runner::run_fleet(all, &fleet, &profiles, &options).await,
        };
        drop(options);
        let _ = display.await;
        if let Some(m) = monitor {
            m.stop.cancel();
            let _ = m.task.await;
        }
        result
    });
    let report = match result {
        Ok(r) => r,
        // Not bad input: the crew stopped it, as it may stop a flight.
        Err(e @ runner::RunError::StoppedJoining { .. }) => {
            eprintln!("{e}");
            return ExitCode::from(1);
        }
        Err(e) => return bad_input(&e.to_string()),
    };
    let svg = eamos_exec::svg::trajectories(&name, &report.trajectories);
    let svg_path = out.join("trajectories.svg");
    if let Err(e) = std::fs::write(&svg_path, svg) {
        eprintln!("warning: cannot write {}: {e}", svg_path.display());
    }
    for e in &report.log_errors {
        eprintln!("warning: {e}");
    }
    print_summary(&name, &report, &out, &clock_of(&fleet, &shown, args.speed));
    if report
        .reports
        .iter()
        .all(|r| r.outcome == Outcome::Completed)
    {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// What a run read: the mission, compiled and sliced, or one drone's
/// slice from a slices directory.
enum Loaded {
    Mission(Mission),
    Slice(Slice, eamos_fleet::Fleet),
}

/// What this process flies.
struct Flight {
    /// The mission's name.
    name: String,
    /// The mission's text, to locate what the logs say (not with a slice
    /// read from a slices directory).
    source: Option<eamos_lang::SourceFile>,
    part: Part,
    fleet: eamos_fleet::Fleet,
    profiles: eamos_profile::ProfileTable,
}

enum Part {
    /// Every peer, here (no `--drone`, no `--gcs`).
    Whole(Slices),
    /// One peer's slice.
    One(Slice),
}

/// Reads what `args` name; on bad input, the exit status, once the reason
/// is printed.
fn load(args: &Args, colour: bool) -> Result<Loaded, ExitCode> {
    if let (Some(dir), Some(drone)) = (&args.slices, &args.drone) {
        return super::slices::read(dir, drone, args.fleet.as_deref())
            .map(|(slice, fleet)| Loaded::Slice(slice, fleet))
            .map_err(|e| bad_input(&e));
    }
    let Some(path) = &args.mission else {
        return Err(bad_input("a mission file or --slices DIR is needed"));
    };
    if args.drone.is_some() {
        // A drone's agent compiles and slices the mission, and does not
        // check it: the proof is the ground station's (or the whole
        // fleet's, or `eamos check`'s), made once for the fleet instead of
        // once per drone. Nothing flies unchecked: a drone holds no token
        // until the ground station starts the mission, which it does only
        // once the mission passed its check (or the crew said
        // `--allow-findings` to it), and only for the same mission and
        // fleet, since every message is scoped by their identity. A fleet
        // of a hundred drones in one process each on one computer then
        // pays for one check, not a hundred.
        mission::load(path, args.fleet.as_deref(), colour)
    } else {
        mission::load_to_fly(path, args.fleet.as_deref(), colour, args.allow_findings)
    }
    .map(Loaded::Mission)
}

/// What this process flies of what it read: the peer of `--drone` or
/// `--gcs`, or every one.
fn flight_of(loaded: Loaded, args: &Args) -> Result<Flight, String> {
    let m = match loaded {
        Loaded::Slice(slice, fleet) => {
            return Ok(Flight {
                name: slice.mission.clone(),
                source: None,
                part: Part::One(slice),
                fleet,
                profiles: eamos_profile::builtin(),
            })
        }
        Loaded::Mission(m) => m,
    };
    let peer = match (&args.drone, args.gcs) {
        (Some(d), _) => Some(d.as_str()),
        (None, true) => Some(GCS),
        (None, false) => None,
    };
    let name = m.slices.mission.clone();
    let part = match peer {
        None => Part::Whole(m.slices),
        Some(p) => match m.slices.get(p) {
            Some(s) => Part::One(s.clone()),
            None => {
                return Err(format!(
                    "`{p}` is not a drone of {name} (its drones: {})",
                    m.net.drones.join(", ")
                ))
            }
        },
    };
    Ok(Flight {
        name,
        source: Some(m.source),
        part,
        fleet: m.fleet,
        profiles: m.profiles,
    })
}

/// Action starts in each flown slice: the length of its progress bar
/// (`None` when a loop makes the number unknown before the flight).
fn action_counts(flown: &[&Slice]) -> Vec<(String, Option<u64>)> {
    flown
        .iter()
        .map(|s| {
            let looping = s
                .transitions
                .iter()
                .any(|t| matches!(t.transition.kind, TransitionKind::LoopBack));
            let n = s
                .transitions
                .iter()
                .filter(|t| matches!(t.transition.kind, TransitionKind::ActionStart(_)))
                .count() as u64;
            (s.drone.clone(), (!looping).then_some(n))
        })
        .collect()
}

/// Live progress per drone: bars when stderr is a terminal, plain lines
/// otherwise (logs, CI).
async fn show_progress(mut rx: mpsc::UnboundedReceiver<Event>, peers: Vec<(String, Option<u64>)>) {
    let tty = std::io::stderr().is_terminal();
    let multi = MultiProgress::with_draw_target(if tty {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    });
    let width = peers.iter().map(|(p, _)| p.len()).max().unwrap_or(3);
    let mut bars = std::collections::HashMap::new();
    let mut counts: std::collections::HashMap<String, (u64, u64)> = Default::default();
    for (p, n) in &peers {
        let bar = match n {
            Some(n) => {
                let b = multi.add(ProgressBar::new(*n));
                b.set_style(
                    ProgressStyle::with_template(&format!(
                        "{{prefix:>{width}}} [{{bar:24}}] {{pos:>3}}/{{len:3}} actions  {{msg}}"
                    ))
                    .expect("template is valid")
                    .progress_chars("=> "),
                );
                b
            }
            None => {
                let b = multi.add(ProgressBar::new_spinner());
                b.set_style(
                    ProgressStyle::with_template(&format!(
                        "{{prefix:>{width}}} {{spinner}} {{pos:>3}} actions  {{msg}}"
                    ))
                    .expect("template is valid"),
                );
                b
            }
        };
        bar.set_prefix(p.clone());
        bars.insert(p.clone(), bar);
    }
    while let Some(e) = rx.recv().await {
        let Some(bar) = bars.get(&e.drone) else {
            continue;
        };
        let c = counts.entry(e.drone.clone()).or_default();
        if let Some(alert) = alert(&e) {
            // Lost peers, stuck drones, aborts: kept on screen.
            let line = format!("[{:>8.2} s] {:>width$} {alert}", e.time, e.drone);
            if tty {
                let _ = multi.println(line);
            } else {
                eprintln!("{line}");
            }
            continue;
        }
        let line = match &e.kind {
            Kind::ActionStarted { action, args, .. } => {
                format!("started {}", ActionCall::new(action.clone(), args.clone()))
            }
            Kind::ActionResumed { action, args, .. } => format!(
                "started {} (resumed)",
                ActionCall::new(action.clone(), args.clone())
            ),
            Kind::ActionFinished { .. } => {
                bar.inc(1);
                finished_line(&e.kind).unwrap_or_default()
            }
            Kind::BridgeSent { .. } => {
                c.0 += 1;
                continue;
            }
            Kind::BridgeReceived { .. } => {
                c.1 += 1;
                continue;
            }
            Kind::ConditionWaiting { condition, .. } => format!("waits for {condition}"),
            Kind::Stopped { reason } => {
                bar.finish_with_message(format!("{reason} ({})", continue_line(c)));
                if !tty {
                    eprintln!("[{:>8.2} s] {:>width$} {reason}", e.time, e.drone);
                }
                continue;
            }
            _ => continue,
        };
        if tty {
            bar.set_message(format!("{line}  ({})", continue_line(c)));
        } else {
            eprintln!("[{:>8.2} s] {:>width$} {line}", e.time, e.drone);
        }
    }
}

/// The line kept on screen for an event a crew must not miss: a peer lost
/// or back, a drone stuck, an abort, a failsafe flown.
fn alert(e: &Event) -> Option<String> {
    Some(match &e.kind {
        Kind::PeerLost { peer } => format!("lost {peer}"),
        Kind::PeerBack { peer } => format!("{peer} is back"),
        Kind::Isolated { lost } => format!("every peer is lost ({})", lost.join(", ")),
        // The ground station flies nothing: it only reports.
        Kind::Stuck { lost, .. } if e.drone == GCS => {
            format!("waits on {}, which is lost", lost.join(", "))
        }
        Kind::Stuck { lost, policy } => {
            format!("stuck: waits on {}, lost; {policy}", lost.join(", "))
        }
        Kind::AbortReceived { reason, .. } => format!("abort: {reason}"),
        Kind::AbortRefused { reason, .. } => reason.clone(),
        Kind::PeerStuck { peer, lost, policy } => format!("{peer} is stuck on {lost}: {policy}"),
        Kind::Failsafe {
            failsafe,
            airborne: true,
            ..
        } => format!("failsafe: {failsafe}"),
        Kind::AdapterWarning { detail } => format!("warning: {detail}"),
        Kind::RoutersWaiting { routers } => format!(
            "none of the fleet's routers answers yet ({}); still trying",
            routers.join(", ")
        ),
        _ => return None,
    })
}

/// How an action ended, in the words a crew reads: only an action that
/// succeeded "finished"; a failed one says why, so that a refused `Arm`
/// never reads as done.
fn finished_line(kind: &Kind) -> Option<String> {
    let Kind::ActionFinished {
        action,
        outcome,
        error,
        ..
    } = kind
    else {
        return None;
    };
    Some(match (outcome.as_str(), error) {
        ("ok", _) => format!("finished {action}"),
        ("cancelled", _) => format!("cancelled {action}"),
        (_, Some(error)) => format!("failed {action}: {error}"),
        (outcome, None) => format!("failed {action} ({outcome})"),
    })
}

fn continue_line(c: &(u64, u64)) -> String {
    format!("{} sent, {} received", c.0, c.1)
}

/// Whose clock the run kept, for the summary: the simulator's at
/// `--speed` when it flew a drone here, else the first autopilot's (see
/// the runner), else the wall's.
fn clock_of(fleet: &eamos_fleet::Fleet, shown: &[String], speed: f64) -> String {
    let adapters: Vec<eamos_fleet::AdapterKind> = shown
        .iter()
        .filter(|p| p.as_str() != GCS)
        .map(|d| fleet.entry(d).adapter)
        .collect();
    if adapters.contains(&eamos_fleet::AdapterKind::Sim) {
        format!("speed {speed}")
    } else if adapters.is_empty() {
        "wall clock".to_string()
    } else {
        "the autopilot's clock".to_string()
    }
}

fn print_summary(mission: &str, report: &RunReport, out: &Path, clock: &str) {
    let longest = report
        .reports
        .iter()
        .map(|r| r.duration())
        .fold(0.0, f64::max);
    let done = report
        .reports
        .iter()
        .all(|r| r.outcome == Outcome::Completed);
    println!(
        "{}: {} after {:.1} s of mission time ({:.1} s wall, {clock})",
        mission,
        if done {
            "completed"
        } else {
            "did not complete"
        },
        longest,
        report.wall.as_secs_f64()
    );
    println!(
        "{:<8} {:<12} {:>8} {:>10} {:>10} {:>10}",
        "peer", "outcome", "actions", "sent", "received", "duration"
    );
    for r in &report.reports {
        let outcome = match &r.outcome {
            Outcome::Completed => "completed",
            Outcome::TimeLimit { .. } => "time limit",
            Outcome::Failed { .. } => "failed",
            Outcome::Stopped => "stopped",
            Outcome::PeerLost { .. } => "peer lost",
            Outcome::Aborted { .. } => "aborted",
        };
        println!(
            "{:<8} {:<12} {:>8} {:>10} {:>10} {:>8.1} s{}",
            r.drone,
            outcome,
            r.actions,
            r.sent,
            r.received,
            r.duration(),
            if r.bridges.retransmissions > 0 {
                format!("  ({} retransmitted)", r.bridges.retransmissions)
            } else {
                String::new()
            }
        );
    }
    for r in &report.reports {
        match &r.outcome {
            Outcome::TimeLimit { waiting } => {
                println!("{} was still waiting when the time limit expired:", r.drone);
                if waiting.is_empty() {
                    println!("  (nothing: its part was done)");
                }
                for w in waiting {
                    println!("  - {w}");
                }
            }
            Outcome::Failed { reason } => println!("{}: {reason}", r.drone),
            Outcome::Aborted { reason } => println!("{}: {reason}", r.drone),
            Outcome::PeerLost { lost, failsafe } => println!(
                "{}: waited on {}, lost; went to its failsafe ({failsafe})",
                r.drone,
                lost.join(", ")
            ),
            _ => {}
        }
    }
    println!(
        "logs: {}/<drone>.{{mission,uniform,adapter}}.jsonl; paths: {}",
        out.display(),
        out.join("trajectories.svg").display()
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn finished(outcome: &str, error: Option<&str>) -> Kind {
        Kind::ActionFinished {
            action: "Arm()".into(),
            instance: 3,
            colour: Default::default(),
            outcome: outcome.into(),
            error: error.map(Into::into),
        }
    }

    #[test]
    fn only_an_action_that_succeeded_reads_as_finished() {
        assert_eq!(
            finished_line(&finished("ok", None)).as_deref(),
            Some("finished Arm()")
        );
        let refused = "the drone refused `Arm`: the vehicle was not ready to arm";
        assert_eq!(
            finished_line(&finished("refused", Some(refused))).unwrap(),
            format!("failed Arm(): {refused}")
        );
        assert_eq!(
            finished_line(&finished("cancelled", Some("`Arm` was cancelled"))).as_deref(),
            Some("cancelled Arm()")
        );
        assert_eq!(
            finished_line(&finished("timeout", None)).as_deref(),
            Some("failed Arm() (timeout)")
        );
    }
}
