//! Compile time of missions: the front end (parse and checks), the net, the
//! slices and all three, for the paper's 34-node and 20-drone / 5000-node
//! missions, and a series of sizes that shows how the time grows.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use eamos_lang::SourceFile;

use eamos_bench::workload;

fn paper_missions(c: &mut Criterion) {
    let profiles = eamos_profile::builtin();
    let mut g = c.benchmark_group("compile");
    for spec in [workload::SMALL, workload::STRESS] {
        let source = SourceFile::new(spec.file_name(), spec.text());
        let mission = workload::front_end(&source, &profiles).expect("generated missions compile");
        let net = eamos_petri::compile(&mission, &profiles);
        g.throughput(Throughput::Elements(spec.nodes as u64));
        g.bench_with_input(BenchmarkId::new("parse", spec.nodes), &source, |b, s| {
            b.iter(|| workload::front_end(s, &profiles))
        });
        g.bench_with_input(BenchmarkId::new("net", spec.nodes), &mission, |b, m| {
            b.iter(|| eamos_petri::compile(m, &profiles))
        });
        g.bench_with_input(BenchmarkId::new("slices", spec.nodes), &net, |b, n| {
            b.iter(|| eamos_slicer::slice(n))
        });
        g.bench_with_input(BenchmarkId::new("total", spec.nodes), &source, |b, s| {
            b.iter(|| workload::compile(s, &profiles))
        });
    }
    g.finish();
}

fn growth(c: &mut Criterion) {
    let profiles = eamos_profile::builtin();
    let mut g = c.benchmark_group("compile_series");
    g.sample_size(10);
    for nodes in workload::SERIES {
        let spec = workload::series(nodes);
        let source = SourceFile::new(spec.file_name(), spec.text());
        g.throughput(Throughput::Elements(nodes as u64));
        g.bench_with_input(BenchmarkId::new("total", nodes), &source, |b, s| {
            b.iter(|| workload::compile(s, &profiles))
        });
    }
    g.finish();
}

criterion_group!(benches, paper_missions, growth);
criterion_main!(benches);
