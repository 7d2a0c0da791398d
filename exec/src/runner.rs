//! Running a mission: the whole fleet in one process ([`run_fleet`]), or
//! one peer of it (a drone's agent or the ground station, [`run_peer`]) as
//! it runs on its own computer, talking zenoh to the others.
//!
//! Both build the same parts: an adapter per drone (the simulator unless
//! the fleet file binds a MAVLink autopilot) wrapped in the uniform layer,
//! a link per peer, exactly-once bridges over it, and an executor per slice.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

use eamos_lang::SourceFile;
use eamos_mid::mavlink::{MavlinkAdapter, MavlinkOptions};
use eamos_mid::{Adapter, MissionClock, SimFleet, Uniform, Vec3};
use eamos_profile::ProfileTable;
use eamos_slicer::Slices;

use crate::executor::{Agent, Executor, ExecutorOptions, Progress, Report};
use crate::fleet::{AdapterKind, Fleet};
use crate::log::{DroneLog, LogWriter};
use crate::transport::faulty::{Faults, FaultyLink};
use crate::transport::inproc::InProcessHub;
use crate::transport::reliable::{Bridges, RetransmitPolicy};
use crate::transport::{zenoh, Endpoint, TransportError, GCS};

/// Which link the peers of a one-process run talk over.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum TransportKind {
    #[default]
    InProcess,
    Zenoh,
}

/// How to run.
#[derive(Clone)]
pub struct RunOptions {
    /// Simulated seconds per real second.
    pub speed: f64,
    /// Mission time limit, seconds.
    pub max_duration: Option<f64>,
    /// Where the logs (and the plot) go.
    pub out: PathBuf,
    pub transport: TransportKind,
    /// Make the links misbehave (tests of exactly-once delivery).
    pub faults: Option<Faults>,
    pub retransmit: RetransmitPolicy,
    pub source: Option<Arc<SourceFile>>,
    pub progress: Option<mpsc::UnboundedSender<Progress>>,
    pub stop: CancellationToken,
    /// How long the ground station waits for the other peers (wall time).
    pub startup_timeout: Duration,
    /// How long a peer stays after its run to acknowledge late copies
    /// (wall time; one-process runs need none).
    pub linger: Duration,
    /// Seeds the simulator's random processes (each drone's wind gusts,
    /// mixed with the drone's index).
    pub seed: u64,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            speed: 20.0,
            max_duration: None,
            out: PathBuf::from("eamos-run"),
            transport: TransportKind::InProcess,
            faults: None,
            retransmit: RetransmitPolicy::default(),
            source: None,
            progress: None,
            stop: CancellationToken::new(),
            startup_timeout: Duration::from_secs(60),
            linger: Duration::from_secs(2),
            seed: 0,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("cannot write the logs in {dir}: {error}")]
    Logs { dir: String, error: String },
    #[error("cannot start the simulator: {0}")]
    Sim(String),
    #[error("cannot connect {drone}: {error}")]
    Adapter { drone: String, error: String },
    #[error("drone `{drone}` has type `{profile}`, which no capability profile describes")]
    Profile { drone: String, profile: String },
    #[error("`{0}` is not a peer of this mission (its peers: {1})")]
    UnknownPeer(String, String),
    #[error(transparent)]
    Transport(#[from] TransportError),
}

/// What a run did, for the summary and the plot.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// One per peer that ran here, the ground station first.
    pub reports: Vec<Report>,
    /// Every drone's path in the fleet frame, sampled as it flew.
    pub trajectories: BTreeMap<String, Vec<Vec3>>,
    pub wall: Duration,
    /// Problems writing the logs (the run itself went on).
    pub log_errors: Vec<String>,
}

/// Every peer of a mission: the ground station, then the drones in the
/// mission's order.
pub fn peers(slices: &Slices) -> Vec<String> {
    std::iter::once(GCS.to_string())
        .chain(slices.distributed.drones.iter().cloned())
        .collect()
}

struct Built {
    adapters: BTreeMap<String, Arc<dyn Adapter>>,
    clock: MissionClock,
    /// Keeps the simulation running.
    _sim: Option<SimFleet>,
}

