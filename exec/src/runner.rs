//! Running a mission: the whole fleet in one process ([`run_fleet`]), or
//! one peer of it (a drone's agent or the ground station, [`run_peer`]) as
//! it runs on its own computer, talking zenoh to the others.
//!
//! Both build the same parts: an adapter per drone (the simulator unless
//! the fleet file binds a MAVLink autopilot) wrapped in the uniform layer,
//! a link per peer, exactly-once bridges over it, and an executor per slice.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

use eamos_lang::SourceFile;
use eamos_mid::mavlink::{MavlinkAdapter, MavlinkOptions};
use eamos_mid::{Adapter, Airframe, MissionClock, SimDrone, SimFleet, Uniform, Vec3};
use eamos_profile::ProfileTable;
use eamos_slicer::{Slice, Slices};

use crate::abort::{CommandOpener, CommandSealer};
use crate::event::{Event, Kind, Sink, Tee};
use crate::executor::{Agent, Executor, ExecutorOptions, Report};
use crate::journal::{self, AgentJournal, JournalError};
use crate::liveness::Liveness;
use crate::log::{LogWriter, WarningTap};
use crate::svg::Paths;
use crate::transport::faulty::{Faults, FaultyLink, Partition};
use crate::transport::inproc::InProcessHub;
use crate::transport::publish;
use crate::transport::reliable::{Bridges, RetransmitPolicy};
use crate::transport::{zenoh, Endpoint, Link, TransportError, GCS};
use eamos_fleet::{AdapterKind, Fleet, Mode};

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
    /// Who reads the run's events besides its mission logs and the plot's
    /// paths: a terminal display, a test, a monitor.
    pub events: Option<Arc<dyn Sink>>,
    pub stop: CancellationToken,
    /// How long the ground station waits for the other peers (wall time).
    pub startup_timeout: Duration,
    /// How long a peer stays after its run to acknowledge late copies
    /// (wall time; one-process runs need none).
    pub linger: Duration,
    /// Seeds the simulator's random processes (each drone's wind gusts,
    /// mixed with the drone's index).
    pub seed: u64,
    /// Where each peer journals what it does (`<peer>.journal`) and each
    /// simulated drone its airframe: a peer started again with the same
    /// directory resumes where it was (see [`crate::journal`]).
    pub journal: Option<PathBuf>,
    /// Cuts peers off the network on demand (tests of lost peers).
    pub partition: Option<Partition>,
    /// Checks the ground station's seal on abort commands.
    pub abort_opener: Option<CommandOpener>,
    /// Seals the abort this peer sends when stopped (the ground station's
    /// key, when it has it).
    pub abort_sealer: Option<CommandSealer>,
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
            events: None,
            stop: CancellationToken::new(),
            startup_timeout: Duration::from_secs(60),
            linger: Duration::from_secs(2),
            seed: 0,
            journal: None,
            partition: None,
            abort_opener: None,
            abort_sealer: None,
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
    /// Stopped (Ctrl-C) while it was still joining the mission's network:
    /// a client of routers that are down keeps trying them, so without
    /// this a drone's agent could not be stopped but by killing it.
    /// Nothing was flown.
    #[error("stopped before {peer} joined the mission's network (nothing was flown)")]
    StoppedJoining { peer: String },
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error(transparent)]
    Journal(#[from] JournalError),
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
    peers_of(&slices.drones)
}

/// The ground station, then `drones`.
fn peers_of(drones: &[String]) -> Vec<String> {
    std::iter::once(GCS.to_string())
        .chain(drones.iter().cloned())
        .collect()
}

struct Built {
    adapters: BTreeMap<String, Arc<dyn Adapter>>,
    clock: MissionClock,
    /// Keeps the simulation running.
    _sim: Option<SimFleet>,
    /// The simulated drones, whose airframes a journaled run records.
    sims: BTreeMap<String, SimDrone>,
}

