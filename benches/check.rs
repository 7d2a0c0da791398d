//! `eamos check` on the paper's 34-node mission and on the 20-drone /
//! 5000-node stress mission, with every structure of the language and
//! without the structures that choose between runs (`If`, condition loops,
//! `Do`): the whole proof (deadlock, termination, safety, dead actions,
//! conflicts, conditions) from the compiled net. The checker stops at
//! `CHECK_MEMORY_MB` (a smaller bound when the benchmarks only run as
//! tests): an incomplete proof is reported by `eamos bench-report`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use eamos_lang::SourceFile;
use eamos_verify::{check_net, Options};

#[path = "../src/cmd/bench_report/workload.rs"]
mod workload;

fn check(c: &mut Criterion) {
    let profiles = eamos_profile::builtin();
    // `cargo test` runs each benchmark once, unoptimised, to see that it
    // works: a small bound keeps that quick.
    let benchmarking = std::env::args().any(|a| a == "--bench");
    let options = Options {
        max_memory_mb: if benchmarking {
            workload::CHECK_MEMORY_MB
        } else {
            16
        },
        ..Options::default()
    };
    let mut g = c.benchmark_group("check");
    g.sample_size(10);
    for (name, spec) in [
        ("check", workload::SMALL),
        ("check", workload::STRESS),
        ("without_choices", workload::STRESS_WITHOUT_CHOICES),
    ] {
        let text = spec.text();
        let source = SourceFile::new(spec.file_name(), text.clone());
        let mission = workload::front_end(&source, &profiles).expect("generated missions compile");
        let net = eamos_petri::compile(&mission, &profiles);
        g.bench_with_input(BenchmarkId::new(name, spec.nodes), &net, |b, n| {
            b.iter(|| check_net(n, &profiles, Some(&text), &options))
        });
    }
    g.finish();
}

criterion_group!(benches, check);
criterion_main!(benches);