/// Creates the adapters of `drones` (a subset of the mission's), each in
/// its uniform layer, logging to `logs`.
async fn build_adapters(
    slices: &Slices,
    fleet: &Fleet,
    profiles: &ProfileTable,
    drones: &[String],
    options: &RunOptions,
    logs: &LogWriter,
) -> Result<Built, RunError> {
    let all = &slices.distributed.drones;
    let needs_sim = drones
        .iter()
        .any(|d| fleet.entry(d).adapter == AdapterKind::Sim);
    let sim = if needs_sim {
        let mut config = fleet.sim.clone().unwrap_or_default();
        config.speed = options.speed;
        Some(SimFleet::start(config).map_err(|e| RunError::Sim(e.to_string()))?)
    } else {
        None
    };
    let clock = sim
        .as_ref()
        .map(SimFleet::clock)
        .unwrap_or_else(MissionClock::wall);
    let mut adapters: BTreeMap<String, Arc<dyn Adapter>> = BTreeMap::new();
    for d in drones {
        let index = all.iter().position(|x| x == d).unwrap_or(0);
        let profile_name = slices
            .distributed
            .profiles
            .get(index)
            .cloned()
            .unwrap_or_else(|| "Quadcopter".to_string());
        let profile = profiles
            .get(&profile_name)
            .cloned()
            .ok_or_else(|| RunError::Profile {
                drone: d.clone(),
                profile: profile_name.clone(),
            })?;
        let log: Arc<DroneLog> = Arc::new(logs.drone(d));
        let entry = fleet.entry(d);
        let adapter: Arc<dyn Adapter> = match entry.adapter {
            AdapterKind::Sim => {
                let fleet_sim = sim
                    .as_ref()
                    .expect("a simulator exists for simulated drones");
                Arc::new(
                    fleet_sim
                        .add_drone(fleet.sim_spec(d, index), log.clone())
                        .map_err(|e| RunError::Sim(e.to_string()))?,
                )
            }
            AdapterKind::Mavlink => {
                let connection = entry.connection.clone().unwrap_or_default();
                Arc::new(
                    MavlinkAdapter::connect(
                        d.clone(),
                        &connection,
                        MavlinkOptions {
                            home: fleet.home(d, index),
                            log: log.clone(),
                            ..MavlinkOptions::default()
                        },
                    )
                    .await
                    .map_err(|e| RunError::Adapter {
                        drone: d.clone(),
                        error: e.to_string(),
                    })?,
                )
            }
        };
        adapters.insert(d.clone(), Arc::new(Uniform::new(adapter, profile, log)));
    }
    Ok(Built {
        adapters,
        clock,
        _sim: sim,
    })
}

/// Opens the link of one peer.
async fn endpoint(
    slices: &Slices,
    fleet: &Fleet,
    peer: &str,
    transport: TransportKind,
    hub: &InProcessHub,
    faults: Option<Faults>,
) -> Result<Endpoint, RunError> {
    let slice = slices.get(peer).expect("every peer has a slice");
    let reads = slice.telemetry.clone();
    let mut e = match transport {
        TransportKind::InProcess => hub.connect(peer, &reads),
        TransportKind::Zenoh => {
            let all = peers(slices);
            let opts = fleet.zenoh_options(&slices.mission_id, &all, peer);
            zenoh::open(&slices.mission_id, peer, &reads, &opts).await?
        }
    };
    if let Some(f) = faults {
        // Each peer's faults differ but follow from the one seed.
        let k = peers(slices).iter().position(|p| p == peer).unwrap_or(0) as u64;
        e.link = Arc::new(FaultyLink::new(
            e.link,
            Faults {
                seed: f.seed.wrapping_mul(1000).wrapping_add(k),
                ..f
            },
        ));
    }
    Ok(e)
}

/// Records each drone's path: a point whenever it has moved 5 cm.
fn record_paths(
    adapters: &BTreeMap<String, Arc<dyn Adapter>>,
    stop: CancellationToken,
) -> Arc<Mutex<BTreeMap<String, Vec<Vec3>>>> {
    let paths: Arc<Mutex<BTreeMap<String, Vec<Vec3>>>> = Arc::default();
    for (name, a) in adapters {
        let mut rx = a.telemetry();
        let paths = paths.clone();
        let name = name.clone();
        let stop = stop.clone();
        tokio::spawn(async move {
            loop {
                let p = rx.borrow_and_update().fleet_position();
                {
                    let mut all = paths.lock().expect("paths lock");
                    let path = all.entry(name.clone()).or_default();
                    if path.last().is_none_or(|q| q.distance(p) >= 0.05) {
                        path.push(p);
                    }
                }
                tokio::select! {
                    _ = stop.cancelled() => return,
                    r = rx.changed() => if r.is_err() { return },
                }
            }
        });
    }
    paths
}

fn executor_options(slices: &Slices, options: &RunOptions) -> ExecutorOptions {
    ExecutorOptions {
        max_duration: options.max_duration,
        startup_timeout: options.startup_timeout,
        flush_timeout: Duration::from_secs(10),
        peers: peers(slices),
        source: options.source.clone(),
        progress: options.progress.clone(),
        stop: options.stop.clone(),
    }
}

