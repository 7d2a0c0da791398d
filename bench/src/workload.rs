//! The workloads of the benchmarks, shared by `benches/*.rs` and the
//! report's probes (which measure the peak memory of the same work in a
//! child process), so that both measure one thing.

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};

use eamos_exec::event::Discard;
use eamos_exec::executor::{Agent, Executor, ExecutorOptions};
use eamos_exec::transport::inproc::InProcessHub;
use eamos_exec::transport::reliable::{Bridges, RetransmitPolicy};
use eamos_exec::transport::zenoh::{self as zenoh_link, ZenohOptions};
use eamos_exec::transport::{Endpoint, GCS};
use eamos_gen::{Constructs, Options, Size};
use eamos_lang::{hir, SourceFile};
use eamos_mid::{Adapter, NullSink, SimConfig, SimDroneSpec, SimFleet, Uniform, Vec3};
use eamos_profile::ProfileTable;
use eamos_slicer::{Slice, Slices};

/// A generated mission of the benchmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MissionSpec {
    pub drones: usize,
    pub nodes: usize,
    pub seed: u64,
    pub constructs: Constructs,
}

/// The paper's small single-drone mission: a 34-node MEG.
pub const SMALL: MissionSpec = MissionSpec {
    drones: 1,
    nodes: 34,
    seed: 1,
    constructs: Constructs::ALL,
};

/// The paper's stress mission: 20 drones, 5000 nodes.
pub const STRESS: MissionSpec = MissionSpec {
    drones: 20,
    nodes: 5000,
    seed: 1,
    constructs: Constructs::ALL,
};

/// The stress mission without the structures that choose between runs: a
/// mission the checker proves by following one path per interleaving class.
pub const STRESS_WITHOUT_CHOICES: MissionSpec = MissionSpec {
    constructs: Constructs::WITHOUT_CHOICES,
    ..STRESS
};

/// The checker gives up past this much memory in the benchmarks (and says
/// the proof is incomplete) rather than exploring until the machine is
/// full.
pub const CHECK_MEMORY_MB: u64 = 256;

/// Sizes (nodes, 20 drones) that show how compile time grows.
pub const SERIES: [usize; 5] = [1_000, 3_000, 10_000, 30_000, 100_000];

pub fn series(nodes: usize) -> MissionSpec {
    MissionSpec { nodes, ..STRESS }
}

impl MissionSpec {
    pub fn text(&self) -> String {
        let options = Options {
            constructs: self.constructs,
            ..Options::new(self.drones, Size::Nodes(self.nodes), self.seed)
        };
        eamos_gen::generate(&options)
            .expect("benchmark missions are within the generator's range")
            .text
    }

    pub fn file_name(&self) -> String {
        let kind = if self.constructs == Constructs::WITHOUT_CHOICES {
            "-without-choices"
        } else {
            ""
        };
        format!(
            "stress-{}d-{}n-s{}{kind}.go",
            self.drones, self.nodes, self.seed
        )
    }
}

/// A mission through every stage of compilation: its slices. Neither the
/// checked mission nor the net is kept: each is freed once the next stage
/// has what it needs from it (the mission once the net is built, a
/// quarter of the compile's peak on the stress mission; the net once
/// distributed, before the cut), so that its memory is reused instead of
/// added to, as `eamos build` does.
pub struct Compiled {
    pub slices: Slices,
}

/// The front end: text to checked mission.
pub fn front_end(source: &SourceFile, profiles: &ProfileTable) -> Result<hir::Mission, String> {
    eamos_lang::compile(source, profiles)
        .map(|c| c.mission)
        .map_err(|d| eamos_lang::render_all(&d, source, eamos_lang::Style::PLAIN))
}

/// Parse, net, slices: what `eamos build` does before writing files.
pub fn compile(source: &SourceFile, profiles: &ProfileTable) -> Result<Compiled, String> {
    compile_in_phases(source, profiles, || ())
}

/// [`compile`], calling `between` once the front end is done and before
/// the net is built: a process of its own hands back there what the
/// front end held ([`eamos_trim::after_phase`]), as `eamos build` does.
pub fn compile_in_phases(
    source: &SourceFile,
    profiles: &ProfileTable,
    between: impl FnOnce(),
) -> Result<Compiled, String> {
    let mission = front_end(source, profiles)?;
    between();
    let net = eamos_petri::compile(&mission, profiles);
    drop(mission);
    let slices = eamos_slicer::slice(net).map_err(|e| e.to_string())?;
    Ok(Compiled { slices })
}

