//! `eamos check` on the paper's 34-node mission and on the 20-drone /
//! 5000-node stress mission, with every structure of the language and
//! without the structures that choose between runs (`If`, condition loops,
//! `Do`): what `eamos check MISSION` does, from the mission's text (front
//! end, net, then the whole proof: deadlock, termination, safety, dead
//! actions, conflicts, conditions, and the spatial properties: separation,
//! airspace, flight state, with the default fleet); and the stress mission
//! with the logic alone (`logic_only`), the baseline of what the spatial
//! properties cost. The checker stops at
//! `CHECK_MEMORY_MB` (a smaller bound when the benchmarks only run as
//! tests): an incomplete proof is reported by `eamos bench-report`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use eamos_lang::SourceFile;
use eamos_verify::{check_net, Options};

use eamos_bench::workload;

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
    let logic_only = Options {
        spatial: false,
        ..options.clone()
    };
    let mut g = c.benchmark_group("check");
    g.sample_size(10);
    for (name, spec, options) in [
        ("check", workload::SMALL, &options),
        ("check", workload::STRESS, &options),
        ("logic_only", workload::STRESS, &logic_only),
        (
            "without_choices",
            workload::STRESS_WITHOUT_CHOICES,
            &options,
        ),
    ] {
        let source = SourceFile::new(spec.file_name(), spec.text());
        g.bench_with_input(BenchmarkId::new(name, spec.nodes), &source, |b, s| {
            b.iter(|| {
                let mission =
                    workload::front_end(s, &profiles).expect("generated missions compile");
                let net = eamos_petri::compile(&mission, &profiles);
                check_net(&net, &profiles, Some(&s.text), options)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, check);
criterion_main!(benches);