/// Runs the whole fleet in this process: one executor per drone plus the
/// ground station, over in-process channels or zenoh on loopback.
pub async fn run_fleet(
    slices: &Slices,
    fleet: &Fleet,
    profiles: &ProfileTable,
    options: &RunOptions,
) -> Result<RunReport, RunError> {
    let wall = Instant::now();
    let logs = LogWriter::create(&options.out).map_err(|e| RunError::Logs {
        dir: options.out.display().to_string(),
        error: e.to_string(),
    })?;
    // Links first: opening a zenoh peer takes a while, and the simulated
    // clock should not run meanwhile.
    let hub = InProcessHub::new();
    let mut endpoints = Vec::new();
    for peer in peers(slices) {
        endpoints.push(
            endpoint(
                slices,
                fleet,
                &peer,
                options.transport,
                &hub,
                options.faults,
            )
            .await?,
        );
    }
    let drones = slices.distributed.drones.clone();
    let built = build_adapters(slices, fleet, profiles, &drones, options, &logs).await?;
    let paths_stop = CancellationToken::new();
    let paths = record_paths(&built.adapters, paths_stop.clone());
    let mut bridges = Vec::new();
    let mut tasks = Vec::new();
    for (peer, e) in peers(slices).into_iter().zip(endpoints) {
        let slice = slices.get(&peer).expect("every peer has a slice").clone();
        let (b, delivered) = Bridges::start(
            slices.mission_id.clone(),
            e.link.clone(),
            e.frames,
            options.retransmit,
        );
        let b = Arc::new(b);
        bridges.push(b.clone());
        let agent = Agent {
            slice,
            drone: built.adapters.get(&peer).cloned(),
            clock: built.clock.clone(),
            bridges: b,
            delivered,
            link: e.link,
            telemetry: e.telemetry,
            log: logs.drone(&peer),
        };
        let exec = Executor::new(agent, executor_options(slices, options));
        tasks.push(tokio::spawn(exec.run()));
    }
    let mut reports = Vec::new();
    for t in tasks {
        match t.await {
            Ok(r) => reports.push(r),
            Err(e) => {
                return Err(RunError::Sim(format!("an executor panicked: {e}")));
            }
        }
    }
    paths_stop.cancel();
    drop(bridges);
    let trajectories = paths.lock().expect("paths lock").clone();
    drop(built);
    let log_errors = logs.finish();
    Ok(RunReport {
        reports,
        trajectories,
        wall: wall.elapsed(),
        log_errors,
    })
}

/// Runs one peer of the mission (`GCS` or a drone) over zenoh, as on that
/// drone's own computer. The ground station holds the initial token: it
/// starts the mission once its peers are up and follows it to the end.
pub async fn run_peer(
    slices: &Slices,
    fleet: &Fleet,
    profiles: &ProfileTable,
    peer: &str,
    options: &RunOptions,
) -> Result<RunReport, RunError> {
    let wall = Instant::now();
    let all = peers(slices);
    if !all.iter().any(|p| p == peer) {
        return Err(RunError::UnknownPeer(peer.to_string(), all.join(", ")));
    }
    let logs = LogWriter::create(&options.out).map_err(|e| RunError::Logs {
        dir: options.out.display().to_string(),
        error: e.to_string(),
    })?;
    let drones: Vec<String> = if peer == GCS {
        Vec::new()
    } else {
        vec![peer.to_string()]
    };
    let built = build_adapters(slices, fleet, profiles, &drones, options, &logs).await?;
    let paths_stop = CancellationToken::new();
    let paths = record_paths(&built.adapters, paths_stop.clone());
    let hub = InProcessHub::new();
    let e = endpoint(
        slices,
        fleet,
        peer,
        TransportKind::Zenoh,
        &hub,
        options.faults,
    )
    .await?;
    let (b, delivered) = Bridges::start(
        slices.mission_id.clone(),
        e.link.clone(),
        e.frames,
        options.retransmit,
    );
    let b = Arc::new(b);
    let agent = Agent {
        slice: slices.get(peer).expect("checked above").clone(),
        drone: built.adapters.get(peer).cloned(),
        clock: built.clock.clone(),
        bridges: b.clone(),
        delivered,
        link: e.link,
        telemetry: e.telemetry,
        log: logs.drone(peer),
    };
    let report = Executor::new(agent, executor_options(slices, options))
        .run()
        .await;
    // Peers whose acknowledgement from us was lost retransmit: stay a
    // moment to acknowledge them again.
    tokio::time::sleep(options.linger).await;
    paths_stop.cancel();
    drop(b);
    let trajectories = paths.lock().expect("paths lock").clone();
    drop(built);
    let log_errors = logs.finish();
    Ok(RunReport {
        reports: vec![report],
        trajectories,
        wall: wall.elapsed(),
        log_errors,
    })
}