/// The drone slice with the most places and transitions.
pub fn largest_drone_slice(slices: &Slices) -> &Slice {
    slices
        .slices
        .iter()
        .filter(|s| s.drone != GCS)
        .max_by_key(|s| s.places.len() + s.transitions.len())
        .expect("a mission has a drone")
}

/// How an agent reaches its peers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkKind {
    InProcess,
    /// A zenoh peer listening on a loopback port (peers connect to it).
    Zenoh,
}

/// An agent ready to receive the start token: its executor built, its
/// bridges running, its drone's adapter up. Keep it to keep all of it
/// alive.
pub struct Ready {
    pub executor: Executor,
    pub hub: InProcessHub,
    pub sim: SimFleet,
}

/// Builds the agent of one drone's slice, as `eamos run --drone` does
/// once it has its slice: a simulated drone in its uniform layer, the
/// link, exactly-once bridges, the executor. Must run inside a tokio
/// runtime.
pub async fn ready_agent(
    slice: Slice,
    profiles: &ProfileTable,
    link: LinkKind,
) -> Result<Ready, String> {
    let hub = InProcessHub::new();
    let endpoint: Endpoint = match link {
        LinkKind::InProcess => hub.connect(&slice.drone, &slice.telemetry),
        LinkKind::Zenoh => {
            let port = free_port()?;
            let options = ZenohOptions {
                listen: vec![format!("tcp/127.0.0.1:{port}")],
                connect: Vec::new(),
                scouting: false,
                ..ZenohOptions::default()
            };
            zenoh_link::open(&slice.mission_id, &slice.drone, &slice.telemetry, &options)
                .await
                .map_err(|e| e.to_string())?
        }
    };
    let sim = SimFleet::start(SimConfig::default()).map_err(|e| e.to_string())?;
    let index = slice
        .drones
        .iter()
        .position(|d| *d == slice.drone)
        .unwrap_or(0);
    let sim_drone = sim
        .add_drone(
            SimDroneSpec::new(slice.drone.clone(), Vec3::new(0.0, 3.0 * index as f64, 0.0)),
            Arc::new(NullSink),
        )
        .map_err(|e| e.to_string())?;
    let profile_name = slice.profile.clone().unwrap_or_else(|| "Quadcopter".into());
    let profile = profiles
        .get(&profile_name)
        .cloned()
        .ok_or_else(|| format!("no profile `{profile_name}`"))?;
    let drone: Arc<dyn Adapter> = Arc::new(Uniform::new(
        Arc::new(sim_drone),
        profile,
        Arc::new(NullSink),
    ));
    let (bridges, delivered) = Bridges::start(
        slice.mission_id.clone(),
        endpoint.link.clone(),
        endpoint.frames,
        RetransmitPolicy::default(),
    );
    let peers = std::iter::once(GCS.to_string())
        .chain(slice.drones.iter().cloned())
        .collect();
    let agent = Agent {
        drone: Some(drone),
        clock: sim.clock(),
        bridges: Arc::new(bridges),
        delivered,
        link: endpoint.link,
        telemetry: endpoint.telemetry,
        events: Arc::new(Discard),
        slice,
    };
    let executor = Executor::new(
        agent,
        ExecutorOptions {
            peers,
            ..ExecutorOptions::default()
        },
    );
    Ok(Ready { executor, hub, sim })
}

/// A loopback TCP port nobody listens on right now, and none this process
/// handed out before: the system may give a port just closed to the next
/// caller, and tests on parallel threads ask for ports before they bind
/// them (two browsers' drivers once met on one port that way).
pub fn free_port() -> Result<u16, String> {
    static GIVEN: Mutex<BTreeSet<u16>> = Mutex::new(BTreeSet::new());
    loop {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .map_err(|e| format!("no free loopback port: {e}"))?;
        if GIVEN.lock().unwrap_or_else(|e| e.into_inner()).insert(port) {
            return Ok(port);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two thousand ports asked for, as parallel tests ask: no two the
    /// same, although the system, asked for a free port that often, hands
    /// out one it gave before.
    #[test]
    fn no_port_is_handed_out_twice() {
        let asked: Vec<_> = (0..4)
            .map(|_| {
                std::thread::spawn(|| (0..500).map(|_| free_port().unwrap()).collect::<Vec<_>>())
            })
            .collect();
        let mut ports: Vec<u16> = asked.into_iter().flat_map(|t| t.join().unwrap()).collect();
        ports.sort_unstable();
        let before = ports.len();
        ports.dedup();
        assert_eq!(ports.len(), before);
    }
}
