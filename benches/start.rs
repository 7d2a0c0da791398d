//! Agent start: from the slice file of a drone to its agent ready to
//! receive the start token, for the largest drone slice of the 20-drone /
//! 5000-node mission and for Drone 1 of the 34-node mission. `decode` reads
//! the slice file's bytes (checksum, postcard, consistency); `ready`
//! decodes and builds the agent: simulated drone in its uniform layer,
//! in-process link, bridges, executor.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use eamos_lang::SourceFile;
use eamos_slicer::Slice;

use eamos_bench::workload;

fn start(c: &mut Criterion) {
    let profiles = eamos_profile::builtin();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("a tokio runtime");
    let mut g = c.benchmark_group("start");
    for spec in [workload::SMALL, workload::STRESS] {
        let source = SourceFile::new(spec.file_name(), spec.text());
        let compiled = workload::compile(&source, &profiles).expect("generated missions compile");
        let bytes = workload::largest_drone_slice(&compiled.slices).to_bytes();
        g.bench_with_input(
            BenchmarkId::new("decode", spec.nodes),
            &bytes,
            |b, bytes| {
                b.iter(|| Slice::from_bytes(bytes).expect("a slice the slicer wrote decodes"))
            },
        );
        g.bench_with_input(BenchmarkId::new("ready", spec.nodes), &bytes, |b, bytes| {
            // Dropping an agent (stopping its simulator and bridges) is not
            // part of its start.
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let t = Instant::now();
                    let ready = runtime.block_on(async {
                        let slice = Slice::from_bytes(bytes).expect("decodes");
                        workload::ready_agent(slice, &profiles, workload::LinkKind::InProcess)
                            .await
                            .expect("the agent starts")
                    });
                    total += t.elapsed();
                    drop(ready);
                }
                total
            })
        });
    }
    g.finish();
}

criterion_group!(benches, start);
criterion_main!(benches);