/// Creates the adapters of `drones` (a subset of the mission's drones
/// `all`, whose profiles `profile_of` names), each in its uniform layer,
/// logging to `logs`.
#[allow(clippy::too_many_arguments)]
async fn build_adapters(
    all: &[String],
    profile_of: &(dyn Fn(&str) -> Option<String> + Sync),
    fleet: &Fleet,
    profiles: &ProfileTable,
    drones: &[String],
    options: &RunOptions,
    logs: &LogWriter,
    events: &Arc<dyn Sink>,
    airframes: &BTreeMap<String, Airframe>,
) -> Result<Built, RunError> {
    let needs_sim = drones
        .iter()
        .any(|d| fleet.entry(d).adapter == AdapterKind::Sim);
    let sim = if needs_sim {
        let mut config = fleet.sim.clone().unwrap_or_default();
        config.speed = options.speed;
        // A resumed simulation goes on from the latest airframe's time.
        let time = airframes.values().map(|a| a.time).fold(0.0, f64::max);
        Some(SimFleet::start_at(config, time).map_err(|e| RunError::Sim(e.to_string()))?)
    } else {
        None
    };
    // The mission clock: the simulator's when it flies a drone here; else
    // the first MAVLink drone's autopilot's, so that a SITL run at a
    // speed-up times Hover and PauseFor in its own seconds; else the wall.
    let first_mavlink = drones
        .iter()
        .find(|d| fleet.entry(d).adapter == AdapterKind::Mavlink);
    let (clock, mut feed) = match (&sim, first_mavlink) {
        (Some(sim), _) => (sim.clock(), None),
        (None, Some(_)) => {
            let (clock, feed) = MissionClock::following();
            (clock, Some(Arc::new(std::sync::Mutex::new(feed))))
        }
        (None, None) => (MissionClock::wall(), None),
    };
    let mut adapters: BTreeMap<String, Arc<dyn Adapter>> = BTreeMap::new();
    let mut sims = BTreeMap::new();
    for d in drones {
        let index = all.iter().position(|x| x == d).unwrap_or(0);
        let profile_name = profile_of(d).unwrap_or_else(|| "Quadcopter".to_string());
        let profile = profiles
            .get(&profile_name)
            .cloned()
            .ok_or_else(|| RunError::Profile {
                drone: d.clone(),
                profile: profile_name.clone(),
            })?;
        let log: Arc<WarningTap> = Arc::new(WarningTap::new(logs.drone(d), events.clone()));
        let entry = fleet.entry(d);
        let adapter: Arc<dyn Adapter> = match entry.adapter {
            AdapterKind::Sim => {
                let fleet_sim = sim
                    .as_ref()
                    .expect("a simulator exists for simulated drones");
                let drone = fleet_sim
                    .add_drone_with_profile(fleet.sim_spec(d, index), profile.clone(), log.clone())
                    .map_err(|e| RunError::Sim(e.to_string()))?;
                if let Some(a) = airframes.get(d) {
                    drone.restore(a).map_err(|e| RunError::Sim(e.to_string()))?;
                }
                sims.insert(d.clone(), drone.clone());
                Arc::new(drone)
            }
            AdapterKind::Mavlink => {
                let connection = entry.connect.clone().unwrap_or_default();
                // The fleet's one mission clock, so that a MAVLink drone's
                // log and telemetry share the time line of the others.
                let mut mavlink = MavlinkOptions {
                    home: fleet.home(d, index),
                    // One geographic frame for the fleet: a real vehicle's
                    // home is where its autopilot says, from the fleet's
                    // origin (a drone's own setting may name another).
                    fleet_origin: fleet.origin(),
                    log: log.clone(),
                    clock: Some(clock.clone()),
                    clock_feed: if Some(d) == first_mavlink {
                        feed.take()
                    } else {
                        None
                    },
                    ..MavlinkOptions::default()
                };
                if let Some(settings) = &entry.mavlink {
                    settings.apply(&mut mavlink);
                }
                Arc::new(
                    MavlinkAdapter::connect(d.clone(), &connection, mavlink)
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
        sims,
    })
}

/// The bridges of one peer, journaled when the run keeps a journal.
fn start_bridges(
    mission_id: &str,
    link: Arc<dyn crate::transport::Link>,
    frames: mpsc::UnboundedReceiver<crate::transport::Frame>,
    options: &RunOptions,
    journal: Option<&AgentJournal>,
) -> (
    Bridges,
    mpsc::UnboundedReceiver<crate::transport::reliable::Delivered>,
) {
    match journal {
        Some(j) => Bridges::start_journaled(
            mission_id.to_string(),
            link,
            frames,
            options.retransmit,
            j.journal.clone(),
            &j.recovered,
        ),
        None => Bridges::start(mission_id.to_string(), link, frames, options.retransmit),
    }
}

/// Opens the journal of the peer of each of `slices`, when the run keeps
/// one.
fn open_journals(
    slices: &[Slice],
    options: &RunOptions,
) -> Result<BTreeMap<String, AgentJournal>, RunError> {
    let Some(dir) = &options.journal else {
        return Ok(BTreeMap::new());
    };
    let mut out = BTreeMap::new();
    for slice in slices {
        out.insert(slice.drone.clone(), journal::open_agent(dir, slice)?);
    }
    Ok(out)
}

/// The airframes recorded for `drones` by an earlier run of this journal
/// (only for peers that resume: a new journal starts every drone at home).
fn recorded_airframes(
    drones: &[String],
    journals: &BTreeMap<String, AgentJournal>,
    options: &RunOptions,
) -> Result<BTreeMap<String, Airframe>, RunError> {
    let mut out = BTreeMap::new();
    let Some(dir) = &options.journal else {
        return Ok(out);
    };
    for d in drones {
        if !journals.get(d).is_some_and(|j| j.recovered.is_resume()) {
            continue;
        }
        if let Some(a) = journal::read_airframe(&journal::airframe_path(dir, d))? {
            out.insert(d.clone(), a);
        }
    }
    Ok(out)
}

/// Records the simulated airframes every few milliseconds of wall time
/// while the run lasts: the simulator lives in this process, and a
/// restarted agent puts its drone back where it was last recorded.
fn record_airframes(
    sims: &BTreeMap<String, SimDrone>,
    options: &RunOptions,
    stop: CancellationToken,
) {
    let Some(dir) = options.journal.clone() else {
        return;
    };
    for (name, drone) in sims {
        let path = journal::airframe_path(&dir, name);
        let drone = drone.clone();
        let stop = stop.clone();
        tokio::spawn(async move {
            let mut last = None;
            loop {
                let a = drone.airframe();
                let changed =
                    last.is_none_or(|l: Airframe| l.position != a.position || l.armed != a.armed);
                if changed {
                    if let Err(e) = journal::write_airframe(&path, &a) {
                        tracing::warn!("cannot record the airframe in {}: {e}", path.display());
                    }
                    last = Some(a);
                }
                tokio::select! {
                    _ = stop.cancelled() => return,
                    _ = tokio::time::sleep(Duration::from_millis(5)) => {}
                }
            }
        });
    }
}

/// The logs of a run: appended to when a peer resumes from its journal
/// (the records of its first run stay), replaced otherwise.
fn open_logs(
    options: &RunOptions,
    journals: &BTreeMap<String, AgentJournal>,
) -> Result<LogWriter, RunError> {
    let resuming = journals.values().any(|j| j.recovered.is_resume());
    let logs = if resuming {
        LogWriter::append(&options.out)
    } else {
        LogWriter::create(&options.out)
    };
    logs.map_err(|e| RunError::Logs {
        dir: options.out.display().to_string(),
        error: e.to_string(),
    })
}

/// Opens the link of the peer that runs `slice`, one of `all`. The ground
/// station waits for the fleet's routers as long as it waits for its
/// drones (the start-up timeout), then says it found none; a drone keeps
/// waiting (it may be powered up before the ground network).
async fn endpoint(
    slice: &Slice,
    all: &[String],
    fleet: &Fleet,
    transport: TransportKind,
    hub: &InProcessHub,
    options: &RunOptions,
) -> Result<Endpoint, RunError> {
    let peer = slice.drone.as_str();
    let reads = slice.telemetry.clone();
    let mut e = match transport {
        TransportKind::InProcess => hub.connect(peer, &reads),
        TransportKind::Zenoh => {
            let opts = fleet.zenoh_options(&slice.mission_id, all, peer);
            // A drone follows only the peers it may wait on; the ground
            // station, every peer.
            let follow = (peer != GCS).then(|| crate::liveness::neighbours(slice));
            let opening =
                zenoh::open_following(&slice.mission_id, peer, &reads, follow.as_deref(), &opts);
            let opened = if peer == GCS {
                zenoh::within(opening, peer, &opts, options.startup_timeout).await
            } else {
                opening.await
            };
            opened.map_err(|e| match e {
                TransportError::PortTaken {
                    peer, endpoints, ..
                } => TransportError::PortTaken {
                    peer,
                    endpoints,
                    fleet: Some(all.len()),
                },
                e => e,
            })?
        }
    };
    if let Some(f) = options.faults {
        // Each peer's faults differ but follow from the one seed.
        let k = all.iter().position(|p| p == peer).unwrap_or(0) as u64;
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

/// Opens the zenoh link of the peer that runs `slice` ([`endpoint`]),
/// unless the run is stopped first. A drone that waits for the fleet's
/// routers for good says so once, after its start-up timeout (the ground
/// station gives up then instead).
async fn join(
    slice: &Slice,
    all: &[String],
    fleet: &Fleet,
    hub: &InProcessHub,
    options: &RunOptions,
    events: &Arc<dyn Sink>,
    clock: &MissionClock,
) -> Result<Endpoint, RunError> {
    let peer = slice.drone.as_str();
    let opening = endpoint(slice, all, fleet, TransportKind::Zenoh, hub, options);
    tokio::pin!(opening);
    let patience = tokio::time::sleep(options.startup_timeout);
    tokio::pin!(patience);
    let mut said = false;
    loop {
        tokio::select! {
            e = &mut opening => return e.map(|e| partitioned(e, options)),
            () = options.stop.cancelled() => {
                return Err(RunError::StoppedJoining { peer: peer.to_string() })
            }
            () = &mut patience, if !said => {
                said = true;
                let opts = fleet.zenoh_options(&slice.mission_id, all, peer);
                if peer != GCS && opts.mode == Mode::Client {
                    events.event(&Event {
                        time: clock.now(),
                        drone: peer.to_string(),
                        kind: Kind::RoutersWaiting { routers: opts.connect },
                    });
                }
            }
        }
    }
}

/// The link of `e` subject to the run's partition, if it has one.
fn partitioned(mut e: Endpoint, options: &RunOptions) -> Endpoint {
    if let Some(p) = &options.partition {
        e.link = Arc::new(FaultyLink::new(e.link, Faults::default()).with_partition(p.clone()));
    }
    e
}

/// Samples each drone's telemetry into the run's events: whenever it
/// has moved 5 cm (the plot's paths are made of these).
fn sample_telemetry(
    adapters: &BTreeMap<String, Arc<dyn Adapter>>,
    clock: &MissionClock,
    events: Arc<dyn Sink>,
    stop: CancellationToken,
) {
    for (name, a) in adapters {
        let mut rx = a.telemetry();
        let events = events.clone();
        let (name, clock, stop) = (name.clone(), clock.clone(), stop.clone());
        tokio::spawn(async move {
            let mut last: Option<Vec3> = None;
            loop {
                let t = *rx.borrow_and_update();
                let p = t.fleet_position();
                if last.is_none_or(|q| q.distance(p) >= 0.05) {
                    last = Some(p);
                    events.event(&Event {
                        time: clock.now(),
                        drone: name.clone(),
                        kind: Kind::Telemetry {
                            position: p,
                            altitude: t.position.z,
                            battery: t.battery,
                        },
                    });
                }
                tokio::select! {
                    _ = stop.cancelled() => return,
                    r = rx.changed() => if r.is_err() { return },
                }
            }
        });
    }
}

/// `events`, and `also` beside them.
fn with_sink(events: Arc<dyn Sink>, also: Arc<dyn Sink>) -> Arc<dyn Sink> {
    Arc::new(Tee::new(vec![events, also]))
}

/// Where a run's events go: its mission logs, the plot's paths and
/// whoever else `options` names.
fn run_sink(logs: &LogWriter, paths: &Arc<Paths>, options: &RunOptions) -> Arc<dyn Sink> {
    let mut sinks: Vec<Arc<dyn Sink>> = vec![Arc::new(logs.missions()), paths.clone()];
    sinks.extend(options.events.clone());
    Arc::new(Tee::new(sinks))
}

fn executor_options(peers: Vec<String>, options: &RunOptions) -> ExecutorOptions {
    ExecutorOptions {
        max_duration: options.max_duration,
        startup_timeout: options.startup_timeout,
        flush_timeout: Duration::from_secs(10),
        peers,
        source: options.source.clone(),
        stop: options.stop.clone(),
        journal: None,
        liveness: Liveness::default(),
        abort_opener: options.abort_opener.clone(),
        abort_sealer: options.abort_sealer.clone(),
        pass_on_aborts: true,
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
    let journals = open_journals(&slices.slices, options)?;
    let logs = open_logs(options, &journals)?;
    // Links first: opening a zenoh peer takes a while, and the simulated
    // clock should not run meanwhile.
    let hub = InProcessHub::new();
    let all = peers(slices);
    let mut endpoints = Vec::new();
    for peer in &all {
        endpoints.push(
            endpoint(
                slices.get(peer).expect("every peer has a slice"),
                &all,
                fleet,
                options.transport,
                &hub,
                options,
            )
            .await
            .map(|e| partitioned(e, options))?,
        );
    }
    let drones = slices.drones.clone();
    let airframes = recorded_airframes(&drones, &journals, options)?;
    let profile_of = |d: &str| {
        let index = drones.iter().position(|x| x == d)?;
        slices.profiles.get(index).cloned()
    };
    let paths = Arc::new(Paths::default());
    let events = run_sink(&logs, &paths, options);
    let built = build_adapters(
        &drones,
        &profile_of,
        fleet,
        profiles,
        &drones,
        options,
        &logs,
        &events,
        &airframes,
    )
    .await?;
    let paths_stop = CancellationToken::new();
    // The samplers hold the run's sink: they stop however this returns.
    let _samplers = paths_stop.clone().drop_guard();
    sample_telemetry(
        &built.adapters,
        &built.clock,
        events.clone(),
        paths_stop.clone(),
    );
    record_airframes(&built.sims, options, paths_stop.clone());
    let mut bridges = Vec::new();
    let mut tasks = Vec::new();
    for (peer, e) in peers(slices).into_iter().zip(endpoints) {
        let slice = slices.get(&peer).expect("every peer has a slice").clone();
        let journal = journals.get(&peer);
        let (b, delivered) = start_bridges(
            &slices.mission_id,
            e.link.clone(),
            e.frames,
            options,
            journal,
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
            events: events.clone(),
        };
        let mut exec_options = executor_options(all.clone(), options);
        exec_options.journal = journal.cloned();
        exec_options.liveness = fleet.liveness(&peer);
        let exec = Executor::new(agent, exec_options);
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
    let trajectories = paths.paths();
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
/// drone's own computer: the peer of `slice`, which names every peer of the
/// mission and its own drone's profile, all this needs of the others. The
/// ground station holds the initial token: it starts the mission once its
/// peers are up and follows it to the end.
pub async fn run_peer(
    slice: &Slice,
    fleet: &Fleet,
    profiles: &ProfileTable,
    options: &RunOptions,
) -> Result<RunReport, RunError> {
    let wall = Instant::now();
    let peer = slice.drone.as_str();
    let all = peers_of(&slice.drones);
    let journals = open_journals(std::slice::from_ref(slice), options)?;
    let logs = open_logs(options, &journals)?;
    let drones: Vec<String> = if peer == GCS {
        Vec::new()
    } else {
        vec![peer.to_string()]
    };
    let airframes = recorded_airframes(&drones, &journals, options)?;
    let profile_of = |d: &str| (d == peer).then(|| slice.profile.clone()).flatten();
    let paths = Arc::new(Paths::default());
    // What this peer does, for observers of the mission's network (a
    // monitor that is no peer): published once the link is open.
    let (published, outbox) = publish::outbox();
    let events = with_sink(run_sink(&logs, &paths, options), published);
    let built = build_adapters(
        &slice.drones,
        &profile_of,
        fleet,
        profiles,
        &drones,
        options,
        &logs,
        &events,
        &airframes,
    )
    .await?;
    let paths_stop = CancellationToken::new();
    // The samplers hold the run's sink: they stop however this returns.
    let _samplers = paths_stop.clone().drop_guard();
    sample_telemetry(
        &built.adapters,
        &built.clock,
        events.clone(),
        paths_stop.clone(),
    );
    record_airframes(&built.sims, options, paths_stop.clone());
    let hub = InProcessHub::new();
    let e = join(slice, &all, fleet, &hub, options, &events, &built.clock).await?;
    tokio::spawn(publish::drain(outbox, e.link.clone()));
    let journal = journals.get(peer);
    let (b, delivered) = start_bridges(
        &slice.mission_id,
        e.link.clone(),
        e.frames,
        options,
        journal,
    );
    let b = Arc::new(b);
    let link = e.link.clone();
    let agent = Agent {
        slice: slice.clone(),
        drone: built.adapters.get(peer).cloned(),
        clock: built.clock.clone(),
        bridges: b.clone(),
        delivered,
        link: e.link,
        telemetry: e.telemetry,
        events,
    };
    let routes_for_drones = peer == GCS && fleet.hub(&all);
    let mode = fleet.zenoh_options(&slice.mission_id, &all, peer).mode;
    let mut exec_options = executor_options(all, options);
    exec_options.pass_on_aborts = mode != Mode::Client;
    exec_options.journal = journal.cloned();
    exec_options.liveness = fleet.liveness(peer);
    let report = Executor::new(agent, exec_options).run().await;
    // Peers whose acknowledgement from us was lost retransmit: stay a
    // moment to acknowledge them again.
    tokio::time::sleep(options.linger).await;
    if routes_for_drones {
        route_until_gone(
            link.as_ref(),
            &slice.drones,
            &options.stop,
            ROUTING_AFTER_END,
        )
        .await;
    }
    paths_stop.cancel();
    drop(b);
    let trajectories = paths.paths();
    drop(built);
    let log_errors = logs.finish();
    Ok(RunReport {
        reports: vec![report],
        trajectories,
        wall: wall.elapsed(),
        log_errors,
    })
}

/// How long at most the ground station of a hub fleet keeps routing
/// once its own run has ended: a simulated drone's failsafe and its last
/// flush take seconds; a real drone landing from altitude, a minute.
const ROUTING_AFTER_END: Duration = Duration::from_secs(120);

/// The ground station of a hub fleet is the drones' router (see
/// [`Fleet::hub`]): it stays until none of `drones` is up any more (a
/// monitor watching does not hold it), `limit` at most, or until stopped.
/// When it left as soon as its own run ended, an abort among 100 drones
/// cut off every drone still passing the abort on or landing: each waited
/// out its flush in silence, and `eamos abort` heard from only some of
/// them.
async fn route_until_gone(
    link: &dyn Link,
    drones: &[String],
    stop: &CancellationToken,
    limit: Duration,
) {
    let Some(mut presence) = link.presence() else {
        return;
    };
    let waiting = async {
        loop {
            let up = {
                let now = presence.borrow_and_update();
                drones.iter().filter(|d| now.contains(*d)).count()
            };
            if up == 0 {
                return;
            }
            tracing::info!("routing for {up} drones still up");
            if presence.changed().await.is_err() {
                return;
            }
        }
    };
    tokio::select! {
        () = waiting => {}
        () = tokio::time::sleep(limit) => {
            tracing::warn!("stopped routing for the drones after {} s", limit.as_secs());
        }
        () = stop.cancelled() => {}
    }
}

#[cfg(test)]
mod tests;
