//! The executor's own speed: local transition firings per second (counted
//! from the executors' `fired` events) when
//! every action succeeds at once. One drone flies a sequence of actions
//! (two firings each, start and end) after the ground station's start
//! token; both executors run to the mission's end over the in-process
//! link, so the figure is the token game, the action bookkeeping and the
//! uniform layer, with no flight and no network.

use std::sync::Arc;

use async_trait::async_trait;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use tokio::sync::watch;

use std::sync::atomic::{AtomicU64, Ordering};

use eamos_exec::event::{Event, Kind, Sink};
use eamos_exec::executor::{Agent, Executor, ExecutorOptions};
use eamos_exec::transport::inproc::InProcessHub;
use eamos_exec::transport::reliable::{Bridges, RetransmitPolicy};
use eamos_exec::transport::GCS;
use eamos_exec::Outcome;
use eamos_lang::SourceFile;
use eamos_mid::{
    ActionCall, ActionError, Adapter, AdapterInfo, CancellationToken, MissionClock, NullSink,
    Telemetry, Uniform, Vec3,
};
use eamos_profile::ProfileTable;
use eamos_slicer::Slices;

use eamos_bench::workload;

/// A drone whose every action succeeds the moment it starts: what is left
/// to measure is the executor.
struct InstantDrone {
    name: String,
    telemetry: watch::Sender<Telemetry>,
    clock: MissionClock,
}

#[async_trait]
impl Adapter for InstantDrone {
    fn info(&self) -> AdapterInfo {
        AdapterInfo {
            kind: "instant".into(),
            drone: self.name.clone(),
            detail: "every action succeeds at once".into(),
        }
    }

    fn telemetry(&self) -> watch::Receiver<Telemetry> {
        self.telemetry.subscribe()
    }

    fn clock(&self) -> MissionClock {
        self.clock.clone()
    }

    async fn run(&self, _call: &ActionCall, _cancel: CancellationToken) -> Result<(), ActionError> {
        Ok(())
    }
}

/// One drone, `actions` actions in sequence.
fn mission(actions: usize) -> String {
    let mut text = String::from("package Firings\n\nvar D1 Quadcopter\n\nfunc SEQ_Fly() {\n");
    for k in 0..actions {
        text.push_str(match k % 4 {
            0 => "\tD1.FlyByX(1)\n",
            1 => "\tD1.Hover(1)\n",
            2 => "\tD1.TakePhoto()\n",
            _ => "\tD1.FlyByX(-1)\n",
        });
    }
    text.push_str("}\n");
    text
}

/// Counts the transitions the executors really fired, from the one
/// stream of events: the rate is firings over time, not the net's size.
#[derive(Default)]
struct Firings(AtomicU64);

impl Sink for Firings {
    fn event(&self, e: &Event) {
        if matches!(e.kind, Kind::Fired { .. }) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Plays the whole mission once: the ground station and the drone.
async fn play(slices: &Slices, profiles: &ProfileTable, fired: Arc<Firings>) {
    let hub = InProcessHub::new();
    let clock = MissionClock::wall();
    let peers: Vec<String> = std::iter::once(GCS.to_string())
        .chain(slices.drones.iter().cloned())
        .collect();
    let mut runs = Vec::new();
    for slice in &slices.slices {
        let endpoint = hub.connect(&slice.drone, &slice.telemetry);
        let (bridges, delivered) = Bridges::start(
            slices.mission_id.clone(),
            endpoint.link.clone(),
            endpoint.frames,
            RetransmitPolicy::default(),
        );
        let drone: Option<Arc<dyn Adapter>> = (slice.drone != GCS).then(|| {
            let instant = InstantDrone {
                name: slice.drone.clone(),
                telemetry: watch::Sender::new(Telemetry::at_home(Vec3::ZERO)),
                clock: clock.clone(),
            };
            let profile = profiles.get("Quadcopter").expect("built in").clone();
            Arc::new(Uniform::new(Arc::new(instant), profile, Arc::new(NullSink)))
                as Arc<dyn Adapter>
        });
        let agent = Agent {
            slice: slice.clone(),
            drone,
            clock: clock.clone(),
            bridges: Arc::new(bridges),
            delivered,
            link: endpoint.link,
            telemetry: endpoint.telemetry,
            events: fired.clone(),
        };
        let options = ExecutorOptions {
            peers: peers.clone(),
            ..ExecutorOptions::default()
        };
        runs.push(tokio::spawn(Executor::new(agent, options).run()));
    }
    for r in runs {
        let report = r.await.expect("an executor does not panic");
        assert_eq!(report.outcome, Outcome::Completed, "{}", report.drone);
    }
}

fn firings(c: &mut Criterion) {
    let profiles = eamos_profile::builtin();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("a tokio runtime");
    let mut g = c.benchmark_group("executor");
    g.sample_size(10);
    let actions = 1000;
    let source = SourceFile::new("firings.go", mission(actions));
    let compiled = workload::compile(&source, &profiles).expect("the mission compiles");
    // One play counted: every run of this mission fires as many.
    let counted = Arc::new(Firings::default());
    runtime.block_on(play(&compiled.slices, &profiles, counted.clone()));
    let fired = counted.0.load(Ordering::Relaxed);
    // A sequence fires each of its transitions once; fewer would mean the
    // executor skipped work the rate then claims.
    let transitions: usize = compiled
        .slices
        .slices
        .iter()
        .map(|s| s.transitions.len())
        .sum();
    assert!(
        fired >= actions as u64 * 2 && fired <= transitions as u64,
        "{fired} firings counted for {actions} actions and {transitions} transitions"
    );
    g.throughput(Throughput::Elements(fired));
    g.bench_with_input(
        BenchmarkId::new("firings", actions),
        &compiled.slices,
        |b, slices| {
            b.iter(|| runtime.block_on(play(slices, &profiles, Arc::new(Firings::default()))))
        },
    );
    g.finish();
}

criterion_group!(benches, firings);
criterion_main!(benches);
